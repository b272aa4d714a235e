"""The pump's leak per stored cycle and its shifts (diagnostics/real/monitor.py), on real cycles.

The ZeMA temperature-span slice (18 healthy and 18 severely leaking cycles, 35-58 °C of
oil, cut at test time); the labels only score.
"""

from __future__ import annotations

import math
from dataclasses import replace
from datetime import UTC, datetime, timedelta

import numpy as np
import pytest

from diagnostics.real.leakage import cycle_point
from diagnostics.real.monitor import monitor_packed, monitor_pump_leak, pack_cycles
from diagnostics.real.shunt import MIN_LEAK_FRACTION
from diagnostics.real.zema import load_1hz, read_records
from diagnostics.timeseries import SeriesRecord
from sim.errors import InputError
from sim.fluid import Fluid
from tests.real_slices import zema_span_slice


@pytest.fixture(scope="module")
def span() -> tuple[list[SeriesRecord], np.ndarray]:
    data, labels = load_1hz(zema_span_slice())
    return read_records(data), np.asarray(labels.leakage).astype(int)


def test_each_cycle_is_judged_as_its_label_says_and_sized_by_its_deficit(
        span: tuple[list[SeriesRecord], np.ndarray]) -> None:
    recs, lab = span
    m = monitor_pump_leak(recs, Fluid())
    assert [c.name for c in m.cycles] == [r.name for r in recs]  # no clock: as given
    assert any("order given" in n for n in m.notes)
    assert np.array_equal([c.leaking for c in m.cycles], lab > 0)
    size = np.array([c.size for c in m.cycles])
    assert np.all(np.abs(size[lab == 0]) < 0.1 * np.median(size[lab == 2]))
    # the orifice's leak at the plateau pressure is K·√Δp, and with the shunt's flow
    # λ·Δp/μ it is the deficit (paper 000 eq. 6 form)
    for c in m.cycles:
        assert c.leak_flow == pytest.approx(c.size * math.sqrt(c.pressure), rel=1e-12)
    mu = Fluid().dynamic_viscosity
    for c in (c for c in m.cycles if c.leaking):
        shunt = m.shunt * c.pressure / mu(c.theta)
        assert c.leak_flow + shunt == pytest.approx(c.deficit, rel=1e-9)
    # the cycle's plateau means, as cycle_point reads them (its working plateaus counted)
    first = cycle_point(recs[0], stop_at_relief=True, relaxation=m.relaxation)
    assert (m.cycles[0].pressure, m.cycles[0].flow) == (first.pressure, first.flow)
    assert first.plateaus >= 1 and m.fitted_on >= 1
    # a healthy pump's leak is a few per cent of ~8 l/min: the severe class leaks
    leak = np.median([c.leak_flow for c in m.cycles if c.leaking]) * 6e4
    assert 0.1 < leak < 1.0


def test_a_step_in_time_order_is_found_where_the_pump_began_to_leak(
        span: tuple[list[SeriesRecord], np.ndarray]) -> None:
    """The records given interleaved, their clock times healthy first: the cycles come back
    in time order with one step, at the first leaking cycle, from ≈ 0 to the leak."""
    recs, lab = span
    order = [*np.flatnonzero(lab == 0), *np.flatnonzero(lab == 2)]
    t0 = datetime(2026, 11, 2, 8, 0, tzinfo=UTC)
    timed = [replace(recs[i], started_at=t0 + timedelta(minutes=k))
             for k, i in enumerate(order)]
    given = timed[::2] + timed[1::2]  # not the clock's order
    m = monitor_pump_leak(given, Fluid(), min_segment=5)
    assert [c.name for c in m.cycles] == [recs[i].name for i in order]
    assert [c.measured_at for c in m.cycles] == sorted(c.measured_at for c in m.cycles)
    assert not any("order given" in n for n in m.notes)
    (step,) = m.shifts
    # one start for every cycle (an import whose records restart at t = 0): as given, said
    alike = monitor_pump_leak([replace(r, started_at=t0) for r in given], Fluid(),
                              min_segment=5)
    assert [c.name for c in alike.cycles] == [r.name for r in given]
    assert any("35 cycle(s) share a clock time" in n for n in alike.notes)
    assert step.index == int((lab == 0).sum()) and step.name == m.cycles[step.index].name
    assert step.measured_at == t0 + timedelta(minutes=step.index)
    sizes = np.array([c.size for c in m.cycles])
    assert step.before == pytest.approx(np.median(sizes[:step.index]))
    assert step.after == pytest.approx(np.median(sizes[step.index:]))
    assert abs(step.before) < 0.1 * step.after


def test_healthy_cycles_read_against_a_baseline_neither_leak_nor_shift(
        span: tuple[list[SeriesRecord], np.ndarray]) -> None:
    """A batch of one class cannot be its own reference (refused, naming the baseline);
    against cycles known healthy it reads no leak, and the small steps the oil's drift
    leaves are below the practical size."""
    recs, lab = span
    healthy = [r for r, k in zip(recs, lab, strict=True) if k == 0]
    with pytest.raises(InputError) as refused:
        monitor_pump_leak(healthy, Fluid())
    assert refused.value.field == "baseline_series_ids"
    base, batch = healthy[:12], healthy[12:]
    m = monitor_pump_leak(batch, Fluid(), baseline=base, min_segment=2)
    assert m.reference == "baseline" and not any(c.leaking for c in m.cycles)
    assert m.shifts == ()
    flow = np.median([c.flow for c in m.cycles])
    judged = [c for c in m.cycles if math.isfinite(c.size)]
    assert judged and all(abs(c.leak_flow) < MIN_LEAK_FRACTION * flow for c in judged)


def test_what_the_estimate_cannot_read_is_refused_by_name(
        span: tuple[list[SeriesRecord], np.ndarray]) -> None:
    recs, _ = span
    bare = replace(recs[3], channels={k: v for k, v in recs[3].channels.items()
                                      if k != "q_work"}, metadata={"series_id": 17})
    with pytest.raises(InputError) as missing:
        monitor_pump_leak([*recs[:3], bare], Fluid())
    assert missing.value.field == "series_ids"
    assert "series 17" in missing.value.message and "q_work" in missing.value.message
    # a cycle without a plateau with flow: the relief valve's pressure, no flow
    still = replace(recs[3], channels=recs[3].channels | {
        "q_work": np.zeros_like(recs[3].channels["q_work"])})
    with pytest.raises(InputError) as flat:
        monitor_pump_leak([*recs[:3], still], Fluid())
    assert flat.value.field == "series_ids" and recs[3].name in flat.value.message
    for kwargs, field in (({"relaxation": -1.0}, "relaxation"), ({"window": 0.0}, "window"),
                          ({"min_segment": 1}, "min_segment"), ({"shunt": -1e-15}, "shunt")):
        with pytest.raises(InputError) as bad:
            monitor_pump_leak(recs, Fluid(), **kwargs)  # type: ignore[arg-type]
        assert bad.value.field == field
    with pytest.raises(InputError) as one:
        monitor_pump_leak(recs[:1], Fluid())
    assert one.value.field == "series_ids"


def test_packed_cycles_give_the_same_answer(span: tuple[list[SeriesRecord], np.ndarray]
                                            ) -> None:
    """What the service sends to its executor's process: the cycles as a few arrays, read
    back as records with the channels the estimate reads; the answer is the same, bit for
    bit (how long the pickling holds the interpreter lock: ``make job-stall``)."""
    import pickle

    recs, lab = span
    t0 = datetime(2026, 11, 2, 8, 0, tzinfo=UTC)
    recs = [replace(r, started_at=t0 + timedelta(minutes=k), metadata={"series_id": k + 1})
            for k, r in enumerate(recs)]
    packed = pack_cycles(recs)
    assert monitor_packed(packed, Fluid(), min_segment=3) == monitor_pump_leak(
        recs, Fluid(), min_segment=3)
    base = [r for r, k in zip(recs, lab, strict=True) if k == 0][:12]
    rest = [r for r in recs if r not in base]
    assert monitor_packed(pack_cycles(rest), Fluid(), baseline=pack_cycles(base)) == \
        monitor_pump_leak(rest, Fluid(), baseline=base)
    assert pickle.loads(pickle.dumps(packed)).records()[5].channels.keys() == {
        "p_pump", "q_work", "oil_temperature"}
    bare = replace(recs[0], channels={"p_pump": recs[0].channels["p_pump"]})
    with pytest.raises(InputError) as missing:
        pack_cycles([bare, *recs[1:]], field="baseline_series_ids")
    assert missing.value.field == "baseline_series_ids" and "q_work" in missing.value.message
