"""The nuisances of every open-loop fit, projected out before the least squares.

A model's compared output is linear in terms nobody asks about: the plant's free responses
(its unknown initial state), a constant (a bias in the stem's level, or a drift of PV) and,
for an external oscillation, a sine and a cosine.  They are projected out once per record
and dynamics (variable projection, Golub & Pereyra 1973).
"""

from __future__ import annotations

import threading
from collections import OrderedDict

import numpy as np

from stiction.ident.process import TransferFunction
from stiction.ident.record import Record, orthonormal_basis

_BASES: OrderedDict = OrderedDict()
_BASES_LOCK = threading.Lock()
CACHED_BASES = 32
"""Nuisance bases kept, the latest used: a diagnosis asks for the same record's basis under the same dynamics
in every fit of a hypothesis (an eigendecomposition and an SVD of the record's length each, 1.8 s of a
3,600-sample diagnosis)."""


def nuisance_basis(record: Record, tf: TransferFunction, omega_rad_s: float | None = None) -> np.ndarray:
    """[n_fit, k] orthonormal basis of the nuisances (read-only: it is shared).  It depends on the record's
    shape alone (length, horizon, warm-up, sample time), not on its values, and is kept for the latest
    ``CACHED_BASES`` (shape, transfer function, frequency).  The entry holds the transfer function itself: while
    it lives, no other function can come to have its identity."""
    key = (record.n, record.horizon, record.skip, record.ts_s, id(tf), omega_rad_s)
    with _BASES_LOCK:
        hit = _BASES.get(key)
        if hit is not None:
            _BASES.move_to_end(key)
            return hit[1]
    q = _basis(record, tf, omega_rad_s)
    q.flags.writeable = False
    with _BASES_LOCK:
        _BASES[key] = (tf, q)
        while len(_BASES) > CACHED_BASES:
            _BASES.popitem(last=False)
    return q


def _basis(record: Record, tf: TransferFunction, omega_rad_s: float | None) -> np.ndarray:
    cols = [record.compared(tf.free_responses(record.n)), np.ones((1, record.n_fit))]
    if omega_rad_s:
        t = record.t_s
        cols.append(record.compared(np.stack([np.sin(omega_rad_s * t), np.cos(omega_rad_s * t)])))
    return orthonormal_basis(np.concatenate(cols).T)


def project_out(x: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Rows of ``x`` [B, n] minus their projection on the columns of ``q`` [n, k]."""
    return x - (x @ q) @ q.T
