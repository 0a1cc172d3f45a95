"""A named parameter's range (``ident.models.parameter_ranges``): its value times exp(-+k), and a lag shorter than
half a sample, which acts within one sample, from 0 (a measured feed-water level loop read a time constant of
0.04 s at 1 s sampling; its range said 0.037-0.050 s, which no record at 1 s can tell)."""

import math

import pytest

from stiction.ident.models import RANGE_LOG, Model, parameter_ranges
from stiction.ident.process import Dynamics
from stiction.ident.valve_model import Hypothesis


def _named(cause: str, **dynamics) -> Model:
    return Model(Hypothesis(dynamics=Dynamics(**dynamics)), fit=None, criterion=0.0, causes=(cause,))


def test_a_named_parameter_has_its_range_about_it():
    (lo, hi) = parameter_ranges(_named("dead_time", dead_time_s=4.0), ts_s=1.0)["dead_time_s"]
    k = RANGE_LOG["dead_time_s"]
    assert (lo, hi) == pytest.approx((4.0 * math.exp(-k), 4.0 * math.exp(k)))


@pytest.mark.parametrize("ts_s", [1.0, 10.0])
def test_a_lag_within_a_sample_runs_from_zero(ts_s):
    short = parameter_ranges(_named("process_type", time_constant_s=0.04 * ts_s), ts_s)["time_constant_s"]
    assert short[0] == 0.0 and short[1] >= 0.5 * ts_s
    long = parameter_ranges(_named("process_type", time_constant_s=30.0 * ts_s), ts_s)["time_constant_s"]
    assert 0.0 < long[0] < 30.0 * ts_s < long[1]
    lagged = parameter_ranges(_named("sensor_lag", sensor_tau_s=0.2 * ts_s), ts_s)["sensor_tau_s"]
    assert lagged[0] == 0.0


def test_the_process_line_says_a_lag_within_half_a_sample_is_a_static_gain():
    from dataclasses import replace

    from stiction.ident.diagnose import diagnose
    from stiction.ident.record import Record
    from stiction.ident.report import process_out
    from stiction.sim.loop import LoopSpec, simulate

    r = simulate([LoopSpec(40.0, 15.0, seed=3)]).kept()
    record = Record(r.op[0], r.pv[0], 1.0)
    model = diagnose(record).extended
    for tau, said in ((0.04, True), (5.0, False)):
        h = replace(model.hypothesis, dynamics=Dynamics(time_constant_s=tau))
        line = process_out(replace(model, hypothesis=h), record).description
        assert ("static gain" in line) == said, line


def test_the_process_line_gives_each_named_parameter_its_range():
    from dataclasses import replace

    from stiction.ident.diagnose import diagnose
    from stiction.ident.record import Record
    from stiction.ident.report import process_out
    from stiction.sim.loop import LoopSpec, simulate

    r = simulate([LoopSpec(40.0, 15.0, seed=3)]).kept()
    record = Record(r.op[0], r.pv[0], 1.0)
    model = diagnose(record).extended
    hyp = replace(model.hypothesis, dynamics=Dynamics(dead_time_s=3.0))
    named = replace(model, hypothesis=hyp, causes=("dead_time",))
    lo, hi = parameter_ranges(named, 1.0)["dead_time_s"]
    assert f"dead time 3 s ({lo:.3g}-{hi:.3g})" in process_out(named, record).description
    unnamed = replace(named, causes=())  # a dead time no cause stands for (none here): no range to give
    assert "dead time 3 s," in process_out(unnamed, record).description
