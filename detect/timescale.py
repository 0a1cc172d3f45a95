"""How many samples a loop's record takes to change, and the sampling the verdict reads it at.

The detector and the window network are trained on the simulated families' windows of ``WINDOW_SAMPLES``
samples, recorded at the families' sample times (``sim.plant_families``).  A historian that records the same loop
several times faster gives the same course in several times the samples: the window network's chunks of 600
samples then hold a fraction of what it was trained to see, and the statistics read cycles of more samples than
any training window held.  Recorded 5 times faster (design seed 3232's slow, level and detuned loops, 3,000
samples), the same loops' windows that show a fault were called 41 % of the time against 59 %, and the settled
balanced accuracy fell from 0.94 to 0.84 (docs/benchmarks.md, "A record sampled faster than the families").

The measure of the record's time scale is PV's half-life: the lag at which the autocorrelation of PV (its noise
median-filtered away, its trend removed) first falls below one half.  A record whose half-life is longer than
nearly every training window's (``HALF_LIFE_MAX``) is read by the verdict at every ``step``-th sample, the step
that brings its half-life to the training windows' median (``HALF_LIFE_TARGET``), where the record is long enough
to keep a training window's length at the coarser sampling.  The readings of S and J read every sample.
"""

from __future__ import annotations

import numpy as np

from stiction.detect import kernels

WINDOW_SAMPLES = 600
"""The families' window, which the detector and the window network are trained on (``sim.plant_families``)."""
EDGE_MEDIAN = 5
"""PV is median-filtered over this many samples first (as ``detect.features`` reads edges): white measurement
noise would otherwise put the autocorrelation's first lag below a half in a noisy record of any time scale."""
HALF_AT = 0.5
HALF_LIFE_MAX = 65.0
"""Samples: the 95th percentile of the half-life over the training seed's family windows (seed 7, 957 windows at
both band scales: 64 and 66).  Read off the training windows, not chosen on any verdict."""
HALF_LIFE_TARGET = 22.0
"""Samples: the median half-life of those windows (21 and 23)."""


def half_life(pv: np.ndarray) -> np.ndarray:
    """[W] each row's half-life in samples (``HALF_AT``; nan for a flat row, half the row's length where the
    autocorrelation never falls that low)."""
    pv = np.atleast_2d(np.asarray(pv, float))
    n = pv.shape[1]
    y = kernels.running_median_rows(np.ascontiguousarray(pv), EDGE_MEDIAN)
    t = np.arange(n, dtype=float) - (n - 1) / 2
    y = y - y.mean(axis=1, keepdims=True)
    y = y - np.outer(y @ t / (t @ t), t)  # the trend removed: a least-squares line through each row
    spectrum = np.fft.rfft(y, 2 * n, axis=1)
    acf = np.fft.irfft(spectrum * np.conj(spectrum), axis=1)[:, : n // 2]
    out = np.full(pv.shape[0], np.nan)
    for i, a in enumerate(acf):
        if a[0] > 0:
            below = np.flatnonzero(a < HALF_AT * a[0])
            out[i] = below[0] if below.size else n // 2
    return out


def verdict_steps(pv: np.ndarray) -> np.ndarray:
    """[W] int: the sampling step the verdict reads each row of ``pv`` [W, N] at (1: every sample).  Only a row
    whose half-life exceeds ``HALF_LIFE_MAX`` is thinned, by the step that brings it nearest ``HALF_LIFE_TARGET``,
    and never below ``WINDOW_SAMPLES`` samples."""
    pv = np.atleast_2d(np.asarray(pv, float))
    most = pv.shape[1] // WINDOW_SAMPLES
    steps = np.ones(pv.shape[0], int)
    if most < 2:
        return steps
    h = half_life(pv)
    slow = np.isfinite(h) & (h > HALF_LIFE_MAX)
    steps[slow] = np.clip(np.rint(h[slow] / HALF_LIFE_TARGET), 1, most).astype(int)
    return steps


def thinned(x: np.ndarray, step: int) -> np.ndarray:
    """Every ``step``-th sample of the last axis, the last sample kept (a record's end is its newest data)."""
    x = np.asarray(x)
    return x[..., (x.shape[-1] - 1) % step :: step]
