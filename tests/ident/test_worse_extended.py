"""A report whose named causes make the simulation of PV worse says so (the criterion that names causes
weighs one-sample predictions; the engineer reads the simulated record)."""

from stiction.ident.diagnose import diagnose
from stiction.ident.record import Record
from stiction.ident.report import WORSE_SHARE, diagnosis_report
from stiction.sim.disturbance import Disturbance
from stiction.sim.extensions import Extensions
from stiction.sim.loop import LoopSpec, simulate

WARNING = "simulates it from OP worse than the canonical model"


def _report(spec: LoopSpec):
    r = simulate([spec]).kept()
    record = Record(r.op[0], r.pv[0], float(r.t_s[1] - r.t_s[0]))
    return diagnosis_report("loop", record, diagnose(record))


def test_causes_that_simulate_pv_worse_are_flagged_and_causes_that_help_are_not():
    # a noise-free self-regulating loop with a lag beyond what the record tells: the one-sample criterion
    # names causes whose simulation of PV is worse than the canonical model's
    worse = _report(LoopSpec(30.0, 10.0, extensions=Extensions(time_constant_s=450.0), seed=3))
    assert worse.causes and worse.extended_error > worse.base_error * (1 + WORSE_SHARE)
    assert any(WARNING in w for w in worse.warnings), worse.warnings
    noise = Disturbance("gaussian", "output", 0.02)
    better = _report(LoopSpec(41.0, 14.0, disturbance=noise, extensions=Extensions(dead_time_s=2.7), seed=3))
    assert better.causes[0] == "dead_time" and better.gain_pct > 0
    assert not any(WARNING in w for w in better.warnings)
