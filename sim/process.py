"""Process and sensor models after the valve, discretised exactly for a 1 s sampled loop.

Thesis Table 2.2 gives the two processes (``level``: 1/(15 s), ``concentration``:
3/(10 s + 1)).  The extensions of the diagnose catalogue that act after the valve
live here too: a process gain ratio, a self-regulating process in place of the
integrating one, a first-order sensor filter and a transport delay.

The continuous plant has two states, ``[process output y, sensor reading]``, and
is driven by the valve's flow MV plus an input (load) disturbance w.  Each loop
gets its own exact zero-order-hold discretisation; a fractional dead time
splits the interval into two held inputs (the modified z-transform).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm


@dataclass(frozen=True)
class ProcessModel:
    """One loop's process as a first-order (or integrating) transfer function.

    ``gain / (time_constant_s * s + 1)``, or ``gain / s`` when ``time_constant_s`` is None.
    """

    gain: float
    time_constant_s: float | None
    controller_gain: float
    integral_time_s: float


LOOPS: dict[str, ProcessModel] = {
    "level": ProcessModel(gain=1.0 / 15.0, time_constant_s=None, controller_gain=3.0, integral_time_s=30.0),
    "concentration": ProcessModel(gain=3.0, time_constant_s=10.0, controller_gain=0.2, integral_time_s=2.0),
}


def continuous_plant(
    process: ProcessModel,
    gain_ratio: float = 1.0,
    time_constant_s: float | None = None,
    sensor_tau_s: float = 0.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(A, B, C)`` of the plant from valve flow to measured PV.

    ``time_constant_s`` makes an integrating process self-regulating with the same
    high-frequency gain (``gain/s`` becomes ``gain*T/(T s + 1)``), or replaces a
    self-regulating process's time constant.
    """
    if process.time_constant_s is None:
        if time_constant_s is None:
            a, b = 0.0, process.gain
        else:
            a, b = -1.0 / time_constant_s, process.gain
    else:
        tc = process.time_constant_s if time_constant_s is None else time_constant_s
        a, b = -1.0 / tc, process.gain / tc
    b *= gain_ratio
    if sensor_tau_s > 0:
        A = np.array([[a, 0.0], [1.0 / sensor_tau_s, -1.0 / sensor_tau_s]])
        C = np.array([0.0, 1.0])
    else:
        A = np.array([[a, 0.0], [0.0, 0.0]])
        C = np.array([1.0, 0.0])
    return A, np.array([b, 0.0]), C


def _zoh(A: np.ndarray, B: np.ndarray, t_s: float) -> tuple[np.ndarray, np.ndarray]:
    """``(e^{A t}, int_0^t e^{A s} ds B)`` via the augmented matrix exponential."""
    n = A.shape[0]
    M = np.zeros((n + 1, n + 1))
    M[:n, :n], M[:n, n] = A, B
    E = expm(M * t_s)
    return E[:n, :n], E[:n, n]


@dataclass(frozen=True)
class DiscretePlant:
    """Exact discretisation for sample time ``ts_s`` and dead time ``delay_samples + frac`` samples.

    ``x[k+1] = Phi x[k] + Gamma_now u[k - delay] + Gamma_prev u[k - delay - 1] + Gamma_w w[k]``
    """

    phi: np.ndarray
    gamma_now: np.ndarray
    gamma_prev: np.ndarray
    gamma_w: np.ndarray
    c: np.ndarray
    delay_samples: int


def discretise(A, B, C, ts_s: float = 1.0, dead_time_s: float = 0.0) -> DiscretePlant:
    delay = dead_time_s / ts_s
    n_delay = int(np.floor(delay + 1e-12))
    frac = delay - n_delay
    phi, gamma = _zoh(A, B, ts_s)
    if frac < 1e-12:
        gamma_now, gamma_prev = gamma, np.zeros_like(gamma)
    else:
        # u[k-n-1] acts over [0, frac*Ts), u[k-n] over [frac*Ts, Ts)
        _, gamma_late = _zoh(A, B, (1.0 - frac) * ts_s)
        phi_late, _ = _zoh(A, B, (1.0 - frac) * ts_s)
        _, gamma_early = _zoh(A, B, frac * ts_s)
        gamma_now, gamma_prev = gamma_late, phi_late @ gamma_early
    return DiscretePlant(phi, gamma_now, gamma_prev, gamma, np.asarray(C, float), n_delay)
