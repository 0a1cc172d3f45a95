"""Diagnose says which answers the data cannot tell apart (issue 25) instead of forcing a choice.

``ties`` reads the forward selection's steps: a cause accepted by less than the tie, a rival
whose fit came as close, a cause turned down by as little; and the record's own limit on a
process lag.  The first test checks that reading on steps written by hand; the others hide an
effect in a simulated loop and require the report to name it or say it cannot be told apart.
"""

from types import SimpleNamespace

import numpy as np
import pytest

from stiction.ident.cause_fit import longest_lag_s, told_lag_s
from stiction.ident.diagnose import diagnose
from stiction.ident.friction import Friction as ReadFriction
from stiction.ident.models import TIE_CRITERION, Candidate, Tie
from stiction.ident.record import Record
from stiction.ident.report import diagnosis_report, shown_ties
from stiction.ident.ties import ties
from stiction.sim.disturbance import Disturbance
from stiction.sim.extensions import Extensions
from stiction.sim.loop import LoopSpec, simulate


def _chosen(time_constant_s):
    return SimpleNamespace(hypothesis=SimpleNamespace(dynamics=SimpleNamespace(time_constant_s=time_constant_s)))


def _record(n: int = 1000, ts_s: float = 2.0) -> Record:
    t = np.arange(n, dtype=float)
    return Record(10 * np.sin(t / 40), 50 + np.sin(t / 40 - 1), ts_s)


def _cand(cause, criterion, delta, accepted=False, **params):
    return Candidate(cause, dict(params), 1.0, criterion, delta, accepted=accepted)


def test_ties_are_read_from_the_steps_as_written():
    half = TIE_CRITERION / 2
    steps = [
        {  # dead time wins clearly over nothing, sensor lag comes within the tie of it, actuator lag does not
            "dead_time": _cand("dead_time", 100.0, -50.0, accepted=True, dead_time_s=2.0),
            "sensor_lag": _cand("sensor_lag", 100.0 + half, -50.0 + half, sensor_tau_s=3.0),
            "actuator_lag": _cand("actuator_lag", 100.0 + 3 * TIE_CRITERION, -40.0, actuator_tau_s=1.0),
            "quantization": _cand("quantization", 100.0, 0.0, quantum_pct=0.1),
            "external_oscillation": Candidate("external_oscillation", {}, None, None, None, note="screened out"),
        },
        {  # then a gain accepted by less than the tie
            "process_gain": _cand("process_gain", 100.0 - half, -half, accepted=True, gain_ratio=1.05),
        },
        {  # and nothing more: a lag turned down by less than the tie, another by more
            "process_type": _cand("process_type", 100.0, half, time_constant_s=80.0),
            "sensor_lag": _cand("sensor_lag", 120.0, 3 * TIE_CRITERION, sensor_tau_s=1.0),
        },
    ]
    record = _record()
    got = {(t.named, t.alternative): t for t in ties(steps, _chosen(None), record)}
    assert set(got) == {
        ("dead_time", "sensor_lag"),
        ("process_gain", "none"),
        ("none", "process_type"),
    }
    assert got["dead_time", "sensor_lag"].delta_criterion == pytest.approx(half)
    assert got["dead_time", "sensor_lag"].parameters == {"sensor_tau_s": 3.0}
    assert got["process_gain", "none"].delta_criterion == pytest.approx(half)
    # the fitted lag and the record's limit are both "none or process_type": the limit is the later one
    lag = [t for t in ties(steps, _chosen(None), record) if t.alternative == "process_type"]
    assert [t.delta_criterion for t in lag] == [pytest.approx(half), None]
    assert lag[1].parameters == {"time_constant_s_low": pytest.approx(told_lag_s(record))}
    assert told_lag_s(record) == pytest.approx(1000 * 2.0 / 6) and told_lag_s(record) < longest_lag_s(record)
    # a process read as self-regulating carries no limit of the record
    assert all(t.delta_criterion is not None for t in ties(steps, _chosen(60.0), record))


def _loop(ext: Extensions, seed: int) -> Record:
    spec = LoopSpec(40.0, 15.0, disturbance=Disturbance("gaussian", "output", 0.03), extensions=ext, seed=seed)
    r = simulate([spec]).kept()
    return Record(r.op[0], r.pv[0], float(r.t_s[1] - r.t_s[0]))


def test_a_lag_longer_than_the_record_can_tell_is_reported_as_such_not_as_none_alone():
    record = _loop(Extensions(time_constant_s=700.0), seed=3)
    d = diagnose(record)
    report = diagnosis_report("long-lag", record, d)
    assert "process_type" not in report.causes  # no lag the record cannot tell is named
    limits = [t for t in report.cannot_tell if t.alternative == "process_type" and t.delta_criterion is None]
    assert limits, report.cannot_tell
    assert limits[0].parameters["time_constant_s_low"] <= 700.0
    assert "does not always tell it from integrating" in limits[0].note


def test_a_lag_the_record_can_tell_is_named_without_the_records_limit():
    record = _loop(Extensions(time_constant_s=60.0), seed=4)
    report = diagnosis_report("lag", record, diagnose(record))
    assert report.causes[0] == "process_type"
    assert not [t for t in report.cannot_tell if t.delta_criterion is None]


def test_a_gain_turned_down_gives_the_interval_the_data_allow_where_it_holds_the_nominal():
    def step(ratio, se):
        cand = _cand("process_gain", 110.0, 3 * TIE_CRITERION, gain_ratio=ratio)
        return [{"process_gain": Candidate(**{**cand.__dict__, "se": {"gain_ratio": se}})}]

    (tie,) = [t for t in ties(step(1.04, 0.03), _chosen(60.0), _record()) if t.alternative == "process_gain"]
    assert tie.named == "none"
    assert tie.parameters == {"gain_ratio_low": pytest.approx(0.98), "gain_ratio_high": pytest.approx(1.10)}
    # the nominal outside two standard errors: the data do not allow it, no interval is offered
    assert not [t for t in ties(step(1.10, 0.03), _chosen(60.0), _record()) if t.alternative == "process_gain"]
    assert "0.98-1.1 times" in tie.note
    # an interval the data pin tightly about the nominal is written with the digits that tell its ends apart
    (tight,) = [t for t in ties(step(1.0, 1e-5), _chosen(60.0), _record()) if t.alternative == "process_gain"]
    assert "0.99998-1.00002 times" in tight.note


def test_a_gain_too_close_to_the_nominal_to_name_is_reported_with_its_interval():
    truth = 1.03
    record = _loop(Extensions(gain_ratio=truth), seed=3)
    report = diagnosis_report("gain", record, diagnose(record))
    if "process_gain" in report.causes:
        assert report.parameters["gain_ratio"] == pytest.approx(truth, abs=0.05)
        return
    (tie,) = [t for t in report.cannot_tell if t.alternative == "process_gain"]
    assert tie.parameters["gain_ratio_low"] <= truth <= tie.parameters["gain_ratio_high"]
    assert tie.parameters["gain_ratio_low"] <= 1.0 <= tie.parameters["gain_ratio_high"]


def test_the_lags_line_is_given_only_beside_a_band_the_data_tell_from_none():
    """The actuator lag's line trades lag against band: where S's interval of two standard errors holds 0, or no S is
    given, there is no band to trade and the report leaves the line out; the other ties stay."""
    line = Tie("actuator_lag", "actuator_lag", None, {"s_pct_at_no_lag": 3.7, "s_pct_per_lag_s": 0.09}, "line")
    deadband = Tie("none", "deadband", 0.0, {"deadband_pct_high": 0.2}, "play")
    band = ReadFriction(2.0, 0.5, 0.3, 0.2, 4.0, 3.0, 0.5, 0.5, 20)
    assert shown_ties([line, deadband], band, withheld=False) == [line, deadband]
    no_band = ReadFriction(0.15, 0.07, 0.08, 0.08, 0.3, 0.1, 0.2, 0.2, 20)  # 0.15 +- 0.08: holds 0
    assert shown_ties([line, deadband], no_band, withheld=False) == [deadband]
    assert shown_ties([line, deadband], band, withheld=True) == [deadband]
    # S's error wide from the lag's own doubt alone (ident.ties.lag_widened): the line is what it is about
    doubted = ReadFriction(2.0, 0.5, 1.5, 0.3, 4.0, 3.0, 1.8, 1.8, 20)  # 2.0 +- 1.5, of which 1.47 the lag's
    assert shown_ties([line, deadband], doubted, withheld=False) == [deadband]
    assert shown_ties([line, deadband], doubted, withheld=False, lag_s_sd_pct=1.47) == [line, deadband]
