"""The process after the valve as a discrete transfer function, for open-loop fits.

``sim.process`` discretises the plant exactly (zero-order hold, fractional dead time);
here the same discretisation becomes ``PV = B(q)/A(q) u`` so that many candidate valve
outputs ``u`` go through it with one call (``ident.kernels.iir_rows``), and the unknown
initial state becomes linear nuisance regressors (the plant's free responses).

Dynamics are named as in the diagnose catalogue and relative to the canonical level
process (``gain/s`` with ``gain = 1/15 s``): ``time_constant_s`` makes it
self-regulating with the same high-frequency gain (``sim.process.continuous_plant``).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from stiction.ident import kernels
from stiction.sim.process import LOOPS, ProcessModel, continuous_plant, discretise

NOMINAL = LOOPS["level"]


def ranged(text: str, lo_hi: tuple[float, float] | None) -> str:
    """``text`` (a value in words) followed by its range, ``(low-high)``, where it has one: how every range a
    diagnosis gives is written (the process line, the summary, the plot's title)."""
    return text + (f" ({lo_hi[0]:.3g}-{lo_hi[1]:.3g})" if lo_hi else "")


@dataclass(frozen=True)
class Dynamics:
    """Everything about the process but its gain (which the fits solve for linearly)."""

    time_constant_s: float | None = None
    """None: integrating; else a first-order lag of this time constant."""
    dead_time_s: float = 0.0
    sensor_tau_s: float = 0.0

    def describe(self, ranges: dict[str, tuple[float, float]] | None = None) -> str:
        """In words; each value followed by its range (low-high) where ``ranges`` gives one, by parameter name."""
        ranges = ranges or {}

        def value(name: str, v: float) -> str:
            return ranged(f"{v:.3g} s", ranges.get(name))

        t = self.time_constant_s
        kind = "integrating" if t is None else f"first order, T {value('time_constant_s', t)}"
        extra = []
        if self.dead_time_s > 0:
            extra.append(f"dead time {value('dead_time_s', self.dead_time_s)}")
        if self.sensor_tau_s > 0:
            extra.append(f"sensor lag {value('sensor_tau_s', self.sensor_tau_s)}")
        return ", ".join([kind, *extra])


@dataclass(frozen=True)
class TransferFunction:
    """``y = b(q^-1)/a(q^-1) u`` plus free responses of the initial state, sample time ``ts_s``."""

    b: np.ndarray
    a: np.ndarray
    phi: np.ndarray
    c: np.ndarray
    delay_samples: int
    ts_s: float

    def response(self, u: np.ndarray) -> np.ndarray:
        """[B, N] inputs (mean valve position over each interval) -> [B, N] PV from rest."""
        return self.response_changed(u, 0, 0)

    def response_changed(self, u: np.ndarray, horizon: int, skip: int) -> np.ndarray:
        """``response`` of [..., N] inputs, each row's change over ``horizon`` samples from the ``skip``-th
        change on (``ident.record.Record.compared`` of the response, in one pass); horizon 0: the response."""
        u = np.asarray(u, dtype=float)
        rows = np.ascontiguousarray(u.reshape(-1, u.shape[-1]))
        out = kernels.iir_rows(np.asarray(self.b, float), np.asarray(self.a, float), rows, horizon, skip)
        return out.reshape(*u.shape[:-1], out.shape[-1])

    def free_responses(self, n: int) -> np.ndarray:
        """[S, N] ``C Phi^k e_i`` for each state i: the output of an initial state, sample by sample."""
        lam, v = np.linalg.eig(self.phi)
        if np.min(np.abs(np.subtract.outer(lam, lam)) + np.eye(lam.size)) > 1e-6:
            # distinct eigenvalues: Phi^k = V diag(lam^k) V^-1
            powers = np.power.outer(lam, np.arange(n))  # [S, N]
            return np.real(np.einsum("j,jk,ji->ik", self.c @ v, powers, np.linalg.inv(v)))
        out = np.empty((self.phi.shape[0], n))
        x = np.eye(self.phi.shape[0])
        for k in range(n):
            out[:, k] = self.c @ x
            x = self.phi @ x
        return out


def _minimal(A: np.ndarray, B: np.ndarray, C: np.ndarray):
    """Drop the sensor state when there is no sensor lag (it is then neither driven nor seen)."""
    if C[1] == 0 and not np.any(A[1]):
        return A[:1, :1], B[:1], C[:1]
    return A, B, C


@lru_cache(maxsize=4096)
def transfer_function(
    dynamics: Dynamics, ts_s: float, gain_ratio: float = 1.0, process: ProcessModel = NOMINAL
) -> TransferFunction:
    """Exact discretisation of ``sim.process`` as a transfer function (SISO: ``C adj(zI-Phi) G``).

    Cached: the fits ask for the same few dynamics thousands of times, and each costs a matrix exponential.
    """
    A, B, C = continuous_plant(process, gain_ratio, dynamics.time_constant_s, dynamics.sensor_tau_s)
    A, B, C = _minimal(A, B, C)
    plant = discretise(A, B, C, ts_s, dynamics.dead_time_s)
    a = np.poly(plant.phi)
    # numerator of C (zI - Phi)^-1 G is det(zI - Phi + G C) - det(zI - Phi)
    num_now = np.poly(plant.phi - np.outer(plant.gamma_now, plant.c)) - a
    num_prev = np.poly(plant.phi - np.outer(plant.gamma_prev, plant.c)) - a
    b = np.zeros(a.size + 1 + plant.delay_samples)
    b[plant.delay_samples : plant.delay_samples + a.size] += num_now
    b[plant.delay_samples + 1 : plant.delay_samples + 1 + a.size] += num_prev
    return TransferFunction(np.trim_zeros(b, "b"), a, plant.phi, plant.c, plant.delay_samples, ts_s)
