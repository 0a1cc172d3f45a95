"""The INLPCA's training loop, compiled: Adam on the inverse network, one window after another; and the
projection of every sample onto the fitted curve (``nearest``).

``quantify.inlpca`` sets each window up (standardising, the initial angles and weights) and
evaluates the fitted curve in numpy; the loop between, 100 iterations of forward pass,
analytic gradients and Adam over 128 samples and 6 hidden units, is some 4,500 small numpy
calls a batch, so a batch of one window cost 14 ms and of fifty 2.8 ms a window.  Here it runs
window by window in compiled loops (``cache=True``: compiled once per machine), the same
arithmetic as ``quantify.inlpca.loss_and_grads`` and its Adam, which the tests hold it to.
It runs without the GIL, through which the agent's Zenoh thread must go on taking in samples.

The loops run over the samples innermost, each a few array streams, so that the compiler turns them into
vector instructions (four or eight samples an instruction): for that the loop's arithmetic must be plain
arithmetic.  Three things kept it scalar, each found by reading the compiled code: a division checked for a
zero divisor (``error_model="numpy"`` drops the check: a zero divisor gives inf, as in numpy), the library's
``exp``, ``sin`` and ``cos`` (a call a sample: ``_exp_bounded`` and ``_sin_cos`` are polynomials, within
1e-14 of them where the training reads them) and sums in strict order (``FAST``: the compiler may reorder a
sum and fuse a multiply-add, never assume a value finite).  The training loop went from 1.04-1.08 to 0.27 ms
a window (50 windows of random canonical loops, best of seven, AMD EPYC family 26 model 2), its weights within
1e-8 of the strict loop's.
A cache names the module it was compiled in (``stiction.quantify.inlpca_kernel`` since the one installed
namespace): one made under another name is not loaded, since numba keys it by this file's size and time,
and this file changed with that move.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

FAST = {"reassoc", "contract", "arcp", "nsz"}
"""LLVM's fast-math flags the training loop may use: reordered sums, fused multiply-adds, reciprocals; not
``nnan``/``ninf`` (a value is never assumed finite)."""
EXP_CLAMP = 40.0
"""``tanh(a) = 1 - 2 / (e^(2a) + 1)`` is +-1 to the last bit past ``|2a| = 40``; e^40 within double range."""
PIO2_HI = 1.5707963267341256
PIO2_LO = 6.077100506506192e-11
"""pi / 2 in two parts (``PIO2_HI`` has 33 significant bits, so ``q * PIO2_HI`` is exact for any q the angles
reach): the reduction of an angle to within pi / 4 loses no digits (Cody and Waite)."""


@njit(cache=True, nogil=True, inline="always", fastmath=FAST, error_model="numpy")
def _exp_bounded(y):
    """``e^y`` for ``|y| <= EXP_CLAMP``: Taylor's series of ``e^(y/64)`` to the 14th power (remainder under
    1e-15 there), squared six times; relative error under 1e-13.  Arithmetic only, so its loop vectorises."""
    z = y * (1.0 / 64.0)
    p = 1 + z * (1 + z * (1 / 2 + z * (1 / 6 + z * (1 / 24 + z * (1 / 120 + z * (1 / 720 + z * (1 / 5040 + z * (
        1 / 40320 + z * (1 / 362880 + z * (1 / 3628800 + z * (1 / 39916800 + z * (1 / 479001600 + z * (
            1 / 6227020800 + z / 87178291200)))))))))))))
    for _ in range(6):
        p = p * p
    return p


@njit(cache=True, nogil=True, inline="always", fastmath=FAST, error_model="numpy")
def _tanh(a):
    """tanh by ``_exp_bounded``: within 1e-14 of ``math.tanh``."""
    y = 2.0 * a
    y = y if y < EXP_CLAMP else EXP_CLAMP
    y = y if y > -EXP_CLAMP else -EXP_CLAMP
    return 1.0 - 2.0 / (_exp_bounded(y) + 1.0)


@njit(cache=True, nogil=True, inline="always", fastmath=FAST, error_model="numpy")
def _sin_cos(theta):
    """``(sin, cos)`` of ``theta``: reduced to ``r`` within pi / 4 of a multiple q of pi / 2, Taylor's series of
    each to the 15th / 16th power of r (remainder under 1e-16), the quadrant q mod 4 choosing the signs."""
    q = math.floor(theta * (2.0 / math.pi) + 0.5)
    r = (theta - q * PIO2_HI) - q * PIO2_LO
    r2 = r * r
    sin_r = r + r * r2 * (-1 / 6 + r2 * (1 / 120 + r2 * (-1 / 5040 + r2 * (1 / 362880 + r2 * (
        -1 / 39916800 + r2 * (1 / 6227020800 - r2 / 1307674368000))))))
    cos_r = 1 + r2 * (-1 / 2 + r2 * (1 / 24 + r2 * (-1 / 720 + r2 * (1 / 40320 + r2 * (-1 / 3628800 + r2 * (
        1 / 479001600 + r2 * (-1 / 87178291200 + r2 / 20922789888000)))))))
    k = int(q) & 3
    s = sin_r if k == 0 else (cos_r if k == 1 else (-sin_r if k == 2 else -cos_r))
    c = cos_r if k == 0 else (-sin_r if k == 1 else (-cos_r if k == 2 else sin_r))
    return s, c


@njit(cache=True, nogil=True, fastmath=FAST, error_model="numpy")
def _hidden_row(out, c, s, w_c, w_s, bias):
    """One hidden unit's activation at every sample: ``out[k] = tanh(c[k] w_c + s[k] w_s + bias)``."""
    for k in range(out.size):
        out[k] = _tanh(c[k] * w_c + s[k] * w_s + bias)


@njit(cache=True, nogil=True, fastmath=FAST, error_model="numpy")
def train(theta, w1, b1, w2, b2, x, iterations, lr, angle_lr, weight_decay):
    """Fit in place: theta [W, N], w1 [W, H, 2], b1 [W, H], w2 [W, 2, H], b2 [W, 2] to x [W, N, 2]."""
    n_win, n = theta.shape
    hidden = b1.shape[1]
    beta1, beta2 = 0.9, 0.999
    h = np.empty((hidden, n))
    c, s = np.empty(n), np.empty(n)
    o0, o1 = np.empty(n), np.empty(n)
    e0, e1 = np.empty(n), np.empty(n)
    x0, x1 = np.empty(n), np.empty(n)
    for w in range(n_win):
        m_th, v_th = np.zeros(n), np.zeros(n)
        m_w1, v_w1 = np.zeros((hidden, 2)), np.zeros((hidden, 2))
        m_b1, v_b1 = np.zeros(hidden), np.zeros(hidden)
        m_w2, v_w2 = np.zeros((2, hidden)), np.zeros((2, hidden))
        m_b2, v_b2 = np.zeros(2), np.zeros(2)
        g_th = np.empty(n)
        g_w1, g_b1 = np.empty((hidden, 2)), np.empty(hidden)
        g_w2, g_b2 = np.empty((2, hidden)), np.empty(2)
        th = theta[w]
        for k in range(n):
            x0[k], x1[k] = x[w, k, 0], x[w, k, 1]
        for t in range(1, iterations + 1):
            for k in range(n):
                s[k], c[k] = _sin_cos(th[k])
                o0[k], o1[k] = b2[w, 0], b2[w, 1]
            for j in range(hidden):  # forward: a hidden unit at every sample, then its share of the outputs
                hj = h[j]
                _hidden_row(hj, c, s, w1[w, j, 0], w1[w, j, 1], b1[w, j])
                u0, u1 = w2[w, 0, j], w2[w, 1, j]
                for k in range(n):
                    o0[k] += hj[k] * u0
                    o1[k] += hj[k] * u1
            g_b2[0] = g_b2[1] = 0.0
            for k in range(n):
                e0[k], e1[k] = (o0[k] - x0[k]) / n, (o1[k] - x1[k]) / n
                g_b2[0] += e0[k]
                g_b2[1] += e1[k]
                g_th[k] = 0.0
            for j in range(hidden):  # backward: a hidden unit's gradients summed over the samples
                hj = h[j]
                a_c, a_s = w1[w, j, 0], w1[w, j, 1]
                u0, u1 = w2[w, 0, j], w2[w, 1, j]
                gw2_0 = gw2_1 = gw1_c = gw1_s = gb1 = 0.0
                for k in range(n):
                    gw2_0 += e0[k] * hj[k]
                    gw2_1 += e1[k] * hj[k]
                    da = (e0[k] * u0 + e1[k] * u1) * (1.0 - hj[k] * hj[k])
                    gw1_c += c[k] * da
                    gw1_s += s[k] * da
                    gb1 += da
                    g_th[k] += da * (c[k] * a_s - s[k] * a_c)
                g_w2[0, j], g_w2[1, j], g_w1[j, 0], g_w1[j, 1], g_b1[j] = gw2_0, gw2_1, gw1_c, gw1_s, gb1
            for k in range(n):
                g_th[k] *= n  # each angle moves only its own sample: its gradient scaled back up
            g_w1 += weight_decay * w1[w]
            g_w2 += weight_decay * w2[w]
            c1, c2 = 1.0 - beta1**t, 1.0 - beta2**t  # Adam's bias corrections
            _adam(th, g_th, m_th, v_th, angle_lr, c1, c2)
            _adam(w1[w], g_w1, m_w1, v_w1, lr, c1, c2)
            _adam(b1[w], g_b1, m_b1, v_b1, lr, c1, c2)
            _adam(w2[w], g_w2, m_w2, v_w2, lr, c1, c2)
            _adam(b2[w], g_b2, m_b2, v_b2, lr, c1, c2)


@njit(cache=True, nogil=True, fastmath=FAST, error_model="numpy")
def _adam(p, g, m, v, lr, c1, c2):
    p, g, m, v = p.ravel(), g.ravel(), m.ravel(), v.ravel()
    for i in range(p.size):
        m[i] = 0.9 * m[i] + (1.0 - 0.9) * g[i]
        v[i] = 0.999 * v[i] + (1.0 - 0.999) * g[i] * g[i]
        p[i] -= lr * (m[i] / c1) / (math.sqrt(v[i] / c2) + 1e-8)


@njit(cache=True, nogil=True, error_model="numpy")
def nearest(x, curve):
    """Index of the curve point nearest to each sample: x [W, N, 2], curve [W, M, 2] -> [W, N] (int64).

    The squared distance itself, point by point: no [W, N, M] array of distances (numpy's blocked
    version held 10 MB for ten windows, and cost 1.3 ms a window in the agent's small batches); the
    first of equally near points, as ``np.argmin``."""
    n_win, n, m = x.shape[0], x.shape[1], curve.shape[1]
    out = np.empty((n_win, n), np.int64)
    for w in range(n_win):
        for i in range(n):
            x0, x1 = x[w, i, 0], x[w, i, 1]
            best, best_d = 0, np.inf
            for j in range(m):
                d0, d1 = x0 - curve[w, j, 0], x1 - curve[w, j, 1]
                d = d0 * d0 + d1 * d1
                if d < best_d:
                    best, best_d = j, d
            out[w, i] = best
    return out
