"""The model-free half of the pipeline: period, denoising, features, physical reading.

Pure numpy, batched over windows of equal length.  The trainer computes its
features with this very function, so training and inference see the same inputs.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from stiction.quantify import features, inlpca, physical
from stiction.quantify.acf import acf_period

ROUGHNESS_NOISY = 0.05
"""Median |second difference| over median |first difference| of OP above which a window is noisy.

A noise-free stiction OP is a chain of ramps, broken only at slips (about 0.01 here).
"""


@dataclass(frozen=True)
class WindowAnalysis:
    period_s: np.ndarray  # [W]
    regularity: np.ndarray  # [W] ACF peak height
    roughness: np.ndarray  # [W]
    noisy: np.ndarray  # [W] bool: the thesis chain denoises these
    fit: inlpca.InlpcaFit
    thesis_input: np.ndarray  # [W, 100] raw window, or the rebuilt OP for noisy windows
    cycle_input: np.ndarray  # [W, CYCLE_FEATURES]
    physical: physical.PhysicalReading


def roughness(op: np.ndarray) -> np.ndarray:
    d1 = np.median(np.abs(np.diff(op, axis=1)), axis=1)
    d2 = np.median(np.abs(np.diff(op, n=2, axis=1)), axis=1)
    return d2 / np.maximum(d1, 1e-12)


def analyse(
    op: np.ndarray,
    pv: np.ndarray,
    ts_s: float = 1.0,
    settings: inlpca.InlpcaSettings = inlpca.DEFAULT_SETTINGS,
    denoise: bool | None = None,
    physical_reading: bool = True,
) -> WindowAnalysis:
    """[W, N] OP and PV windows (percent, sample time ``ts_s``) -> everything the predictors need.

    ``denoise``: whether the thesis chain uses the rebuilt OP; by default where OP is rough.
    ``physical_reading``: False skips it (all nan), for callers that never use it (the trainer).
    """
    op, pv = np.atleast_2d(op).astype(float), np.atleast_2d(pv).astype(float)
    period_s, regularity = acf_period(op, ts_s)
    rough = roughness(op)
    noisy = rough > ROUGHNESS_NOISY if denoise is None else np.full(op.shape[0], denoise)
    fit = inlpca.fit(op, pv, settings)
    raw = features.thesis_window(op)
    rebuilt = features.rebuilt_op(fit, period_s, ts_s)
    thesis_input = np.where(noisy[:, None], rebuilt, raw)
    cycle_input = features.cycle_features(fit, period_s)
    reading = physical.read_best(op, pv, ts_s) if physical_reading else physical.no_reading(op.shape[0])
    return WindowAnalysis(period_s, regularity, rough, noisy, fit, thesis_input, cycle_input, reading)


def analyse_where(op, pv, ts_s, denoise, need: np.ndarray, level: np.ndarray) -> WindowAnalysis:
    """``analyse`` of the windows in ``need`` (the physical reading only of the ``level`` ones), the
    others left empty: nan, no fit, not denoised; the ACF period for every window."""
    n = op.shape[0]
    if need.all() and level.all():
        return analyse(op, pv, ts_s, denoise=denoise)
    period_s, regularity = acf_period(op, ts_s)
    reading = physical.no_reading(n)
    if level.any():
        reading = _scatter(reading, physical.read_best(op[level], pv[level], ts_s), level)
    empty = WindowAnalysis(
        period_s, regularity, np.full(n, np.nan), np.zeros(n, bool), inlpca.no_fit(op.shape),
        np.full((n, features.THESIS_WINDOW), np.nan), np.full((n, features.CYCLE_FEATURES), np.nan), reading,
    )  # fmt: skip
    if not need.any():
        return empty
    some = analyse(op[need], pv[need], ts_s, denoise=denoise, physical_reading=False)
    return dataclasses.replace(
        empty,
        roughness=_put(empty.roughness, some.roughness, need),
        noisy=_put(empty.noisy, some.noisy, need),
        fit=_scatter(empty.fit, some.fit, need),
        thesis_input=_put(empty.thesis_input, some.thesis_input, need),
        cycle_input=_put(empty.cycle_input, some.cycle_input, need),
    )


def _put(full: np.ndarray, part: np.ndarray, where: np.ndarray) -> np.ndarray:
    out = full.copy()
    out[where] = part
    return out


def _scatter(full, part, where: np.ndarray):
    """A dataclass of per-window arrays, ``part``'s rows put where ``where`` is true."""
    values = {}
    for f in dataclasses.fields(full):
        a, b = getattr(full, f.name), getattr(part, f.name)
        values[f.name] = (
            tuple(_put(x, y, where) for x, y in zip(a, b, strict=True)) if isinstance(a, tuple) else _put(a, b, where)
        )
    return type(full)(**values)
