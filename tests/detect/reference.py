"""Plain per-half-cycle loops: the references the vectorised detect code is checked against."""

import numpy as np

from stiction.detect.oscillation import detrend, half_cycles
from stiction.detect.shape import APEXES


def amplitude(y, crossings):
    swings = [
        float(np.percentile(np.abs(y[a:b]), 90)) for a, b in zip(crossings[:-1], crossings[1:], strict=True) if b > a
    ]
    return float(np.median(swings)) if swings else float(np.ptp(y)) / 2


def stiction_index(x):
    y = detrend(np.asarray(x, float))
    sd = float(np.std(y))
    if not sd > 0:
        return float("nan")
    _, zc = half_cycles(y, sd)
    if zc.size < 3:
        return float("nan")
    apexes = np.linspace(0.1, 0.9, APEXES)
    mse_sine = mse_triangle = 0.0
    used = 0
    for a, b in zip(zc[:-1], zc[1:], strict=True):
        seg = y[a : b + 1]
        if seg.size < 5:
            continue
        used += 1
        u = np.linspace(0.0, 1.0, seg.size)
        errors = []
        for shape in [np.sin(np.pi * u)] + [np.where(u <= p, u / p, (1 - u) / (1 - p)) for p in apexes]:
            coef = np.polyfit(shape, seg, 1)  # least squares y = c1 * shape + c0
            errors.append(np.mean((seg - np.polyval(coef, shape)) ** 2))
        mse_sine += errors[0]
        mse_triangle += min(errors[1:])
    total = mse_sine + mse_triangle
    return float(mse_sine / total) if used and total > 0 else float("nan")


def regularity(crossings):
    """(r, mean period) as numpy reads them: intervals, each pair of half periods one period."""
    intervals = np.diff(np.asarray(crossings)).astype(float)
    if intervals.size < 3:
        return 0.0, float("nan")
    periods = intervals[1:] + intervals[:-1]
    sd, mean = float(np.std(periods)), float(np.mean(periods))
    return (mean / (3 * sd) if sd > 0 else np.inf), mean


def robust_regularity(crossings):
    """(r, mean period) by the periods' median and median absolute deviation, the spread at least sqrt(2/12)."""
    intervals = np.diff(np.asarray(crossings)).astype(float)
    if intervals.size < 3:
        return 0.0, float("nan")
    periods = intervals[1:] + intervals[:-1]
    middle = float(np.median(periods))
    spread = max(1.4826 * float(np.median(np.abs(periods - middle))), np.sqrt(2 / 12))
    return middle / (3 * spread), float(np.mean(periods))


def swing_spread(y, crossings):
    """MAD (times 1.4826) over median of each half cycle's 90th percentile of |y| over y[a..b]."""
    swings = [np.percentile(np.abs(y[a : b + 1]), 90) for a, b in zip(crossings[:-1], crossings[1:], strict=True)]
    if not swings or not np.median(swings) > 0:
        return float("nan")
    middle = float(np.median(swings))
    return 1.4826 * float(np.median(np.abs(np.array(swings) - middle))) / middle


def crossings(x, hysteresis):
    state = 0
    out = []
    for k, v in enumerate(x):
        s = 1 if v > hysteresis else -1 if v < -hysteresis else 0
        if s and s != state:
            if state:
                j = k
                while j > 0 and np.sign(x[j - 1]) == s:
                    j -= 1
                out.append(j)
            state = s
    return np.asarray(out, dtype=int)


def detrend_polyfit(x):
    t = np.arange(x.size, dtype=float)
    slope, intercept = np.polyfit(t, x, 1)
    return x - (slope * t + intercept)


def squared_bicoherence(x, segment):
    x = detrend_polyfit(np.asarray(x, float))
    x = x / (np.std(x) or 1.0)
    starts = range(0, x.size - segment + 1, segment // 2)
    window = np.hanning(segment)
    spectra = np.array([np.fft.fft(window * (x[s : s + segment] - x[s : s + segment].mean())) for s in starts])
    f = segment // 2
    out = np.full((f, f), np.nan)
    for i1 in range(f):
        for i2 in range(1, i1 + 1):
            if i1 + i2 >= f:
                continue
            x1, x2, x12 = spectra[:, i1], spectra[:, i2], spectra[:, i1 + i2]
            den = np.sum(np.abs(x1 * x2) ** 2) * np.sum(np.abs(x12) ** 2)
            if den > 0:
                out[i1, i2] = np.abs(np.sum(x1 * x2 * np.conj(x12))) ** 2 / den
    return out, len(spectra)


def jump_share(y, top_share):
    steps = sorted(abs(b - a) for a, b in zip(y[:-1], y[1:], strict=True))
    total = sum(steps)
    if not total > 0:
        return 0.0
    k = max(1, int(top_share * len(steps)))
    return sum(steps[-k:]) / total


def still_share(y, pv, u, edge):
    noise_pv = 1.4826 * np.median(np.abs(np.diff(pv))) + 1e-12
    noise_op = 1.4826 * np.median(np.abs(np.diff(u))) + 1e-12
    span = max(edge * 2, len(u) // 30)
    spans = [k for k in range(0, len(u) - span, span // 2)]
    hits = [abs(y[k + span] - y[k]) < 2 * noise_pv and abs(u[k + span] - u[k]) > 3 * noise_op for k in spans]
    return sum(hits) / len(hits) if hits else 0.0


def stuck_ramp(y, pv, u, parts, op_share, pv_share, noise_k, min_r2):
    from scipy.ndimage import uniform_filter1d

    noise = 1.4826 * np.median(np.abs(np.diff(pv))) / np.sqrt(2) + 1e-12
    level = uniform_filter1d(np.asarray(y, float), 5, mode="nearest")
    range_pv = np.percentile(level, 97.5) - np.percentile(level, 2.5)
    range_op = np.percentile(u, 97.5) - np.percentile(u, 2.5)
    if range_pv < 4.4 * noise or not range_op > 0:
        return 0.0, 0.0
    span = max(len(y) // parts, 10)
    spans = list(range(0, len(y) - span, max(span // 4, 1)))
    hits = []
    for k in spans:
        seg = u[k : k + span + 1]
        if abs(seg[-1] - seg[0]) < op_share * range_op:
            continue
        if np.ptp(level[k : k + span + 1]) > max(noise_k * noise, pv_share * range_pv):
            continue
        if np.corrcoef(np.arange(seg.size), seg)[0, 1] ** 2 >= min_r2:
            hits.append(abs(seg[-1] - seg[0]))
    return (len(hits) / len(spans) if spans else 0.0), max(hits, default=0.0)


def step_kurtosis(y, rounding_rel):
    d = np.diff(y)
    d = d - d.mean()
    v = np.mean(d * d)
    rounding = rounding_rel * max(1.0, float(np.max(np.abs(y))))  # steps that differ by the arithmetic's rounding
    return float(np.mean(d**4) / v**2) if v > rounding**2 else 3.0


def swings_sorted(y, crossings, through):
    """Each half cycle's 90th percentile of |y| over y[a : b + through], read from the sorted half cycle as the
    kernel reads it (lower value plus the share of the step to the next): the number the kernel's selection must
    give to the bit."""
    out = []
    for a, b in zip(crossings[:-1], crossings[1:], strict=True):
        b = b + through
        if b <= a:
            continue
        v = np.sort(np.abs(y[a:b]))
        pos = 0.9 * (b - a - 1)
        lo = int(np.floor(pos))
        hi = min(lo + 1, b - a - 1)
        out.append(v[lo] + (v[hi] - v[lo]) * (pos - lo))
    return np.array(out)


def stuck_steps_alone(edges_op, edges_pv, pv, sp):
    """``detect.setpoint``'s stuck steps of one window, its statistics taken with numpy's per-row calls (the
    median of PV's distance to its level, OP's two percentiles), as before the batch took them at once."""
    from stiction.detect import setpoint

    change = setpoint._steps(sp, edges_op.size)
    if change is None:
        return []
    noise = float(setpoint._noise(np.median(np.abs(pv - edges_pv))))
    steps = setpoint._counted(change, noise)
    if steps is None:
        return []
    range_op = float(np.percentile(edges_op, 97.5) - np.percentile(edges_op, 2.5))
    return setpoint._stuck(edges_op, edges_pv, np.asarray(sp, float), steps, noise, range_op)
