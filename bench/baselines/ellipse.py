"""Choudhury's apparent stiction from an ellipse fitted to the PV-OP plot (Choudhury, Shah & Thornhill 2008).

OP and PV are band-pass filtered around the oscillation (frequency-domain filter,
0.5 to 2 times the ACF frequency, as their Wiener filter does), an ellipse is fitted
by direct least squares (Fitzgibbon et al. 1999, in Halir & Flusser's stable form)
and the apparent stiction is its largest width along OP:
``2 m n / sqrt(m^2 sin^2 a + n^2 cos^2 a)`` with semi-axes m, n and angle a.

It measures the band S only, in OP percent; here ``fs_pct = 12 S / 5`` (this valve).
It does not give fd.
"""

from __future__ import annotations

import numpy as np

from stiction.quantify.acf import acf_period
from stiction.sim.valve import PCT_OF_500LBF_PER_PCT_OF_SPAN


def _band_pass(x: np.ndarray, period_s: float, ts_s: float) -> np.ndarray:
    spectrum = np.fft.rfft(x - x.mean())
    f = np.fft.rfftfreq(x.size, ts_s)
    f0 = 1.0 / period_s
    spectrum[(f < 0.5 * f0) | (f > 2.0 * f0)] = 0
    return np.fft.irfft(spectrum, x.size)


def fit_ellipse(x: np.ndarray, y: np.ndarray) -> np.ndarray | None:
    """Conic coefficients (a, b, c, d, e, f) of ``a x^2 + b xy + c y^2 + d x + e y + f = 0``, or None."""
    d1 = np.column_stack([x * x, x * y, y * y])
    d2 = np.column_stack([x, y, np.ones_like(x)])
    s1, s2, s3 = d1.T @ d1, d1.T @ d2, d2.T @ d2
    try:
        t = -np.linalg.solve(s3, s2.T)
    except np.linalg.LinAlgError:
        return None
    m = s1 + s2 @ t
    m = np.array([m[2] / 2, -m[1], m[0] / 2])
    _, vecs = np.linalg.eig(m)
    vecs = np.real(vecs)
    cond = 4 * vecs[0] * vecs[2] - vecs[1] ** 2
    ok = np.flatnonzero(cond > 0)
    if ok.size == 0:
        return None
    a1 = vecs[:, ok[0]]
    return np.concatenate([a1, t @ a1])


def width_along_x(coef: np.ndarray) -> float:
    """Length of the ellipse's longest chord parallel to x (through its centre)."""
    a, b, c, d, e, f = coef
    # centre
    den = b * b - 4 * a * c
    x0 = (2 * c * d - b * e) / den
    y0 = (2 * a * e - b * d) / den
    # value of the conic at the centre gives the scale: a u^2 + b u v + c v^2 = -F0 around the centre
    f0 = a * x0 * x0 + b * x0 * y0 + c * y0 * y0 + d * x0 + e * y0 + f
    # chord along x through the centre: a u^2 = -f0
    return float(2 * np.sqrt(max(-f0 / a, 0.0)))


def apparent_stiction(op: np.ndarray, pv: np.ndarray, ts_s: float = 1.0) -> np.ndarray:
    """[W, 2] (fs_pct, nan) from the apparent stiction band of each window."""
    op, pv = np.atleast_2d(op).astype(float), np.atleast_2d(pv).astype(float)
    periods, _ = acf_period(op, ts_s)
    out = np.full((op.shape[0], 2), np.nan)
    for i in range(op.shape[0]):
        if not np.isfinite(periods[i]):
            continue
        x, y = _band_pass(op[i], periods[i], ts_s), _band_pass(pv[i], periods[i], ts_s)
        coef = fit_ellipse(x, y)
        if coef is None:
            continue
        band_pct = width_along_x(coef)
        # the thesis baseline: the apparent band taken as the static band fs / 12 (Choudhury 2008 reads S)
        out[i, 0] = band_pct * PCT_OF_500LBF_PER_PCT_OF_SPAN
    return out
