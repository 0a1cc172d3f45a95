"""The valve assembly over one sample interval: deadband, actuator lag and the sticky stem.

OP reaches the stem through the deadband's play and the actuator's first-order lag
(both extensions of the diagnose catalogue, ``sim.extensions``); the stem sticks and
slips as ``sim.valve`` says.  The closed loop (``sim.loop``) and the open-loop fits
of ``ident`` drive this one function, vectorised over loops or over candidate valves.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stiction.sim.extensions import backlash
from stiction.sim.valve import Friction, lagged_valve_step, valve_step


@dataclass(frozen=True)
class Actuation:
    """End of one interval, arrays over loops (percent of span)."""

    mv_pct: np.ndarray
    """Stem position at the end of the interval."""
    flow_pct: np.ndarray
    """Mean stem position over the interval: what the process sees."""
    drive_pct: np.ndarray
    """The actuator's drive after deadband and lag."""
    played_pct: np.ndarray
    """Output of the deadband's play."""


def subset(friction: Friction, idx) -> Friction:
    """The valves ``idx`` of a batch (every field may be per loop or shared)."""

    def pick(x):
        x = np.asarray(x)
        return x[idx] if x.ndim else x

    return Friction(pick(friction.fs_lbf), pick(friction.stop_lbf), pick(friction.slip_s), pick(friction.lbf_per_pct),
                    pick(friction.slide_pct_s), pick(friction.tracks))  # fmt: skip


def actuate(
    op_pct: np.ndarray,
    mv_pct: np.ndarray,
    drive_pct: np.ndarray,
    played_pct: np.ndarray,
    friction: Friction,
    deadband_pct: np.ndarray,
    actuator_tau_s: np.ndarray,
    ts_s: float,
) -> Actuation:
    """One interval of OP held at ``op_pct``; the stem starts the interval stuck at ``mv_pct``."""
    played = backlash(op_pct, played_pct, deadband_pct)
    target = np.where(deadband_pct > 0, played, op_pct)
    lagged = actuator_tau_s > 0
    slip = valve_step(target, mv_pct, friction, drive_pct)
    mv_next, deficit, drive = slip.mv_pct, slip.deficit_pct_s, target
    if np.any(lagged):
        idx = np.flatnonzero(lagged)
        slip_lag, drive_lag = lagged_valve_step(
            drive_pct[idx], target[idx], actuator_tau_s[idx], ts_s, mv_pct[idx], subset(friction, idx)
        )
        mv_next, deficit, drive = mv_next.copy(), deficit.copy(), np.array(drive, dtype=float)
        mv_next[idx], deficit[idx], drive[idx] = slip_lag.mv_pct, slip_lag.deficit_pct_s, drive_lag
    return Actuation(mv_next, mv_next - deficit / ts_s, drive, played)
