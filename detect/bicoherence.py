"""Choudhury's bicoherence test for a nonlinear loop (Choudhury, Shah & Thornhill 2004,
"Diagnosis of poor control-loop performance using higher-order statistics", Automatica 40).

A linear loop driven by Gaussian noise has a flat, insignificant squared bicoherence; a
nonlinearity such as stiction couples frequencies.  ``NGI`` (non-Gaussianity index: mean
squared bicoherence less its 95 % significance level) and ``NLI`` (nonlinearity index: how far
the peak stands out) decide: nonlinear where ``NGI > 0.001`` and ``NLI > 0.01``.  A
nonlinear oscillating loop is then read as sticky, and the apparent band S is the width of an
ellipse fitted to the PV-OP plot (Choudhury, Thornhill & Shah 2005) along OP.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from stiction.detect import kernels
from stiction.detect.oscillation import Detrended, detrend, detrended

NGI_MIN = 0.001
NLI_MIN = 0.01
CHI2_2DOF_95 = 5.991


@dataclass(frozen=True)
class Bicoherence:
    ngi: float
    nli: float
    nonlinear: bool
    excess: float = float("nan")
    """Mean squared bicoherence less its expectation for a linear Gaussian signal, ``1/K`` over K
    segments: near 0 for a linear loop whatever the window's length.  Choudhury's NGI subtracts the
    single value's 95 % level, ``5.99/(2K)``, so that a linear loop's NGI is about ``-2/K``: -0.25
    over 600 samples, -0.07 over 1,800; a feature that follows the window's length, not the loop."""
    peak_excess: float = float("nan")
    """The largest squared bicoherence less its expectation over M values of a linear Gaussian signal,
    ``1 - M^(-1/(K-1))`` (each value Beta(1, K-1)): near 0 for a linear loop at any length, where
    Choudhury's NLI falls as 1/K (0.30 over 600 samples, 0.15 over 1,800)."""


def squared_bicoherence(x: np.ndarray, segment: int) -> tuple[np.ndarray, int]:
    """[F, F] squared bicoherence over the principal domain (others nan) and the segment count."""
    f = segment // 2
    values, k = _domain_values(x, segment)
    b2 = np.full((f, f), np.nan)
    i1, i2 = _domain(f)
    b2[i1, i2] = values
    return b2, k


def _domain_values(x: np.ndarray, segment: int, d: Detrended | None = None) -> tuple[np.ndarray, int]:
    """The squared bicoherence at each pair of ``_domain`` (nan where undefined) and the segment count:
    half-overlapping Hann-windowed segments, one FFT for all, the sums over segments compiled."""
    d = d if d is not None else detrended(np.asarray(x, float))
    x = d.y / (d.sd or 1.0)
    step = segment // 2
    starts = np.arange(0, x.size - segment + 1, step)
    segs = x[starts[:, None] + np.arange(segment)]  # [K, segment], half overlapping
    spectra = np.fft.fft(_hann(segment) * (segs - segs.mean(axis=1, keepdims=True)), axis=1)
    i1, i2 = _domain(segment // 2)  # only the principal domain is computed
    return kernels.squared_bicoherence(spectra, i1, i2), len(starts)


@functools.lru_cache(maxsize=8)
def _hann(segment: int) -> np.ndarray:
    """The Hann window of a segment (read-only, cached: the same few lengths for every window)."""
    w = np.hanning(segment)
    w.flags.writeable = False
    return w


@functools.lru_cache(maxsize=8)
def _domain(f: int) -> tuple[np.ndarray, np.ndarray]:
    """Frequency index pairs of the principal domain: 0 < i2 <= i1, i1 + i2 < f (read-only, cached)."""
    i1, i2 = np.meshgrid(np.arange(f), np.arange(f), indexing="ij")
    inside = (i2 <= i1) & (i1 + i2 < f) & (i2 > 0)
    out = np.ascontiguousarray(i1[inside]), np.ascontiguousarray(i2[inside])
    for a in out:
        a.flags.writeable = False
    return out


def test(x: np.ndarray, d: Detrended | None = None) -> Bicoherence:
    """NGI and NLI of one signal (the control error or PV; ``d``: its ``detrended``, where the caller has it)."""
    n = np.asarray(x).size
    segment = 2 ** min(max(math.floor(math.log2(n / 4)), 5), 7) if n > 0 else 32  # 32..128, at least ~7 segments
    b2, k = _domain_values(x, segment, d)
    values = b2[np.isfinite(b2)]
    if values.size == 0 or k < 2:
        return Bicoherence(float("nan"), float("nan"), False)
    threshold = CHI2_2DOF_95 / (2 * k)
    mean, peak = float(values.mean()), float(values.max())
    ngi = mean - threshold  # the mean over the principal domain against its 95 % level
    nli = abs(peak - (mean + 2 * float(values.std())))
    excess = mean - 1.0 / k
    peak_excess = peak - (1.0 - values.size ** (-1.0 / (k - 1)))
    return Bicoherence(ngi, nli, bool(ngi > NGI_MIN and nli > NLI_MIN), excess, peak_excess)


def ellipse_band_pct(op: np.ndarray, pv: np.ndarray) -> float:
    """Apparent band S: the width along OP of the ellipse through the PV-OP plot's covariance, % of span.

    The ellipse ``[op, pv] C^-1 [op, pv]' = 2`` (the one a sinusoid traces) meets the OP axis
    at ``pv = 0``: S is the distance between those two points.
    """
    d = np.stack([detrend(np.asarray(op, float)), detrend(np.asarray(pv, float))])
    c = np.cov(d)
    try:
        inv = np.linalg.inv(c)
    except np.linalg.LinAlgError:
        return float("nan")
    return float(2 * np.sqrt(2 / inv[0, 0])) if inv[0, 0] > 0 else float("nan")
