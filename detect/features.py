"""The evidence one window gives on stiction: the published tests' statistics and the stick-slip
signature, as one feature vector the detector weighs (``detect.verdict``)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import median_filter

from detect import bicoherence, horch, oscillation, shape

NAMES = (
    "regularity_log",
    "cycles_log",
    "horch_phase",
    "shape_op",
    "shape_pv",
    "ngi",
    "nli",
    "pv_jump_share",
    "op_jump_share",
    "pv_still_share",
    "pv_kurtosis_log",
)
EDGE_MEDIAN = 5
"""Median filter width (samples) that removes noise and keeps a slip's edge."""
TOP_SHARE = 0.05


@dataclass(frozen=True)
class Evidence:
    oscillation: oscillation.Oscillation
    horch: horch.Horch
    bicoherence: bicoherence.Bicoherence
    shape_op: float
    shape_pv: float
    vector: np.ndarray
    """Features in the order of ``NAMES``; nan replaced by neutral values."""


def _edges(x: np.ndarray) -> np.ndarray:
    """Each row median-filtered over ``EDGE_MEDIAN`` samples: noise removed, a slip's edge kept."""
    return median_filter(x, size=(1, EDGE_MEDIAN), mode="nearest")


def jump_share(x: np.ndarray) -> float:
    """Share of the (median-filtered) signal's total variation spent in its largest 5 % of steps:
    near 1 for a signal that stands still and jumps, about 0.1-0.2 for a smooth or noisy one."""
    return _jump_share(_edges(np.asarray(x, float)[None, :])[0])


def _jump_share(y: np.ndarray) -> float:
    d = np.abs(np.diff(y))
    total = d.sum()
    if not total > 0:
        return 0.0
    k = max(1, int(TOP_SHARE * d.size))
    return float(np.sort(d)[-k:].sum() / total)


def still_share(pv: np.ndarray, op: np.ndarray) -> float:
    """Share of the window in which PV's filtered level stays within its noise while OP moves by
    more than its noise: the valve stuck while the controller winds up."""
    pv = np.asarray(pv, float)
    return _still_share(_edges(pv[None, :])[0], pv, np.asarray(op, float))


def _still_share(y: np.ndarray, pv: np.ndarray, u: np.ndarray) -> float:
    noise_pv = 1.4826 * np.median(np.abs(np.diff(pv))) + 1e-12
    noise_op = 1.4826 * np.median(np.abs(np.diff(u))) + 1e-12
    span = max(EDGE_MEDIAN * 2, u.size // 30)
    k = np.arange(0, u.size - span, span // 2)
    if k.size == 0:
        return 0.0
    pv_moves = np.abs(y[k + span] - y[k])
    op_moves = np.abs(u[k + span] - u[k])
    return float(np.mean((pv_moves < 2 * noise_pv) & (op_moves > 3 * noise_op)))


def kurtosis(x: np.ndarray) -> float:
    d = x - x.mean()
    v = np.mean(d * d)
    return float(np.mean(d**4) / v**2) if v > 0 else 3.0


def evidence(op: np.ndarray, pv: np.ndarray, ts_s: float = 1.0, sp: np.ndarray | None = None) -> Evidence:
    op, pv = np.asarray(op, float), np.asarray(pv, float)
    return evidence_rows(op[None, :], pv[None, :], ts_s, [sp])[0]


def evidence_rows(op: np.ndarray, pv: np.ndarray, ts_s: float = 1.0, sps=None) -> list[Evidence]:
    """``evidence`` of each row of ``op``, ``pv`` [W, N] (``sps``: each row's setpoint or None);
    the edge filters run on all rows together (PV's once, where three features read it), the rest row by row."""
    op, pv = np.asarray(op, float), np.asarray(pv, float)
    sps = [None] * op.shape[0] if sps is None else sps
    errors = np.stack([p if sp is None else p - np.asarray(sp, float) for p, sp in zip(pv, sps, strict=True)])
    bic = [bicoherence.test(e) for e in errors]  # one at a time: batched, the spectra outgrow the cache (3x slower)
    edges_op, edges_pv = _edges(op), _edges(pv)
    return [
        _evidence(op[i], pv[i], errors[i], sps[i], ts_s, bic[i], edges_op[i], edges_pv[i]) for i in range(op.shape[0])
    ]


def _evidence(op, pv, error, sp, ts_s, b, edges_op, edges_pv) -> Evidence:
    osc = oscillation.detect(error, ts_s)
    period = osc.period_s / ts_s if osc.period_s else None
    h = horch.test(op, pv, sp, period)
    si_op, si_pv = shape.stiction_index(op), shape.stiction_index(pv)
    vector = np.array(
        [
            np.log(min(max(osc.regularity, 1e-2), 1e3)),
            np.log1p(osc.cycles),
            h.phase if np.isfinite(h.phase) else 0.5,
            si_op if np.isfinite(si_op) else 0.5,
            si_pv if np.isfinite(si_pv) else 0.5,
            np.clip(b.ngi, -0.5, 0.5) if np.isfinite(b.ngi) else 0.0,
            np.clip(b.nli, 0, 1) if np.isfinite(b.nli) else 0.0,
            _jump_share(edges_pv),
            _jump_share(edges_op),
            _still_share(edges_pv, pv, op),
            np.log(kurtosis(np.diff(edges_pv)) + 1e-3),
        ]
    )
    return Evidence(osc, h, b, si_op, si_pv, vector)
