"""A report is assembled once: the pipeline's draft says nothing of an unknown process, and each
warning is added where its fact is known (no sizing, a failed one, a read one), never taken back."""

import pytest

from stiction.ident.sizing import Sizing
from stiction.quantify.assembly import NOT_IDENTIFIED, NOT_READ_PREFIX, NOT_READ_WARNING, assemble, needs_sizing
from stiction.quantify.identified import quantify_sized
from stiction.quantify.pipeline import Quantifier, Window
from stiction.schemas.diagnosis import Process
from stiction.sim.grid import case_specs
from stiction.sim.loop import simulate
from stiction.sim.plant_loops import plant_loops, simulate_plant, stable

PROCESS = Process(kind="self_regulating", gain=0.8, gain_se=0.05, time_constant_s=12.0, dead_time_s=2.0,
                  sensor_tau_s=0.0, actuator_tau_s=1.2, sample_time_s=1.0,
                  description="first order, T 12 s, dead time 2 s, gain 0.8 % per %, actuator lag 1.2 s")  # fmt: skip
PROCESS_WARNINGS = (NOT_IDENTIFIED, NOT_READ_WARNING)


@pytest.fixture(scope="module")
def quantifier():
    return Quantifier()


@pytest.fixture(scope="module")
def windows(quantifier):
    """A sticky canonical loop declared a level loop, and a sticky plant-like loop of unknown process
    that the pipeline calls sticky."""
    specs = case_specs(seed=7)
    r = simulate(list(specs.values())[:1]).kept()
    declared = Window("declared", r.op[0], r.pv[0], process="level")
    loops = [loop for loop in plant_loops(30, 2027) if loop.cause == "stiction"]
    plant = [Window(f"s{i}", op, pv, ts_s=ts_s, sp=sp) for i, (op, pv, sp, ts_s) in enumerate(simulate_plant(loops))
             if stable(op, pv)]  # fmt: skip
    unknown = next(w for w, rep in zip(plant, quantifier.quantify(plant), strict=True) if rep.verdict == "stiction")
    return declared, unknown


def test_the_pipelines_draft_says_nothing_of_an_unknown_process_and_its_report_says_it_once(quantifier, windows):
    declared, unknown = windows
    results = quantifier.results([declared, unknown])
    drafts = [r.draft for r in results]
    assert all(w not in d.warnings for d in drafts for w in PROCESS_WARNINGS)
    known, unsure = (r.report for r in results)
    assert known.warnings == drafts[0].warnings  # a declared process: nothing to add
    assert unsure.verdict == "stiction" and needs_sizing(drafts[1])
    assert [unsure.warnings.count(w) for w in PROCESS_WARNINGS] == [1, 1]
    assert unsure.s_pct is None and unsure.method == "none"


def test_a_sizing_is_assembled_into_the_draft_and_a_newer_one_replaces_it_without_leftovers(quantifier, windows):
    _, unknown = windows
    draft = quantifier.results([unknown])[0].draft
    ranges = {"time_constant_s": (10.3, 14.0), "dead_time_s": (1.5, 2.6), "actuator_tau_s": (0.5, 3.0)}
    read = assemble(draft, Sizing(2.0, 0.5, 0.4, 0.6, PROCESS, 6, parameter_ranges=ranges), 900.0, note="re-read")
    assert read.method == "identified" and read.s_pct == 2.0 and read.estimate_t_end_s == 900.0
    # the identified process's numbers with their uncertainty: the gain's standard error, the ranges of its fields
    assert read.process.gain_se == 0.05
    assert read.process.parameter_ranges == ranges  # the lags' too: S trades with an actuator's
    assert (read.process.actuator_tau_s, read.process.sensor_tau_s) == (1.2, 0.0)
    assert not set(PROCESS_WARNINGS) & set(read.warnings) and read.warnings[-1] == "re-read"
    assert read.warnings[0].startswith("process identified from OP and PV")
    nan = float("nan")
    unread = assemble(draft, Sizing(nan, nan, nan, nan, PROCESS, 1, "1 slip(s)"), 900.0, note="re-read")
    assert unread.method == "none" and unread.process.source == "identified" and "re-read" not in unread.warnings
    assert unread.warnings.count(NOT_READ_PREFIX + "1 slip(s)") == 1
    failed = assemble(draft, Sizing(nan, nan, nan, nan, None, 0, "no model"), notes=["export: 3 duplicates"])
    assert failed.warnings[-2:] == [NOT_READ_PREFIX + "no model", "export: 3 duplicates"]
    assert [failed.warnings.count(w) for w in PROCESS_WARNINGS] == [1, 1]
    doubted = assemble(draft, Sizing(0.3, 0.1, 0.4, 0.1, PROCESS, 6, doubts=("the band S 0.3 +- 0.4 % ...",)), 900.0)
    assert doubted.s_pct == 0.3 and doubted.warnings[-1] == "the band S 0.3 +- 0.4 % ..."  # said beside the numbers
    assert "the band S 0.3 +- 0.4 % ..." not in unread.warnings
    # the draft itself is untouched: every assembly starts from the window's facts
    assert assemble(draft) == quantifier.results([unknown])[0].report


def test_quantify_sized_reads_s_and_j_under_the_identified_process_of_an_unknown_sticky_loop(quantifier, windows):
    _, unknown = windows
    (report, _), = quantify_sized(quantifier, [unknown])  # fmt: skip
    assert report.process.source == "identified"
    assert NOT_IDENTIFIED not in report.warnings and NOT_READ_WARNING not in report.warnings


def test_a_sticky_measured_stem_shown_beside_a_loop_not_read_leaves_no_word_that_s_and_j_were_not_read(
    quantifier, windows
):
    from stiction.ident.valve_check import ValveCheck

    _, unknown = windows
    draft = quantifier.results([unknown])[0].draft
    assert draft.verdict == "stiction" and needs_sizing(draft)
    stem = ValveCheck(True, 80.0, 2.0, 0.5, 0.0, 1.0, 0.0, 0.1, 0.4, 0.4, "two_parameter")
    r = assemble(draft, stem=stem)  # no sizing (``--no-identify``): the stem's numbers are the report's
    assert r.method == "stem" and r.s_pct == 2.0 and r.s_se_pct == 0.4
    assert not set(PROCESS_WARNINGS) & set(r.warnings)
    assert any(w.startswith("the stem reads S 2 +- 0.4 %, which the report shows") for w in r.warnings)
    plain = assemble(draft)  # without it, the loop says what it could not read, as before
    assert set(PROCESS_WARNINGS) <= set(plain.warnings) and plain.method == "none"


def test_an_identified_process_that_explains_none_of_pv_is_said_so_where_it_is_shown(quantifier, windows):
    _, unknown = windows
    draft = quantifier.results([unknown])[0].draft
    explains = assemble(draft, Sizing(2.0, 0.5, 0.4, 0.6, PROCESS.model_copy(update={"pv_explained_share": 0.87}), 6))
    assert explains.process.pv_explained_share == 0.87
    assert "explains none" not in explains.warnings[0]
    blind = PROCESS.model_copy(update={"pv_explained_share": -1.5})
    nothing = assemble(draft, Sizing(2.0, 0.5, 0.4, 0.6, blind, 6))
    assert nothing.process.pv_explained_share == -1.5
    assert nothing.warnings[0].startswith("process identified from OP and PV")
    assert "it explains none of PV's course (pv_explained_share -1.5" in nothing.warnings[0]
