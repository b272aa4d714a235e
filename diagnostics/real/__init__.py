"""Real measured data: adapters turning public data sets into the import format, and estimates.

* :mod:`~diagnostics.real.zema` — the ZeMA condition-monitoring rig (UCI data set);
* :mod:`~diagnostics.real.leakage` — pump leakage per load cycle from pressure and flow
  plateaus, change detection over cycles, and scores against labels (scoring only).
"""
