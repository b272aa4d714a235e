"""Diagnosis of hydraulic rigs on top of :mod:`sim`: measurements, inversions, ranking, trends.

The front door is :func:`diagnostics.diagnose.diagnose`; the pieces are usable alone:
measurement records (:mod:`diagnostics.measurement`), closed-form equivalent clearances
(:mod:`diagnostics.inversion`), pump slip (:mod:`diagnostics.slip`), throttle-valve
equivalence tables (:mod:`diagnostics.throttle`), trends (:mod:`diagnostics.trends`),
the velocity-ratio index (:mod:`diagnostics.ratio_index`) and pump characterisation
(:mod:`diagnostics.pump`).
"""
