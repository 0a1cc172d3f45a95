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
Every kernel here divides without checking for a zero divisor (``error_model="numpy"``: inf or nan, as numpy
gives; the check was a branch at every division).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from stiction.ident.kernels import chain_step, piece_coefficients, write_piece
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
    """[Z, N]: ``sum_t z[i, t] D(t + skip - e)`` for each row i of ``z`` [Z, n_fit] and raw sample ``e``: a
    convolution with ``D`` reversed, by numpy's FFT (``scipy.signal``'s import alone cost a command 2 s)."""
    size = z.shape[1] + d.size - 1
    fast = 1 << (size - 1).bit_length()  # a power of two: numpy's FFT of any other length is several times slower
    full = np.fft.irfft(np.fft.rfft(z, fast, axis=1) * np.fft.rfft(d[::-1], fast)[None, :], fast, axis=1)
    first = d.size - 1 - record.skip - record.horizon
    return full[:, first : first + record.n]


@njit(cache=True, nogil=True, error_model="numpy")
def _regressors_at(coef, at, breaks, m, k, n, slip_share, snapshot, out):
    """Write into ``out`` [4] one slip set's regressors at sample ``k`` (``ident.kernels.path_regressors``
    at one sample): its piece's coefficients, and in a slip's own interval the mix with the piece before."""
    piece = np.searchsorted(at[:m], k, side="right")
    for row in range(4):
        out[row] = coef[piece, row]
    if not snapshot and piece > 0 and at[piece - 1] == k and 0 < k < n:
        share = abs(breaks[piece - 1]) + slip_share
        for row in range(4):
            out[row] -= share * (coef[piece, row] - coef[piece - 1, row])


@njit(cache=True, nogil=True, error_model="numpy")
def _chain_states(d, breaks, landing, m):
    """The chain of ``ident.kernels.piece_coefficients`` before each slip j of one set (and after the last):
    (whether a held slip came, its landing, its direction, the jumps' sum, that sum at the held slip) [M + 1]."""
    held = np.zeros(m + 1, np.bool_)
    last_landing, last_d = np.zeros(m + 1), np.zeros(m + 1)
    crossing, at_last = np.zeros(m + 1), np.zeros(m + 1)
    for j in range(m):
        held[j + 1], last_landing[j + 1], last_d[j + 1], crossing[j + 1], at_last[j + 1] = chain_step(
            held[j], last_landing[j], last_d[j], crossing[j], at_last[j], d[j], breaks[j], landing[j]
        )
    return held, last_landing, last_d, crossing, at_last


@njit(cache=True, nogil=True, error_model="numpy")
def changed_steps(at, d, breaks, landing, n, slip_share, snapshot, index, shift, new_landing, dropped, tolerance,
                  max_steps):  # fmt: skip
    """Each candidate's steps against the base slip set (``at``, ``d``, ``breaks``, ``landing`` [M]): candidate c
    is the base with slip ``index[c]`` dropped, or moved by ``shift[c]`` samples to land at ``new_landing[c]``.
    (count [C], row [C, S], at [C, S], size [C, S]); a count of -1 where a candidate has more than ``max_steps``.

    Only the pieces from the changed slip to the next held slip after it differ: past a held slip both chains
    restart alike (``ident.kernels.piece_coefficients``).  So each candidate is read there alone, at its
    slips' samples and the ones after them (``_regressors_at``), from the base's chain before it."""
    m = at.size
    c_count = index.size
    count = np.zeros(c_count, np.int64)
    row_of = np.zeros((c_count, max_steps), np.int64)
    step_at = np.zeros((c_count, max_steps), np.int64)
    size = np.zeros((c_count, max_steps))
    base_coef = np.empty((m + 1, 4))
    piece_coefficients(at, d, breaks, landing, m, base_coef)
    held, last_landing, last_d, crossing, at_last = _chain_states(d, breaks, landing, m)
    tol = np.empty(4)
    for row in range(4):
        scale = 0.0
        for j in range(m + 1):
            scale = max(scale, abs(base_coef[j, row]))
        tol[row] = tolerance * max(scale, 1e-300)
    lb, ll, ld = np.empty(m), np.empty(m), np.empty(m)
    la_int = np.empty(m, np.int64)
    lc = np.empty((m + 1, 4))
    times = np.empty(2 * m + 2, np.int64)
    vb, vc, prev = np.empty(4), np.empty(4), np.empty(4)
    for c in range(c_count):
        i = index[c]
        e = i + 1
        while e < m and breaks[e] > 0:
            e += 1
        lo, hi = i, min(e, m - 1)
        # the candidate's slips lo..hi and the one after (a slip the sample after slip hi may hold), and its
        # pieces from the one before slip lo on
        k_local = 0
        for j in range(lo, min(hi + 2, m)):
            if j == i and dropped[c]:
                continue
            la_int[k_local], ld[k_local], lb[k_local], ll[k_local] = at[j], d[j], breaks[j], landing[j]
            if j == i:
                la_int[k_local], ll[k_local] = at[j] + shift[c], new_landing[c]
            k_local += 1
        for row in range(4):
            lc[0, row] = base_coef[lo, row]
        h, hl, hd, cr, al = held[lo], last_landing[lo], last_d[lo], crossing[lo], at_last[lo]
        for t in range(k_local):
            h, hl, hd, cr, al = chain_step(h, hl, hd, cr, al, ld[t], lb[t], ll[t])
            write_piece(lc, t + 1, h, hl, hd, cr, al)
        t_count = 0
        for j in range(lo, hi + 1):
            times[t_count], times[t_count + 1] = at[j], at[j] + 1
            t_count += 2
        if not dropped[c]:  # the moved slip's own samples (its others are the base's)
            times[t_count], times[t_count + 1] = at[i] + shift[c], at[i] + shift[c] + 1
            t_count += 2
        sorted_times = np.sort(times[:t_count])
        prev[:] = 0.0
        mc = 0
        last = -1
        for q in range(t_count):
            k = sorted_times[q]
            if k == last or k >= n:
                continue
            last = k
            _regressors_at(base_coef, at, breaks, m, k, n, slip_share, snapshot, vb)
            _regressors_at(lc, la_int, lb, k_local, k, n, slip_share, snapshot, vc)
            for row in range(4):
                diff = vc[row] - vb[row]
                if abs(diff - prev[row]) > tol[row]:
                    if mc == max_steps:
                        mc = -1
                        break
                    row_of[c, mc], step_at[c, mc], size[c, mc] = row, k, diff - prev[row]
                    mc += 1
                    prev[row] = diff
            if mc < 0:
                break
        count[c] = mc
    return count, row_of, step_at, size


@njit(cache=True, nogil=True, error_model="numpy")
def needed_lags(count, at, n):
    """[N] whether some candidate has two steps this many samples apart (its own steps' lags included)."""
    need = np.zeros(n, np.bool_)
    for c in range(count.size):
        for s in range(count[c]):
            for u in range(count[c]):
                need[abs(at[c, s] - at[c, u])] = True
    return need


@njit(cache=True, nogil=True, error_model="numpy")
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


@njit(cache=True, nogil=True, error_model="numpy")
def _pair(products, lag_index, d_size, horizon, skip, n_fit, a, b):
    """``<D_a, D_b>`` over the compared samples, a <= b (raw samples of two steps)."""
    lag = b - a
    lo = max(0, skip - b + horizon)
    hi = min(n_fit - 1 + skip - b + horizon, d_size - 1 - lag)
    if hi < lo:
        return 0.0
    row = products[lag_index[lag]]
    return row[hi + 1] - row[lo]


@njit(cache=True, nogil=True, error_model="numpy")
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
        self.z = z
        self.gram = z @ z.T
        self.d = step_response(record, tf)
        self.corr = step_correlations(record, self.d, np.vstack([z, q.T]))

    def base_fit(self, rows: np.ndarray, gain_free: bool, nominal_gain: float):
        """(rss, solved [len(rows)], rss as the candidates' normal equations give it) of the base itself, its
        residual summed sample by sample as ``ident.kernels.projected_fits`` sums it."""
        rss, solved = delta_fits(self.gram, self.corr, self.n_basis, np.zeros(1, np.int64), np.zeros((1, 1), np.int64),
                                 np.zeros((1, 1), np.int64), np.zeros((1, 1)), np.zeros((1, 1)), np.zeros(1, np.int64),
                                 self.d.size, self.record.horizon, self.record.skip, self.record.n_fit,
                                 rows.astype(np.int64), gain_free, float(nominal_gain))  # fmt: skip
        z = self.z
        resid = z[4] if gain_free else z[4] - nominal_gain * z[0]
        resid = resid - solved[0] @ z[rows]
        return float(resid @ resid), solved[0], rss[0]

    def fits(self, base, slip_share: float, snapshot: bool, index: np.ndarray, shift: np.ndarray,
             new_landing: np.ndarray, dropped: np.ndarray, rows: np.ndarray, gain_free: bool,
             nominal_gain: float):  # fmt: skip
        """(rss [C], solved [C, len(rows)]) of the base slip set (an ``ident.valve_model.Slips``) with one slip
        changed each (``changed_steps``), as ``ident.kernels.projected_fits`` gives them; nan where a candidate
        differs from the base in more than ``MAX_STEPS`` steps."""
        record = self.record
        count, row_of, at, size = changed_steps(
            np.asarray(base.at, np.int64), np.asarray(base.directions, float), np.asarray(base.breaks, float),
            np.asarray(base.landing_drive, float), record.n, slip_share, snapshot, index.astype(np.int64),
            shift.astype(np.int64), new_landing.astype(float), dropped.astype(np.bool_), STEP_TOLERANCE, MAX_STEPS,
        )  # fmt: skip
        lags = np.flatnonzero(needed_lags(count, at, record.n))
        lag_index = np.full(record.n, -1, np.int64)
        lag_index[lags] = np.arange(lags.size)
        products = lag_products(self.d, lags.astype(np.int64))
        return delta_fits(self.gram, self.corr, self.n_basis, count, row_of, at, size, products, lag_index,
                          self.d.size, record.horizon, record.skip, record.n_fit, rows.astype(np.int64), gain_free,
                          float(nominal_gain))  # fmt: skip
