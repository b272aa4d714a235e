"""The compiled inference path of the diagnosis (issue 9).

:mod:`~diagnostics.fastpath.kernel` (the numerics: batched steady solves,
Levenberg-Marquardt pair fits and profiles on the whitened residuals of
:class:`~diagnostics.record_model.RecordModel`), :mod:`~diagnostics.fastpath.chord` (the
chord Newton of the maps' grid solves and the fits' evaluations),
:mod:`~diagnostics.fastpath.singles` (the one-parameter fits on the maps),
:mod:`~diagnostics.fastpath.pchip` (masked PCHIP), :mod:`~diagnostics.fastpath.compiled` (one numba
module per rig, cached on disk), :mod:`~diagnostics.fastpath.maps` (signature maps and
healthy predictions at a condition) and :mod:`~diagnostics.fastpath.fits` (a pair fit in
one call).  :class:`diagnostics.ranking.Ranker` uses it by default (``method="fast"``).
"""
