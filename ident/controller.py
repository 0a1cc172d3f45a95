"""The loop's PI controller, read from its own record: ``OP = Kc (e + Ts/Ti sum e)``.

A positional PI's output is a linear function of the control error and its running sum, so
one least-squares fit per window reads ``Kc`` and ``Ti`` (an offset takes the sum before the
window; without a setpoint a constant one is assumed and a ramp term takes it).  Where the
recorded PV is what the controller saw, the fit is exact; where it explains OP only in part
(a cascade, manual moves, a different algorithm, noise the controller never saw) ``explained``
says so and the values are not used.

The pipeline uses it to recognise the thesis's own level loop without ``--process level``:
its controller (Kc 3, Ti 30 s, sampled every second, spec/thesis-loop.md) is a fingerprint
no plant loop of the measured sets shares.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stiction.ident import kernels

MIN_EXPLAINED = 0.999
"""Share of OP's variance the PI must explain for its Kc and Ti to identify a controller."""
MATCH_REL = 0.02
"""Relative tolerance on Kc and Ti for a match with a known controller."""


@dataclass(frozen=True)
class PiFit:
    """Arrays over windows."""

    kc: np.ndarray
    ti_s: np.ndarray
    explained: np.ndarray
    """1 - residual variance / OP variance of the fit (all three nan where OP does not move or the
    error's columns are dependent: a flat PV)."""


def fit_pi(op: np.ndarray, pv: np.ndarray, ts_s: float = 1.0, sps=None) -> PiFit:
    """Least-squares ``Kc``, ``Ti`` of each row of ``op``, ``pv`` [W, N]; ``sps``: each row's setpoint,
    or None for a constant one (all rows or that row)."""
    op, pv = np.atleast_2d(np.asarray(op, float)), np.atleast_2d(np.asarray(pv, float))
    n_win = op.shape[0]
    sps = [None] * n_win if sps is None else sps
    e = [-p if sp is None else np.asarray(sp, float) - p for p, sp in zip(pv, sps, strict=True)]
    out = np.array([kernels.pi_fit(np.ascontiguousarray(op[w]), np.ascontiguousarray(e[w]), float(ts_s))
                    for w in range(n_win)]).reshape(n_win, 3)  # fmt: skip
    return PiFit(out[:, 0], out[:, 1], out[:, 2])


def matches(fit: PiFit, kc: float, ti_s: float) -> np.ndarray:
    """Windows whose PI explains OP and has this ``kc`` and ``ti_s`` to within ``MATCH_REL``."""
    with np.errstate(invalid="ignore"):
        return (
            (fit.explained >= MIN_EXPLAINED)
            & (np.abs(fit.kc / kc - 1) <= MATCH_REL)
            & (np.abs(fit.ti_s / ti_s - 1) <= MATCH_REL)
        )
