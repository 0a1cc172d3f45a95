"""Hammerstein search: He's stiction model driven by the measured OP, the known process, offset and drift fitted.

The literature's model-based quantification (He et al. 2007; Jelali 2008; Choudhury
et al. 2008): for every candidate ``(fs, fd)`` replay the valve on the measured OP,
integrate its flow through the process structure, fit the process gain, offset and
drift by least squares to the measured PV, and keep the candidate with the smallest
residual.  Grid search, then two finer grids around the best candidate.  The process
is given its best chance: the canonical level process with its known gain (fitted
freely, the gain trades off against the band and the search drifts to small fs).

Vectorised over windows and candidates: one pass over the samples replays every
candidate of every window at once.
"""

from __future__ import annotations

import numpy as np

from stiction.quantify.physical import LEVEL_GAIN_PER_S
from stiction.sim.valve import FRICTION_FULL_SCALE_LBF, VALVE

LBF_PER_PCT_FRICTION = FRICTION_FULL_SCALE_LBF / 100.0
HORIZON = 5
SKIP = 100
"""Samples left out of the fit at the start: the stem's position before its first slip is unknown."""


def _replay_cost(op, pv, fs_pct, fd_pct, gain_per_s: float = LEVEL_GAIN_PER_S) -> np.ndarray:
    """[W, C] residual variance of PV against each candidate's integrated flow, after offset and drift."""
    n_win, n = op.shape
    band = fs_pct * LBF_PER_PCT_FRICTION / VALVE.lbf_per_pct  # [W, C] OP percent
    stop = fd_pct * LBF_PER_PCT_FRICTION / VALVE.lbf_per_pct
    mv = np.broadcast_to(op[:, :1], band.shape).copy()  # forgotten at the first slip
    level = np.zeros(band.shape)
    integral = np.empty((n,) + band.shape)
    for k in range(n):
        integral[k] = level
        gap = op[:, k : k + 1] - mv
        mv = np.where(np.abs(gap) > band, op[:, k : k + 1] - np.sign(gap) * stop, mv)
        level = level + mv
    x = integral[SKIP:] * gain_per_s  # [T, W, C] PV each candidate predicts, up to an offset
    # compare changes over HORIZON samples: a slip one sample late costs locally, not for the rest
    # of the window as it does on PV itself; the mean change absorbs a drift
    r = (pv[:, SKIP + HORIZON :] - pv[:, SKIP:-HORIZON]).T[:, :, None] - (x[HORIZON:] - x[:-HORIZON])
    r = r - r.mean(axis=0)
    return np.mean(r**2, axis=0)


def _candidates(fs_lo, fs_hi, n_fs, ratio_lo, ratio_hi, n_ratio):
    fs = np.linspace(fs_lo, fs_hi, n_fs)
    ratio = np.linspace(ratio_lo, ratio_hi, n_ratio)
    f, r = np.meshgrid(fs, ratio, indexing="ij")
    return f.ravel(), r.ravel()


def hammerstein_search(op: np.ndarray, pv: np.ndarray, chunk: int = 20) -> np.ndarray:
    """[W, 2] estimated (fs_pct, fd_pct) for windows [W, N] of the level loop."""
    op, pv = np.atleast_2d(op).astype(float), np.atleast_2d(pv).astype(float)
    out = np.empty((op.shape[0], 2))
    for i in range(0, op.shape[0], chunk):
        out[i : i + chunk] = _search(op[i : i + chunk], pv[i : i + chunk])
    return out


def _search(op, pv):
    n_win = op.shape[0]
    fs, ratio = _candidates(2.0, 110.0, 28, 0.0, 0.96, 13)  # coarse: 364 candidates
    fs = np.broadcast_to(fs, (n_win, fs.size))
    ratio = np.broadcast_to(ratio, fs.shape)
    cost = _replay_cost(op, pv, fs, fs * ratio)
    best = np.argmin(cost, axis=1)
    f0, r0 = fs[np.arange(n_win), best], ratio[np.arange(n_win), best]
    step_f, step_r = 4.0, 0.08
    for _ in range(2):  # two finer grids around the best so far
        offsets_f, offsets_r = _candidates(-step_f, step_f, 9, -step_r, step_r, 9)
        fs = np.clip(f0[:, None] + offsets_f[None, :], 0.5, 120.0)
        ratio = np.clip(r0[:, None] + offsets_r[None, :], 0.0, 0.99)
        cost = _replay_cost(op, pv, fs, fs * ratio)
        best = np.argmin(cost, axis=1)
        f0, r0 = fs[np.arange(n_win), best], ratio[np.arange(n_win), best]
        step_f, step_r = step_f / 4, step_r / 4
    return np.stack([f0, f0 * r0], axis=1)
