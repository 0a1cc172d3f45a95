"""Diagnose on a loop the project's simulator did not make (sim.independent: the spec written a second time):
a dead time.  The sensor lag's test is a file of its own (test_diagnose_independent_lag.py): each takes one to two
minutes, and the test workers take a file at a time."""

from dataclasses import replace

import pytest

from stiction.ident.diagnose import diagnose
from stiction.ident.models import cause_parameters
from stiction.ident.record import Record
from stiction.sim.extensions import Extensions
from stiction.sim.grid import effect_loops
from stiction.sim.independent import simulate_independent


@pytest.mark.slow
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
