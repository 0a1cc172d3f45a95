"""The sampled loop's record, compiled: ``sim.loop.advance`` repeated over every sample of every loop.

``advance`` (numpy over loops) is the definition and stays the reference; this is its transcription
loop by loop and sample by sample, with the same operations in the same order, so that a record is
the same to the last bit where the libm calls agree (tests/sim/test_kernel.py checks it against
``advance`` repeated).  A sample of the numpy step costs about 30 array operations whatever the
batch (125 us a sample here); compiled, a loop-sample costs well under a microsecond.

``error_model="numpy"``: a division by zero gives inf or nan as numpy does (the lagged valve's
breakaway time relies on it), not an exception.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from stiction.sim.valve import SLIDING_TOL_PCT


@njit(cache=True, error_model="numpy")
def _nan_to_num(x, nan):
    """``np.nan_to_num`` of one float: nan -> ``nan``, +-inf -> the largest finite float of that sign."""
    if np.isnan(x):
        return nan
    if np.isinf(x):
        return 1.7976931348623157e308 if x > 0 else -1.7976931348623157e308
    return x


@njit(cache=True, error_model="numpy")
def _clip(x, lo, hi):
    return min(max(x, lo), hi)


@njit(cache=True, error_model="numpy")
def _lagged_step(p0, op, tau_s, ts_s, mv, fs_lbf, stop_lbf, slip_s, lbf_per_pct, slide):
    """``sim.valve.lagged_valve_step`` for one valve: ``(mv_end, deficit, p_end)``."""
    decay = np.exp(-ts_s / tau_s)
    p_end = op + (p0 - op) * decay
    d = np.sign(op - p0)
    d_drive = d
    band = fs_lbf / lbf_per_pct
    stop = stop_lbf / lbf_per_pct
    step = max(band - stop, 1e-9)
    rate0 = abs(op - p0) / tau_s
    carried = d != 0 and abs(d * (p0 - mv) - stop) <= SLIDING_TOL_PCT and rate0 > slide
    p_break = mv + d * band
    already = abs(p0 - mv) > band or carried
    slipped = already or (d * (p_end - p_break) > 0)
    t_break = 0.0 if already else tau_s * np.log((op - p0) / (op - p_break))
    t_break = _clip(_nan_to_num(t_break, 0.0), 0.0, ts_s) if slipped else ts_s
    p_at_break = p0 if already else p_break
    if already and not carried:
        d = np.sign(p0 - mv)
    t_slide = t_break
    if slipped and d == d_drive and rate0 > slide:
        t_slide = _clip(_nan_to_num(tau_s * np.log(rate0 / slide), 0.0), t_break, ts_s)
    p_slid = op + (p0 - op) * np.exp(-t_slide / tau_s) if t_slide > t_break else p_at_break
    mv_first = p_slid - d * stop
    n_more = np.floor(max(d * (p_end - p_slid), 0.0) / step) if slipped else 0.0
    mv_end = mv_first + d * n_more * step if slipped else mv
    t_last = tau_s * np.log((op - p0) / (op - (p_slid + d * n_more * step))) if n_more > 0 else t_slide
    t_last = _clip(_nan_to_num(t_last, ts_s), t_slide, ts_s)
    slid = 0.0
    if t_slide > t_break:
        rise = op * (t_slide - t_break) + (p0 - op) * tau_s * (np.exp(-t_break / tau_s) - np.exp(-t_slide / tau_s))
        slid = rise - d * stop * (t_slide - t_break)
    if n_more > 0:
        rise = op * (t_last - t_slide) + (p0 - op) * tau_s * (np.exp(-t_slide / tau_s) - np.exp(-t_last / tau_s))
        stair = rise - (d * stop + d * step / 2) * (t_last - t_slide)
    else:
        stair = mv_first * (t_last - t_slide)
    integral = mv * t_break + slid + stair + mv_end * (ts_s - t_last)
    deficit = (mv_end * ts_s - integral if slipped else 0.0) + (mv_end - mv) * slip_s
    return mv_end, deficit, p_end


@njit(cache=True, error_model="numpy")
def run_loops(
    kc, ti_s, sp, fs_lbf, stop_lbf, slip_s, lbf_per_pct, slide_pct_s, tracks, phi, gamma_now, gamma_prev, gamma_w, c,
    delay, deadband_pct, actuator_tau_s, w, z, ts_s, x, error_sum, mv, drive, played, flow_hist, k0,
):  # fmt: skip
    """Every loop over every sample from the given state (updated in place, as at the end).

    Arguments are ``sim.loop.Batch`` and ``LoopState`` as arrays over loops; returns ``(op, pv, mv)``
    records ``(n_loops, n_samples)``, MV being the stem at each sample.
    """
    n, n_samples = w.shape
    ring = flow_hist.shape[1]
    op_rec = np.empty((n, n_samples))
    pv_rec = np.empty((n, n_samples))
    mv_rec = np.empty((n, n_samples))
    for i in range(n):
        x0, x1 = x[i, 0], x[i, 1]
        e_sum, stem, dr, pl = error_sum[i], mv[i], drive[i], played[i]
        half = deadband_pct[i] / 2
        for j in range(n_samples):
            k = k0 + j
            mv_rec[i, j] = stem
            pv = c[i, 0] * x0 + c[i, 1] * x1 + z[i, j]
            error = sp[i] - pv
            e_sum = e_sum + error
            op = kc[i] * (error + ts_s / ti_s[i] * e_sum)
            op_rec[i, j] = op
            pv_rec[i, j] = pv

            pl = _clip(pl, op - half, op + half)
            target = pl if deadband_pct[i] > 0 else op
            if actuator_tau_s[i] > 0:
                stem_next, deficit, dr = _lagged_step(
                    dr, target, actuator_tau_s[i], ts_s, stem, fs_lbf[i], stop_lbf[i], slip_s[i], lbf_per_pct[i],
                    slide_pct_s[i],
                )
            else:
                force = lbf_per_pct[i] * (target - stem)
                jump = 0.0
                if abs(force) > fs_lbf[i]:
                    jump = (force - np.sign(force) * stop_lbf[i]) / lbf_per_pct[i]
                if tracks[i]:
                    d = np.sign(target - dr)
                    stop = stop_lbf[i] / lbf_per_pct[i]
                    if d != 0 and abs(d * (dr - stem) - stop) <= SLIDING_TOL_PCT:
                        jump = target - d * stop - stem
                stem_next = stem + jump
                deficit = jump * slip_s[i]
                dr = target
            flow = stem_next - deficit / ts_s

            flow_hist[i, k % ring] = flow
            flow_now = flow_hist[i, (k - delay[i]) % ring]
            flow_prev = flow_hist[i, (k - delay[i] - 1) % ring]
            y0 = phi[i, 0, 0] * x0 + phi[i, 0, 1] * x1
            y1 = phi[i, 1, 0] * x0 + phi[i, 1, 1] * x1
            x0 = y0 + gamma_now[i, 0] * flow_now + gamma_prev[i, 0] * flow_prev + gamma_w[i, 0] * w[i, j]
            x1 = y1 + gamma_now[i, 1] * flow_now + gamma_prev[i, 1] * flow_prev + gamma_w[i, 1] * w[i, j]
            stem = stem_next
        x[i, 0], x[i, 1] = x0, x1
        error_sum[i], mv[i], drive[i], played[i] = e_sum, stem, dr, pl
    return op_rec, pv_rec, mv_rec
