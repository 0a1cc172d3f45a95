"""The fitted reading's inner loop, compiled: the physical valve driven by the recorded OP, integrated by the level
process, against the recorded PV, for many candidate frictions at once.

``ident.open_loop`` keeps the definitions (``first_breakaways``, ``breakaway_residual``: numpy, one candidate);
tests/ident/test_open_loop.py holds this kernel to them.  A candidate from one breakaway costs one pass over the
window (1,000 samples: about 3 us).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True, error_model="numpy")
def _line_rss_prefix(pv):
    """Prefix sums of ``pv`` (less its first sample), ``k * pv`` and ``pv**2``: any leading stretch's RSS about its
    least-squares line in O(1) (``_line_rss``)."""
    n = pv.size
    p1 = np.empty(n)
    pt = np.empty(n)
    p2 = np.empty(n)
    a1 = 0.0
    at = 0.0
    a2 = 0.0
    for k in range(n):
        y = pv[k] - pv[0]
        a1 += y
        at += k * y
        a2 += y * y
        p1[k] = a1
        pt[k] = at
        p2[k] = a2
    return p1, pt, p2


@njit(cache=True, nogil=True, error_model="numpy")
def _second_difference_prefix(pv):
    """Prefix sums of ``pv``'s squared second differences: ``out[k]`` sums those within samples ``0..k``."""
    n = pv.size
    out = np.zeros(n)
    acc = 0.0
    for k in range(2, n):
        d2 = pv[k] - 2 * pv[k - 1] + pv[k - 2]
        acc += d2 * d2
        out[k] = acc
    return out


@njit(cache=True, nogil=True, error_model="numpy")
def _line_rss(p1, pt, p2, k):
    """The RSS of samples ``0..k`` about their least-squares line (``_stretch_rss`` of the prefix sums; nothing
    under three samples)."""
    return _stretch_rss(p1[k], p2[k], pt[k], k + 1, True) if k >= 2 else 0.0


@njit(cache=True, nogil=True, error_model="numpy")
def _stretch_rss(s1, s2, st, count, ramp):
    """A stretch's RSS about its mean (``ramp``: about its least-squares line) from its sums of ``r``, ``r**2`` and
    ``j * r`` (``j`` from 0)."""
    m = float(count)
    rss = s2 - s1 * s1 / m
    if ramp and m >= 3:
        tt = m * (m - 1) / 2
        sxx = (m - 1) * m * (2 * m - 1) / 6 - tt * tt / m
        sxy = st - tt * s1 / m
        rss -= sxy * sxy / sxx
    return max(rss, 0.0)


@njit(cache=True, nogil=True, error_model="numpy")
def breakaways(op, band_pct, max_events, ks, ds):
    """The first breakaways a stem stuck somewhere at the window's start can make (``open_loop.first_breakaways``),
    written to ``ks`` (sample) and ``ds`` (+1 up, -1 down); at most ``max_events``, evenly spaced in their order where
    there are more.  Returns how many."""
    n = op.size
    count = 0
    hi = -np.inf
    lo = np.inf
    for k in range(n):
        if hi - lo >= 2 * band_pct:
            break  # no stem held still through sample k - 1
        if op[k] > hi:
            ks[count] = k
            ds[count] = 1
            count += 1
        if op[k] < lo:
            ks[count] = k
            ds[count] = -1
            count += 1
        hi = max(hi, op[k])
        lo = min(lo, op[k])
    if count <= max_events:
        return count
    for e in range(max_events):  # evenly spaced, in place (the source index never trails the target)
        src = int(round(e * (count - 1) / (max_events - 1))) if max_events > 1 else 0
        ks[e] = ks[src]
        ds[e] = ds[src]
    return max_events


@njit(cache=True, nogil=True, error_model="numpy")
def event_rss(
    op, pv, fs_lbf, stop_lbf, slip_share, gain_ts, lbf_per_pct, segment, max_events, ramp, cap_ratio, order=0
):
    """[C] each candidate's least residual sum of squares over its first breakaways, and that breakaway's sample
    and direction ([C] each).

    The stem's start is not a number to grid: a stem stuck anywhere at the window's start holds still, making a
    level that is a line in time, until its first breakaway, and from there lands where the OP of that sample puts
    it (``op - direction * stop / lbf_per_pct``), whatever it started from.  So a start is one of the samples OP
    could break away at (``breakaways``): the samples up to it are held to their own least-squares line (its
    slope is the stuck stem's flow), and those after it to the valve's level from there, with a free offset in
    every stretch of ``segment`` samples counted from it (``ramp``: a free line in every stretch, a constant flow
    the valve does not make).  A candidate whose residual exceeds ``cap_ratio`` times the best of the candidates
    before it is left unfinished, inf (the search reads only residuals near its best: order the candidates best
    guess first).

    ``order`` 2: the residual's second differences are summed instead (on either side of the breakaway, not
    across it; ``segment`` and ``ramp`` do not apply, a line has none): the least squares of a noise that is a
    random walk's integral, which a wandering inflow makes of the level."""
    n = op.size
    pv = pv - pv[0]  # offsets are free: small numbers keep the sums exact
    p1, pt, p2 = _line_rss_prefix(pv)
    q2 = _second_difference_prefix(pv)
    out = np.empty(fs_lbf.size)
    best_k = np.zeros(fs_lbf.size, np.int64)
    best_d = np.zeros(fs_lbf.size, np.int64)
    ks = np.empty(2 * n, np.int64)
    ds = np.empty(2 * n, np.int64)
    best_all = np.inf
    for c in range(fs_lbf.size):
        events = breakaways(op, fs_lbf[c] / lbf_per_pct, max_events, ks, ds)
        cap = cap_ratio * best_all
        out[c] = cap
        for e in range(events):
            k1 = ks[e]
            total = q2[k1] if order == 2 else _line_rss(p1, pt, p2, k1)
            if total >= out[c]:
                continue
            mv = op[k1] - ds[e] * stop_lbf[c] / lbf_per_pct
            level = 0.0
            s1 = 0.0
            s2 = 0.0
            st = 0.0
            count = 0
            r1 = 0.0
            r2 = 0.0
            for k in range(k1 + 1, n):
                r = pv[k] - level
                if order == 2:
                    if k >= k1 + 3:
                        d2 = r - 2 * r1 + r2
                        total += d2 * d2
                        if total >= out[c]:
                            break
                    r2 = r1
                    r1 = r
                else:
                    s1 += r
                    s2 += r * r
                    st += count * r
                    count += 1
                    if count == segment or k == n - 1:
                        total += _stretch_rss(s1, s2, st, count, ramp)
                        s1 = 0.0
                        s2 = 0.0
                        st = 0.0
                        count = 0
                        if total >= out[c]:
                            break
                force = lbf_per_pct * (op[k] - mv)
                flow = mv
                if abs(force) > fs_lbf[c]:
                    jump = (force - np.sign(force) * stop_lbf[c]) / lbf_per_pct
                    mv += jump
                    flow = mv - jump * slip_share
                level += gain_ts * flow
            if total < out[c]:
                out[c] = total
                best_k[c] = k1
                best_d[c] = ds[e]
        if out[c] >= cap:
            out[c] = np.inf
        best_all = min(best_all, out[c])
    return out, best_k, best_d
