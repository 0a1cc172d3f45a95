"""A measured loop prepared for open-loop fits: the compared signal and its nuisance space.

Fits compare the change of PV over ``horizon`` samples, ``L(q) = 1 - q^-horizon``,
applied alike to the data and to every model's output.  For an integrating process
this is an ``horizon``-step prediction from the measured PV, so an error in the stem's
level costs only for ``horizon`` samples instead of for the rest of the record; for a
self-regulating one it removes the unknown operating point.  The first ``skip``
samples only warm the filters up (unknown inputs before the record, dead time).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def change(x: np.ndarray, horizon: int) -> np.ndarray:
    """``x[k] - x[k - horizon]`` for ``k >= horizon`` along the last axis."""
    return x[..., horizon:] - x[..., :-horizon]


@dataclass(frozen=True)
class Record:
    op_pct: np.ndarray
    pv_pct: np.ndarray
    ts_s: float
    horizon: int = 1
    skip: int = 12
    mv_pct: np.ndarray | None = None
    """The measured stem position, where the export has it."""

    def __post_init__(self):
        if self.op_pct.shape != self.pv_pct.shape or self.op_pct.ndim != 1:
            raise ValueError("op and pv must be 1-D of equal length")
        if self.n_fit < 20:
            raise ValueError(f"{self.op_pct.size} samples leave {self.n_fit} to compare after the warm-up")

    @property
    def n(self) -> int:
        return self.op_pct.size

    @property
    def n_fit(self) -> int:
        return self.n - self.horizon - self.skip

    @property
    def t_s(self) -> np.ndarray:
        return np.arange(self.n) * self.ts_s

    def compared(self, x: np.ndarray) -> np.ndarray:
        """The compared part of any signal [..., N]: its change over the horizon after the warm-up."""
        return change(x, self.horizon)[..., self.skip :]

    def compared_response(self, tf, u: np.ndarray) -> np.ndarray:
        """``compared(tf.response(u))`` in one pass (``tf``: an ``ident.process.TransferFunction``)."""
        return tf.response_changed(u, self.horizon, self.skip)

    @property
    def target(self) -> np.ndarray:
        return self.compared(self.pv_pct)


def orthonormal_basis(columns: np.ndarray, rtol: float = 1e-9) -> np.ndarray:
    """[n, q] orthonormal basis of the span of ``columns`` [n, p]; dependent or empty columns dropped."""
    if columns.size == 0:
        return np.zeros((columns.shape[0], 0))
    u, s, _ = np.linalg.svd(columns, full_matrices=False)
    keep = s > rtol * max(s.max(), 1e-300)
    return u[:, keep]


NOISY_CHANGE_CORRELATION = 0.0
"""Lag-1 correlation of PV's one-sample changes below which PV's noise hides its own changes."""


def choose_horizon(pv_pct: np.ndarray) -> int:
    """The compared horizon for a record: one sample, unless white noise dominates PV's changes.

    A loop whose PV ramps (an integrating level, any loop sampled fast) has smooth one-sample
    changes, positively correlated from sample to sample; where measurement noise dominates
    (flow loops sampled every 10 s) the changes are the noise's differences, correlated about
    -0.5, and a one-sample comparison sees little but noise: compare over a longer horizon,
    about 1/75 of the record (4 to 30 samples), so that the valve's moves stand out.
    """
    d = np.diff(np.asarray(pv_pct, float))
    d = d - d.mean()
    power = float(np.sum(d * d))
    c1 = float(np.sum(d[1:] * d[:-1]) / power) if power > 0 else 1.0
    if c1 >= NOISY_CHANGE_CORRELATION:
        return 1
    return int(np.clip(round(d.size / 75), 4, 30))


def process_sign(op_pct: np.ndarray, pv_pct: np.ndarray) -> int:
    """+1 where PV rises as OP rises (a direct-acting loop), -1 where it falls; read from the controller.

    A PI controller's proportional part moves OP against PV in the very sample PV moves
    (``dOP = -Kc dPV + ...``); a stable loop has a process of the sign that makes this feedback
    negative.  So the sign of the process gain is the sign opposite to OP's and PV's
    simultaneous changes, whatever the process does - and a fit that needs the other sign has
    fitted the controller backwards, not the process.
    """
    d_op, d_pv = np.diff(np.asarray(op_pct, float)), np.diff(np.asarray(pv_pct, float))
    c = float(np.sum((d_op - d_op.mean()) * (d_pv - d_pv.mean())))
    return -1 if c > 0 else 1
