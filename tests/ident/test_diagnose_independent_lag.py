"""Diagnose on a loop the project's simulator did not make (sim.independent: the spec written a second time):
a sensor lag.  A file of its own beside test_diagnose_independent_dead_time.py, so that the two tests of one to two
minutes each run on the two test workers side by side."""

import pytest

from stiction.ident.diagnose import diagnose
from stiction.ident.models import cause_parameters
from stiction.ident.record import Record
from stiction.sim.grid import effect_loops
from stiction.sim.independent import simulate_independent


@pytest.mark.slow
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
