"""The verdict on loops with a hidden cause: the shipped detector, loops of a seed it was not trained on."""

import numpy as np
import pytest

from agent.predictor import DEFAULT_MODELS_DIR
from detect.features import evidence
from detect.training import DETECTOR_FILE, SIM_SEED
from detect.verdict import Detector, decide, fit_logistic
from sim.plant_loops import plant_loops, simulate_plant, stable


@pytest.fixture(scope="module")
def detector():
    return Detector.load(DEFAULT_MODELS_DIR / DETECTOR_FILE)


@pytest.fixture(scope="module")
def judged(detector):
    loops = plant_loops(12, SIM_SEED + 1000)
    out = {}
    for loop, (op, pv, sp, ts_s) in zip(loops, simulate_plant(loops), strict=True):
        if not stable(op, pv):
            continue
        out.setdefault(loop.cause, []).append(decide(detector, evidence(op, pv, ts_s, sp), []))
    return out


def test_look_alikes_are_rarely_called_stiction(judged):
    others = [v for cause, vs in judged.items() if cause != "stiction" for v in vs]
    called = sum(v.verdict == "stiction" for v in others)
    assert called <= 0.1 * len(others)


def test_sticky_plant_loops_are_called_sticky_more_often_than_not_given_the_probability(judged):
    sticky = [v.stiction_probability for v in judged["stiction"]]
    others = [v.stiction_probability for c, vs in judged.items() if c != "stiction" for v in vs]
    assert np.median(sticky) > np.quantile(others, 0.9)


def test_an_external_load_oscillation_is_another_cause_not_stiction(judged):
    verdicts = judged["external_oscillation"]
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


def test_detector_file_names_the_features_it_was_trained_on(tmp_path, detector):
    path = tmp_path / "d.json"
    detector.save(path)
    assert Detector.load(path).stiction.classes == detector.stiction.classes
    path.write_text(path.read_text().replace("regularity_log", "something_else"))
    with pytest.raises(ValueError, match="features"):
        Detector.load(path)
