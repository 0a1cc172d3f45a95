"""A report whose named causes make the simulation of PV worse says so (the criterion that names causes
weighs one-sample predictions; the engineer reads the simulated record)."""

import pytest

from stiction.ident.diagnose import diagnose
from stiction.ident.record import Record
from stiction.ident.report import WORSE_SHARE, diagnosis_report
from stiction.sim.disturbance import Disturbance
from stiction.sim.extensions import Extensions
from stiction.sim.loop import LoopSpec, simulate
from tests.measured import PLANT

WARNING = "simulates it from OP worse than the canonical model"


def _report(spec: LoopSpec):
    r = simulate([spec]).kept()
    record = Record(r.op[0], r.pv[0], float(r.t_s[1] - r.t_s[0]))
    return diagnosis_report("loop", record, diagnose(record))


def test_causes_that_simulate_pv_worse_are_flagged_and_causes_that_help_are_not():
    # a noise-free self-regulating loop with a lag beyond what the record tells: the one-sample criterion
    # names causes whose simulation of PV is worse than the canonical model's (twice as bad; at a lag of 450 s it was
    # 1.8 times until the band's search no longer walked a stem level the data cannot read from 0 %: 1.03 since)
    worse = _report(LoopSpec(30.0, 10.0, extensions=Extensions(time_constant_s=600.0), seed=3))
    assert worse.causes and worse.extended_error > worse.base_error * (1 + WORSE_SHARE)
    assert any(WARNING in w for w in worse.warnings), worse.warnings
    noise = Disturbance("gaussian", "output", 0.02)
    better = _report(LoopSpec(41.0, 14.0, disturbance=noise, extensions=Extensions(dead_time_s=2.7), seed=3))
    assert better.causes[0] == "dead_time" and better.gain_pct > 0
    assert not any(WARNING in w for w in better.warnings)


def test_a_model_that_simulates_the_measured_record_far_worse_gives_no_friction():
    """A measured flow loop (2111FIC51001, labelled 0.003 sticky) on which the one-sample criterion named a process
    gain 185 times the nominal, a lag of 0.5 s and a dead time of 90 s, and read S 2.95 +- 1.34 % of span under them:
    that model simulates PV from OP 3.2 times as badly as the canonical one, beyond any loop the catalogue makes
    (``UNFIT_RATIO``). Its causes are said with a warning; its friction is not given."""
    from stiction.bridge.historian import read_export
    from stiction.ident.report import UNFIT_RATIO, diagnose_loop

    files = sorted(PLANT.glob("stic_2111FIC51001_0610_0004_*.csv"))
    if not files:
        pytest.skip("measured plant data not here")
    e = read_export(files[0])
    report = diagnose_loop("fic51001", e.op, e.pv, e.ts_s, e.mv, e.warnings, e.op.size, sp=e.sp)[0]
    assert report.causes and report.extended_error > UNFIT_RATIO * report.base_error
    assert report.s_pct is None and report.j_pct is None and report.fs_pct is None
    assert any("friction numbers are withheld" in w and "times as badly" in w for w in report.warnings)
    assert not any(WARNING in w for w in report.warnings)  # one warning of the model's course, not two
