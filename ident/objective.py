"""The separable least-squares objective of every open-loop fit.

For a candidate valve path ``u`` and process dynamics, the model's compared output is
``g * L(G u)`` plus nuisance terms that enter linearly: the plant's free responses
(its unknown initial state), a constant (a bias in the stem's level, or a drift of PV)
and, for an external oscillation, a sine and a cosine.  The nuisances are projected
out once per record and dynamics; the gain ratio ``g`` (over the nominal process) is
either fixed or solved in closed form per candidate.  Variable projection (Golub &
Pereyra 1973): only the valve's and the dynamics' parameters are searched.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ident.process import TransferFunction
from ident.record import Record, orthonormal_basis


@dataclass(frozen=True)
class Scores:
    rss: np.ndarray
    """[B] residual sum of squares over the compared samples."""
    gain_ratio: np.ndarray
    """[B] the process gain over the nominal's (fixed, or solved)."""


def nuisance_basis(record: Record, tf: TransferFunction, omega_rad_s: float | None = None) -> np.ndarray:
    cols = [record.compared(tf.free_responses(record.n)), np.ones((1, record.n_fit))]
    if omega_rad_s:
        t = record.t_s
        cols.append(record.compared(np.stack([np.sin(omega_rad_s * t), np.cos(omega_rad_s * t)])))
    return orthonormal_basis(np.concatenate(cols).T)


def project_out(x: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Rows of ``x`` [B, n] minus their projection on the columns of ``q`` [n, k]."""
    return x - (x @ q) @ q.T


def score(
    record: Record,
    flow_pct: np.ndarray,
    tf: TransferFunction,
    gain_ratio: float | None = 1.0,
    omega_rad_s: float | None = None,
) -> Scores:
    """Residual sum of squares of each candidate path [B, N]; ``gain_ratio=None`` solves for it."""
    q = nuisance_basis(record, tf, omega_rad_s)
    y = project_out(record.target[None, :], q)[0]
    r = project_out(record.compared(tf.response(flow_pct)), q)
    if gain_ratio is None:
        rr = np.einsum("ij,ij->i", r, r)
        g = np.where(rr > 0, (r @ y) / np.where(rr > 0, rr, 1.0), 0.0)
    else:
        g = np.full(r.shape[0], float(gain_ratio))
    resid = y[None, :] - g[:, None] * r
    return Scores(np.einsum("ij,ij->i", resid, resid), g)
