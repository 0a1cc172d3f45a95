"""The agent's background sizing plan (pure): who is sized when, and what their reports carry."""

import math

from stiction.agent.sizing_plan import NOTE, SizingPlan
from stiction.ident.sizing import Sizing
from stiction.quantify.assembly import NOT_IDENTIFIED, NOT_READ_PREFIX, NOT_READ_WARNING, assemble
from stiction.schemas.diagnosis import Process
from stiction.schemas.report import Estimate, ProcessInfo, StictionReport

PROCESS = Process(kind="self_regulating", gain=0.8, gain_se=0.05, time_constant_s=12.0, dead_time_s=2.0,
                  sensor_tau_s=0.0, actuator_tau_s=0.0, sample_time_s=1.0,
                  description="first order, T 12 s, dead time 2 s, gain 0.8 % per %")  # fmt: skip


def _report(loop_id="L1", verdict="stiction", source="none"):
    """A pipeline's draft (``quantify.assembly``): the window's facts, nothing said of the process yet."""
    none = Estimate(fs_pct=None, fd_pct=None)
    kind = "unknown" if source == "none" else "integrating"
    return StictionReport(
        loop_id=loop_id, verdict=verdict, stiction_probability=0.9, likely_cause="stiction", regularity=2.0,
        amplitude_pct=1.0, process=ProcessInfo(kind=kind, source=source, sample_time_s=1.0), fs_pct=None,
        fd_pct=None, s_pct=None, j_pct=None, s_se_pct=None, j_se_pct=None, fs_se_pct=None, fd_se_pct=None,
        period_s=100.0, denoised=False, method="none", thesis=none, physical=None, learned=none, ood_score=None,
        explained=None, oscillating=True, warnings=[], model_version="test",
        n_samples=1000,
    )  # fmt: skip


def test_only_sticky_loops_of_unknown_process_are_sized_one_at_a_time_and_again_after_the_refresh():
    plan = SizingPlan(refresh_s=600.0)
    assert not plan.wanted(_report(verdict="no_oscillation"), 0.0)
    assert not plan.wanted(_report(source="declared"), 0.0)
    assert plan.wanted(_report("L1"), 0.0)
    plan.started("L1")
    assert not plan.wanted(_report("L1"), 1.0) and plan.wanted(_report("L2"), 1.0)
    assert not plan.has_room()  # one in flight at most: L2 waits for it
    plan.finished("L1", Sizing(2.0, 0.5, 0.4, 0.6, PROCESS, 6), 900.0, now_s=10.0)
    assert plan.wanted(_report("L2"), 11.0) and plan.has_room()
    assert not plan.wanted(_report("L1"), 600.0) and plan.wanted(_report("L1"), 610.0)


def test_a_sized_loops_reports_carry_its_process_and_numbers_in_place_of_the_warnings():
    plan = SizingPlan(refresh_s=600.0)
    plan.finished("L1", Sizing(2.0, 0.5, 0.4, 0.6, PROCESS, 6), 900.0, now_s=0.0)
    r = plan.apply(_report("L1"))
    assert r.method == "identified" and r.s_pct == 2.0 and r.j_se_pct == 0.6 and r.estimate_t_end_s == 900.0
    # fs = 12 lbf/% (S + J)/2 and fd = 12 lbf/% (S - J)/2, in % of 500 lbf (5 lbf each)
    assert math.isclose(r.fs_pct, 3.0) and math.isclose(r.fd_pct, 1.8)
    assert r.process.source == "identified" and r.process.time_constant_s == 12.0 and r.process.description
    assert NOT_READ_WARNING not in r.warnings and NOT_IDENTIFIED not in r.warnings and NOTE in r.warnings
    # the same sizing never decorates a report that is not sticky, or whose process is known
    assert plan.apply(_report("L1", verdict="other_cause")).method == "none"
    assert plan.apply(_report("L1", source="declared")).process.source == "declared"
    assert plan.apply(_report("L2")) == assemble(_report("L2"))


def test_a_sizing_that_read_nothing_says_why_and_so_does_a_failed_one():
    plan = SizingPlan(refresh_s=600.0)
    nan = float("nan")
    plan.finished("L1", Sizing(nan, nan, nan, nan, PROCESS, 1, "1 slip(s) read in the record"), 5.0, now_s=0.0)
    r = plan.apply(_report("L1"))
    assert r.method == "none" and r.s_pct is None and r.process.source == "identified"
    assert NOT_READ_PREFIX + "1 slip(s) read in the record" in r.warnings
    plan.finished("L2", None, 5.0, now_s=0.0)  # the worker failed: the report says so, nothing else changes
    failed = plan.apply(_report("L2"))
    assert failed.warnings[-1] == NOT_READ_PREFIX + "the background identification failed" and plan.done == 2
    assert failed.model_copy(update={"warnings": failed.warnings[:-1]}) == assemble(_report("L2"))


def test_a_new_loops_partial_window_is_sized_from_500_samples_and_again_when_full_or_twice_as_long():
    plan = SizingPlan(refresh_s=3600.0)
    assert not plan.wanted(_report("L1").model_copy(update={"n_samples": 200, "partial": True}), 0.0)
    assert plan.wanted(_report("L1").model_copy(update={"n_samples": 500, "partial": True}), 0.0)
    plan.started("L1", n_samples=500, partial=True)
    plan.finished("L1", Sizing(1.0, 0.2, 0.3, 0.4, PROCESS, 4), 9.0, 0.0)  # read
    assert not plan.wanted(_report("L1").model_copy(update={"n_samples": 999, "partial": True}), 1.0)
    assert plan.wanted(_report("L1").model_copy(update={"n_samples": 1000, "partial": True}), 1.0)  # twice
    assert plan.wanted(_report("L1").model_copy(update={"n_samples": 800, "partial": False}), 1.0)  # full
    plan.started("L1", n_samples=1000, partial=False)
    plan.finished("L1", Sizing(2.0, 0.5, 0.4, 0.6, PROCESS, 6), 99.0, 2.0)
    assert not plan.wanted(_report("L1"), 3.0)  # a full window's sizing holds for the hour


def test_a_partial_window_that_read_nothing_is_sized_again_at_half_as_long_again():
    """A stream that ends before its window fills (a replayed 751-sample export) is still sized on most of it."""
    plan = SizingPlan(refresh_s=3600.0)
    plan.started("L1", n_samples=500, partial=True)
    plan.finished("L1", Sizing(float("nan"), float("nan"), float("nan"), float("nan"), PROCESS, 1, "1 slip"), 9.0, 0.0)
    assert not plan.wanted(_report("L1").model_copy(update={"n_samples": 749, "partial": True}), 1.0)
    assert plan.wanted(_report("L1").model_copy(update={"n_samples": 750, "partial": True}), 1.0)
    plan.started("L1", n_samples=750, partial=True)
    plan.finished("L1", Sizing(1.0, 0.2, 0.3, 0.4, PROCESS, 4), 19.0, 2.0)  # read: then twice as long, or full
    assert not plan.wanted(_report("L1").model_copy(update={"n_samples": 1125, "partial": True}), 3.0)
    assert plan.wanted(_report("L1").model_copy(update={"n_samples": 1000, "partial": False}), 3.0)


def test_a_loop_whose_stream_records_its_stem_has_it_checked_whatever_its_verdict_and_its_reports_carry_it():
    from stiction.ident.valve_check import ValveCheck

    plan = SizingPlan(refresh_s=600.0)
    assert not plan.stem_wanted("L1", False, 1000, 0.0)  # no valve position recorded
    assert not plan.stem_wanted("L1", True, 200, 0.0)  # a new loop's first samples: too few yet
    assert plan.stem_wanted("L1", True, 1000, 0.0)
    plan.stem_started("L1")
    assert not plan.stem_wanted("L1", True, 1000, 1.0)  # one check a loop at a time
    sticky = ValveCheck(True, 120.0, 2.0, 0.5, 1.0, 1.0, 0.0, 0.1, 0.4, 0.4, "two_parameter")
    plan.stem_finished("L1", (sticky, None), now_s=10.0)
    assert not plan.stem_wanted("L1", True, 1000, 600.0) and plan.stem_wanted("L1", True, 1000, 610.0)
    r = plan.apply(_report("L1", verdict="no_oscillation"))  # OP and PV saw no fault: the stem did
    assert r.verdict == "stiction" and r.method == "stem" and r.s_pct == 2.0 and r.s_se_pct == 0.4
    assert any(w.startswith("the measured stem (mv) sticks") for w in r.warnings)
    plan.stem_finished("L2", None, now_s=10.0)  # a worker that failed: said, the verdict left alone
    r2 = plan.apply(_report("L2", verdict="no_oscillation"))
    assert r2.verdict == "no_oscillation" and any("measured stem failed" in w for w in r2.warnings)


def test_a_sticky_level_loop_left_unfitted_is_fitted_and_refitted_after_the_refresh_sharing_the_workers():
    from stiction.quantify.pipeline import FITTED_WARNING, UNFITTED_WARNING

    plan = SizingPlan(refresh_s=600.0)
    level = _report("F1", source="declared").model_copy(update={"warnings": [UNFITTED_WARNING]})
    assert plan.fit_wanted(level, 0.0) and not plan.fit_wanted(_report("F2", source="declared"), 0.0)
    assert not plan.fit_wanted(level.model_copy(update={"verdict": "other_cause"}), 0.0)
    plan.fit_started("F1")
    assert not plan.fit_wanted(level, 1.0)  # in flight
    assert not plan.has_room()  # the one worker is busy: a sizing waits for the fit
    plan.fit_finished("F1", 5.0)
    assert plan.has_room() and plan.fits_done == 1
    carried = level.model_copy(update={"warnings": [FITTED_WARNING]})  # its reports now carry the fit
    assert not plan.fit_wanted(level, 600.0) and not plan.fit_wanted(carried, 600.0)
    assert plan.fit_wanted(carried, 605.0) and plan.fit_wanted(level, 605.0)


def test_a_trusted_slip_reading_is_checked_once_a_refresh_and_not_while_its_window_is_being_fitted():
    plan = SizingPlan(refresh_s=600.0)
    slips = _report("C1", source="declared")
    assert plan.check_wanted(slips, True, 0.0) and not plan.check_wanted(slips, False, 0.0)
    assert not plan.check_wanted(slips.model_copy(update={"verdict": "other_cause"}), True, 0.0)
    plan.fit_started("C1")
    assert not plan.check_wanted(slips, True, 1.0) and not plan.fit_due("C1", 1.0)
    plan.fit_finished("C1", 5.0)  # checked (explained, or fitted): not again before the refresh
    assert not plan.check_wanted(slips, True, 604.0) and plan.check_wanted(slips, True, 605.0)
