"""Diagnose on a loop the project's simulator did not make (sim.independent: the spec written a second time)."""

from dataclasses import replace

from stiction.ident.diagnose import diagnose
from stiction.ident.models import cause_parameters
from stiction.ident.record import Record
from stiction.sim.extensions import Extensions
from stiction.sim.grid import effect_loops
from stiction.sim.independent import simulate_independent


def test_a_dead_time_hidden_in_a_loop_of_the_independent_simulator_is_named_and_read():
    # a dead time there delays the stem itself, slips and all (sim.loop delays each interval's mean flow)
    spec = replace(effect_loops("dead_time", 1, seed=4711)[0], extensions=Extensions(dead_time_s=2.6))
    r = simulate_independent(spec, total_s=1600, kept_from_s=600)
    d = diagnose(Record(r.op, r.pv, r.ts_s))
    assert "dead_time" in d.causes, d.causes
    assert abs(cause_parameters(d.extended)["dead_time_s"] - 2.6) < 0.3
