"""The least squares of many slip sets that each differ from one base set in a few places, without
filtering any of them through the process.

A slip moved by a sample, or one slip dropped, changes the stem's regressors (``ident.valve_model.ROWS``)
in a few pieces only: each row of a candidate is the base's plus a few steps, ``sum_j delta_j 1[t >= e_j]``.
The process is linear and time-invariant, so the compared response of a step at ``e`` is one function
``D(t + skip - e)`` (the compared unit-step response, ``step_response``), and everything the normal
equations need of a candidate follows from the base's projected regressors and a few numbers per step:

- ``<z, D_e>`` for the base's projected rows, the target and the nuisances' basis: one correlation
  each, for every ``e`` at once (FFT);
- ``<D_a, D_b>``: a cumulative product of ``D`` with itself at the lag ``b - a``, for the few lags the
  candidates need.

The cost of a candidate is then its steps squared, not the record's length times the process's order:
the slip refinement and the pruning of a long record (hundreds of candidates of thousands of samples,
two thirds of a 3,600-sample diagnosis) fall to a few per cent of it.  Exact up to rounding:
``tests/ident/test_delta_fits.py`` holds it to ``ident.fit._fit_sets``, which filters every candidate.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from scipy.signal import fftconvolve

from stiction.ident.kernels import piece_coefficients
from stiction.ident.objective import project_out
from stiction.ident.process import TransferFunction
from stiction.ident.record import Record

MAX_STEPS = 48
"""Steps a candidate may differ from the base by (over its four rows); one with more is fitted in full."""
STEP_TOLERANCE = 1e-11
"""Relative size under which a regressor's difference from the base is rounding, not a step."""


def step_response(record: Record, tf: TransferFunction) -> np.ndarray:
    """``D`` [N + horizon]: ``D[tau + horizon]`` is the compared response at compared sample ``t`` of a unit
    step in the regressor at raw sample ``e``, ``tau = t + skip - e`` (zero before ``tau = -horizon``)."""
    h, n = record.horizon, record.n
    s = tf.response(np.ones((1, n + h)))[0]
    d = s.copy()
    d[h:] -= s[:n]
    return d


def step_correlations(record: Record, d: np.ndarray, z: np.ndarray) -> np.ndarray:
    """[Z, N]: ``sum_t z[i, t] D(t + skip - e)`` for each row i of ``z`` [Z, n_fit] and raw sample ``e``."""
    full = fftconvolve(z, d[::-1][None, :], axes=1)
    first = d.size - 1 - record.skip - record.horizon
    return full[:, first : first + record.n]


@njit(cache=True, nogil=True)
def _regressors_at(coef, at, breaks, m, k, n, slip_share, snapshot, out):
    """Write into ``out`` [4] one slip set's regressors at sample ``k`` (``ident.kernels.path_regressors``
    at one sample): its piece's coefficients, and in a slip's own interval the mix with the piece before."""
    piece = np.searchsorted(at[:m], k, side="right")
    for row in range(4):
        out[row] = coef[piece, row]
    if not snapshot and piece > 0 and at[piece - 1] == k and 0 < k < n:
        share = breaks[piece - 1] + slip_share
        for row in range(4):
            out[row] -= share * (coef[piece, row] - coef[piece - 1, row])


@njit(cache=True, nogil=True)
def _same_slip(slip_at, directions, breaks, landing, u, i, v, j):
    """Whether slip i of set u and slip j of set v are the same slip."""
    return (
        slip_at[u, i] == slip_at[v, j]
        and directions[u, i] == directions[v, j]
        and breaks[u, i] == breaks[v, j]
        and landing[u, i] == landing[v, j]
    )


@njit(cache=True, nogil=True)
def candidate_steps(slip_at, directions, breaks, landing, counts, n, slip_share, snapshot, tolerance, max_steps):
    """Each slip set's steps against the first's (the base): (count [C], row [C, S], at [C, S], size [C, S]);
    a count of -1 where a set has more than ``max_steps`` (it is fitted in full).  The regressors change only
    at a slip's sample and the one after it, so both sets are read there alone (``_regressors_at``)."""
    c_count, width = slip_at.shape
    count = np.zeros(c_count, np.int64)
    row_of = np.zeros((c_count, max_steps), np.int64)
    at = np.zeros((c_count, max_steps), np.int64)
    size = np.zeros((c_count, max_steps))
    base_coef = np.empty((width + 1, 4))
    coef = np.empty((width + 1, 4))
    mb = counts[0]
    piece_coefficients(slip_at[0], directions[0], breaks[0], landing[0], mb, base_coef)
    scale = np.zeros(4)
    for j in range(mb + 1):
        for row in range(4):
            scale[row] = max(scale[row], abs(base_coef[j, row]))
    vb, vc, prev = np.empty(4), np.empty(4), np.empty(4)
    times = np.empty(2 * (mb + width) + 1, np.int64)
    for c in range(c_count):
        mc = counts[c]
        piece_coefficients(slip_at[c], directions[c], breaks[c], landing[c], mc, coef)
        tol = np.empty(4)
        for row in range(4):
            own = 0.0
            for j in range(mc + 1):
                own = max(own, abs(coef[j, row]))
            tol[row] = tolerance * max(scale[row], own, 1e-300)
        # the sets differ from slip j0 on to their last differing slips; the pieces before are the same, and
        # past a held slip of the common end both chains restart alike
        j0 = 0
        while j0 < min(mb, mc) and _same_slip(slip_at, directions, breaks, landing, 0, j0, c, j0):
            j0 += 1
        eb, ec = mb - 1, mc - 1
        while eb >= j0 and ec >= j0 and _same_slip(slip_at, directions, breaks, landing, 0, eb, c, ec):
            eb, ec = eb - 1, ec - 1
        while eb + 1 < mb and breaks[0, eb + 1] > 0:
            eb, ec = eb + 1, ec + 1
        eb, ec = min(eb + 1, mb - 1), min(ec + 1, mc - 1)
        t_count = 0
        for j in range(j0, eb + 1):
            times[t_count], times[t_count + 1] = slip_at[0, j], slip_at[0, j] + 1
            t_count += 2
        for j in range(j0, ec + 1):
            times[t_count], times[t_count + 1] = slip_at[c, j], slip_at[c, j] + 1
            t_count += 2
        sorted_times = np.sort(times[:t_count])
        prev[:] = 0.0
        m = 0
        last = -1
        for i in range(t_count):
            k = sorted_times[i]
            if k == last or k >= n:
                continue
            last = k
            _regressors_at(base_coef, slip_at[0], breaks[0], mb, k, n, slip_share, snapshot, vb)
            _regressors_at(coef, slip_at[c], breaks[c], mc, k, n, slip_share, snapshot, vc)
            for row in range(4):
                diff = vc[row] - vb[row]
                if abs(diff - prev[row]) > tol[row]:
                    if m == max_steps:
                        m = -1
                        break
                    row_of[c, m], at[c, m], size[c, m] = row, k, diff - prev[row]
                    m += 1
                    prev[row] = diff
            if m < 0:
                break
        count[c] = m
    return count, row_of, at, size


@njit(cache=True, nogil=True)
def needed_lags(count, at, n):
    """[N] whether some candidate has two steps this many samples apart (its own steps' lags included)."""
    need = np.zeros(n, np.bool_)
    for c in range(count.size):
        for s in range(count[c]):
            for u in range(count[c]):
                need[abs(at[c, s] - at[c, u])] = True
    return need


@njit(cache=True, nogil=True)
def lag_products(d, lags):
    """[L, D + 1]: cumulative ``sum_{i < j} d[i] d[i + lag]`` for each of ``lags``."""
    out = np.zeros((lags.size, d.size + 1))
    for li in range(lags.size):
        lag = lags[li]
        acc = 0.0
        for i in range(d.size):
            if i + lag < d.size:
                acc += d[i] * d[i + lag]
            out[li, i + 1] = acc
    return out


@njit(cache=True, nogil=True)
def _pair(products, lag_index, d_size, horizon, skip, n_fit, a, b):
    """``<D_a, D_b>`` over the compared samples, a <= b (raw samples of two steps)."""
    lag = b - a
    lo = max(0, skip - b + horizon)
    hi = min(n_fit - 1 + skip - b + horizon, d_size - 1 - lag)
    if hi < lo:
        return 0.0
    row = products[lag_index[lag]]
    return row[hi + 1] - row[lo]


@njit(cache=True, nogil=True)
def delta_fits(gram0, corr, n_basis, count, row_of, at, size, products, lag_index, d_size, horizon, skip, n_fit,
               rows, gain_free, nominal_gain):  # fmt: skip
    """(rss [C], solved [C, len(rows)]) as ``ident.kernels.projected_fits`` gives them, from the base's Gram
    ``gram0`` [5, 5] (its four projected rows and the projected target), ``corr`` [5 + K, N] the rows', the
    target's and the K nuisances' correlations with the step response, and each candidate's steps."""
    c_count = count.size
    r = rows.size
    rss = np.full(c_count, np.nan)
    solved = np.zeros((c_count, r))
    cz = np.zeros((5, 4))
    cq = np.zeros((n_basis, 4))
    dd = np.zeros((4, 4))
    g = np.zeros((5, 5))
    for c in range(c_count):
        m = count[c]
        if m < 0:
            continue
        cz[:] = 0.0
        cq[:] = 0.0
        dd[:] = 0.0
        for s in range(m):
            rs, es, ds = row_of[c, s], at[c, s], size[c, s]
            for i in range(5):
                cz[i, rs] += ds * corr[i, es]
            for j in range(n_basis):
                cq[j, rs] += ds * corr[5 + j, es]
            for u in range(m):
                ru, eu, du = row_of[c, u], at[c, u], size[c, u]
                if eu >= es:
                    dd[rs, ru] += ds * du * _pair(products, lag_index, d_size, horizon, skip, n_fit, es, eu)
                else:
                    dd[rs, ru] += ds * du * _pair(products, lag_index, d_size, horizon, skip, n_fit, eu, es)
        g[:] = gram0
        for i in range(4):
            for k in range(4):
                proj = 0.0
                for j in range(n_basis):
                    proj += cq[j, i] * cq[j, k]
                g[i, k] += cz[i, k] + cz[k, i] + dd[i, k] - proj
        for i in range(4):
            g[4, i] += cz[4, i]
            g[i, 4] += cz[4, i]
        # the target: the projected PV's change, less a fixed gain's drive row
        tt = g[4, 4] if gain_free else g[4, 4] - 2.0 * nominal_gain * g[0, 4] + nominal_gain * nominal_gain * g[0, 0]
        if r == 0:
            rss[c] = tt
            continue
        gram = np.empty((r, r))
        rhs = np.empty(r)
        trace = 0.0
        for u in range(r):
            for w in range(r):
                gram[u, w] = g[rows[u], rows[w]]
            trace += gram[u, u]
            rhs[u] = g[rows[u], 4] - (0.0 if gain_free else nominal_gain * g[rows[u], 0])
        ridged = gram.copy()
        ridge = 1e-9 * trace + 1e-12
        for u in range(r):
            ridged[u, u] += ridge
        b = np.linalg.solve(ridged, rhs)
        total = tt
        for u in range(r):
            total -= 2.0 * b[u] * rhs[u]
            for w in range(r):
                total += b[u] * gram[u, w] * b[w]
            solved[c, u] = b[u]
        rss[c] = max(total, 0.0)
    return rss, solved


class NearBase:
    """What every candidate near one base set shares: the base's projected rows and target, their Gram, the
    step response and its correlations (once per base; candidates come in chunks)."""

    def __init__(self, record: Record, tf: TransferFunction, q: np.ndarray, base_regs: np.ndarray):
        x0 = record.compared_response(tf, base_regs)
        z = np.vstack([x0 - (x0 @ q) @ q.T, project_out(record.target[None, :], q)])
        self.record, self.base_regs, self.n_basis = record, base_regs, q.shape[1]
        self.gram = z @ z.T
        self.d = step_response(record, tf)
        self.corr = step_correlations(record, self.d, np.vstack([z, q.T]))

    def fits(self, packed: tuple[np.ndarray, ...], slip_share: float, snapshot: bool, rows: np.ndarray,
             gain_free: bool, nominal_gain: float):  # fmt: skip
        """(rss [C], solved [C, len(rows)]) of slip sets (``ident.valve_model.packed_slips``), as
        ``ident.kernels.projected_fits`` gives them; nan where a set differs from the base in more than
        ``MAX_STEPS`` steps."""
        record = self.record
        count, row_of, at, size = candidate_steps(*packed, record.n, slip_share, snapshot, STEP_TOLERANCE, MAX_STEPS)
        lags = np.flatnonzero(needed_lags(count, at, record.n))
        lag_index = np.full(record.n, -1, np.int64)
        lag_index[lags] = np.arange(lags.size)
        products = lag_products(self.d, lags.astype(np.int64))
        return delta_fits(self.gram, self.corr, self.n_basis, count, row_of, at, size, products, lag_index,
                          self.d.size, record.horizon, record.skip, record.n_fit, rows.astype(np.int64), gain_free,
                          float(nominal_gain))  # fmt: skip
