"""Horch's cross-correlation test for stiction (Horch 1999, "A simple method for detection of
stiction in control valves", Control Engineering Practice 7).

For a self-regulating loop, the cross-correlation of the controller output with the control
error is odd under stiction (OP integrates a square-ish error: a quarter period out of phase)
and even when a sinusoidal load or tight tuning drives the oscillation.  With ``tau_l < 0 <
tau_r`` the zero crossings of the CCF nearest lag zero, ``dphi = pi (tau_r + tau_l) /
(tau_r - tau_l)``; ``|dphi| > 2 pi / 3`` reads stiction, ``< pi / 3`` no stiction, between
undecided.  The test does not apply to integrating processes, where OP and PV are in phase
under stiction too.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stiction.detect.oscillation import Detrended, detrended

STICTION = 2 / 3
NO_STICTION = 1 / 3
"""|dphi| / pi above and below which the test decides."""


@dataclass(frozen=True)
class Horch:
    phase: float
    """|dphi| / pi in 0..1: 1 odd (stiction), 0 even (no stiction); nan where no crossings were found."""
    verdict: str
    """``stiction``, ``no_stiction`` or ``undecided``."""


def circular_products(u: np.ndarray, e: np.ndarray) -> np.ndarray:
    """``sum_t u(t) e(t + lag)`` for every lag, by FFT over twice the window (no wrap-around), of each row
    of ``u``, ``e`` [W, N] (or of one signal each): a batch's in one transform, each row as if alone."""
    n = np.shape(u)[-1]
    size = 1 << int(np.ceil(np.log2(2 * n)))
    return np.fft.irfft(np.conj(np.fft.rfft(u, size, axis=-1)) * np.fft.rfft(e, size, axis=-1), size, axis=-1)


def _lagged_products(u: np.ndarray, e: np.ndarray, max_lag: int, c: np.ndarray | None = None) -> np.ndarray:
    """``sum_t u(t) e(t + lag)`` for lags ``-max_lag..max_lag`` (``c``: ``circular_products`` of the two,
    where the caller has it): the cross-correlation of the two detrended signals less its normalisation,
    which moves no sign change."""
    c = circular_products(u, e) if c is None else c
    return np.concatenate([c[c.size - max_lag :], c[: max_lag + 1]])


def _crossing(lags: np.ndarray, c: np.ndarray) -> float:
    """Lag of the first sign change of ``c`` going outward along ``lags``, interpolated."""
    s = np.signbit(c)
    k = np.flatnonzero(s[1:] != s[:-1])
    if k.size == 0:
        return float("nan")
    i = int(k[0])
    a, b = c[i], c[i + 1]
    return float(lags[i] + (lags[i + 1] - lags[i]) * a / (a - b)) if a != b else float(lags[i])


def test(
    op: np.ndarray,
    pv: np.ndarray,
    sp: np.ndarray | None = None,
    period_samples: float | None = None,
    op_d: Detrended | None = None,
    e_d: Detrended | None = None,
    products: np.ndarray | None = None,
) -> Horch:
    """Horch's test on one window; the error is ``sp - pv`` (``-pv`` detrended without a setpoint).
    ``op_d``, ``e_d``: OP's and the error's ``detrended``, ``products``: their ``circular_products``, where
    the caller has them."""
    if op_d is None:
        op_d = detrended(np.asarray(op, float))
    if e_d is None:
        e_d = detrended(-np.asarray(pv, float) if sp is None else np.asarray(sp, float) - np.asarray(pv, float))
    op, e = op_d.y, e_d.y
    if not (op_d.sd > 0 and e_d.sd > 0):
        return Horch(float("nan"), "undecided")
    max_lag = int(min(op.size // 2, period_samples if period_samples and np.isfinite(period_samples) else op.size // 4))
    # the test reads where the CCF changes sign, not its scale: the detrended signals (mean zero) go in
    # as they are, unnormalised (a mean, a subtraction and a standard deviation each, 70 us a window)
    lag = max(max_lag, 2)
    lags, c = np.arange(-lag, lag + 1), _lagged_products(op, e, lag, products)
    mid = max_lag
    if c[mid] == 0:
        return Horch(1.0, "stiction")
    right = _crossing(lags[mid:], c[mid:])
    left = _crossing(lags[mid::-1], c[mid::-1])
    if not (np.isfinite(right) and np.isfinite(left)) or right <= left:
        return Horch(float("nan"), "undecided")
    phase = abs(right + left) / (right - left)
    verdict = "stiction" if phase > STICTION else "no_stiction" if phase < NO_STICTION else "undecided"
    return Horch(float(phase), verdict)
