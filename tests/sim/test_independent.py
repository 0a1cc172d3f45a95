"""The independent simulator (sim.independent) against the spec's reference solution and closed forms."""

import numpy as np

from stiction.sim.independent import FORCE_LBF_PER_PCT_OP, IN_PER_PCT, _Stem, _valve_interval, simulate_independent
from stiction.sim.loop import LoopSpec
from stiction.sim.reference import reference_simulate


def test_its_canonical_loop_is_the_reference_solution_until_the_chaos_parts_them():
    # the same ODE, integrated another way (the valve and the process apart, every slip an event): the stems agree
    # to 1e-3 % of span over five cycles, after which the spec's chaos may part any two correct simulators
    ours = simulate_independent(LoopSpec(40.0, 20.0), total_s=300, kept_from_s=0)
    ref = reference_simulate(40.0, 20.0, duration_s=300)
    assert np.ptp(ref["mv"]) > 5  # it cycles
    np.testing.assert_allclose(ours.mv, ref["mv"], atol=1e-3)
    np.testing.assert_allclose(ours.pv, ref["pv"], atol=1e-3)


def test_a_lagged_drive_breaks_the_stuck_stem_away_where_its_force_reaches_fs():
    # stuck at 0 with fs = 60 lbf (a band of 5 % of OP); the drive relaxes from 0 to 20 % with a lag of 2 s: the
    # force 12 lbf/% * drive reaches 60 lbf at t = -2 ln(1 - 5/20), inside the interval, not at its start or end
    stem = _Stem()
    x, v, slips = _valve_interval(0.0, 0.0, 0.0, 20.0, 2.0, 60.0, 30.0, 0.0, stem)
    t_break = -2.0 * np.log(1 - 5.0 / 20.0)
    assert slips and abs(slips[0][0] - t_break) < 1e-6
    # the drive keeps rising after the first slip, and the stem follows it in further slips, behind it by under
    # the band (where it ends stuck, its force within fs)
    drive_end = 20.0 * (1 - np.exp(-1 / 2.0))
    assert 0 < drive_end - x / IN_PER_PCT < 60.0 / FORCE_LBF_PER_PCT_OP
    assert v != 0.0 or abs(FORCE_LBF_PER_PCT_OP * drive_end - 300.0 * x) <= 60.0


def test_without_a_lag_the_stem_slips_only_at_the_sample_instant():
    stem = _Stem()
    _, _, slips = _valve_interval(0.0, 0.0, 8.0, 8.0, 0.0, 60.0, 30.0, 5.0, stem)
    assert len(slips) == 1 and slips[0][0] == 5.0 and slips[0][1] - 5.0 < 0.1
