"""The physical reading: for a known integrating process, every slip of the stem reads fs and fd.

For the canonical level loop (``PV' = MV / 15 s``, spec/thesis-loop.md) the mean
flow over each sample interval is ``15 s * (PV[k+1] - PV[k])``, and the stem's
position follows from it (a slip of 1 % withholds ``Fv/k`` s of flow,
``sim.valve``).  With MV known:

- a slip at sample k means the stem was stuck at k-1 with ``|OP - MV| <= S`` and
  broke away at k with ``|OP - MV| > S``: each slip brackets the band ``S = fs/12``,
  and every stuck sample bounds it from below;
- after a slip ``|OP[k] - MV[k+1]| = (fd + k r)/12`` exactly, r the stop residual.

Noise in PV (or a disturbance on the process input) breaks this reading; it says so
by ``consistent = False`` and the pipeline then trusts the learned predictor.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sim.valve import VALVE, lbf_to_pct, pct_to_lbf, stop_residual_in

LEVEL_GAIN_PER_S = 1.0 / 15.0
SETTLE_SAMPLES = 5  # the MV recursion forgets its start by a factor ~0.012 a sample


@dataclass(frozen=True)
class PhysicalReading:
    """Estimates with their standard errors, all in percent of 500 lbf; arrays over windows."""

    fs_pct: np.ndarray
    fd_pct: np.ndarray
    fs_se_pct: np.ndarray
    fd_se_pct: np.ndarray
    slips: np.ndarray
    bracketed: np.ndarray
    """The slips' brackets on the band intersect: the noise-free reading, exact to the bracket."""


def reconstruct_mv(pv: np.ndarray, ts_s: float = 1.0, gain_per_s: float = LEVEL_GAIN_PER_S) -> np.ndarray:
    """[W, N] stem position from PV of an integrating process (the first samples are settling)."""
    flow = np.diff(pv, axis=1) / (gain_per_s * ts_s)
    c = VALVE.viscous_lbf_s_per_in / VALVE.spring_lbf_per_in / ts_s
    mv = np.empty_like(pv, dtype=float)
    mv[:, 0] = flow[:, 0]
    for k in range(flow.shape[1]):
        mv[:, k + 1] = (flow[:, k] - c * mv[:, k]) / (1 - c)
    return mv


def _robust_se(x: np.ndarray) -> float:
    """Standard error of a median from the MAD (normal efficiency factor 1.25)."""
    mad = 1.4826 * np.median(np.abs(x - np.median(x)))
    return 1.25 * mad / np.sqrt(x.size)


def read(op: np.ndarray, pv: np.ndarray, ts_s: float = 1.0, gain_per_s: float = LEVEL_GAIN_PER_S) -> PhysicalReading:
    """Per slip: the band from the gaps just before and at the breakaway, fd from the gap after.

    Robust medians over slips with their standard errors; when the brackets of all
    slips intersect (no noise), fs is the intersection's midpoint instead.
    """
    op, pv = np.atleast_2d(op).astype(float), np.atleast_2d(pv).astype(float)
    mv = reconstruct_mv(pv, ts_s, gain_per_s)[:, SETTLE_SAMPLES:]
    op = op[:, SETTLE_SAMPLES:]
    move = np.abs(np.diff(mv, axis=1))
    big = np.percentile(move, 99, axis=1, keepdims=True)
    slipped = move > 0.25 * big
    slipped[:, 0] = False  # a slip needs the stuck sample before it
    gap = np.abs(op - mv)
    gap_after = np.abs(op[:, :-1] - mv[:, 1:])
    to_pct = VALVE.lbf_per_pct * 100.0 / 500.0
    n_win = op.shape[0]
    fs, fd, fs_se, fd_se = (np.full(n_win, np.nan) for _ in range(4))
    bracketed = np.zeros(n_win, bool)
    slips = slipped.sum(axis=1)
    for i in range(n_win):
        k = np.flatnonzero(slipped[i])
        if k.size < 4:
            continue
        fs_k = 0.5 * (gap[i, k - 1] + gap[i, k]) * to_pct
        fd_k = gap_after[i, k] * to_pct
        fs[i], fd[i] = np.median(fs_k), np.median(fd_k)
        fs_se[i], fd_se[i] = _robust_se(fs_k), _robust_se(fd_k)
        stuck = ~slipped[i]
        stuck[0] = False  # its predecessor is unknown: it may have been a slip
        low, high = gap[i, :-1][stuck].max(), gap[i, k].min()
        if low < high:
            bracketed[i] = True
            fs[i] = 0.5 * (low + high) * to_pct
            fs_se[i] = (high - low) * to_pct / np.sqrt(12)
        # the stop residual: fd is a fraction of a lbf below the force left on the stem
        residual_lbf = VALVE.spring_lbf_per_in * stop_residual_in(pct_to_lbf(fs[i] - fd[i]))
        fd[i] -= lbf_to_pct(residual_lbf)
    return PhysicalReading(fs, fd, fs_se, fd_se, slips, bracketed)
