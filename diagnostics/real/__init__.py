"""Real measured data: adapters turning public data sets into the import format, and estimates.

* :mod:`~diagnostics.real.zema` — the ZeMA condition-monitoring rig (UCI data set);
* :mod:`~diagnostics.real.leakage` — pump leakage per load cycle from pressure and flow
  plateaus, change detection over cycles, and scores against labels (scoring only);
* :mod:`~diagnostics.real.shunt` — leak size as an orifice plus a laminar shunt (paper 000
  eq. 6), the accumulator gas's relaxation time found without labels;
* :mod:`~diagnostics.real.profile` — the same leak size plateau by plateau, each plateau
  against the healthy flow of the same plateau, on the whole program's scale;
* :mod:`~diagnostics.real.accumulator` — accumulator gas volume per cycle from the oil
  stored at the load steps (polytropic gas, pre-charge referred to one temperature);
* :mod:`~diagnostics.real.precharge` — accumulator volume of the rig and pre-charge per
  cycle from where the accumulator stops storing oil (empty below the pre-charge);
* :mod:`~diagnostics.real.switching` — valve switching time and lag from the pressure step,
  the same from block means as from raw samples;
* :mod:`~diagnostics.real.scoring` — scores of an estimate against an ordered label and its
  confounds with the other labels (labels enter only here).
"""
