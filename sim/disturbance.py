"""Disturbances of thesis 4.2 with the relative amplitudes of ``spec/thesis-loop.md``.

A disturbance of coefficient c on the input is ``c * RMS(MV_clean)`` times a unit
shape, on the output ``c * RMS(PV_clean)`` times a unit shape, where ``*_clean``
is the same loop without disturbance over the kept samples (mean removed).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

Shape = Literal["sine", "gaussian", "brownian"]
Where = Literal["input", "output"]


@dataclass(frozen=True)
class Disturbance:
    shape: Shape
    where: Where
    coefficient: float
    omega_rad_s: float | None = None
    """Angular frequency of a sine, rad/s."""

    def __post_init__(self):
        if self.shape not in ("sine", "gaussian", "brownian"):
            raise ValueError(f"unknown disturbance shape {self.shape!r}: expected sine, gaussian or brownian")
        if self.where not in ("input", "output"):
            raise ValueError(f"disturbance must act on 'input' or 'output', not {self.where!r}")
        if self.shape == "sine" and not self.omega_rad_s:
            raise ValueError("a sine disturbance needs omega_rad_s > 0")
        if not np.isfinite(self.coefficient) or self.coefficient < 0:
            raise ValueError(f"disturbance coefficient must be finite and >= 0, got {self.coefficient}")

    def label(self) -> str:
        shape = f"sine({self.omega_rad_s:.3g})" if self.shape == "sine" else self.shape
        return f"{self.where}, {self.coefficient:.3g} {shape}"


def kasdin_ar_coefficients(alpha: float, order: int = 63) -> np.ndarray:
    """AR filter of Kasdin's power-law noise: ``a0 = 1, a_k = (k - 1 - alpha/2) a_{k-1} / k``."""
    a = np.empty(order + 1)
    a[0] = 1.0
    for k in range(1, order + 1):
        a[k] = (k - 1 - alpha / 2) * a[k - 1] / k
    return a


def unit_shape(
    shape: Shape, n_samples: int, ts_s: float, rng: np.random.Generator, omega_rad_s: float | None = None
) -> np.ndarray:
    """The unit disturbance shape of thesis 4.2 over a record of ``n_samples``."""
    if shape == "sine":
        return np.sin(omega_rad_s * ts_s * np.arange(n_samples))
    white = rng.standard_normal(n_samples)
    if shape == "gaussian":
        return white
    from scipy.signal import lfilter  # here: its import costs every process that only names this module half a second

    coloured = lfilter([1.0], kasdin_ar_coefficients(2.0), white)
    coloured = coloured - coloured.mean()
    return coloured / np.sqrt(np.mean(coloured**2))


def rms(x: np.ndarray, axis: int = -1) -> np.ndarray:
    """Root mean square after removing the mean."""
    return np.sqrt(np.mean((x - x.mean(axis=axis, keepdims=True)) ** 2, axis=axis))


def periodic_wave(shape: str, phase: np.ndarray) -> np.ndarray:
    """A unit wave of ``phase`` (cycles, in [0, 1)): ``sine``, ``triangle`` (1 at the cycle's start, -1 at its
    middle) or ``square`` (1 in its first half)."""
    if shape == "sine":
        return np.sin(2 * np.pi * phase)
    if shape == "triangle":
        return 4 * np.abs(phase - 0.5) - 1
    if shape == "square":
        return np.where(phase < 0.5, 1.0, -1.0)
    raise ValueError(f"wave shape {shape!r}: one of sine, triangle, square")


def first_order(x: np.ndarray, keep: float, settled: bool = False) -> np.ndarray:
    """``x`` through ``y[k] = keep * y[k-1] + (1 - keep) * x[k]``, from rest or (``settled``) from ``x[0]``."""
    from scipy.signal import lfilter  # here, not at import: the agent loads the simulator's loop, not this

    zi = [keep * x[0]] if settled else [0.0]
    return lfilter([1 - keep], [1, -keep], x, zi=zi)[0]

