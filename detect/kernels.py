"""The window's evidence where numpy pays per call, compiled: half-cycle fits, zero crossings,
half-cycle peaks and the stick-slip shares.

Each walks a 1000-sample window once or a few times with decisions per sample or per half
cycle; in numpy they were some 60 small calls a window (0.6 ms of the 1.25 ms the evidence
cost).  numba compiles them (``cache=True``: once per machine, as ``ident/kernels.py``); the
plain loops in ``tests/detect/reference.py`` are the references they are tested against.
A cache names the module it was compiled in (``stiction.detect.kernels`` since the one installed
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
def crossings(x, hysteresis):
    """Indices where ``x`` passes from below ``-h`` to above ``+h`` or back, each walked back to
    the first sample of the run of the new sign before it (``detect.oscillation``)."""
    n = x.size
    out = np.empty(n, np.int64)
    count = 0
    state = 0
    for k in range(n):
        v = x[k]
        s = 1 if v > hysteresis else (-1 if v < -hysteresis else 0)
        if s != 0 and s != state:
            if state != 0:
                j = k
                while j > 0 and (x[j - 1] > 0 if s == 1 else x[j - 1] < 0):
                    j -= 1
                out[count] = j
                count += 1
            state = s
    return out[:count]


@njit(cache=True, nogil=True, error_model="numpy")
def regularity(crossings):
    """(r, mean period) from successive zero crossings: each pair of half periods is one period, and
    ``r = mean / (3 sd)`` (inf where every period is equal; 0 and nan under three half periods)."""
    m = crossings.size - 2  # periods: pairs of successive half periods
    if crossings.size < 4:
        return 0.0, np.nan
    total = 0.0
    for i in range(m):
        total += float(crossings[i + 2] - crossings[i])
    mean = total / m
    ss = 0.0
    for i in range(m):
        d = float(crossings[i + 2] - crossings[i]) - mean
        ss += d * d
    sd = math.sqrt(ss / m)
    return (mean / (3.0 * sd) if sd > 0 else np.inf), mean


ROUNDING_SD = math.sqrt(2.0 / 12.0)
"""The least spread of periods (samples) a record can tell: each zero crossing is placed to a sample, so a period,
the difference of two crossings, carries two roundings of sd 1/sqrt(12) each (``robust_regularity``)."""


@njit(cache=True, nogil=True, error_model="numpy")
def robust_regularity(crossings):
    """(r, mean period) as ``regularity``, but ``r = median / (3 * spread)`` with the spread the periods' median
    absolute deviation times 1.4826 (their standard deviation where they are normal), at least ``ROUNDING_SD``
    (0 and nan under three half periods)."""
    m = crossings.size - 2
    if crossings.size < 4:
        return 0.0, np.nan
    periods = np.empty(m)
    for i in range(m):
        periods[i] = float(crossings[i + 2] - crossings[i])
    middle = np.median(periods)
    spread = max(1.4826 * np.median(np.abs(periods - middle)), ROUNDING_SD)
    return middle / (3.0 * spread), periods.mean()


@njit(cache=True, nogil=True, error_model="numpy")
def _swings(y, crossings, through):
    """Each half cycle's 90th percentile (numpy's linear rule) of ``|y|`` over ``y[a : b + through]`` (``through``
    1: both ends; 0: ``[a, b)``), empty half cycles left out."""
    n_half = crossings.size - 1
    swings = np.empty(max(n_half, 0))
    longest = 0
    for h in range(n_half):
        longest = max(longest, crossings[h + 1] + through - crossings[h])
    top = np.empty(max(longest, 1))  # the largest values of a half cycle (``_order_pair``), reused
    used = 0
    for h in range(n_half):
        a, b = crossings[h], crossings[h + 1] + through
        if b <= a:
            continue
        pos = 0.9 * (b - a - 1)
        lo = int(math.floor(pos))
        v_lo, v_hi = _order_pair(y, a, b, lo, top)
        swings[used] = v_lo + (v_hi - v_lo) * (pos - lo)
        used += 1
    return swings[:used]


@njit(cache=True, nogil=True, error_model="numpy")
def _order_pair(y, a, b, lo, top):
    """The ``lo``-th and the next smallest of ``|y[a:b]|`` (the next: the ``lo``-th again where ``lo`` is the last),
    from the ``b - a - lo`` largest kept sorted in ``top`` as they are walked: a tenth of the half cycle, where a
    sort of all of it cost some 1.3 us a half cycle.  The numbers a sort reads (a nan among them: the sort's)."""
    t = b - a - lo
    count = 0
    for j in range(a, b):
        v = abs(y[j])
        if v != v:  # nan: the sort's answer
            w = np.sort(np.abs(y[a:b]))
            return w[lo], w[min(lo + 1, b - a - 1)]
        if count < t:
            k = count
            count += 1
        elif v > top[0]:
            k = 0
            while k + 1 < t and top[k + 1] < v:
                top[k] = top[k + 1]
                k += 1
            top[k] = v
            continue
        else:
            continue
        while k > 0 and top[k - 1] > v:  # filling: insert v among the first values, ascending
            top[k] = top[k - 1]
            k -= 1
        top[k] = v
    return top[0], (top[1] if t > 1 else top[0])


@njit(cache=True, nogil=True, error_model="numpy")
def swing_spread(y, crossings):
    """How much the half cycles' swings differ: the median absolute deviation of each half cycle's 90th percentile
    of ``|y|`` (over ``y[a..b]``, both ends, numpy's linear rule) times 1.4826, over their median; nan without a
    half cycle or where the median is 0."""
    swings = _swings(y, crossings, 1)
    if swings.size == 0:
        return np.nan
    middle = np.median(swings)
    if not middle > 0:
        return np.nan
    return 1.4826 * np.median(np.abs(swings - middle)) / middle


@njit(cache=True, nogil=True, error_model="numpy")
def half_cycle_peaks(y, crossings):
    """Median over half cycles ``[a, b)`` of the 90th percentile (numpy's linear rule) of ``|y|``;
    nan without a half cycle."""
    swings = _swings(y, crossings, 0)
    if swings.size == 0:
        return np.nan
    return np.median(swings)


@njit(cache=True, nogil=True, error_model="numpy")
def shape_errors(y, crossings, apexes, min_samples):
    """``(sum of the half sine's MSE, sum of the best triangle's MSE, half cycles used)`` over the
    half cycles ``y[a..b]`` (both ends) of at least ``min_samples`` samples, each fitted with
    ``p * shape + q`` in closed form (``detect.shape``).  The half sine's sums in one pass (its values by the
    angle-addition recurrence: within 2e-11 of ``sin`` over a half cycle of 1,000 samples, 6e-9 of 20,000);
    each triangle's from the half cycle's prefix sums of ``y`` and ``k * y`` and the closed sums of ``k`` and ``k^2`` on
    either side of its apex, so that the apexes cost nothing per sample."""
    mse_sine = 0.0
    mse_triangle = 0.0
    used = 0
    n_apex = apexes.size
    p0 = np.empty(y.size + 1)  # p0[j] = sum of y over the half cycle's first j samples, p1 the same of k * y
    p1 = np.empty(y.size + 1)
    for h in range(crossings.size - 1):
        a, b = crossings[h], crossings[h + 1]
        m = b - a + 1
        if m < min_samples:
            continue
        used += 1
        d = m - 1.0
        sy = syy = ss = sss = ssy = 0.0
        p0[0] = p1[0] = 0.0
        step = 2.0 * math.cos(math.pi / d)  # sin((k + 1) t) = 2 cos(t) sin(k t) - sin((k - 1) t), t = pi / d
        f_prev, f = -math.sin(math.pi / d), 0.0
        for k in range(m):
            v = y[a + k]
            if k:
                f_prev, f = f, step * f - f_prev
            sy += v
            syy += v * v
            ss += f
            sss += f * f
            ssy += f * v
            p0[k + 1] = p0[k] + v
            p1[k + 1] = p1[k] + k * v
        cyy = syy - sy * sy / m
        css = sss - ss * ss / m
        csy = ssy - ss * sy / m
        mse_sine += max(cyy - csy * csy / css, 0.0) / m
        k_all = d * m / 2.0  # sum of k over the half cycle
        k2_all = d * m * (2.0 * d + 1.0) / 6.0  # sum of k^2
        best = np.inf
        for s in range(n_apex):
            p = apexes[s]
            c = min(int(p * d) + 1, m)  # samples with k / d <= p: the rising side
            while c < m and c / d <= p:
                c += 1
            while c > 0 and (c - 1) / d > p:
                c -= 1
            rise, fall = 1.0 / (p * d), 1.0 / (1.0 - p)  # f = rise * k before the apex, fall * (1 - k / d) after
            k_l = c * (c - 1.0) / 2.0
            k2_l = (c - 1.0) * c * (2.0 * c - 1.0) / 6.0
            k_r, k2_r, n_r = k_all - k_l, k2_all - k2_l, m - c
            sf = rise * k_l + fall * (n_r - k_r / d)
            sff = rise * rise * k2_l + fall * fall * (n_r - 2.0 * k_r / d + k2_r / (d * d))
            sfy = rise * p1[c] + fall * ((sy - p0[c]) - (p1[m] - p1[c]) / d)
            css = sff - sf * sf / m
            csy = sfy - sf * sy / m
            mse = max(cyy - csy * csy / css, 0.0) / m
            if mse < best:
                best = mse
        mse_triangle += best
    return mse_sine, mse_triangle, used


@njit(cache=True, nogil=True, error_model="numpy")
def _abs_steps(x):
    d = np.empty(x.size - 1)
    for k in range(d.size):
        d[k] = abs(x[k + 1] - x[k])
    return d


@njit(cache=True, nogil=True, error_model="numpy")
def jump_share(y, top_share):
    """Share of ``y``'s total variation spent in its largest ``top_share`` of steps (``detect.features``)."""
    d = _abs_steps(y)
    total = d.sum()
    if not total > 0:
        return 0.0
    k = max(1, int(top_share * d.size))
    return np.partition(d, d.size - k)[d.size - k :].sum() / total


@njit(cache=True, nogil=True, error_model="numpy")
def still_share(y, pv, u, edge):
    """Share of spans in which ``y`` (PV's filtered level) stays within twice PV's noise while OP
    ``u`` moves by more than three times its own (``detect.features``)."""
    noise_pv = 1.4826 * np.median(_abs_steps(pv)) + 1e-12
    noise_op = 1.4826 * np.median(_abs_steps(u)) + 1e-12
    span = max(edge * 2, u.size // 30)
    step = span // 2
    count = 0
    hits = 0
    for k in range(0, u.size - span, step):
        count += 1
        if abs(y[k + span] - y[k]) < 2 * noise_pv and abs(u[k + span] - u[k]) > 3 * noise_op:
            hits += 1
    return hits / count if count else 0.0


@njit(cache=True, nogil=True, error_model="numpy")
def stuck_ramp(y, pv, u, parts, op_share, pv_share, noise_k, min_r2):
    """(share, travel): the share of spans (a ``parts``-th of the window, every quarter span) in
    which OP ``u`` (median-filtered) ramps, a straight line (R^2 >= ``min_r2``) over at least
    ``op_share`` of its range, while PV's level ``y`` (median-filtered, then averaged over 5
    samples) stays within ``noise_k`` times PV's noise or ``pv_share`` of its own range; and the
    largest OP travel over such a span (``detect.features``).

    PV's noise is its standard deviation read from its steps (robust: a slip is one step of
    hundreds).  Read from PV's distance to its median-filtered level, as before 2026-11-26, it was
    0.73 of a white noise's, and a still PV's level spread over more than the bound in half the
    spans (a measured flow valve stuck for 50 minutes under noise read not stuck).  A window whose
    PV level ranges over less than 4.4 noises (6 of the old reading's, for white noise) shows no
    PV signal to stand still against: nothing to read."""
    n = y.size
    noise = 1.4826 * np.median(_abs_steps(pv)) / np.sqrt(2.0) + 1e-12
    level = np.empty(n)
    for k in range(n):
        total = 0.0
        for j in range(k - 2, k + 3):
            total += y[min(max(j, 0), n - 1)]
        level[k] = total / 5.0
    range_pv = np.quantile(level, 0.975) - np.quantile(level, 0.025)  # by selection, not a sort: half the time
    range_op = np.quantile(u, 0.975) - np.quantile(u, 0.025)
    if range_pv < 4.4 * noise or not range_op > 0:
        return 0.0, 0.0
    span = max(n // parts, 10)
    step = max(span // 4, 1)
    still = max(noise_k * noise, pv_share * range_pv)
    count = 0
    hits = 0
    travel = 0.0
    for k in range(0, n - span, step):
        count += 1
        moved = abs(u[k + span] - u[k])
        if moved < op_share * range_op:
            continue
        lo, hi = level[k], level[k]
        for j in range(k, k + span + 1):
            lo, hi = min(lo, level[j]), max(hi, level[j])
        if hi - lo > still:
            continue
        m = span + 1
        t_mean = span / 2.0
        u_mean = 0.0
        for j in range(k, k + m):
            u_mean += u[j]
        u_mean /= m
        stt = suu = stu = 0.0
        for j in range(m):
            dt, du = j - t_mean, u[k + j] - u_mean
            stt += dt * dt
            suu += du * du
            stu += dt * du
        if suu > 0 and stu * stu / (stt * suu) >= min_r2:
            hits += 1
            travel = max(travel, moved)
    return (hits / count if count else 0.0), travel


@njit(cache=True, nogil=True, error_model="numpy")
def step_kurtosis(y, rounding_rel):
    """Kurtosis of ``y``'s steps (3.0 for steps that never vary, or vary only by the arithmetic's rounding,
    ``rounding_rel`` of the signal's size: a straight line's steps, as a historian's compression stores a
    stretch; ``oscillation.ROUNDING_REL``)."""
    n = y.size - 1
    mean = (y[n] - y[0]) / n
    v = 0.0
    q = 0.0
    size = 1.0
    for k in range(n + 1):
        size = max(size, abs(y[k]))
    for k in range(n):
        x = y[k + 1] - y[k]
        e = (x - mean) * (x - mean)
        v += e
        q += e * e
    v /= n
    q /= n
    return q / (v * v) if v > (rounding_rel * size) ** 2 else 3.0


@njit(cache=True, nogil=True, error_model="numpy")
def squared_bicoherence(spectra, i1, i2):
    """``|sum X(f1) X(f2) X*(f1+f2)|^2 / (sum |X(f1) X(f2)|^2 sum |X(f1+f2)|^2)`` over the segments
    (rows of ``spectra``) at each frequency pair ``(i1, i2)``; nan where the denominator is 0
    (``detect.bicoherence``)."""
    out = np.empty(i1.size)
    for p in range(i1.size):
        a, b = i1[p], i2[p]
        num = 0j
        d12 = 0.0
        d3 = 0.0
        for k in range(spectra.shape[0]):
            x1, x2, x12 = spectra[k, a], spectra[k, b], spectra[k, a + b]
            prod = x1 * x2
            num += prod * x12.conjugate()
            d12 += prod.real * prod.real + prod.imag * prod.imag
            d3 += x12.real * x12.real + x12.imag * x12.imag
        den = d12 * d3
        out[p] = (num.real * num.real + num.imag * num.imag) / den if den > 0 else np.nan
    return out


@njit(cache=True, nogil=True, error_model="numpy")
def running_median_rows(x, width):
    """Each row of ``x`` [W, N] median-filtered over ``width`` samples (odd), the edges repeating the first
    and last sample: ``scipy.ndimage.median_filter(x, size=(1, width), mode="nearest")``, which cost 40-50 us
    a row of 1,000 (its general rank filter) where this walk costs a few."""
    n_rows, n = x.shape
    half = width // 2
    out = np.empty_like(x)
    buf = np.empty(width)
    for r in range(n_rows):
        for i in range(n):
            for j in range(width):
                k = min(max(i - half + j, 0), n - 1)
                v = x[r, k]
                m = j
                while m > 0 and buf[m - 1] > v:  # insertion sort of a handful of values
                    buf[m] = buf[m - 1]
                    m -= 1
                buf[m] = v
            out[r, i] = buf[half]
    return out


@njit(cache=True, nogil=True, error_model="numpy")
def median(x):
    """``np.median`` of a 1-d array (nan if it holds one): the mean of the two middle values of an even
    count.  For few-sample medians, where numpy's call costs tens of us: the physical reading's four a window's
    slips (``quantify.physical``), the stuck setpoint step's two a step (``detect.setpoint``)."""
    n = x.size
    if n == 0:
        return np.nan
    s = np.sort(x)
    if np.isnan(s[-1]):
        return np.nan
    if n % 2:
        return s[n // 2]
    return (s[n // 2 - 1] + s[n // 2]) / 2.0
