"""The physical reading: for a known integrating process, every slip of the stem reads fs and fd.

For the canonical level loop (``PV' = MV / 15 s``, spec/thesis-loop.md) the mean
flow over each sample interval is ``15 s * (PV[k+1] - PV[k])``, and the stem's
position follows from it (a slip of 1 % withholds ``Fv/k`` s of flow,
``sim.valve``).  With MV known:

- a slip at sample k means the stem was stuck at k-1 with ``|OP - MV| <= S`` and
  broke away at k with ``|OP - MV| > S``: each slip brackets the band ``S = fs/12``,
  and every stuck sample bounds it from below;
- after a slip ``|OP[k] - MV[k+1]| = (fd + k r)/12`` exactly, r the stop residual.

White noise in PV breaks the sample-by-sample reading.  Between slips the stem is
still, so the flow series ``15 s * dPV`` is piecewise constant plus noise: an optimal
segmentation of it (penalised least squares) finds the slips as segment boundaries and
the stem's positions as segment means, and the same brackets then read fs and fd
(``read_segmented``).  Slow disturbances on the process input make the flow itself vary
and defeat both readings; their standard errors say so, and the pipeline then fits the
valve to the whole record (``ident.open_loop``, where its residual is PV's noise) or trusts
the learned predictor.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stiction.detect import kernels
from stiction.ident.segment import noise_variance, segment_ends
from stiction.quantify import physical_kernel
from stiction.sim.process import LOOPS
from stiction.sim.valve import PCT_OF_500LBF_PER_PCT_OF_SPAN, VALVE, lbf_to_pct, pct_to_lbf, stop_residual_in

LEVEL_GAIN_PER_S = LOOPS["level"].gain
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
    segmented: np.ndarray
    """The reading comes from the segmented flow (noisy windows), not sample by sample."""


def reconstruct_mv(pv: np.ndarray, ts_s: float = 1.0, gain_per_s: float = LEVEL_GAIN_PER_S) -> np.ndarray:
    """[W, N] stem position from PV of an integrating process (the first samples are settling)."""
    flow = np.diff(np.atleast_2d(pv).astype(float), axis=1) / (gain_per_s * ts_s)
    c = VALVE.viscous_lbf_s_per_in / VALVE.spring_lbf_per_in / ts_s
    # mv[k+1] = (flow[k] - c mv[k]) / (1 - c) from mv[0] = flow[0], compiled
    return physical_kernel.stem_from_flow(np.ascontiguousarray(flow), float(c))


def _median(x) -> float:
    """``np.median`` of a 1-d array, compiled (``detect.kernels.median``)."""
    return kernels.median(np.ascontiguousarray(x, dtype=float))


def _from_slips(gap_stuck, gap_broke, gap_after) -> tuple[float, float, float, float]:
    """Per-slip readings -> (fs, fd, their standard errors), percent of 500 lbf.

    The band lies between the gap at the last stuck sample and the gap at breakaway; fd is the
    force left on the stem after the slip, less the Stribeck stop residual (a fraction of a lbf).
    """
    fs_k = 0.5 * (gap_stuck + gap_broke) * PCT_OF_500LBF_PER_PCT_OF_SPAN
    stop_k = gap_after * PCT_OF_500LBF_PER_PCT_OF_SPAN
    fs, stop = float(_median(fs_k)), float(_median(stop_k))
    fd = stop - float(lbf_to_pct(VALVE.spring_lbf_per_in * stop_residual_in(pct_to_lbf(fs - stop))))
    return fs, fd, _robust_se(fs_k), _robust_se(stop_k)


def _robust_se(x: np.ndarray) -> float:
    """Standard error of a median from the MAD (normal efficiency factor 1.25)."""
    mad = 1.4826 * _median(np.abs(x - _median(x)))
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
    n_win = op.shape[0]
    fs, fd, fs_se, fd_se = (np.full(n_win, np.nan) for _ in range(4))
    bracketed = np.zeros(n_win, bool)
    slips = slipped.sum(axis=1)
    for i in range(n_win):
        k = np.flatnonzero(slipped[i])
        if k.size < 4:
            continue
        fs[i], fd[i], fs_se[i], fd_se[i] = _from_slips(gap[i, k - 1], gap[i, k], gap_after[i, k])
        stuck = ~slipped[i]
        stuck[0] = False  # its predecessor is unknown: it may have been a slip
        if not stuck.any():  # a stem moving at every sample: no stuck gap bounds the band from below
            continue
        low, high = gap[i, :-1][stuck].max(), gap[i, k].min()
        if low < high:  # no noise: the intersection of all brackets
            bracketed[i] = True
            fs[i] = 0.5 * (low + high) * PCT_OF_500LBF_PER_PCT_OF_SPAN
            fs_se[i] = (high - low) * PCT_OF_500LBF_PER_PCT_OF_SPAN / np.sqrt(12)
    return PhysicalReading(fs, fd, fs_se, fd_se, slips, bracketed, np.zeros(n_win, bool))


SAMPLEWISE_TRUSTED_SE_PCT = 0.25
SEGMENT_PENALTY = 3.0
"""Penalty per segment, in units of the flow's noise variance times log(N) (a BIC-like choice)."""


def read_segmented(
    op: np.ndarray, pv: np.ndarray, ts_s: float = 1.0, gain_per_s: float = LEVEL_GAIN_PER_S
) -> PhysicalReading:
    """The reading from the flow's optimal segmentation: for windows with white noise in PV or flow."""
    op, pv = np.atleast_2d(op).astype(float), np.atleast_2d(pv).astype(float)
    flow = np.diff(pv, axis=1) / (gain_per_s * ts_s)
    n_win, n = flow.shape
    ends = segment_ends(flow, SEGMENT_PENALTY * noise_variance(flow) * np.log(n) + 1e-12)
    fs, fd, fs_se, fd_se, slips = (np.full(n_win, np.nan) for _ in range(5))
    for w in range(n_win):
        bounds = [0, *ends[w]]
        mv = physical_kernel.piece_means(flow[w], np.array(ends[w], dtype=np.int64))  # each piece's mean flow
        starts = np.array(bounds[1:-1])  # interval of each slip: the first of the next piece
        jumps = np.abs(np.diff(mv))
        if jumps.size < 4:
            continue
        real = (jumps > 0.25 * np.median(jumps)) & (starts >= 2)  # not a split of one stuck stretch
        k, i = starts[real], np.flatnonzero(real)
        if k.size < 4:
            continue
        fs[w], fd[w], fs_se[w], fd_se[w] = _from_slips(
            np.abs(op[w, k - 1] - mv[i]), np.abs(op[w, k] - mv[i]), np.abs(op[w, k] - mv[i + 1])
        )
        slips[w] = k.size
    return PhysicalReading(fs, fd, fs_se, fd_se, slips, np.zeros(n_win, bool), np.ones(n_win, bool))


def no_reading(n_win: int) -> PhysicalReading:
    nan, no = np.full(n_win, np.nan), np.zeros(n_win, bool)
    return PhysicalReading(nan, nan, nan, nan, np.zeros(n_win), no, no)


def read_best(
    op: np.ndarray, pv: np.ndarray, ts_s: float = 1.0, gain_per_s: float = LEVEL_GAIN_PER_S
) -> PhysicalReading:
    """Sample by sample where that is trusted; else the segmented reading where its errors are smaller."""
    strict = read(op, pv, ts_s, gain_per_s)
    worst = np.fmax(strict.fs_se_pct, strict.fd_se_pct)
    redo = ~(worst <= SAMPLEWISE_TRUSTED_SE_PCT)
    if not redo.any():
        return strict
    seg = read_segmented(np.atleast_2d(op)[redo], np.atleast_2d(pv)[redo], ts_s, gain_per_s)
    better = np.fmax(seg.fs_se_pct, seg.fd_se_pct) < np.nan_to_num(worst[redo], nan=np.inf)
    idx = np.flatnonzero(redo)[better]
    fields = {}
    for name in ("fs_pct", "fd_pct", "fs_se_pct", "fd_se_pct", "slips", "bracketed", "segmented"):
        merged = np.array(getattr(strict, name), dtype=float if name not in ("bracketed", "segmented") else bool)
        merged[idx] = getattr(seg, name)[better]
        fields[name] = merged
    return PhysicalReading(**fields)


def warm_up() -> None:
    """Compile (or load from their caches) the reading's kernels, both ways (sample by sample, and segmented for
    a noisy window), before the first report: on a machine's first run they cost the first sticky level loops'
    reports about a second (the demo's p99 latency 0.8 s in a fresh clone, 17 ms once compiled)."""
    t = np.arange(400.0)
    stem = 50 + 2 * np.sign(np.sin(2 * np.pi * t / 80))  # a level loop's stem slipping twice a cycle
    pv = 50 + np.cumsum(stem - 50) * LEVEL_GAIN_PER_S
    op = 50 + 4 * (2 * np.abs((t / 80) % 1 - 0.5) - 0.5)
    noisy = pv + np.random.default_rng(0).normal(0, 0.05, t.size)
    read_best(np.stack([op, op]), np.stack([pv, noisy]))
