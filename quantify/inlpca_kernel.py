"""The INLPCA's training loop, compiled: Adam on the inverse network, one window after another; and the
projection of every sample onto the fitted curve (``nearest``).

``quantify.inlpca`` sets each window up (standardising, the initial angles and weights) and
evaluates the fitted curve in numpy; the loop between, 100 iterations of forward pass,
analytic gradients and Adam over 128 samples and 6 hidden units, is some 4,500 small numpy
calls a batch, so a batch of one window cost 14 ms and of fifty 2.8 ms a window.  Here it runs
window by window in compiled loops (``cache=True``: compiled once per machine), the same
arithmetic as ``quantify.inlpca.loss_and_grads`` and its Adam, which the tests hold it to.
It runs without the GIL: a batch of fifty windows takes 150 ms, through which the agent's
Zenoh callback thread must go on taking in samples.
A cache names the module it was compiled in (``stiction.quantify.inlpca_kernel`` since the one installed
namespace): one made under another name is not loaded, since numba keys it by this file's size and time,
and this file changed with that move.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def train(theta, w1, b1, w2, b2, x, iterations, lr, angle_lr, weight_decay):
    """Fit in place: theta [W, N], w1 [W, H, 2], b1 [W, H], w2 [W, 2, H], b2 [W, 2] to x [W, N, 2]."""
    n_win, n = theta.shape
    hidden = b1.shape[1]
    beta1, beta2 = 0.9, 0.999
    h = np.empty(hidden)
    for w in range(n_win):
        m_th, v_th = np.zeros(n), np.zeros(n)
        m_w1, v_w1 = np.zeros((hidden, 2)), np.zeros((hidden, 2))
        m_b1, v_b1 = np.zeros(hidden), np.zeros(hidden)
        m_w2, v_w2 = np.zeros((2, hidden)), np.zeros((2, hidden))
        m_b2, v_b2 = np.zeros(2), np.zeros(2)
        g_th = np.empty(n)
        g_w1, g_b1 = np.empty((hidden, 2)), np.empty(hidden)
        g_w2, g_b2 = np.empty((2, hidden)), np.empty(2)
        for t in range(1, iterations + 1):
            g_w1[:] = 0.0
            g_b1[:] = 0.0
            g_w2[:] = 0.0
            g_b2[:] = 0.0
            for k in range(n):
                c, s = math.cos(theta[w, k]), math.sin(theta[w, k])
                o0, o1 = b2[w, 0], b2[w, 1]
                for j in range(hidden):
                    h[j] = _tanh(c * w1[w, j, 0] + s * w1[w, j, 1] + b1[w, j])
                    o0 += h[j] * w2[w, 0, j]
                    o1 += h[j] * w2[w, 1, j]
                e0, e1 = (o0 - x[w, k, 0]) / n, (o1 - x[w, k, 1]) / n
                g_b2[0] += e0
                g_b2[1] += e1
                gt = 0.0
                for j in range(hidden):
                    g_w2[0, j] += e0 * h[j]
                    g_w2[1, j] += e1 * h[j]
                    da = (e0 * w2[w, 0, j] + e1 * w2[w, 1, j]) * (1.0 - h[j] * h[j])
                    g_w1[j, 0] += c * da
                    g_w1[j, 1] += s * da
                    g_b1[j] += da
                    gt += da * (c * w1[w, j, 1] - s * w1[w, j, 0])
                g_th[k] = gt * n  # each angle moves only its own sample: its gradient scaled back up
            g_w1 += weight_decay * w1[w]
            g_w2 += weight_decay * w2[w]
            c1, c2 = 1.0 - beta1**t, 1.0 - beta2**t  # Adam's bias corrections
            _adam(theta[w], g_th, m_th, v_th, angle_lr, c1, c2)
            _adam(w1[w], g_w1, m_w1, v_w1, lr, c1, c2)
            _adam(b1[w], g_b1, m_b1, v_b1, lr, c1, c2)
            _adam(w2[w], g_w2, m_w2, v_w2, lr, c1, c2)
            _adam(b2[w], g_b2, m_b2, v_b2, lr, c1, c2)


@njit(cache=True, nogil=True, inline="always")
def _tanh(a):
    """tanh by one exp: equal to math.tanh within a few ulp (3e-16 absolute), a quarter of its time
    here (9 ns against 33 in glibc); tanh was most of the loop's time.  exp's overflow gives +-1."""
    return 1.0 - 2.0 / (math.exp(2.0 * a) + 1.0)


@njit(cache=True, nogil=True)
def _adam(p, g, m, v, lr, c1, c2):
    p, g, m, v = p.ravel(), g.ravel(), m.ravel(), v.ravel()
    for i in range(p.size):
        m[i] = 0.9 * m[i] + (1.0 - 0.9) * g[i]
        v[i] = 0.999 * v[i] + (1.0 - 0.999) * g[i] * g[i]
        p[i] -= lr * (m[i] / c1) / (math.sqrt(v[i] / c2) + 1e-8)


@njit(cache=True, nogil=True)
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
