"""A band the fit reads but the report doubts: an interval of two standard errors that holds no band,
and a process gain no valve loop has (``ident.trust.band_doubts``); a clear band under a plausible
process raises neither."""

from stiction.ident.friction import Friction
from stiction.ident.trust import PLAUSIBLE_GAIN, band_doubts
from stiction.schemas.diagnosis import Process


def _doubts(f: Friction, process: Process) -> list[str]:
    return band_doubts(f.s_pct, f.s_se_pct, process)


def _friction(s_pct: float, s_se_pct: float) -> Friction:
    return Friction(s_pct, 0.5, s_se_pct, 0.1, 2 * s_pct, s_pct, s_se_pct, 0.2, 12)


def _process(kind: str, gain: float) -> Process:
    tau_s = 6.0 if kind == "self_regulating" else None
    return Process(kind=kind, gain=gain, gain_se=None, time_constant_s=tau_s, dead_time_s=0.0, sensor_tau_s=0.0,
                   actuator_tau_s=0.0, sample_time_s=10.0, description="")  # fmt: skip


def test_a_band_whose_interval_holds_zero_is_said_to_be_indistinguishable_from_none():
    said = _doubts(_friction(0.12, 0.54), _process("self_regulating", 1.2))
    assert len(said) == 1 and "cannot tell from none" in said[0]
    assert _doubts(_friction(2.0, 0.4), _process("self_regulating", 1.2)) == []


def test_a_slip_read_clear_of_zero_tells_the_band_from_none_whatever_ss_error():
    """A valve's band is at least its slip: where J's interval excludes 0, S's wide error (an actuator lag's doubt,
    carried along the line that ends at J) does not make the band one the data cannot tell from none."""
    process = _process("integrating", 0.07)
    assert band_doubts(11.7, 15.2, process, 11.1, 3.5) == []
    said = band_doubts(11.7, 15.2, process, 11.1, 6.0)  # J's interval holds 0 as well
    assert len(said) == 1 and "cannot tell from none" in said[0]
    assert band_doubts(11.7, 15.2, process) == said  # no slip read: S alone decides, as before


def test_a_process_gain_no_valve_loop_has_is_doubted_where_it_is_a_static_gain():
    said = _doubts(_friction(2.3, 0.75), _process("self_regulating", 112.0))
    assert len(said) == 1 and "112 % of span per % of travel" in said[0]
    assert _doubts(_friction(2.3, 0.75), _process("self_regulating", 0.9 * PLAUSIBLE_GAIN)) == []
    # an integrating process's gain is a rate (%/s per %): another unit, not judged by this bound
    assert _doubts(_friction(2.3, 0.75), _process("integrating", 112.0)) == []


def test_a_withheld_band_raises_no_doubt():
    nan = float("nan")
    assert _doubts(Friction(nan, nan, nan, nan, nan, nan, nan, nan, 0), _process("self_regulating", 1.0)) == []


def test_a_sizing_read_from_a_diagnosis_carries_its_doubts():
    from types import SimpleNamespace

    from stiction.ident.sizing import from_report

    report = SimpleNamespace(s_pct=0.12, j_pct=0.09, s_se_pct=0.54, j_se_pct=0.08, slips=660, warnings=[],
                             cannot_tell=[], parameter_ranges={}, process=_process("self_regulating", 1.2))  # fmt: skip
    sizing = from_report(report)
    assert sizing.read and len(sizing.doubts) == 1 and "cannot tell from none" in sizing.doubts[0]
    report.s_se_pct = 0.05
    assert from_report(report).doubts == ()


def test_a_band_read_without_a_standard_error_is_withheld_with_the_reason():
    """Every number a report gives has an uncertainty: a fit that holds a parameter at its bound (fd at zero on a
    measured flow window, 2411FIC20102_20241226_0953 read without its setpoint) read S and J with none, and the
    report gave them bare.  Hidden here in a real diagnosis whose S is read with its error."""
    from dataclasses import replace

    from stiction.ident.report import diagnose_loop, diagnosis_report
    from stiction.sim.disturbance import Disturbance
    from stiction.sim.loop import LoopSpec, simulate

    r = simulate([LoopSpec(40.0, 15.0, disturbance=Disturbance("gaussian", "output", 0.01), seed=3)]).kept()
    given, record, d = diagnose_loop("sticky", r.op[0], r.pv[0], 1.0)
    assert given.s_pct is not None and given.s_se_pct is not None and given.j_se_pct is not None
    assert given.base_friction.s_pct is not None and given.base_friction.s_se_pct is not None
    nan = float("nan")
    bare = diagnosis_report("sticky", record, replace(d, friction=replace(d.friction, s_se_pct=nan, j_se_pct=nan)))
    assert bare.s_pct is None and bare.j_pct is None and bare.fs_pct is None
    assert any("no standard error" in w and "withheld" in w for w in bare.warnings), bare.warnings
    # the canonical model's reading beside it too (7 of 61 measured windows gave it bare)
    bare = diagnosis_report("sticky", record, replace(d, base_friction=replace(d.base_friction, j_se_pct=nan)))
    assert bare.s_pct is not None and bare.base_friction.s_pct is None and bare.base_friction.j_pct is None
