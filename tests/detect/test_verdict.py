"""The verdict on loops with a hidden cause: the shipped detector, family loops of a seed it was not trained on."""

import numpy as np
import pytest

from stiction.detect.features import evidence
from stiction.detect.training import SIM_SEED
from stiction.detect.verdict import STICTION_AT, Detector, at_equal_priors, decide, fit_logistic, short_of
from stiction.sim.plant_families import LOOK_ALIKES, family_loops, simulate_families, stable


@pytest.fixture(scope="module")
def judged(detector):
    """Verdicts by what each window shows: ``fault`` (a valve fault exercised in the window), the
    look-alike cause given, or ``unexercised`` (a faulty valve the window never shows)."""
    loops = family_loops(3, SIM_SEED + 1000)
    out = {}
    for loop, rec in zip(loops, simulate_families(loops), strict=True):
        if not stable(rec):
            continue
        key = "fault" if rec.shows_fault else (loop.cause if loop.cause in LOOK_ALIKES else "unexercised")
        out.setdefault(key, []).append(decide(detector, evidence(rec.op, rec.pv, rec.ts_s, rec.sp), []))
    return out


def _look_alikes(judged):
    return [v for cause, vs in judged.items() if cause not in ("fault", "unexercised") for v in vs]


def test_look_alikes_are_rarely_called_stiction(judged):
    others = _look_alikes(judged)
    called = sum(v.verdict == "stiction" for v in others)
    assert called <= 0.15 * len(others)


def test_windows_that_show_a_valve_fault_are_called_sticky_more_often_than_not_given_the_probability(judged):
    sticky = [v.stiction_probability for v in judged["fault"]]
    assert sum(v.verdict == "stiction" for v in judged["fault"]) > 0.5 * len(sticky)
    assert np.median(sticky) > np.quantile([v.stiction_probability for v in _look_alikes(judged)], 0.9)


def test_an_external_load_oscillation_is_another_cause_not_stiction(judged):
    verdicts = judged["sine"] + judged["triangle"] + judged["square"]  # an upstream loop's cycle, filtered
    assert sum(v.verdict == "other_cause" for v in verdicts) >= 0.75 * len(verdicts)
    named = [v.likely_cause for v in verdicts if v.verdict == "other_cause"]
    assert "stiction" not in named and named.count("external_oscillation") >= 0.5 * len(named)


def test_bad_data_comes_first_and_carries_no_probability(detector):
    rng = np.random.default_rng(0)
    v = decide(detector, evidence(rng.normal(50, 1, 600), np.full(600, 3.5e-44)), ["PV does not move"])
    assert v.verdict == "bad_data" and v.stiction_probability is None


def test_logistic_fit_recovers_a_known_boundary():
    rng = np.random.default_rng(1)
    x = rng.normal(size=(400, 3))
    labels = ["stiction" if 2 * a - b > 0 else "other" for a, b, _ in x]
    model = fit_logistic(x, labels, ("other", "stiction"), l2=1e-4)
    p = model.probabilities(x)
    assert np.allclose(p.sum(axis=1), 1.0)
    assert np.mean((p[:, 1] > 0.5) == np.array([label == "stiction" for label in labels])) > 0.95
    w = model.weights[:, 1] - model.weights[:, 0]
    assert w[0] > 0 > w[1] and abs(w[2]) < 0.2 * abs(w[0])


def test_a_model_fitted_to_one_sticky_window_in_four_reads_at_equal_priors_where_the_classes_balance():
    """Two classes of equal spread, one a quarter of the windows: fitted as they come, the model says 0.25 where
    the two classes' densities meet, and its 0.5 calls too few; read at equal priors it says 0.5 there, and its
    0.5 is the balanced point (reference: the densities' own crossing, halfway between the means)."""
    rng = np.random.default_rng(3)
    sticky = rng.random(4000) < 0.25
    x = (rng.normal(size=4000) + np.where(sticky, 1.0, -1.0))[:, None]
    labels = ["stiction" if s else "other" for s in sticky]
    raw = fit_logistic(x, labels, ("other", "stiction"), l2=1e-6)
    even = at_equal_priors(raw, float(sticky.mean()))
    at_crossing = np.zeros((1, 1))
    assert raw.probabilities(at_crossing)[0, 1] == pytest.approx(0.25, abs=0.04)
    assert even.probabilities(at_crossing)[0, 1] == pytest.approx(0.5, abs=0.04)
    assert np.allclose(even.weights, raw.weights)

    def balanced(model):
        called = model.probabilities(x)[:, 1] >= 0.5
        return 0.5 * (called[sticky].mean() + (~called[~sticky]).mean())

    assert balanced(even) > balanced(raw) + 0.02


def test_a_feature_left_out_weighs_nothing_and_the_rest_fit_as_without_it():
    """Reference: the same fit on the other columns alone."""
    rng = np.random.default_rng(2)
    x = rng.normal(size=(400, 3))
    labels = ["stiction" if a + x2 + 0.3 * rng.normal() > 0 else "other" for a, _, x2 in x]
    left_out = np.array([False, True, False])
    model = fit_logistic(x, labels, ("other", "stiction"), left_out=left_out)
    alone = fit_logistic(x[:, ~left_out], labels, ("other", "stiction"))
    assert np.all(model.weights[1] == 0)
    assert np.allclose(model.weights[~left_out], alone.weights, atol=1e-3)
    assert np.allclose(model.probabilities(x), alone.probabilities(x[:, ~left_out]), atol=1e-3)


def test_detector_file_names_the_features_it_was_trained_on(tmp_path, detector):
    path = tmp_path / "d.json"
    detector.save(path)
    assert Detector.load(path).stiction.classes == detector.stiction.classes
    path.write_text(path.read_text().replace("regularity_log", "something_else"))
    with pytest.raises(ValueError, match="features"):
        Detector.load(path)



def test_a_models_folder_whose_detector_names_other_features_is_refused_with_a_model_error(tmp_path, detector):
    import shutil

    from stiction.quantify.pipeline import Quantifier
    from stiction.quantify.predictor import DEFAULT_MODELS_DIR, ModelError

    for f in list(DEFAULT_MODELS_DIR.glob("*.onnx")) + list(DEFAULT_MODELS_DIR.glob("*.card.json")):
        shutil.copy(f, tmp_path / f.name)
    detector.save(tmp_path / "detector.json")
    body = (tmp_path / "detector.json").read_text()
    (tmp_path / "detector.json").write_text(body.replace("bic_excess", "ngi"))  # a file trained before 2026-11-25
    with pytest.raises(ModelError, match="retrain it"):
        Quantifier(tmp_path)
    (tmp_path / "detector.json").write_text("not json")
    with pytest.raises(ModelError, match="detector.json"):
        Quantifier(tmp_path)

def _slow_loop(fs_pct: float, load_pct: float, seed: int):
    """A sticky valve (fd 0.7 fs) or a linear one under a slow load, under a slow PI (Kc 0.5)."""
    from tests.detect.loops import slow_flow_loop

    return slow_flow_loop(fs_pct, seed, load_pct=load_pct)


def test_a_valve_stuck_while_op_ramps_is_found_and_a_slow_load_followed_by_op_is_not(detector):
    from stiction.detect.verdict import STUCK_AT
    from tests.detect.loops import slow_flow_loops

    slow_flow_loops([dict(fs_pct=fs, seed=s, load_pct=load) for s in range(4) for fs, load in ((3.6, 0.0), (0.0, 1.0),
                                                                                            (0.0, 2.0))])  # fmt: skip

    assert detector.stuck is not None and detector.stuck.probability >= STICTION_AT  # the test can call it alone
    for seed in range(4):
        op, pv, sp, ts_s = _slow_loop(3.6, 0.0, seed)  # a band of 1.5 % of span
        ev = evidence(op, pv, ts_s, sp)
        assert ev.stuck_ramp >= STUCK_AT
        v = decide(detector, ev, [])
        assert v.verdict == "stiction" and v.stiction_probability >= detector.stuck.probability
        assert "stuck valve" in v.reason
        # a linear valve, OP following a slow load: PV wanders, OP does not ramp on a still PV
        for load_pct in (1.0, 2.0):
            op, pv, sp, ts_s = _slow_loop(0.0, load_pct, seed)
            assert evidence(op, pv, ts_s, sp).stuck_ramp < STUCK_AT


def test_the_stuck_valve_test_raises_the_probability_where_it_speaks_and_nowhere_else(detector):
    from dataclasses import replace

    from stiction.detect.verdict import StuckRule

    x = np.array([evidence(*_slow_loop(3.6, 0.0, s)[:2]).vector for s in range(3)])
    plain = replace(detector, stuck=None, step=None).stiction_probability(x)
    ramp = replace(detector, stuck=StuckRule(0.1, 0.97), step=None)
    ruled = ramp.stiction_probability(x, np.array([[0.0, 0.9], [0.1, 0.0], [0.5, 0.0]]))
    assert ruled[0] == plain[0] and ruled[1] == max(plain[1], 0.97) and ruled[2] == max(plain[2], 0.97)
    step = replace(detector, stuck=None, step=StuckRule(0.25, 0.93))
    ruled = step.stiction_probability(x, np.array([[0.9, 0.0], [0.0, 0.24], [0.0, 0.25]]))
    assert ruled[0] == plain[0] and ruled[1] == plain[1] and ruled[2] == max(plain[2], 0.93)
    assert np.array_equal(detector.stiction_probability(x), plain)  # without statistics, the logistic model alone


def test_measured_a_valve_that_sticks_between_setpoint_moves_shows_stuck_ramps_a_level_cycle_none(measured_evidence):
    from stiction.detect.verdict import STUCK_AT

    stuck = [ev.stuck_ramp for ev in measured_evidence("stic_2411FIC20102_10*.csv")]
    cycling = [ev.stuck_ramp for ev in measured_evidence("stic_2111LIC31102B_*.csv")]
    assert sum(s >= STUCK_AT for s in stuck) >= len(stuck) // 2 and max(cycling) == 0.0


def test_a_detector_file_without_the_stuck_valve_test_still_loads(tmp_path, detector):
    import json
    from dataclasses import replace

    path = tmp_path / "detector.json"
    replace(detector, stuck=None, step=None).save(path)
    assert "stuck_ramp" not in json.loads(path.read_text()) and "stuck_step" not in json.loads(path.read_text())
    assert Detector.load(path).stuck is None and Detector.load(path).step is None
    detector.save(path)
    assert Detector.load(path).stuck == detector.stuck and Detector.load(path).step == detector.step


def test_a_probability_short_of_the_verdict_is_said_to_lean_not_called_healthy(detector):
    from dataclasses import replace

    from stiction.detect.verdict import LEANS_AT

    op, pv, sp, ts_s = _slow_loop(0.0, 1.0, 0)
    ev = evidence(op, pv, ts_s, sp)
    for p in (0.3, 0.6, 0.9):  # a stiction model that says p whatever it sees
        logistic = replace(detector.stiction, weights=0 * detector.stiction.weights,
                           bias=np.array([0.0, np.log(p / (1 - p))]))  # fmt: skip
        v = decide(replace(detector, stiction=logistic, stuck=None, step=None, cycle=None), ev, [])
        assert v.stiction_probability == pytest.approx(p)
        assert (v.verdict == "stiction") == (p >= STICTION_AT)
        assert ("lean to stiction" in v.reason) == (LEANS_AT <= p < STICTION_AT)


def test_a_long_record_is_read_as_its_last_600_samples_are(detector):
    """The detector is trained on windows of 600 samples; an export or an agent's window holds 1,000 to
    3,600.  Hidden effect: the record's length.  Sticky flow loops cycling every 65-175 s, recorded
    every second: over 3,000 samples they must be read as over their last 600.  A feature that counted
    the window's cycles, or a bicoherence whose null level falls as 1/segments, read the long record's
    limit cycle as more like an external one (0.2 lower in median, one called not sticky)."""
    from stiction.sim.extensions import Extensions
    from stiction.sim.loop import LoopSpec
    from stiction.sim.plant_loops import PlantLoop, simulate_plant
    from stiction.sim.process import ProcessModel

    loops = []
    for seed, fs_pct in enumerate([6, 8, 10, 12, 15, 8, 10, 12]):
        process = ProcessModel(gain=1.0, time_constant_s=5.0, controller_gain=0.5 + 0.1 * seed, integral_time_s=5.0)
        spec = LoopSpec(fs_pct, 0.6 * fs_pct, process=process, extensions=Extensions(dead_time_s=1.0), seed=seed,
                        sp_pct=50.0)  # fmt: skip
        loops.append(PlantLoop(spec, "stiction", 1, 0.0, 0.0, 0.05, 0.0, ()))
    p_long, p_short = [], []
    for op, pv, sp, ts_s in simulate_plant(loops, samples=3000):
        p_long.append(decide(detector, evidence(op, pv, ts_s, sp), []).stiction_probability)
        p_short.append(decide(detector, evidence(op[-600:], pv[-600:], ts_s, sp[-600:]), []).stiction_probability)
    p_long, p_short = np.array(p_long), np.array(p_short)
    assert np.all(p_short >= STICTION_AT)  # the loops the detector was trained to see
    assert np.median(p_long - p_short) > -0.05
    assert np.all(p_long >= STICTION_AT)


def test_a_sticky_limit_cycle_is_called_whatever_the_historian_sampling(detector):
    """Hidden effect: the sample time.  Sticky flow loops of the independent simulator (Choudhury's valve,
    ``sim.two_parameter``, trained on by nothing), recorded every second and every 5 s: a limit cycle
    called sticky at 1 s (45-220 samples a period) must be called at 5 s (7-45).  A cycle model that read
    the cycles a window holds called the fast ones an external oscillation (two of six at 0.27 and 0.43)."""
    from dataclasses import replace

    from stiction.sim import two_parameter

    loops = [loop for loop in two_parameter.draw(10, 11) if loop.kind == "flow" and loop.cause == "stiction"]
    slow, fast = (
        two_parameter.simulate([replace(loop, ts_s=ts_s) for loop in loops], samples)
        for ts_s, samples in ((1.0, 3000), (5.0, 600))
    )  # every loop at each rate in one vectorised run
    cycles = 0
    for loop, *records in zip(loops, slow, fast, strict=True):
        evs = [evidence(r.op, r.pv, r.ts_s, r.sp) for r in records]
        v_slow, v_fast = (decide(detector, ev, []) for ev in evs)
        if v_slow.verdict == "stiction" and evs[1].oscillation.oscillating:
            cycles += 1
            assert v_fast.verdict == "stiction", (loop, v_slow.stiction_probability, v_fast.stiction_probability)
    assert cycles >= 4  # the draw holds limit cycles at both rates


def test_a_probability_short_of_the_threshold_never_reads_as_the_threshold():
    assert short_of(STICTION_AT - 4e-4, STICTION_AT) == f"{STICTION_AT - 0.01:.2f}"
    assert short_of(0.423, STICTION_AT) == "0.42" and short_of(0.4249, STICTION_AT) == "0.42"
    assert short_of(0.426, STICTION_AT) == "0.43"  # rounding up below the threshold is still honest


ATOL = 0.01
"""How far a weight (or a feature's mean or scale) of the detector this code trains may be from the shipped one's:
half the staleness ``test_the_shipped_detector_is_the_one_this_code_trains`` was written for (0.02), above what
another machine's instruction set moves (0.008)."""


@pytest.mark.slow
def test_the_shipped_detector_is_the_one_this_code_trains(tmp_path):
    """A change to the simulator or the evidence moves the detector's training windows, and a detector trained
    before it answers for code that no longer exists: the valve's slide along a lagged drive (944ebdf) moved the
    shipped general and cycle models by up to 0.02 in a weight, unnoticed until a retrain for another reason.

    Within ``ATOL``: the same code trains slightly other weights on another instruction set (on an AMD EPYC family
    25 model 1, without AVX-512, up to 0.008 in a weight and 0.002 in a feature's mean, against the Intel Xeon
    family 6 model 167 the shipped detector was trained on): the simulated loops' chaos carries numpy's vectorised
    math's last bits into the training windows."""
    import json

    from stiction.cli import main
    from stiction.detect.verdict import DETECTOR_FILE
    from stiction.quantify.predictor import DEFAULT_MODELS_DIR

    assert main(["train", "--detector", "--models", str(tmp_path)]) == 0
    fresh = json.loads((tmp_path / DETECTOR_FILE).read_text())
    shipped = json.loads((DEFAULT_MODELS_DIR / DETECTOR_FILE).read_text())
    stale = []

    def compare(a, b, path):
        if isinstance(a, dict) and isinstance(b, dict) and set(a) == set(b):
            for k in a:
                compare(a[k], b[k], f"{path}/{k}")
        elif isinstance(a, (int, float, list)) and not (isinstance(a, list) and a and isinstance(a[0], str)):
            x, y = np.asarray(a, float), np.asarray(b, float)
            if x.shape != y.shape or not np.allclose(x, y, rtol=1e-6, atol=ATOL):
                stale.append(path)
        elif a != b:
            stale.append(path)

    compare(shipped, fresh, "")
    assert not stale, f"the shipped detector is not what this code trains ({', '.join(stale)}): retrain it with " \
        "`stiction train --detector --replace-shipped`"


def test_the_statistics_and_the_window_network_combine_to_the_larger_unless_they_contradict_each_other():
    from stiction.detect.verdict import LEANS_AT, STICTION_AT, combined, disagree

    stats = np.array([0.2, 0.6, 0.4, 0.1, 0.9, 0.3])
    net = np.array([0.3, 0.7, 0.8, 0.9, 0.1, np.nan])
    p = combined(stats, net)
    np.testing.assert_allclose(p[:3], [0.3, 0.7, 0.8])  # agreeing, or one leaning: the larger
    assert disagree(stats, net).tolist() == [False, False, False, True, True, False]
    assert np.all((p[3:5] >= LEANS_AT) & (p[3:5] < STICTION_AT))  # contradicting: not settled either way
    assert p[5] == 0.3  # no network reading: the statistics'


def test_a_call_neither_reading_makes_surely_beside_a_lean_is_not_settled():
    from stiction.detect.verdict import LEANS_AT, STICTION_AT, SURE_AT, beside_cycle, combined, weakly_called

    below_sure = (STICTION_AT + SURE_AT) / 2
    leaning = (LEANS_AT + STICTION_AT) / 2
    stats = np.array([below_sure, leaning, SURE_AT, below_sure, below_sure, 0.2])
    net = np.array([leaning, below_sure, leaning, STICTION_AT, 0.2, below_sure])
    assert weakly_called(stats, net).tolist() == [True, True, False, False, False, False]
    p = combined(stats, net)
    assert np.all((p[:2] >= LEANS_AT) & (p[:2] < STICTION_AT))  # an unsure call beside a lean, either way round
    assert p[2] == SURE_AT  # a sure call stands beside a lean
    assert p[3] == below_sure  # both call: the larger
    assert np.all((p[4:] >= LEANS_AT) & (p[4:] < STICTION_AT))  # a contradiction, as before
    # beside a regular cycle the rule is not applied: an unsure cycle call the network leans to stands
    assert beside_cycle(np.array([below_sure]), np.array([leaning]))[0] == below_sure


def test_an_unsettled_verdict_says_why_in_its_reason(detector):
    """A window whose general-model reading calls it without being sure while the network only leans is reported as
    not settled, and its reason says that neither reading settled it."""
    from stiction.detect.verdict import LEANS_AT, STICTION_AT, SURE_AT, decide_rows

    rng = np.random.default_rng(5)
    loops = family_loops(1, SIM_SEED + 1919)
    recs = [r for r in simulate_families(loops) if stable(r)]
    evs = [evidence(r.op, r.pv, r.ts_s, r.sp) for r in recs]
    x = np.stack([ev.vector for ev in evs])
    alone = detector.stiction_probability(x, None, np.array([ev.oscillation.oscillating for ev in evs]))
    general = [i for i, ev in enumerate(evs) if not ev.oscillation.oscillating and ev.stuck.max() == 0]
    assert general
    # the network's reading chosen beside each window's own statistics so that exactly one of the two calls, unsurely
    seq = np.array([STICTION_AT + (SURE_AT - STICTION_AT) * rng.uniform(0.1, 0.9) if a < STICTION_AT
                    else (LEANS_AT + STICTION_AT) / 2 for a in alone])  # fmt: skip
    verdicts = decide_rows(detector, [evs[i] for i in general], [[]] * len(general), [False] * len(general),
                           seq[general])  # fmt: skip
    unsure = 0
    for i, v in zip(general, verdicts, strict=True):
        lo = min(alone[i], seq[i])
        if LEANS_AT <= lo < STICTION_AT and max(alone[i], seq[i]) < SURE_AT:
            unsure += 1
            assert v.verdict != "stiction" and LEANS_AT <= v.stiction_probability < STICTION_AT
            assert "short of the 0.8 a sure call needs" in v.reason
        else:
            assert "a sure call needs" not in v.reason
        assert "beside a cycle the statistics read surely healthy" not in v.reason  # the cycle's rule, not this one's
    assert unsure >= 3, f"only {unsure} windows read unsurely: the test does not exercise the rule"


def test_beside_a_cycle_the_network_raises_a_call_or_unsettles_one_the_cycle_model_is_not_sure_of():
    from stiction.detect.verdict import CYCLE_SURE_AT, LEANS_AT, STICTION_AT, beside_cycle

    sure, unsure = CYCLE_SURE_AT, (STICTION_AT + CYCLE_SURE_AT) / 2
    cycle = np.array([sure, sure, 0.2, 0.2, 0.6, unsure, unsure, unsure])
    net = np.array([0.1, 0.9, 0.9, 0.1, np.nan, 0.1, LEANS_AT, 0.9])
    p = beside_cycle(cycle, net)
    assert p[0] == sure and p[1] == 0.9  # a sure call stands whatever the network reads; the network may raise it
    assert LEANS_AT <= p[2] < STICTION_AT  # the network reads a fault the cycle model reads healthy: not settled
    assert p[3] == 0.2 and p[4] == 0.6  # agreeing healthy, or no network reading: the cycle model's
    assert LEANS_AT <= p[5] < STICTION_AT  # an unsure call the network reads as healthy: not settled
    assert p[6] == unsure and p[7] == 0.9  # an unsure call the network only leans against, or agrees with, stands


def test_beside_a_cycle_read_surely_healthy_a_lean_of_the_network_does_not_unsettle_it():
    from stiction.detect.verdict import CYCLE_HEALTHY_AT, LEANS_AT, STICTION_AT, beside_cycle

    leaning = (LEANS_AT + STICTION_AT) / 2
    healthy, unsure_healthy = CYCLE_HEALTHY_AT / 2, (CYCLE_HEALTHY_AT + LEANS_AT) / 2
    below_lean = (CYCLE_HEALTHY_AT + LEANS_AT) / 2
    cycle = np.array([healthy, healthy, healthy, unsure_healthy, healthy, healthy])
    net = np.array([leaning, STICTION_AT, 0.9, leaning, np.nan, below_lean])
    p = beside_cycle(cycle, net)
    assert p[0] == healthy  # a lean beside a sure healthy reading: healthy
    assert np.all((p[1:3] >= LEANS_AT) & (p[1:3] < STICTION_AT))  # the network calls it: a contradiction, unsettled
    assert p[3] == leaning  # a cycle not surely healthy: the lean stands, not settled
    assert p[4] == healthy  # no network reading
    assert p[5] == below_lean  # both healthy: the larger, as before the rule (it speaks only beside a lean)


def test_a_cycle_read_surely_healthy_beside_a_leaning_network_is_reported_healthy_and_says_so(detector):
    """A regular cycle the cycle model reads surely healthy, beside a network set to lean, is reported as another
    cause at the cycle model's probability, and its reason says the network only leaned."""
    from stiction.detect.verdict import CYCLE_HEALTHY_AT, LEANS_AT, STICTION_AT, decide_rows

    loops = [lp for lp in family_loops(2, SIM_SEED + 2323) if lp.cause in ("sine", "square", "triangle")]
    recs = [r for r in simulate_families(loops) if stable(r)]
    evs = [evidence(r.op, r.pv, r.ts_s, r.sp) for r in recs]
    x = np.stack([ev.vector for ev in evs])
    osc = np.array([ev.oscillation.oscillating for ev in evs])
    alone = detector.stiction_probability(x, np.stack([ev.stuck for ev in evs]), osc)
    picked = [i for i in range(len(evs)) if osc[i] and alone[i] < CYCLE_HEALTHY_AT]
    assert len(picked) >= 3, f"only {len(picked)} cycles read surely healthy: the test does not exercise the rule"
    leaning = (LEANS_AT + STICTION_AT) / 2
    verdicts = decide_rows(detector, [evs[i] for i in picked], [[]] * len(picked), [False] * len(picked),
                           np.full(len(picked), leaning))  # fmt: skip
    for i, v in zip(picked, verdicts, strict=True):
        assert v.verdict == "other_cause" and v.stiction_probability == pytest.approx(alone[i])
        assert "a lean, beside a cycle the statistics read surely healthy" in v.reason


def test_the_network_speaks_beside_the_general_and_the_cycle_model_but_not_the_canonical_loops(detector):
    from stiction.detect.features import NAMES
    from stiction.detect.verdict import beside_cycle, combined

    x = np.zeros((4, len(NAMES)))
    seq = np.array([0.99, 0.99, 0.99, np.nan])
    osc, canon = np.array([False, True, False, True]), np.array([False, False, True, False])
    base = detector.stiction_probability(x, None, osc, canon)
    with_net = detector.stiction_probability(x, None, osc, canon, seq)
    assert base[0] != base[1]  # the general and the cycle model read the same statistics differently
    for k, rule in ((0, combined), (1, beside_cycle)):  # each beside its own statistics' model
        assert with_net[k] == pytest.approx(float(rule(base[k : k + 1], seq[k : k + 1])[0]))
        assert with_net[k] != base[k]
    assert with_net[2] == base[2]  # the canonical loop's model speaks alone
    assert with_net[3] == base[3]  # a window the network did not read: the cycle model alone


def test_verdicts_made_together_are_each_windows_own_verdict(detector):
    """``decide_rows`` (the pipeline's: the models run once on every window) against ``decide`` window by window: the
    same verdicts to the last bit, whatever windows are beside one, over windows that cycle and do not, data
    problems, the canonical loop, and a window network that spoke, did not, or read nothing."""
    from stiction.detect.verdict import decide_rows

    loops = family_loops(1, SIM_SEED + 1717)
    recs = [r for r in simulate_families(loops) if stable(r)]
    evs = [evidence(r.op, r.pv, r.ts_s, r.sp) for r in recs]
    assert any(ev.oscillation.oscillating for ev in evs) and not all(ev.oscillation.oscillating for ev in evs)
    rng = np.random.default_rng(5)
    blocked = [["PV does not move"] if k % 9 == 4 else [] for k in range(len(evs))]
    canonical = [k % 7 == 3 for k in range(len(evs))]
    network = [None if k % 5 == 0 else (np.nan if k % 5 == 1 else float(rng.uniform())) for k in range(len(evs))]
    together = decide_rows(detector, evs, blocked, canonical, network)
    alone = [decide(detector, *args) for args in zip(evs, blocked, canonical, network, strict=True)]
    assert together == alone
    assert decide_rows(detector, evs[3:8], blocked[3:8], canonical[3:8], network[3:8]) == alone[3:8]
    kinds = {v.verdict for v in together}
    assert {"stiction", "bad_data"} <= kinds and kinds & {"other_cause", "no_oscillation"}
    assert any(v.sequence for v in together) and not all(v.sequence for v in together)
