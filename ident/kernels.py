"""The sequential recursions of the fits, compiled: the valve's walk and the optimal segmentation;
the PI controller's least squares, which the agent runs on every window; the stem's regressors
from a set of slips (``path_regressors``: piece by piece, where numpy's gathers and cumulative sums
cost a quarter of a diagnosis); the stem's pieces from a segmentation (``path_pieces``: a loop over
thousands of pieces, a third of a long record's diagnosis); and the process's difference equation
(``iir_rows``: scipy.signal.lfilter's recursion, whose import alone cost every command half a second);
and the candidates' least squares on projected regressors (``projected_fits``: one candidate's rows in
cache at a time, where numpy wrote and reread the projected batch).

The first two run sample by sample with a decision at each step, which numpy cannot
vectorise over time; the third is four columns of one window, where numpy's per-call cost
was 100 us a window.  numba compiles them (``cache=True``: once per machine).  Their
plain-Python (or plain numpy) transcriptions in ``tests/ident`` are the references they are
tested against.
A cache names the module it was compiled in (``stiction.ident.kernels`` since the one installed
namespace): one made under another name is not loaded, since numba keys it by this file's size and time,
and this file changed with that move.
Every kernel here divides without checking for a zero divisor (``error_model="numpy"``: inf or nan, as numpy
gives; the check was a branch at every division).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, nogil=True, error_model="numpy")
def _break(start, end, mean, moves, decay, k, level, d, band):
    """(share of interval k's time before the break, drive at the break) for a stem at ``level`` slipping in
    ``d``; the drive relaxes by ``decay`` an interval (``ident.valve_model.time_share``)."""
    if not moves:
        return 0.0, mean[k]
    s, e = start[k], end[k]
    if e == s:
        return 0.0, s
    if d * (s - level) > band:  # past the band when the interval starts: it breaks away at once
        return 0.0, s
    frac = (level + d * band - s) / (e - s)
    frac = min(max(frac, 0.0), 1.0)
    t = frac
    if 0.0 < decay < 1.0:
        t = math.log1p(-frac * (1.0 - decay)) / math.log(decay)
    return t, s + frac * (e - s)


@njit(cache=True, nogil=True, error_model="numpy")
def _wider(x, cap):
    """``x`` [C, M] copied into zeros of [C, cap]."""
    out = np.zeros((x.shape[0], cap), x.dtype)
    out[:, : x.shape[1]] = x
    return out


SLIDE_MIN_SHARE = 1e-6
SLIDE_MIN_TRAVEL_PCT = 1e-9
"""A slide shorter than this share of an interval, or along a drive that moves less than this in it (a flat OP
through a short lag), is none: the stem sticks where it is (its landing's share of the interval would be 0/0)."""


@njit(cache=True, nogil=True, error_model="numpy")
def walk(start, end, mean, moves, decay, read_at, read_dir, read_levels, use_levels, band, stop, level0, window,
         slide):  # fmt: skip
    """Per candidate: its slips (see ``ident.fit.walk``).  Returns counts [C] and [C, N] arrays of events.
    ``slide`` [C]: the drive's speed (% of OP an interval) above which the candidate's stem slides along with
    it; a slide's samples are slips at a held landing whose break is minus the share of the interval that
    reads the old level (``ident.valve_model.path_regressors``)."""
    n_cand, n, n_read = band.size, end.size, read_at.size
    anchor = np.full(n, -1, np.int64)
    for j in range(n_read):
        if 0 <= read_at[j] < n:
            anchor[read_at[j]] = j
    counts = np.zeros(n_cand, np.int64)
    # one candidate's slips go to buffers of the record's length, reused, and then to the outputs, which
    # have room for twice the read slips and grow when a candidate needs more (five outputs of the record's
    # length were megabytes a call; growing them inside the loop over samples made the loop twice as slow):
    # 1.7-2.5 ms a call of 40 candidates on 3,600 samples, against 2.4-3.5 ms with outputs of the record's length
    b_at, b_dirs = np.empty(n, np.int64), np.empty(n, np.int64)
    b_brk, b_land, b_forced, b_off = np.empty(n), np.empty(n), np.empty(n, np.bool_), np.empty(n)
    cap = min(n, 2 * n_read + 16)
    at = np.zeros((n_cand, cap), np.int64)
    dirs = np.zeros((n_cand, cap), np.int64)
    brk = np.zeros((n_cand, cap))
    land = np.zeros((n_cand, cap))
    forced = np.zeros((n_cand, cap), np.bool_)
    offs = np.zeros((n_cand, cap))
    can_slide = moves and 0.0 < decay < 1.0
    tau = -1.0 / math.log(decay) if can_slide else 0.0  # the lag in intervals
    for c in range(n_cand):
        level = level0[c]
        used = np.zeros(n_read, np.bool_)
        m = 0
        sliding, slide_d = False, 0
        for k in range(1, n):
            if sliding:
                # carried along by a drive still faster than the slide speed, its way: a held landing a sample
                s0, e0 = start[k], end[k]
                op = (e0 - decay * s0) / (1.0 - decay)
                rate = abs(op - s0) / tau
                t_c = tau * math.log(rate / slide[c]) if rate > slide[c] else 0.0
                if (e0 - s0) * slide_d > SLIDE_MIN_TRAVEL_PCT and t_c > SLIDE_MIN_SHARE:
                    j = anchor[k]
                    if j >= 0 and not used[j] and read_dir[j] == slide_d:
                        used[j] = True  # a slip the data read inside the slide is the slide's
                    if t_c >= 1.0:
                        stem_at, share = e0, (e0 - mean[k]) / (e0 - s0)
                    else:  # it sticks where the drive slows to the slide speed
                        stem_at = op + (s0 - op) * math.exp(-t_c / tau)
                        area = op * t_c + (s0 - op) * tau * (1.0 - math.exp(-t_c / tau)) + (1.0 - t_c) * stem_at
                        share = (stem_at - area) / (stem_at - s0)
                        sliding = False
                    b_at[m], b_dirs[m], b_brk[m], b_land[m], b_forced[m] = k, slide_d, -share, stem_at, False
                    b_off[m] = 0.0
                    m += 1
                    level = stem_at - slide_d * stop[c]
                    continue
                sliding = False
            gap = end[k] - level
            if abs(gap) > band[c]:
                d = 1 if gap > 0 else -1
                f, p = _break(start, end, mean, moves, decay, k, level, d, band[c])
                slid = False
                off = 0.0
                if can_slide:
                    op = (end[k] - decay * start[k]) / (1.0 - decay)
                    rate = abs(op - p) / tau
                    if (op - start[k]) * d > 0 and rate > slide[c]:
                        # it slides on from the break: to the interval's end, or to where the drive slows;
                        # the flow follows the drive there, the landing's level only after
                        slid = True
                        t_e = min(f + tau * math.log(rate / slide[c]), 1.0)
                        p = op + (start[k] - op) * math.exp(-t_e / tau) if t_e < 1.0 else end[k]
                        sliding, slide_d = t_e >= 1.0, d
                        along = op * (t_e - f) + (start[k] - op) * tau * (math.exp(-f / tau) - math.exp(-t_e / tau))
                        off = along - (t_e - f) * p
                b_at[m], b_dirs[m], b_brk[m], b_land[m], b_forced[m] = k, d, (-f if slid else f), p, False
                b_off[m] = off
                m += 1
                level = p - d * stop[c]
                best, best_dist = -1, window + 1
                # the read slips within the window (read_at increases): the nearest unused one of this direction
                for j in range(np.searchsorted(read_at, k - window), n_read):
                    if read_at[j] > k + window:
                        break
                    dist = abs(read_at[j] - k)
                    if not used[j] and read_dir[j] == d and dist < best_dist:
                        best, best_dist = j, dist
                if best >= 0:
                    used[best] = True
                    # the observer pulls the stem back to the data's landing, never past its own: behind a
                    # long lag the drive breaks a stem away again and again as it creeps on (a stair of
                    # slips a few samples apart), which PV reads as one step; set at the stair's end at its
                    # first slip, the stem slipped no more (``ident.fit.walk``)
                    if use_levels and not slid and d * (read_levels[best] - level) < 0:
                        level = read_levels[best]
                continue
            j = anchor[k]
            if j >= 0 and not used[j]:
                d = read_dir[j]
                soon = False
                for i in range(k + 1, min(k + 1 + window, n)):
                    g = end[i] - level
                    if abs(g) > band[c]:
                        soon = (g > 0) == (d > 0)
                        break
                if soon:
                    continue
                b_at[m], b_dirs[m], b_brk[m], b_land[m], b_forced[m] = k, d, 0.0, mean[k], True
                b_off[m] = 0.0
                m += 1
                used[j] = True
                level = read_levels[j] if use_levels else mean[k] - d * stop[c]
        if m > cap:
            cap = min(n, max(m, 2 * cap))
            at, dirs, brk, land, forced = (_wider(at, cap), _wider(dirs, cap), _wider(brk, cap), _wider(land, cap),
                                           _wider(forced, cap))  # fmt: skip
            offs = _wider(offs, cap)
        at[c, :m], dirs[c, :m], brk[c, :m], land[c, :m], forced[c, :m] = (b_at[:m], b_dirs[:m], b_brk[:m],
                                                                          b_land[:m], b_forced[:m])  # fmt: skip
        offs[c, :m] = b_off[:m]
        counts[c] = m
    return counts, at, dirs, brk, land, forced, offs


@njit(cache=True, nogil=True, error_model="numpy")
def segment_row(f, penalty):
    """Ends of the optimal pieces of ``f`` under ``SSE + penalty * pieces`` (PELT, Killick et al. 2012).

    Pruning with K = 0 keeps it exact for squared error: a start that cannot beat the best
    partition now never will.
    """
    n = f.size
    c1 = np.zeros(n + 1)
    c2 = np.zeros(n + 1)
    for i in range(n):
        c1[i + 1] = c1[i] + f[i]
        c2[i + 1] = c2[i] + f[i] * f[i]
    best = np.empty(n + 1)
    best[0] = -penalty
    last = np.zeros(n + 1, np.int64)
    cand = np.empty(n + 1, np.int64)
    cost = np.empty(n + 1)
    n_cand = 1
    cand[0] = 0
    for t in range(1, n + 1):
        b, arg = np.inf, 0
        for i in range(n_cand):
            s = cand[i]
            length = t - s
            sse = (c2[t] - c2[s]) - (c1[t] - c1[s]) ** 2 / length
            cost[i] = best[s] + sse
            if cost[i] + penalty < b:
                b, arg = cost[i] + penalty, s
        best[t], last[t] = b, arg
        kept = 0
        for i in range(n_cand):
            if cost[i] <= b:
                cand[kept] = cand[i]
                kept += 1
        cand[kept] = t
        n_cand = kept + 1
    ends = np.empty(n, np.int64)
    m = 0
    t = n
    while t > 0:
        ends[m] = t
        m += 1
        t = last[t]
    return ends[:m][::-1].copy()


@njit(cache=True, nogil=True, error_model="numpy")
def path_pieces(u, bounds, noise_sd, min_jump_sd):
    """(starts, levels) of the stem's pieces from a segmentation of ``u`` (``bounds``: 0, then each
    piece's end): a piece of one sample between two levels joins the nearer one, and a piece whose level
    is within ``min_jump_sd`` standard errors of the one before merges into it (``ident.stem._path``).
    Each piece's mean comes from two cumulative sums; its plain-Python transcription is in ``tests/ident``."""
    m = bounds.size
    drop = np.zeros(m, np.bool_)
    for i in range(1, m - 2):
        a, b = bounds[i], bounds[i + 1]
        if b - a == 1 and min(u[a - 1], u[b]) < u[a] < max(u[a - 1], u[b]):
            if abs(u[a] - u[b]) < abs(u[a] - u[a - 1]):
                drop[i + 1] = True
            else:
                drop[i] = True
    kept = np.empty(m, np.int64)
    k = 0
    for i in range(m):
        if not drop[i]:
            kept[k] = bounds[i]
            k += 1
    total = np.zeros(u.size + 1)
    for i in range(u.size):
        total[i + 1] = total[i] + u[i]
    starts = np.empty(k, np.int64)
    levels = np.empty(k)
    starts[0] = kept[0]
    levels[0] = (total[kept[1]] - total[0]) / (kept[1] - 0)
    p = 1
    for i in range(1, k - 1):
        a, b = kept[i], kept[i + 1]
        level = (total[b] - total[a]) / (b - a)
        se = noise_sd * math.sqrt(1.0 / (b - a) + 1.0 / (a - starts[p - 1]))
        if abs(level - levels[p - 1]) < min_jump_sd * se:
            s = starts[p - 1]
            levels[p - 1] = (total[b] - total[s]) / (b - s)
            continue
        starts[p] = a
        levels[p] = level
        p += 1
    return starts[:p].copy(), levels[:p].copy()


@njit(cache=True, nogil=True, error_model="numpy")
def _dot(a, b):
    s = 0.0
    for k in range(a.size):
        s += a[k] * b[k]
    return s


@njit(cache=True, nogil=True, error_model="numpy")
def _axpy(y, d, x):
    """``y -= d * x`` in place."""
    for k in range(y.size):
        y[k] -= d * x[k]


@njit(cache=True, nogil=True, error_model="numpy")
def pi_fit(op, e, ts_s):
    """``(Kc, Ti, explained)`` of the least-squares fit ``OP = a + b t + Kc e + (Kc Ts/Ti) sum e`` of one
    window (``ident.controller``): modified Gram-Schmidt, twice, on the four columns scaled to unit
    length; nan where OP does not move or the columns are dependent."""
    n = op.size
    x = np.empty((4, n))
    acc = 0.0
    for k in range(n):
        acc += e[k] * ts_s
        x[0, k] = 1.0
        x[1, k] = k / n
        x[2, k] = e[k]
        x[3, k] = acc
    scale = np.empty(4)
    for j in range(4):
        scale[j] = math.sqrt(_dot(x[j], x[j])) + 1e-300
        x[j] /= scale[j]
    r = np.zeros((4, 4))
    for j in range(4):
        for _ in range(2):  # the second pass restores orthogonality that the first lost to rounding
            for i in range(j):
                d = _dot(x[i], x[j])
                r[i, j] += d
                _axpy(x[j], d, x[i])
        norm = math.sqrt(_dot(x[j], x[j]))
        if not norm > 1e-9:
            return np.nan, np.nan, np.nan
        r[j, j] = norm
        x[j] /= norm
    mean = op.mean()
    var = 0.0
    for k in range(n):
        var += (op[k] - mean) ** 2
    if not var > 0:
        return np.nan, np.nan, np.nan
    z = np.empty(4)
    res = op.copy()
    for j in range(4):
        z[j] = _dot(x[j], res)
        _axpy(res, z[j], x[j])
    c = np.empty(4)
    for j in range(3, -1, -1):
        s = z[j]
        for i in range(j + 1, 4):
            s -= r[j, i] * c[i]
        c[j] = s / r[j, j]
    kc = c[2] / scale[2]
    integral = c[3] / scale[3]
    ti = kc / integral if integral != 0 else np.inf
    res_mean = res.mean()
    ss = 0.0
    for k in range(n):
        ss += (res[k] - res_mean) ** 2
    return kc, ti, 1.0 - ss / var


IIR_BLOCK_ROWS = 16
"""Rows ``iir_rows`` filters together: their samples of one time step sit side by side (SIMD lanes),
and a block's [N, 16] buffers stay in cache.  Transposing the whole batch instead (a diagnosis filters
up to 5,000 candidate paths of 3,600 samples in one call) made two copies of 140 MB each and spent
three quarters of the time moving them: 0.57 s against 0.15 s a call (``stiction diagnose`` of a
3,600-sample level loop 35 -> 27 s)."""


@njit(cache=True, nogil=True, error_model="numpy")
def iir_rows(b, a, x, horizon, skip):
    """Each row of ``x`` [R, N] through ``b(q^-1) / a(q^-1)`` from rest:
    ``a0 y[k] = sum b_i x[k-i] - sum_{i>0} a_i y[k-i]``.  Time runs in the outer loop and a block of
    ``IIR_BLOCK_ROWS`` rows in the inner one; the numerator's zero taps (a dead time's) are skipped.
    With ``horizon`` above 0 each row comes out compared as a record compares it
    (``ident.record.Record.compared``): its change over ``horizon`` samples from the ``skip``-th change
    on, written straight from the block's buffer (the filtered batch and its change were two more arrays
    of the batch's size, a tenth of a diagnosis)."""
    rows, n = x.shape
    if a[0] != 1.0:  # a monic denominator: no division a sample (a quarter of the filter's time)
        b, a = b / a[0], a / a[0]
    width = n - horizon - skip if horizon > 0 else n
    out = np.empty((rows, max(width, 0)))
    taps = np.flatnonzero(b[1:]) + 1
    m_block = IIR_BLOCK_ROWS
    bx = np.empty((n, m_block))
    by = np.empty((n, m_block))
    for r0 in range(0, rows, m_block):
        m = min(m_block, rows - r0)
        for k in range(n):
            for r in range(m):
                bx[k, r] = x[r0 + r, k]
        for k in range(n):
            for r in range(m):
                by[k, r] = b[0] * bx[k, r]
            for i in taps:
                if i > k:
                    break
                for r in range(m):
                    by[k, r] += b[i] * bx[k - i, r]
            for i in range(1, min(a.size, k + 1)):
                for r in range(m):
                    by[k, r] -= a[i] * by[k - i, r]
        if horizon > 0:
            for r in range(m):
                for j in range(width):
                    out[r0 + r, j] = by[horizon + skip + j, r] - by[skip + j, r]
        else:
            for r in range(m):
                for k in range(n):
                    out[r0 + r, k] = by[k, r]
    return out


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def chain_step(held, last_landing, last_d, crossing, at_last, d, brk, landing):
    """The chain of a slip set's pieces after one more slip: (whether a slip at a held drive came, its landing,
    its direction, the sum of the jumps at a moving drive, that sum at the held slip)."""
    if brk <= 0:
        return True, landing, d, crossing, crossing
    return held, last_landing, last_d, crossing + d, at_last


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def write_piece(coef, j, held, last_landing, last_d, crossing, at_last):
    """``coef[j]``, the coefficients of ``ident.valve_model.ROWS`` on a piece, from the chain before it: the last
    held slip's landing less its stop, plus the jumps since (or the level before the first slip)."""
    if held:
        coef[j, 0], coef[j, 1], coef[j, 3] = last_landing, -last_d, 0.0
    else:
        coef[j, 0], coef[j, 1], coef[j, 3] = 0.0, 0.0, 1.0
    coef[j, 2] = crossing - at_last


@njit(cache=True, nogil=True, error_model="numpy")
def piece_coefficients(at, d, breaks, landing, m, coef):
    """Write into ``coef`` [M + 1, 4] the coefficients of ``ident.valve_model.ROWS`` on each piece of one slip
    set (rows ``at``, ``d``, ``breaks``, ``landing`` [M], the first ``m`` real): piece 0 before the first slip,
    piece j + 1 from slip j on, chained from the last slip at a held drive (or the level before the first)."""
    h, hl, hd, cr, al = False, 0.0, 0.0, 0.0, 0.0
    write_piece(coef, 0, h, hl, hd, cr, al)
    for j in range(m):
        h, hl, hd, cr, al = chain_step(h, hl, hd, cr, al, d[j], breaks[j], landing[j])
        write_piece(coef, j + 1, h, hl, hd, cr, al)


@njit(cache=True, nogil=True, error_model="numpy")
def path_regressors(at, d, breaks, landing, offset, counts, n, slip_share, snapshot):
    """[V, 4, n] regressors of each slip set (rows ``at``, ``d``, ``breaks``, ``landing`` [V, M], the
    first ``counts[v]`` real, ``at`` increasing), as ``ident.valve_model.path_regressors_many`` says:
    a piece per slip (``piece_coefficients``); then each slip's interval, the old position until the break,
    less the slip's ``slip_share`` of the interval (last slip first: each reads its predecessor's sample
    unchanged), plus the slip's known ``offset`` in the drive's row (a stem sliding on after its break)."""
    v_count = at.shape[0]
    out = np.zeros((v_count, 4, n))
    coef = np.empty((at.shape[1] + 1, 4))
    for v in range(v_count):
        m = counts[v]
        piece_coefficients(at[v], d[v], breaks[v], landing[v], m, coef)
        piece = 0
        for k in range(n):
            while piece < m and at[v, piece] <= k:
                piece += 1
            for row in range(4):
                out[v, row, k] = coef[piece, row]
        if snapshot:
            continue
        for j in range(m - 1, -1, -1):
            k = at[v, j]
            if 0 < k < n:
                share = abs(breaks[v, j]) + slip_share
                for row in range(4):
                    out[v, row, k] -= share * (out[v, row, k] - out[v, row, k - 1])
                out[v, 0, k] += offset[v, j]
    return out


@njit(cache=True, nogil=True, error_model="numpy")
def projected_fits(x, xq, q_t, yp, rows, gain_free, nominal_gain):
    """Every candidate's least squares of ``ident.fit._batch_fit`` without writing its projected batch:
    ``x`` [C, m, n] a candidate's regressors compared (not projected), the first the one a fixed gain moves
    to the target's side, ``xq`` [C, m, k] = ``x @ q`` (one BLAS call), ``q_t`` [k, n] the nuisances'
    orthonormal basis, transposed, ``yp`` [n] the target projected, ``rows`` those of the m solved for.
    Per candidate its rows are projected into a buffer of one candidate's size (in cache), the normal
    equations (with the ridge of ``_batch_fit``) formed and solved, and the residual summed from that buffer:
    (rss [C], solved [C, len(rows)]).  numpy wrote the projected batch, a temporary of its size and the
    residuals, and read them again.  Every loop runs along contiguous samples."""
    c_count, m, n = x.shape
    k = q_t.shape[0]
    r = rows.size
    rss = np.empty(c_count)
    solved = np.zeros((c_count, r))
    buf = np.empty((m, n))
    target = np.empty(n)
    gram = np.empty((r, r))
    rhs = np.empty(r)
    for c in range(c_count):
        for i in range(m):
            row = buf[i]
            row[:] = x[c, i]
            for j in range(k):
                a = xq[c, i, j]
                qj = q_t[j]
                for t in range(n):
                    row[t] -= a * qj[t]
        if gain_free:
            target[:] = yp
        else:
            b0 = buf[0]
            for t in range(n):
                target[t] = yp[t] - nominal_gain * b0[t]
        trace = 0.0
        for u in range(r):
            bu = buf[rows[u]]
            for w in range(u, r):
                bw = buf[rows[w]]
                s = 0.0
                for t in range(n):
                    s += bu[t] * bw[t]
                gram[u, w] = s
                gram[w, u] = s
            trace += gram[u, u]
            s = 0.0
            for t in range(n):
                s += bu[t] * target[t]
            rhs[u] = s
        if r > 0:
            ridge = 1e-9 * trace + 1e-12
            for u in range(r):
                gram[u, u] += ridge
            b = np.linalg.solve(gram, rhs)
            for u in range(r):
                bu = buf[rows[u]]
                coef = b[u]
                for t in range(n):
                    target[t] -= coef * bu[t]
                solved[c, u] = coef
        total = 0.0
        for t in range(n):
            total += target[t] * target[t]
        rss[c] = total
    return rss, solved
