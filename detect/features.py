"""The evidence one window gives on stiction: the published tests' statistics and the stick-slip
signature, as one feature vector the detector weighs (``detect.verdict``)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stiction.detect import bicoherence, horch, kernels, oscillation, setpoint, shape

NAMES = (
    "regularity_log",
    "cycles_ref_log",
    "horch_phase",
    "shape_op",
    "shape_pv",
    "bic_excess",
    "bic_peak_excess",
    "pv_jump_share",
    "op_jump_share",
    "pv_still_share",
    "pv_kurtosis_log",
)
REF_SAMPLES = 600
"""The cycles feature counts the cycles a window of this many samples holds (the simulated windows'
length): a count over the window itself grows with the window, and a detector trained on windows of
600 samples read a long record's many cycles as an external oscillation (held-out families' sticky
limit cycles over 1,800 samples: level 74 -> 51 % called).  Every feature reads the loop, not the
window's length.  No fewer than ``oscillation.MIN_CYCLES`` for a window that holds that many: an
oscillating training window held at least two, and a slow cycle of a long record read as less
(0.7 a 600 samples) lay outside what the models were fitted on, where the cycle model called a
sluggish level loop's wander sticky (an independent simulator's look-alikes, 2 of 12 -> 1 of 12)."""
EDGE_MEDIAN = 5
"""Median filter width (samples) that removes noise and keeps a slip's edge."""
TOP_SHARE = 0.05
STUCK_SPAN_PARTS = 8
"""The stuck-ramp test's span: an eighth of the window (15 min of a 2-hour window)."""
STUCK_OP_SHARE = 0.25
STUCK_PV_SHARE = 0.15
STUCK_NOISE = 2.5
STUCK_R2 = 0.95
"""OP ramps over a quarter of its range, a straight line (R^2 0.95: an integral winding up on a
constant error, not a load followed), while PV stays within 2.5 times its noise or 15 % of its
range.  Set on simulated plant-like loops (``stiction bench detect``): at 0.95 no look-alike
class shows it in more than 4 % of its loops."""


@dataclass(frozen=True)
class Evidence:
    oscillation: oscillation.Oscillation
    horch: horch.Horch
    bicoherence: bicoherence.Bicoherence
    shape_op: float
    shape_pv: float
    vector: np.ndarray
    """Features in the order of ``NAMES``; nan replaced by neutral values."""
    stuck_ramp: float = 0.0
    """Share of the window's spans in which OP ramps while PV stands still (``stuck_ramp``): the
    valve stuck while the controller winds up, seen without a regular oscillation."""
    stuck_step: setpoint.StuckStep | None = None
    """The setpoint step whose response shows the stuck valve best (the largest OP travel), if any
    (``detect.setpoint``)."""

    @property
    def stuck(self) -> np.ndarray:
        """The two stuck-valve tests' statistics, as ``detect.verdict.Detector`` weighs them: the
        stuck-ramp share and the stuck setpoint step's OP travel in shares of OP's range (0: none)."""
        return np.array([self.stuck_ramp, self.stuck_step.travel_share if self.stuck_step else 0.0])


def _edges(x: np.ndarray) -> np.ndarray:
    """Each row median-filtered over ``EDGE_MEDIAN`` samples: noise removed, a slip's edge kept."""
    return kernels.running_median_rows(np.ascontiguousarray(np.atleast_2d(x), dtype=float), EDGE_MEDIAN)


def _jump_share(y: np.ndarray) -> float:
    """Share of the (median-filtered) signal's total variation spent in its largest 5 % of steps:
    near 1 for a signal that stands still and jumps, about 0.1-0.2 for a smooth or noisy one."""
    return float(kernels.jump_share(np.ascontiguousarray(y, dtype=float), TOP_SHARE))


def _still_share(y: np.ndarray, pv: np.ndarray, u: np.ndarray) -> float:
    """Share of the window in which PV's filtered level ``y`` stays within its noise while OP moves by
    more than its noise: the valve stuck while the controller winds up."""
    return float(kernels.still_share(*(np.ascontiguousarray(a, dtype=float) for a in (y, pv, u)), EDGE_MEDIAN))


def _stuck_ramp(y: np.ndarray, pv: np.ndarray, u: np.ndarray) -> tuple[float, float]:
    """(share, OP travel): spans in which OP ``u`` ramps in a straight line while PV's level ``y`` stands still."""
    arrays = (np.ascontiguousarray(a, dtype=float) for a in (y, pv, u))
    share, travel = kernels.stuck_ramp(*arrays, STUCK_SPAN_PARTS, STUCK_OP_SHARE, STUCK_PV_SHARE, STUCK_NOISE, STUCK_R2)
    return float(share), float(travel)


def stuck_travel(op: np.ndarray, pv: np.ndarray, sp: np.ndarray | None = None) -> float:
    """The largest OP travel (% of span) over which PV stood still in one window, by either
    stuck-valve test (as ``evidence``: a stuck ramp, or a setpoint step's still phase); 0 where
    neither saw one.  A valve that stood still while OP moved that far has a band S of about that
    at least (``ident.trust.stuck_travel_contradicts``)."""
    pv, op = np.asarray(pv, float), np.asarray(op, float)
    edges = _edges(np.stack([pv, op]))
    travel = _stuck_ramp(edges[0], pv, edges[1])[1]
    steps = setpoint.stuck_steps(edges[1], edges[0], pv, sp)
    return max([travel] + [st.travel for st in steps])


def warm_up() -> None:
    """Compile (or load from their cache) the evidence's kernels now, not in the first report's time."""
    t = np.arange(200, dtype=float)
    evidence(np.sin(t / 7), np.sign(np.sin(t / 7)), 1.0)
    smooth, crossings = oscillation.half_cycles(np.sin(t / 7), 1.0)  # a cycle of outlying periods reads it
    kernels.swing_spread(np.ascontiguousarray(smooth, dtype=float), crossings)
    kernels.median(np.arange(5.0))  # the stuck setpoint step's, read only where a setpoint moves


def evidence(op: np.ndarray, pv: np.ndarray, ts_s: float = 1.0, sp: np.ndarray | None = None) -> Evidence:
    op, pv = np.asarray(op, float), np.asarray(pv, float)
    return evidence_rows(op[None, :], pv[None, :], ts_s, [sp])[0]


def evidence_rows(op: np.ndarray, pv: np.ndarray, ts_s: float = 1.0, sps=None) -> list[Evidence]:
    """``evidence`` of each row of ``op``, ``pv`` [W, N] (``sps``: each row's setpoint or None);
    the edge filters run on all rows together (PV's once, where three features read it), the rest row by row."""
    op, pv = np.asarray(op, float), np.asarray(pv, float)
    sps = [None] * op.shape[0] if sps is None else sps
    errors = np.stack([p if sp is None else p - np.asarray(sp, float) for p, sp in zip(pv, sps, strict=True)])
    # each signal detrended once for every test that reads it, all rows at once
    d_op, d_pv, d_error = (oscillation.detrended_rows(x) for x in (op, pv, errors))
    # one at a time: batched, the spectra outgrow the cache (3x slower)
    bic = [bicoherence.test(e, d) for e, d in zip(errors, d_error, strict=True)]
    edges_op, edges_pv = _edges(op), _edges(pv)
    # the error's ACF and Horch's products of OP and the error, every row in one transform each (each row's
    # numbers as if alone); Horch's error is sp - pv, the negative of ``error`` (pv - sp): detrending is linear
    y_op, y_error = np.stack([d.y for d in d_op]), np.stack([d.y for d in d_error])
    acf = oscillation.autocorrelation(y_error, oscillation.max_lag(op.shape[1]))  # a flat row's: nan, unread
    products = horch.circular_products(y_op, -y_error)
    stuck_steps = setpoint.stuck_steps_rows(edges_op, edges_pv, pv, sps)
    return [
        _evidence(
            op[i], pv[i], errors[i], sps[i], ts_s, bic[i], edges_op[i], edges_pv[i], (d_op[i], d_pv[i], d_error[i]),
            (acf[i], products[i]), stuck_steps[i],
        )  # fmt: skip
        for i in range(op.shape[0])
    ]


def _evidence(op, pv, error, sp, ts_s, b, edges_op, edges_pv, detrended, transforms, steps) -> Evidence:
    d_op, d_pv, d_error = detrended
    acf, products = transforms
    osc = oscillation.detect(error, ts_s, d_error, acf)
    period = osc.period_s / ts_s if osc.period_s else None
    h = horch.test(op, pv, sp, period, d_op, oscillation.Detrended(-d_error.y, d_error.sd), products)
    si_op, si_pv = shape.stiction_index(op, d_op), shape.stiction_index(pv, d_pv)
    vector = np.array(
        [
            np.log(min(max(osc.regularity, 1e-2), 1e3)),
            np.log1p(max(osc.cycles * REF_SAMPLES / max(op.size, 1), min(osc.cycles, oscillation.MIN_CYCLES))),
            h.phase if np.isfinite(h.phase) else 0.5,
            si_op if np.isfinite(si_op) else 0.5,
            si_pv if np.isfinite(si_pv) else 0.5,
            np.clip(b.excess, -0.5, 0.5) if np.isfinite(b.excess) else 0.0,
            np.clip(b.peak_excess, -1, 1) if np.isfinite(b.peak_excess) else 0.0,
            _jump_share(edges_pv),
            _jump_share(edges_op),
            _still_share(edges_pv, pv, op),
            np.log(kernels.step_kurtosis(np.ascontiguousarray(edges_pv), oscillation.ROUNDING_REL) + 1e-3),
        ]
    )
    step = max(steps, key=lambda st: st.travel_share) if steps else None
    return Evidence(osc, h, b, si_op, si_pv, vector, _stuck_ramp(edges_pv, pv, edges_op)[0], step)
