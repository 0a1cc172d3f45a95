"""Training sets for the detector: simulated plant loops in families (``sim.plant_families``),
labelled by what each window shows, the thesis's own sticky loops, and (optionally) labelled
measured windows given as feature vectors.

A window is ``stiction`` where it shows a valve fault in the two-parameter sense (a band S,
with or without a slip: backlash counts); otherwise it is the look-alike it was given
(``LOOK_ALIKE_CLASS``), or ``noise`` for a faulty valve the window never exercises."""

from __future__ import annotations

import numpy as np

from stiction.detect.features import evidence
from stiction.detect.verdict import STEP_AT, Detector, fit_logistic, fit_stuck_rule
from stiction.sim.grid import random_loops
from stiction.sim.loop import simulate
from stiction.sim.plant_families import FAMILIES, family_loops, simulate_families, stable

LOOK_ALIKE_CLASS = {
    "sine": "external_oscillation",
    "triangle": "external_oscillation",
    "square": "external_oscillation",
    "tuning": "tuning",
    "quantization": "quantization",
    "compression": "quantization",
    "noise": "noise",
}
"""The look-alike a family cause stands for in the report's ``likely_cause``."""
OTHERS = ("external_oscillation", "tuning", "quantization", "noise")
DETECTOR_FILE = "detector.json"
SIM_SEED = 7
N_PER_CAUSE = 20
"""Family loops of each cause in each family the shipped detector is trained on (880 in all)."""
THESIS_SHARE = 3
"""Canonical sticky loops per family cause, noisy and noise-free each (120 beside the 880)."""
"""Offset of the detector's simulated training seed; ``bench detect`` evaluates on other seeds."""
MEASURED_WEIGHT = 5.0
"""Weight of one measured tag (split over its windows) against one simulated loop."""


def simulated_set(n_per_cause: int, seed: int, families: tuple[str, ...] = FAMILIES):
    """Feature vectors, classes and stuck-valve statistics (``Evidence.stuck``, [n, 2]) of the family
    loops (``n_per_cause`` of every cause in every family) and of ``2 * THESIS_SHARE * n_per_cause``
    canonical (thesis) sticky loops, half of them noise-free (the thesis's own loop is recognised as
    sticky without flags); and each row's family (``"thesis"`` for those)."""
    loops = family_loops(n_per_cause, seed, families)
    evs, classes, family = [], [], []
    for loop, rec in zip(loops, simulate_families(loops), strict=True):
        if stable(rec):
            evs.append(evidence(rec.op, rec.pv, rec.ts_s, rec.sp))
            classes.append("stiction" if rec.shows_fault else LOOK_ALIKE_CLASS.get(loop.cause, "noise"))
            family.append(loop.family)
    n_thesis = THESIS_SHARE * n_per_cause
    canonical = random_loops(n_thesis, seed + 1) + random_loops(n_thesis, seed + 2, noisy=False)
    thesis = simulate(canonical).kept()
    for i in range(thesis.op.shape[0]):
        evs.append(evidence(thesis.op[i], thesis.pv[i], 1.0, thesis.sp[i]))
        classes.append("stiction")
        family.append("thesis")
    x = np.nan_to_num(np.array([e.vector for e in evs]))
    return x, classes, np.array([e.stuck for e in evs]), family


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
