"""A setpoint step the valve did not follow: the stuck valve seen in a step response.

An operator steps the setpoint.  Through a valve that moves, PV starts towards the new setpoint
as soon as OP moves (after the process's dead time) and follows OP's travel.  Through a stuck
valve PV stands still while the controller's integral winds OP up in a straight line, until the
stem breaks free: then PV jumps towards (often past) the setpoint within a few samples while OP
hardly moves, or turns back on the proportional kick.

Per step (one segment up to the next step), on PV's level (median-filtered, then averaged over
five samples, as ``detect.features``):

- *still*: samples until PV's progress towards the new setpoint leaves a zone of a fifth of the
  step (or three times the level's noise, if larger);
- *travel*: OP's move from before the step to the end of the still phase, in shares of OP's range
  over the window; *kick*: its move in the first two samples (the proportional kick);
- *rise*: samples from leaving the zone to three fifths of the step; *rise travel*: OP's move
  over the rise in the still phase's direction, against the still phase's travel;
- *back*: samples of the still phase in which PV wandered as far the other way (a load, not a
  stuck valve).

A step is a stuck response where the still phase is at least ``MIN_STILL`` samples, OP travelled
at least ``MIN_TRAVEL`` of its range in a straight line (R^2 >= ``MIN_R2``) and at least twice its
kick (a ramp, not the proportional jump a dead time would show), PV stayed put (back in at most
``MAX_BACK`` of the still phase), then rose in at most ``MAX_RISE`` of the still phase's duration
while OP travelled at most ``MAX_RISE_TRAVEL`` of the still phase's travel (a jump: a valve that
follows OP after a dead zone, as a deadband's, lets PV rise only as OP travels on).

Thresholds set on simulated plant-like loops with one to three setpoint steps each
(``sim.plant_loops``, seed 2030, 100 loops a class): 3 % of the deadband loops, 1 % of the noise
loops and none of the others show such a step; 19 % of the sticky loops do (most sticky loops
cycle and are called by the other tests).  The 2-hour windows of a measured flow loop labelled
sticky (2411FIC20102 of ``stictiongpt_plant``) show it with still phases of 17-190 samples at
10 s and rises of 2-17; its healthy neighbour 2111FIC46002 follows its setpoint steps within a
sample or two.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stiction.detect import kernels

MAX_STEPS = 20
"""More setpoint changes than this in a window: a cascade's moving setpoint, not operator steps."""
STEP_NOISE = 3.0
"""A setpoint change counts as a step from three times PV's noise."""
ZONE = 0.2
MIN_STILL = 8
MIN_TRAVEL = 0.25
MIN_R2 = 0.9
MAX_BACK = 0.2
MAX_RISE = 0.35
MAX_RISE_TRAVEL = 0.2


@dataclass(frozen=True)
class StuckStep:
    """One setpoint step the valve did not follow (sample indices within the window)."""

    step: int
    still_samples: int
    rise_samples: int
    travel: float
    """OP's travel over the still phase, in OP's units (% of span)."""
    travel_share: float
    """The same in shares of OP's range over the window."""


def _level(y: np.ndarray) -> np.ndarray:
    """Five-sample moving average (edges held), as the stuck-ramp test's level."""
    padded = np.concatenate([np.full(2, y[0]), y, np.full(2, y[-1])])
    c = np.cumsum(np.concatenate([[0.0], padded]))
    return (c[5:] - c[:-5]) / 5.0


def _r2(x: np.ndarray) -> float:
    t = np.arange(x.size, dtype=float)
    sx, st = x - x.mean(), t - t.mean()
    den = float(np.dot(sx, sx) * np.dot(st, st))
    return float(np.dot(sx, st) ** 2 / den) if den > 0 else 0.0


def stuck_steps(edges_op: np.ndarray, edges_pv: np.ndarray, pv: np.ndarray, sp: np.ndarray | None) -> list[StuckStep]:
    """The setpoint steps of one window whose response shows a stuck valve.  ``edges_op``,
    ``edges_pv``: OP and PV median-filtered (``detect.features._edges``); ``pv`` raw, for its noise."""
    return stuck_steps_rows(edges_op[None, :], edges_pv[None, :], np.asarray(pv, float)[None, :], [sp])[0]


def stuck_steps_rows(edges_op: np.ndarray, edges_pv: np.ndarray, pv: np.ndarray, sps) -> list[list[StuckStep]]:
    """``stuck_steps`` of each row of [W, N] arrays (``sps``: each row's setpoint or None): the noise
    medians and OP's percentiles of the rows whose setpoint moves taken in one call each (per row, numpy's
    ``median`` and ``percentile`` cost 0.1 ms a window), the same numbers as row by row (the test compares them
    with ``tests/detect/reference.py``'s window at a time)."""
    found: list[list[StuckStep]] = [[] for _ in range(len(sps))]
    changes = {i: _steps(sp, edges_op.shape[1]) for i, sp in enumerate(sps)}
    moving = [i for i, change in changes.items() if change is not None]
    if not moving:
        return found
    noises = _noise(np.median(np.abs(pv[moving] - edges_pv[moving]), axis=1))
    stepped = []
    for i, noise in zip(moving, noises, strict=True):
        steps = _counted(changes[i], float(noise))
        if steps is not None:
            stepped.append((i, float(noise), steps))
    if not stepped:
        return found
    rows = [i for i, _, _ in stepped]
    lo, hi = np.percentile(edges_op[rows], [2.5, 97.5], axis=1)
    for (i, noise, steps), h, low in zip(stepped, hi, lo, strict=True):
        found[i] = _stuck(edges_op[i], edges_pv[i], np.asarray(sps[i], float), steps, noise, float(h - low))
    return found


def _steps(sp: np.ndarray | None, n_op: int) -> np.ndarray | None:
    """The setpoint's changes (absolute, sample to sample), or None where it has no step to read:
    none given, too short a window, or a setpoint that never moves (the common case)."""
    if sp is None:
        return None
    sp = np.asarray(sp, float)
    if sp.size < 2 * MIN_STILL or n_op != sp.size:
        return None
    change = np.abs(np.diff(sp))
    return change if np.any(change > 1e-9) else None


def _noise(median_abs_deviation):
    """PV's noise (a standard deviation) from the median of its absolute deviations from its median-filtered level."""
    return 1.4826 * median_abs_deviation + 1e-12


def _counted(change: np.ndarray, noise: float) -> np.ndarray | None:
    """The samples at which a step starts (a change of three times PV's noise), or None where there are
    none or more than ``MAX_STEPS`` (a cascade's moving setpoint)."""
    steps = np.flatnonzero(change > max(STEP_NOISE * noise, 1e-9)) + 1
    return None if steps.size == 0 or steps.size > MAX_STEPS else steps


def _stuck(u: np.ndarray, edges_pv: np.ndarray, sp: np.ndarray, steps, noise: float, range_op: float) -> list:
    """The steps whose response shows a stuck valve, given PV's noise and OP's range."""
    n = sp.size
    if not range_op > 0:
        return []
    level = _level(edges_pv)
    ends = list(steps[1:]) + [n]
    found = []
    for s, e in zip(steps, ends, strict=True):
        s, e = int(s), int(e)
        if s < 5 or e - s < MIN_STILL + 2:
            continue
        d_sp = sp[s] - sp[s - 1]
        before = float(kernels.median(np.ascontiguousarray(level[max(0, s - 10) : s])))
        u0 = float(kernels.median(np.ascontiguousarray(u[s - 5 : s])))
        progress = np.sign(d_sp) * (level[s:e] - before) / abs(d_sp)
        zone = max(ZONE, 3.0 * noise / np.sqrt(5.0) / abs(d_sp))
        left = np.flatnonzero(progress > zone)
        if left.size == 0:
            continue
        still = int(left[0])
        if still < MIN_STILL:
            continue
        travel = abs(u[s + still] - u0)
        kick = abs(u[min(s + 2, n - 1)] - u0)
        if travel < MIN_TRAVEL * range_op or travel < 2.0 * kick or _r2(u[s : s + still + 1]) < MIN_R2:
            continue
        if np.count_nonzero(-progress[:still] > zone) > MAX_BACK * still:
            continue
        reached = np.flatnonzero(progress > 0.6)
        if reached.size == 0 or reached[0] < still:
            continue
        rise = int(reached[0]) - still
        direction = np.sign(u[s + still] - u0)
        rise_travel = direction * (u[s + int(reached[0])] - u[s + still])
        if rise > MAX_RISE * still or rise_travel > MAX_RISE_TRAVEL * travel:
            continue
        found.append(StuckStep(s, still, rise, float(travel), float(travel / range_op)))
    return found
