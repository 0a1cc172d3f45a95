"""Training sets for the detector: simulated plant-like loops of every class, the thesis's own
sticky loops, and (optionally) labelled measured windows given as feature vectors."""

from __future__ import annotations

import numpy as np

from detect.features import evidence
from detect.verdict import STEP_AT, Detector, fit_logistic, fit_stuck_rule
from sim.grid import random_loops
from sim.loop import simulate
from sim.plant_loops import CLASSES, plant_loops, simulate_plant, stable

OTHERS = tuple(c for c in CLASSES if c != "stiction")
DETECTOR_FILE = "detector.json"
SIM_SEED = 7
"""Offset of the detector's simulated training seed; ``bench detect`` evaluates on other seeds."""
MEASURED_WEIGHT = 5.0
"""Weight of one measured tag (split over its windows) against one simulated loop."""


def simulated_set(n_per_class: int, seed: int) -> tuple[np.ndarray, list[str], np.ndarray]:
    """Feature vectors, causes and stuck-valve statistics (``Evidence.stuck``, [n, 2]) of plant-like
    loops and of twice as many canonical (thesis) sticky loops, half of them noise-free: the
    thesis's own loop must be recognised as sticky without flags."""
    loops = plant_loops(n_per_class, seed)
    evs, causes = [], []
    for loop, (op, pv, sp, ts_s) in zip(loops, simulate_plant(loops), strict=True):
        if stable(op, pv):
            evs.append(evidence(op, pv, ts_s, sp))
            causes.append(loop.cause)
    canonical = random_loops(n_per_class, seed + 1) + random_loops(n_per_class, seed + 2, noisy=False)
    thesis = simulate(canonical).kept()
    for i in range(thesis.op.shape[0]):
        evs.append(evidence(thesis.op[i], thesis.pv[i], 1.0, thesis.sp[i]))
        causes.append("stiction")
    return np.nan_to_num(np.array([e.vector for e in evs])), causes, np.array([e.stuck for e in evs])


def train(
    x: np.ndarray,
    causes: list[str],
    measured_x: np.ndarray | None = None,
    measured_sticky: list[bool] | None = None,
    measured_tags: list[str] | None = None,
    trained_on: str = "",
    stuck: np.ndarray | None = None,
) -> Detector:
    """The stiction model on everything given; the cause model on the simulated look-alikes; the
    stuck-valve rules (``stuck``: the simulated windows' ``Evidence.stuck``) on the simulated windows only."""
    labels = ["stiction" if c == "stiction" else "other" for c in causes]
    weights = np.ones(len(labels))
    features = x
    if measured_x is not None and len(measured_x):
        tags = list(measured_tags or range(len(measured_x)))
        count = {t: tags.count(t) for t in tags}
        features = np.vstack([x, np.nan_to_num(measured_x)])
        labels += ["stiction" if s else "other" for s in measured_sticky]
        weights = np.concatenate([weights, [MEASURED_WEIGHT / count[t] for t in tags]])
    stiction = fit_logistic(features, labels, ("other", "stiction"), weights)
    others = [i for i, c in enumerate(causes) if c != "stiction"]
    cause = fit_logistic(x[others], [causes[i] for i in others], OTHERS)
    ramp = step = None
    if stuck is not None:
        stuck = np.asarray(stuck, float).reshape(-1, 2)
        ramp, step = fit_stuck_rule(stuck[:, 0], causes), fit_stuck_rule(stuck[:, 1], causes, STEP_AT)
    return Detector(stiction, cause, trained_on, ramp, step)
