"""``stiction bench diagnose`` counts a loop as "cannot tell" only where the report's own set covers the truth."""

from stiction.bench.diagnose import _said_cannot_tell, _summary


def _row(truth, named, ties, ranges=None):
    return {"truth": truth, "named": named, "ties": ties, "params": {}, "ranges": ranges or {}, "gain_pct": 0.0,
            "covered": None,
            "fs_fd_base": [1.0, 1.0], "fs_fd_ext": [1.0, 1.0], "fs_fd_true": [1.0, 1.0], "seconds": 1.0}  # fmt: skip


def test_a_set_covers_the_truth_by_name_and_within_its_bounds():
    lag_limit = ("none", "process_type", None, {"time_constant_s_low": 333.0})
    assert _said_cannot_tell("process_type", _row({"time_constant_s": 450.0}, [], [lag_limit]))
    assert not _said_cannot_tell("process_type", _row({"time_constant_s": 200.0}, [], [lag_limit]))
    gain = ("none", "process_gain", 5.0, {"gain_ratio_low": 0.95, "gain_ratio_high": 1.08})
    assert _said_cannot_tell("process_gain", _row({"gain_ratio": 1.05}, [], [gain]))
    assert not _said_cannot_tell("process_gain", _row({"gain_ratio": 1.2}, [], [gain]))
    assert not _said_cannot_tell("dead_time", _row({"dead_time_s": 1.0}, [], [gain]))
    rival = ("sensor_lag", "dead_time", 1.2, {"dead_time_s": 0.8})
    assert _said_cannot_tell("dead_time", _row({"dead_time_s": 1.0}, ["sensor_lag"], [rival]))
    combined = ("none", "process_gain+process_type", 0.5, {"time_constant_s": 80.0})
    assert _said_cannot_tell("process_type", _row({"time_constant_s": 90.0}, [], [combined]))


def test_named_loops_are_not_counted_twice_and_misses_stay_misses():
    lag_limit = ("none", "process_type", None, {"time_constant_s_low": 333.0})
    rows = [
        _row({"time_constant_s": 100.0}, ["process_type"], []),  # named
        _row({"time_constant_s": 450.0}, [], [lag_limit]),  # beyond the record: cannot tell
        _row({"time_constant_s": 200.0}, [], [lag_limit]),  # within reach, read as none: a miss
    ]
    s = _summary("process_type", rows)
    assert s["named_share"] == 1 / 3 and s["cannot_tell_share"] == 1 / 3


def test_a_gain_in_fit_is_counted_over_the_loops_not_said_to_be_a_tie():
    """A cause the data cannot tell apart gains nothing; the share of loops whose fit gained is also given without
    those, pooled over the causes."""
    from stiction.bench.diagnose import _pooled

    lag_limit = ("none", "process_type", None, {"time_constant_s_low": 333.0})
    rows = [
        _row({"time_constant_s": 100.0}, ["process_type"], []) | {"gain_pct": 40.0},  # named, gained
        _row({"time_constant_s": 450.0}, [], [lag_limit]),  # a tie: no gain, not counted
        _row({"time_constant_s": 200.0}, [], [lag_limit]),  # a miss: no gain, counted
    ]
    s = _summary("process_type", rows)
    assert s["gain_positive_share"] == 1 / 3 and s["gain_positive_not_tied"] == [1, 2]
    assert _pooled([s["gain_positive_not_tied"], [3, 4]]) == 4 / 6 and _pooled([[0, 0]]) is None


def test_the_lag_line_is_summarised_where_the_report_gives_one():
    """S as read and S on the report's lag line at the true lag, medians over the loops that have a line."""
    def lag_row(tau, named, s_true, s_read, s_se, on_line):
        extra = {"s_true": s_true, "s_read": s_read, "s_se": s_se, "s_on_line_at_true_lag": on_line}
        return _row({"actuator_tau_s": tau}, named, []) | extra

    rows = [
        lag_row(6.0, ["actuator_lag"], 30.0, 40.0, 2.0, 31.0),  # S read 10 off, its errors 2: not covered
        lag_row(2.0, ["actuator_lag"], 20.0, 21.0, 1.0, 20.5),
        lag_row(3.0, ["dead_time"], 20.0, 25.0, 1.0, float("nan")),  # no lag named: no line
    ]
    line = _summary("actuator_lag", rows)["lag_line"]
    assert line == {"n": 2, "s_read_err_median_pct": 5.5, "s_on_line_err_median_pct": 0.75, "s_within_2se_share": 0.5}
    assert _summary("dead_time", rows[2:])["lag_line"] is None


def test_the_bench_draws_other_loops_from_another_seed(capsys):
    """``--seed`` draws other loops over the same ranges (to see how much a figure owes to its draw), and
    the JSON says which seed it drew from."""
    import json

    from stiction.bench.diagnose import SEED
    from stiction.cli import main
    from stiction.sim.grid import effect_loops

    assert effect_loops("dead_time", 2, 7) != effect_loops("dead_time", 2, SEED)
    argv = ["bench", "diagnose", "--loops", "1", "--causes", "none", "--workers", "1", "--seed", "7", "--json"]
    assert main(argv) in (0, None)
    figures = json.loads(capsys.readouterr().out)
    assert figures["seed"] == 7 and figures["per_cause"]["none"]["n"] == 1
    (row,) = figures["per_cause"]["none"]["loops"]  # each loop's own row, for reading a miss without a script
    assert row["truth"] == {} and row["fs_fd_true"] == [effect_loops("none", 1, 7)[0].fs_pct, row["fs_fd_true"][1]]
    assert set(row) >= {"named", "params", "fs_fd_ext", "covered", "seconds"}


def test_the_bench_records_each_loop_over_the_samples_asked_and_refuses_too_few(capsys):
    """``--samples`` simulates the same loops longer (the time a long record takes, `stiction diagnose` reads up to
    3,600 samples of an export); a record too short to diagnose is refused in one line."""
    import json

    from stiction.bench.diagnose import _one
    from stiction.cli import main
    from stiction.sim.grid import effect_loops

    spec = effect_loops("none", 1, 11)[0]
    assert _one(spec)["samples"] == 1000 and _one(spec, samples=400)["samples"] == 400
    argv = ["bench", "diagnose", "--loops", "1", "--causes", "none", "--workers", "1", "--samples", "400", "--json"]
    assert main(argv) in (0, None)
    assert json.loads(capsys.readouterr().out)["samples"] == 400
    assert main(argv[:-3] + ["--samples", "100"]) not in (0, None)
    assert "--samples 100" in capsys.readouterr().err


def test_a_named_parameter_counts_as_held_where_the_truth_lies_in_its_range():
    rows = [
        _row({"dead_time_s": 3.0}, ["dead_time"], [], {"dead_time_s": [2.5, 3.5]}),  # held
        _row({"dead_time_s": 3.0}, ["dead_time"], [], {"dead_time_s": [3.2, 4.0]}),  # named, range misses
        _row({"dead_time_s": 3.0}, [], []),  # not named: no range to count
    ]
    s = _summary("dead_time", rows)
    assert s["param_in_range"] == [1, 2] and s["param_in_range_share"] == 0.5
