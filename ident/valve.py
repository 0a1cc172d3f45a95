"""The valve driven by a measured OP, for many candidate valves at once.

Open loop: the measured OP is what the controller sent, so the stem's path follows from
OP and the valve's parameters alone, whatever the process does.  ``sim.actuator``
advances every candidate one interval per sample; the initial stem position is a
candidate parameter too (the gap between OP and the stem when the record starts).
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from sim.actuator import actuate
from sim.valve import VALVE, Friction, pct_to_lbf


@dataclass(frozen=True)
class ValveCandidates:
    """Arrays over candidates; friction in percent of 500 lbf (the thesis's valve), the rest in % of OP or s."""

    fs_pct: np.ndarray
    fd_pct: np.ndarray
    gap0_pct: np.ndarray
    """OP minus the stem's position at the first sample."""
    deadband_pct: np.ndarray
    actuator_tau_s: np.ndarray

    @classmethod
    def of(cls, fs_pct, fd_pct, gap0_pct=0.0, deadband_pct=0.0, actuator_tau_s=0.0) -> ValveCandidates:
        arrays = np.broadcast_arrays(
            *(np.asarray(x, float) for x in (fs_pct, fd_pct, gap0_pct, deadband_pct, actuator_tau_s))
        )
        return cls(*(np.ascontiguousarray(a.ravel()) for a in arrays))

    def __len__(self) -> int:
        return self.fs_pct.size

    def take(self, idx) -> ValveCandidates:
        return ValveCandidates(*(getattr(self, f.name)[idx] for f in fields(self)))

    def concat(self, other: ValveCandidates) -> ValveCandidates:
        return ValveCandidates(*(np.concatenate([getattr(self, f.name), getattr(other, f.name)]) for f in fields(self)))

    @property
    def band_pct(self) -> np.ndarray:
        """S, the stiction band in % of OP (``fs / 12 lbf per %``)."""
        return pct_to_lbf(self.fs_pct) / VALVE.lbf_per_pct

    @property
    def stop_pct(self) -> np.ndarray:
        """How far the stem stays behind OP after a slip, % of OP (``fd / 12``, the Stribeck residual aside)."""
        return pct_to_lbf(self.fd_pct) / VALVE.lbf_per_pct


@dataclass(frozen=True)
class ValvePath:
    mv_pct: np.ndarray
    """[B, N] stem position at each sample."""
    flow_pct: np.ndarray
    """[B, N] mean stem position over each interval (what the process integrates)."""


def respond(op_pct: np.ndarray, c: ValveCandidates, ts_s: float) -> ValvePath:
    """Drive every candidate valve with the same OP record [N]."""
    op_pct = np.asarray(op_pct, float)
    n_cand, n = len(c), op_pct.size
    friction = Friction.physical(pct_to_lbf(c.fs_pct), pct_to_lbf(c.fd_pct))
    mv = op_pct[0] - c.gap0_pct
    drive = np.full(n_cand, op_pct[0])
    played = drive.copy()
    mv_rec, flow_rec = np.empty((n_cand, n)), np.empty((n_cand, n))
    op_b = np.empty(n_cand)
    for k in range(n):
        mv_rec[:, k] = mv
        op_b.fill(op_pct[k])
        act = actuate(op_b, mv, drive, played, friction, c.deadband_pct, c.actuator_tau_s, ts_s)
        mv, drive, played = act.mv_pct, act.drive_pct, act.played_pct
        flow_rec[:, k] = act.flow_pct
    return ValvePath(mv_rec, flow_rec)
