"""The nuisances of every open-loop fit, projected out before the least squares.

A model's compared output is linear in terms nobody asks about: the plant's free responses
(its unknown initial state), a constant (a bias in the stem's level, or a drift of PV) and,
for an external oscillation, a sine and a cosine.  They are projected out once per record
and dynamics (variable projection, Golub & Pereyra 1973).
"""

from __future__ import annotations

import numpy as np

from stiction.ident.process import TransferFunction
from stiction.ident.record import Record, orthonormal_basis


def nuisance_basis(record: Record, tf: TransferFunction, omega_rad_s: float | None = None) -> np.ndarray:
    cols = [record.compared(tf.free_responses(record.n)), np.ones((1, record.n_fit))]
    if omega_rad_s:
        t = record.t_s
        cols.append(record.compared(np.stack([np.sin(omega_rad_s * t), np.cos(omega_rad_s * t)])))
    return orthonormal_basis(np.concatenate(cols).T)


def project_out(x: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Rows of ``x`` [B, n] minus their projection on the columns of ``q`` [n, k]."""
    return x - (x @ q) @ q.T
