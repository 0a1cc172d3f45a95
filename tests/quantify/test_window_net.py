"""The window network in the verdict: a valve fault hidden in a loop that does not cycle, which the window's
statistics barely lean on, is found, and the same loop with a healthy valve is not called; where the statistics
read the window as healthy and the network as sticky, the report says the data do not settle it; and among regular
cycles, where the network speaks beside the cycle model, a valve's deadband cycle the cycle model misses is found.

The loops come from the independent simulator (``sim.two_parameter``: Choudhury's valve under SIMC-tuned PI, a
slow wander on the load), which no model of the verdict is trained on; seed 9090, recorded 1,000 samples (the
agent's window)."""

import dataclasses

import numpy as np
import pytest

from stiction.detect.features import evidence
from stiction.detect.verdict import decide
from stiction.quantify.pipeline import Quantifier
from stiction.quantify.window import Window
from stiction.sim import two_parameter


@pytest.fixture(scope="module")
def quantifier():
    q = Quantifier()
    assert q.window_net is not None, "the shipped models hold a window network"
    return q


def _pair(kind: str, cause: str, nth: int):
    """The ``nth`` loop of ``kind`` and ``cause`` of seed 9090, and the same loop with a healthy valve."""
    loop = [lp for lp in two_parameter.draw(6, 9090) if lp.kind == kind and lp.cause == cause][nth]
    healthy = dataclasses.replace(loop, s_pct=0.0, j_pct=0.0, cause="none")
    sticky_rec, healthy_rec = two_parameter.simulate([loop, healthy], 1000)
    return loop, sticky_rec, healthy_rec


def _report(q, rec, name):
    return q.quantify([Window(name, rec.op, rec.pv, rec.ts_s, sp=rec.sp)])[0]


def test_a_valve_fault_in_a_loop_that_does_not_cycle_is_found_and_its_healthy_twin_is_not(quantifier):
    """A valve with 8 % of backlash and no slip (a valve fault: S > 0, J = 0) in a flow loop under a slow wander."""
    loop, sticky, healthy = _pair("flow", "backlash", 2)
    assert sticky.shows_fault and loop.s_pct > 2.0  # the record shows it: the stem stuck and moved
    ev = evidence(sticky.op, sticky.pv, sticky.ts_s, sticky.sp)
    assert not ev.oscillation.oscillating  # no limit cycle to read its shape
    found = _report(quantifier, sticky, "sticky")
    assert found.verdict == "stiction", found.warnings
    assert any(w.startswith("window network:") for w in found.warnings)
    # the window's statistics alone do not call it: the network is what finds it
    alone = decide(quantifier.detector, ev, [])
    assert alone.verdict != "stiction" and alone.stiction_probability < 0.5
    twin = _report(quantifier, healthy, "healthy")
    assert twin.verdict != "stiction" and twin.stiction_probability < 0.2


def test_where_the_statistics_read_healthy_and_the_network_sticky_the_report_cannot_tell(quantifier):
    """A backlash without slip: the network reads it at 0.98, the statistics at 0.24.  Neither verdict is
    settled: the report is not called sticky, and its warning says the data lean to stiction without settling it,
    with both readings; the healthy twin is read healthy by both."""
    loop, sticky, healthy = _pair("flow", "backlash", 4)
    assert sticky.shows_fault and loop.j_pct == 0.0
    report = _report(quantifier, sticky, "backlash")
    assert report.verdict == "no_oscillation" and 0.35 <= report.stiction_probability < 0.5
    said = " ".join(report.warnings)
    assert "do not settle it" in said and "contradict each other" in said and "window network" in said
    twin = _report(quantifier, healthy, "healthy")
    assert twin.verdict == "no_oscillation" and twin.stiction_probability < 0.2


def test_the_network_reads_the_loop_not_the_records_length_or_units(quantifier):
    """A sticky level loop (S 1.5 %, J 1.2 %, every 5 s, no regular cycle) over its last 600 samples and over 1,000,
    and with PV in engineering units: the network reads a fault in each, the units change nothing."""
    from stiction.quantify.predictor import sequence_probabilities

    loop = [lp for lp in two_parameter.draw(12, 9090) if lp.kind == "level" and lp.cause == "stiction"][0]
    (sticky,) = two_parameter.simulate([loop], 1000)
    assert sticky.shows_fault and not evidence(sticky.op, sticky.pv, sticky.ts_s, sticky.sp).oscillation.oscillating
    records = [
        (sticky.op, sticky.pv, sticky.sp),
        (sticky.op[-600:], sticky.pv[-600:], sticky.sp[-600:]),
        (sticky.op, 3.0 * sticky.pv + 200.0, 3.0 * sticky.sp + 200.0),
    ]
    net = [sequence_probabilities(quantifier.window_net, op[None], pv[None], [sp])[0] for op, pv, sp in records]
    assert min(net) >= 0.5, net
    np.testing.assert_allclose(net[2], net[0], atol=1e-4)
    reports = quantifier.quantify(
        [Window(name, op, pv, sticky.ts_s, sp=sp) for name, (op, pv, sp) in zip("abc", records, strict=True)]
    )
    assert [r.verdict for r in reports] == ["stiction"] * 3
    np.testing.assert_allclose(reports[2].stiction_probability, reports[0].stiction_probability, atol=1e-4)


def test_a_deadband_limit_cycle_the_cycle_model_misses_is_found_by_the_network_beside_it(quantifier):
    """A level loop whose valve has a deadband of 4.9 % of span and no slip cycles regularly: a valve fault (the
    two-parameter S with J = 0).  The cycle model alone leans on it without calling it (0.35); the network reads OP
    and PV as a faulty valve's and raises it, and the report says which reading found it.  Family seed 9091, which
    neither the network (from seed 1000) nor the detector is trained on."""
    from stiction.sim.plant_families import family_loops, simulate_families

    loop = [lp for lp in family_loops(3, 9091, bands="plant") if lp.family == "level" and lp.cause == "backlash"][1]
    (rec,) = simulate_families([loop], samples=1000)
    ev = evidence(rec.op, rec.pv, rec.ts_s, rec.sp)
    assert ev.oscillation.oscillating and rec.shows_fault and loop.j_pct == 0.0
    alone = decide(quantifier.detector, ev, [])
    assert alone.verdict != "stiction"
    report = _report(quantifier, rec, "deadband cycle")
    assert report.verdict == "stiction", report.warnings
    said = [w for w in report.warnings if w.startswith("window network:")]
    assert said and "with a regular cycle" in said[0]


def test_the_network_run_a_slice_at_a_time_gives_what_one_run_of_every_chunk_gives(quantifier):
    """``sequence_probabilities`` runs the chunks ``NET_BATCH_CHUNKS`` at a time (the runtime's memory); the
    reference runs every chunk at once and averages each window's log-odds by hand."""
    from stiction.detect import sequence
    from stiction.quantify.predictor import NET_BATCH_CHUNKS, sequence_probabilities

    loops = two_parameter.draw(4, 9090)[: NET_BATCH_CHUNKS + 5]
    recs = two_parameter.simulate(loops, 1400)
    op, pv = np.stack([r.op for r in recs]), np.stack([r.pv for r in recs])
    sps = [r.sp for r in recs]
    got = sequence_probabilities(quantifier.window_net, op, pv, sps, max_chunks=3)
    x, readable = sequence.chunk_rows(op, pv, sps, 3)
    assert len(x) > 2 * NET_BATCH_CHUNKS  # more than two slices, the last a part
    logits = quantifier.window_net.run(x)["logit"].reshape(len(recs), -1)
    want = 1 / (1 + np.exp(-logits.mean(axis=1)))
    np.testing.assert_allclose(got, np.where(readable, want, np.nan), rtol=1e-5, atol=1e-6)
