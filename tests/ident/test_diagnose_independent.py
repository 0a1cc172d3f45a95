"""Diagnose on a loop the project's simulator did not make (sim.independent: the spec written a second time)."""

from dataclasses import replace

from stiction.ident.diagnose import diagnose
from stiction.ident.models import cause_parameters
from stiction.ident.record import Record
from stiction.sim.extensions import Extensions
from stiction.sim.grid import effect_loops
from stiction.sim.independent import simulate_independent


def test_a_dead_time_hidden_in_a_loop_of_the_independent_simulator_is_named_and_read():
    # a dead time there delays the stem itself, slips and all (sim.loop delays each interval's mean flow). The loop is
    # chaotic: its last bits, and so which of its near-equal fits wins, differ between processor models. A dead time of
    # 2.6 s was named on 7 of 8 seeds (4711-4718) on an AMD EPYC family 25 model 1, seed 4711's read as an actuator lag
    # and a process gain there (named on the Xeons); 4.0 s was named on 8 of 8, read 3.80-4.27 s: a cause the test can
    # hold on every machine
    truth_s = 4.0
    spec = replace(effect_loops("dead_time", 1, seed=4711)[0], extensions=Extensions(dead_time_s=truth_s))
    r = simulate_independent(spec, total_s=1600, kept_from_s=600)
    rec = Record(r.op, r.pv, r.ts_s)
    d = diagnose(rec)
    assert "dead_time" in d.causes, d.causes
    lo, hi = d.parameter_ranges(rec.ts_s)["dead_time_s"]
    assert lo <= truth_s <= hi, (truth_s, lo, hi)
    assert abs(cause_parameters(d.extended)["dead_time_s"] - truth_s) < 0.4


def test_a_sensor_lag_the_screen_reads_short_is_read_within_its_range():
    # a first-pass fit reads the slips through the lag's inverse filter, whose noise grows with the lag: the screen's
    # best lay at 3.5 s for this lag of 4.39 s, and the read 3.27 s with a range that stopped short of the truth
    # (ident.cause_fit.ABOVE_THE_SCREEN); the loop is the bench's (stiction bench diagnose --draws wide --seed 3737)
    from stiction.sim.grid import EFFECT_RANGES

    spec = effect_loops("sensor_lag", 8, 3737 + list(EFFECT_RANGES).index("sensor_lag"), draws="wide")[3]
    truth = spec.extensions.sensor_tau_s
    r = simulate_independent(spec)
    rec = Record(r.op, r.pv, r.ts_s)
    d = diagnose(rec)
    assert "sensor_lag" in d.causes, d.causes
    lo, hi = d.parameter_ranges(rec.ts_s)["sensor_tau_s"]
    assert lo <= truth <= hi, (truth, lo, hi)
    # the read itself to diagnose's goal (25 %): seed 3737's eight lags were read 2-23 % off on an AMD EPYC family 25
    # model 1, this one 17 % (within 15 % on the Xeons), every one within its range
    assert abs(cause_parameters(d.extended)["sensor_tau_s"] / truth - 1) < 0.25
