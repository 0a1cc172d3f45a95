"""The identified process says how much of PV's course it explains (``pv_explained_share``): PV simulated from OP
through it against the same model with the valve held still.  A model fitted a sample ahead to a PV that OP does not
drive (another loop's PV, hidden behind this loop's OP) explains none of it, and the report says so."""

from dataclasses import replace

import numpy as np
import pytest

from stiction.ident.diagnose import diagnose
from stiction.ident.friction import explained_share, simulated_pv
from stiction.ident.record import Record
from stiction.ident.report import diagnosis_report
from stiction.ident.trust import course_share
from stiction.sim.disturbance import Disturbance
from stiction.sim.loop import LoopSpec, simulate

NONE_EXPLAINED = "the identified model explains none of PV's course"


@pytest.fixture(scope="module")
def loops():
    noise = Disturbance("gaussian", "output", 0.02)
    r = simulate([LoopSpec(41.0, 14.0, disturbance=noise, seed=3), LoopSpec(30.0, 10.0, disturbance=noise, seed=4)])
    r = r.kept()
    return r.op, r.pv, float(r.t_s[1] - r.t_s[0])


def _diagnosed(op, pv, ts_s):
    record = Record(op, pv, ts_s)
    d = diagnose(record)
    return record, d, diagnosis_report("loop", record, d)


@pytest.mark.slow
def test_a_loop_driven_by_its_valve_is_explained_and_a_pv_its_op_does_not_drive_is_not(loops):
    op, pv, ts_s = loops
    record, d, own = _diagnosed(op[0], pv[0], ts_s)
    assert own.process.pv_explained_share > 0.9
    assert not any(NONE_EXPLAINED in w for w in own.warnings)
    # the share against its definition: the model's squared error over the same model's with the valve held still
    fit = d.extended.fit
    still = simulated_pv(replace(fit, gain_ratio=0.0), record)  # the valve moves nothing
    skip = record.skip
    expected = 1 - np.mean((record.pv_pct - simulated_pv(fit, record))[skip:] ** 2) / np.mean(
        (record.pv_pct - still)[skip:] ** 2
    )
    assert explained_share(fit, record) == pytest.approx(expected, rel=1e-9)
    # the other loop's PV behind this loop's OP: the one-sample criterion still names causes, and the model they
    # make simulates PV from OP worse than with the valve held still
    _, _, hidden = _diagnosed(op[1], pv[0], ts_s)
    assert hidden.process.pv_explained_share <= 0
    assert sum(NONE_EXPLAINED in w for w in hidden.warnings) == 1
    assert course_share(hidden.process.pv_explained_share) == "explains none of PV's course"


def test_a_pv_with_no_course_has_no_share_to_give(loops):
    op, _, ts_s = loops
    record = Record(op[0], np.full(op[0].size, 40.0), ts_s)
    d = diagnose(record)
    assert np.isnan(explained_share(d.extended.fit, record))
    assert course_share(None) == "PV has no course to explain"
