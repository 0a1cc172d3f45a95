"""A record without its setpoint says what the verdict cannot do without it."""

import numpy as np

from stiction.quantify.pipeline import NO_SETPOINT_WARNING, Quantifier
from stiction.quantify.window import Window
from stiction.sim.plant_families import family_loops, simulate_families


def test_a_record_without_sp_says_the_setpoint_step_test_could_not_run():
    loops = [loop for loop in family_loops(2, 3234, families=("flow",)) if loop.sp_steps][:3]
    records = simulate_families(loops, samples=600, start="operating_point")
    q = Quantifier(fit_valve=False)
    with_sp = q.quantify([Window(f"a{i}", r.op, r.pv, r.ts_s, sp=r.sp) for i, r in enumerate(records)])
    without = q.quantify([Window(f"b{i}", r.op, r.pv, r.ts_s) for i, r in enumerate(records)])
    assert not any(NO_SETPOINT_WARNING in r.warnings for r in with_sp)
    read = [r for r in without if r.verdict != "bad_data"]
    assert read and all(NO_SETPOINT_WARNING in r.warnings for r in read)
    flat = Window("flat", np.r_[np.zeros(300), np.ones(300)], np.full(600, 5.0), 1.0)  # a dead PV: bad data only
    (dead,) = q.quantify([flat])
    assert dead.verdict == "bad_data" and NO_SETPOINT_WARNING not in dead.warnings
