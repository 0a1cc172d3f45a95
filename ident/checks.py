"""Data problems a report names before it reads any friction: pure functions of one window.

A check that ``blocks`` means no friction number can be read from the window (a sensor that
does not move, a controller that does not drive the valve, a valve pinned at a limit most of
the time); the others are warnings the numbers carry.  Thresholds are in samples and shares of
the window, so they hold at any sample time.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

FLAT_REL = 1e-6
"""A signal whose range is below this share of its size (or of 1 %) does not move."""
FROZEN_SHARE = 0.5
"""PV repeating one value for this share of the window is frozen."""
MIN_DISTINCT_PV = 4
PINNED_WARN_SHARE = 0.2
PINNED_BLOCK_SHARE = 0.5
PINNED_RUN = 5
"""Samples in a row at the window's OP extreme that count as resting on a limit."""
HELD_OP_SHARE = 0.9
"""OP unchanged from one sample to the next on this share of the window: manual or held."""
COMPRESSED_FACTOR = 3.0
"""Samples per point where a signal bends (its compression factor, Thornhill, Choudhury & Shah 2004, "The impact
of compression on data-driven process analyses", J. Process Control 14) from which a window is read as a
historian's compressed archive: straight lines between stored values.  They found oscillation and nonlinearity
tests misled from a factor of about 3; the families of ``sim.plant_families`` compress at 11-44, the measured
exports here are at 1.0-1.4."""
LINE_REL = 1e-6
"""A signal's second difference within this share of its range is no bend: a straight line stored as such, up to
the export's rounding."""


@dataclass(frozen=True)
class Check:
    name: str
    blocks: bool
    message: str


def flat(x: np.ndarray):
    """Whether a signal moves no more than its own rounding (a constant 3.5e-44 is a dead sensor); of each
    row of a [W, N] batch, an array of W."""
    return np.ptp(x, axis=-1) <= FLAT_REL * np.maximum(1.0, np.max(np.abs(x), axis=-1))


def _longest_run(x: np.ndarray) -> tuple[int, int]:
    """(length, start) of the longest stretch of exactly repeated values."""
    change = np.flatnonzero(np.diff(x) != 0) + 1
    edges = np.concatenate([[0], change, [x.size]])
    lengths = np.diff(edges)
    k = int(np.argmax(lengths))
    return int(lengths[k]), int(edges[k])


def _share_in_runs(mask: np.ndarray, min_run: int) -> float:
    """Share of samples where ``mask`` holds in runs of at least ``min_run``."""
    padded = np.concatenate([[False], mask, [False]]).astype(np.int8)
    d = np.diff(padded)
    starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
    lengths = ends - starts
    return float(lengths[lengths >= min_run].sum()) / mask.size


STUCK_SHUT_OP_PCT = 10.0
"""OP travel (% of span, one way) over a frozen PV past which the frozen PV may be a valve that does not
move at all, not only a sensor: the controller winding up against a valve that does not open."""
ONE_WAY_SLACK = 1.25
"""OP went one way over the stretch when its range is within this factor of its net travel."""


def compression_factor(x: np.ndarray) -> float:
    """Samples per point where ``x`` bends or holds (``COMPRESSED_FACTOR``): a point of a straight stretch that
    moves (second difference within ``LINE_REL`` of the range, first difference beyond it) is an interpolated one;
    a held sample is not counted as such (``held_op``, ``frozen_pv`` name those archives)."""
    x = np.asarray(x, float)
    if x.size < 3:
        return 1.0
    tol = LINE_REL * max(float(np.ptp(x)), 1e-300)
    moving = np.abs(np.diff(x)) > tol
    straight = (np.abs(np.diff(x, 2)) <= tol) & moving[1:] & moving[:-1]
    return x.size / (x.size - int(np.count_nonzero(straight)))


def _compressed(name: str, x: np.ndarray) -> Check | None:
    """A record whose OP runs in straight lines (``COMPRESSED_FACTOR``) gets no verdict (``bad_data``).  No controller
    writes OP so (a PI controller's OP is curved wherever the error is not constant; the thesis's noise-free cases and
    every simulated and measured record here have OP factors of 1.0-1.3), so it is an archive; and on the held-out
    families of ``sim.plant_families`` (a fifth of each cause's records compressed with a deadband of 0.1-1 % of span)
    the verdict's probability on such records ranked the windows that show a fault above the look-alikes with AUC
    0.62 / 0.59 (design seed 3031 / seed 9797, held out), against 0.82 / 0.78 on the raw ones; of the compressed
    windows it called sticky, 30 % / 21 % showed a fault (a fifth of them do), against 61 % / 48 % raw (2026-11-27).
    A PV in straight lines alone only warns: a noise-free simulation's integrating PV is straight while the stem
    sticks (the thesis's C1-C10: PV factors up to 22), and where only PV read so the verdict kept its AUC (0.93 /
    0.91)."""
    factor = compression_factor(x)
    if factor < COMPRESSED_FACTOR:
        return None
    if name == "OP":
        return Check(
            "compressed_op",
            True,
            f"OP runs in straight lines between points about {factor:.0f} samples apart: a historian's compressed "
            "archive, whose stored lines read as a stuck valve's ramps and their corners as slips; on such records "
            "the verdict tells a sticky valve from a healthy one little better than chance, so it is not given: "
            "export the raw values where the historian keeps them",
        )
    return Check(
        f"compressed_{name.lower()}",
        False,
        f"{name} runs in straight lines between points about {factor:.0f} samples apart: a historian's compressed "
        "archive (or a record without noise, as a simulation writes one): a stored line reads as a ramp and its "
        "corners as slips, so the verdict and the numbers may read the archive rather than the valve; export the raw "
        "values where the historian keeps them",
    )


def _frozen_message(op: np.ndarray, pv: np.ndarray, run: int, start: int) -> str:
    """What a PV that repeats one value can be.  Where OP moved one way far meanwhile, a valve stuck
    shut (or fully stuck) looks the same as a dead sensor from OP and PV: both are said, neither chosen."""
    head = f"PV frozen at {pv[start]:.4g} for {run} of {pv.size} samples (from sample {start}): "
    return head + (_stuck_or_dead(op[start : start + run]) or "a sensor or archive that stopped updating")


def _flat_message(op: np.ndarray, pv: np.ndarray) -> str:
    """What a PV that never moves in the window can be: as ``_frozen_message``, over the whole window."""
    head = f"PV does not move (constant at {pv[0]:.4g} over {pv.size} samples): "
    return head + (_stuck_or_dead(op) or "a dead or disconnected sensor, nothing to read")


def _stuck_or_dead(stretch: np.ndarray) -> str | None:
    """Where OP moved one way by ``STUCK_SHUT_OP_PCT`` or more over the stretch of a PV that did not move: both
    things it can be, neither chosen; else None."""
    if stretch.size < 2:
        return None
    travel = float(stretch[-1] - stretch[0])
    one_way = float(np.ptp(stretch)) <= ONE_WAY_SLACK * abs(travel)  # its noise may wiggle, not turn back
    if abs(travel) >= STUCK_SHUT_OP_PCT and one_way:
        return (
            f"meanwhile OP moved {travel:+.3g} % one way, so this is a valve that does not move at all (stuck, or "
            "shut) or a sensor or archive that stopped updating; OP and PV cannot tell which: check the valve "
            "and the transmitter"
        )
    return None


def data_checks(op: np.ndarray, pv: np.ndarray) -> list[Check]:
    """Every data problem of the window, the blocking ones first."""
    op, pv = np.asarray(op, float), np.asarray(pv, float)
    n = pv.size
    out: list[Check] = []
    if flat(pv):
        out.append(Check("flat_pv", True, _flat_message(op, pv)))
    else:
        run, start = _longest_run(pv)
        distinct = np.unique(pv).size
        if run >= FROZEN_SHARE * n and run >= 50:
            out.append(Check("frozen_pv", True, _frozen_message(op, pv, run, start)))
        elif distinct < MIN_DISTINCT_PV:
            out.append(
                Check(
                    "stepped_pv",
                    True,
                    f"PV takes only {distinct} distinct values: a stepped or on/off signal with no cycle shape to read",
                )
            )
    if flat(op):
        out.append(
            Check(
                "manual",
                True,
                f"OP does not move (constant at {op[0]:.4g} %): the controller is in manual or its output is "
                "frozen, so it does not drive the valve",
            )
        )
        return out
    top, bottom = op == op.max(), op == op.min()
    still = np.concatenate([[False], np.diff(op) == 0])
    for at, value, where in ((top, op.max(), "upper"), (bottom, op.min(), "lower")):
        share = _share_in_runs(at, PINNED_RUN)
        moving_elsewhere = not at.all() and float(np.mean(still[~at])) < 0.5  # resting only at the limit
        if share >= PINNED_WARN_SHARE and moving_elsewhere:
            blocks = share >= PINNED_BLOCK_SHARE
            out.append(
                Check(
                    "saturated_op",
                    blocks,
                    f"OP pinned at its {where} limit {value:.4g} % for {share:.0%} of the window: the valve "
                    "saturates and the loop is out of control there",
                )
            )
    out += [c for c in (_compressed("PV", pv), _compressed("OP", op)) if c is not None]
    held = float(np.mean(np.diff(op) == 0))
    if held >= HELD_OP_SHARE:
        out.append(
            Check(
                "held_op",
                False,
                f"OP unchanged between samples on {held:.0%} of the window: manual mode with operator steps, "
                "or an archive that stores OP only when it changes",
            )
        )
    return sorted(out, key=lambda c: not c.blocks)


def data_checks_rows(op: np.ndarray, pv: np.ndarray) -> list[list[Check]]:
    """``data_checks`` of each row of ``op``, ``pv`` [W, N]: rows where no check can fire are screened
    out together, by conditions each check needs (a share of repeated values, of samples at OP's
    extremes, a range within rounding, fewer than four values), and only the rest are checked one by
    one; the answers are ``data_checks``'s.  The agent checks hundreds of windows a second, most of
    them clean (0.2 ms a window row by row)."""
    op, pv = np.asarray(op, float), np.asarray(pv, float)
    w, n = pv.shape
    if n < 2:
        return [data_checks(op[i], pv[i]) for i in range(w)]

    pv_repeats = np.count_nonzero(np.diff(pv, axis=1) == 0, axis=1)
    lo, hi = pv.min(axis=1, keepdims=True), pv.max(axis=1, keepdims=True)
    inner = (pv > lo) & (pv < hi)  # two distinct values strictly inside the range make four in all
    inner_lo = np.where(inner, pv, np.inf).min(axis=1)
    inner_hi = np.where(inner, pv, -np.inf).max(axis=1)
    held = np.diff(op, axis=1) == 0
    at_limit = np.maximum(np.count_nonzero(op == op.max(axis=1, keepdims=True), axis=1),
                          np.count_nonzero(op == op.min(axis=1, keepdims=True), axis=1))  # fmt: skip
    may_fire = (
        flat(pv)
        | (pv_repeats + 1 >= max(FROZEN_SHARE * n, 50))  # a frozen run of r samples repeats r - 1 times
        | ~(inner_lo < inner_hi)
        | flat(op)
        | (at_limit >= PINNED_WARN_SHARE * n)
        | (np.mean(held, axis=1) >= HELD_OP_SHARE - 1e-9)
        | (_straight_share(op) >= 1 - 1 / COMPRESSED_FACTOR - 1e-9)
        | (_straight_share(pv) >= 1 - 1 / COMPRESSED_FACTOR - 1e-9)
    )
    return [data_checks(op[i], pv[i]) if may_fire[i] else [] for i in range(w)]


def _straight_share(x: np.ndarray) -> np.ndarray:
    """[W] an upper bound on each row's share of straight moving points (``compression_factor``): the points whose
    second difference is within ``LINE_REL`` of the row's range."""
    tol = LINE_REL * np.maximum(np.ptp(x, axis=1), 1e-300)
    return np.count_nonzero(np.abs(np.diff(x, 2, axis=1)) <= tol[:, None], axis=1) / x.shape[1]


def impossible_friction(
    s_pct: float, j_pct: float, s_se_pct: float, j_se_pct: float, op_range_pct: float
) -> str | None:
    """Why no valve can have this band S and jump J (% of span), or None: a band wider than OP
    ever moved or than the span, a jump below zero or above the band (each beyond two standard
    errors)."""
    if not (np.isfinite(s_pct) and np.isfinite(j_pct)):
        return None
    s_se = s_se_pct if np.isfinite(s_se_pct) else 0.0
    j_se = j_se_pct if np.isfinite(j_se_pct) else 0.0
    if s_pct <= 0 or s_pct - 2 * s_se > min(op_range_pct, 100.0):
        return f"the fit reads a band S of {s_pct:.3g} % where OP moved {op_range_pct:.3g} %: no valve slips so"
    if j_pct + 2 * j_se < 0 or j_pct - 2 * j_se > s_pct + 2 * s_se:
        return f"the fit reads a jump J of {j_pct:.3g} % with a band of {s_pct:.3g} %: no valve jumps so"
    return None


def blocking(checks: list[Check]) -> list[Check]:
    return [c for c in checks if c.blocks]
