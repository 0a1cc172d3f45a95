"""The stem's path read from PV under a process hypothesis: where the valve slipped.

Between slips a sticky stem is still, so the process input is piecewise constant.
Under a hypothesis the input is recovered from PV by inverting the process's poles
(``a(q)``, shifted by the dead time and scaled by the steady-state gain); the sensor's
pole is inverted only partly (to ``SENSOR_SHARPEN`` of its time constant), because its
exact inverse amplifies the noise tenfold, and the sampling zeros are not inverted at
all: both only smear a jump over a sample or two, which ``ident.fit`` then refines.
An optimal segmentation of the recovered input (``ident.segment``) gives the slips:
the first interval of every new piece.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ident.process import Dynamics, transfer_function
from ident.segment import segment_ends

SEGMENT_PENALTY = 2.0
"""Penalty per piece in units of the input estimate's noise variance times log(N) (BIC: level and place)."""
MIN_JUMP_SD = 3.0
"""A piece whose level differs from its predecessor's by less than this many standard errors is no slip."""
SENSOR_SHARPEN = 0.3


@dataclass(frozen=True)
class StemPath:
    """Slips of the stem: arrays over slips, indices are sample intervals (the slip happens in interval k)."""

    slips: np.ndarray
    directions: np.ndarray
    """+1 where the stem jumped up, -1 down."""
    levels: np.ndarray
    """[n_slips + 1] mean input over each piece, in the hypothesis's units (the first piece precedes the slips)."""
    noise_sd: float
    """Noise of the input estimate per sample."""

    def with_slips(self, slips: np.ndarray) -> StemPath:
        return StemPath(np.asarray(slips, int), self.directions, self.levels, self.noise_sd)


def pv_noise_sd(pv: np.ndarray) -> float:
    """White measurement noise on PV, from the MAD of its second differences (ramps and levels cancel)."""
    d2 = np.diff(pv, n=2)
    return float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / np.sqrt(6.0))


def inverse_filter(dynamics: Dynamics, ts_s: float) -> tuple[np.ndarray, int]:
    """``(c, shift)``: the input of interval k is about ``sum_i c_i PV[k + shift - i]``."""
    process = transfer_function(Dynamics(dynamics.time_constant_s), ts_s)  # y = b/(1 - p q^-1) u, b at lag 1
    c = process.a / process.b.sum()
    if dynamics.sensor_tau_s > 0:
        p = np.exp(-ts_s / dynamics.sensor_tau_s)
        r = np.exp(-ts_s / (SENSOR_SHARPEN * dynamics.sensor_tau_s))
        # (1 - p q^-1) / (1 - p) sharpened to (1 - p q^-1) / (1 - r q^-1) * (1 - r) / (1 - p), as FIR
        n_taps = int(np.ceil(np.log(1e-6) / np.log(r))) + 1 if r > 0 else 1
        taps = np.convolve([1.0, -p], r ** np.arange(n_taps))[:n_taps]
        c = np.convolve(c, taps * (1 - r) / (1 - p))
    shift = 1 + int(round(dynamics.dead_time_s / ts_s + (0.5 if dynamics.sensor_tau_s > 0 else 0.0)))
    return c, shift


def input_estimate(pv: np.ndarray, dynamics: Dynamics, ts_s: float) -> tuple[np.ndarray, int, float]:
    """``(u_hat, k0, noise_sd)``: the input of intervals ``k0 ..`` recovered from PV [N], and its noise."""
    c, shift = inverse_filter(dynamics, ts_s)
    filtered = np.convolve(pv, c, mode="valid")  # filtered[i] = sum_j c_j PV[i + len(c) - 1 - j]
    k0 = max(0, c.size - 1 - shift)
    u = filtered[k0 + shift - (c.size - 1) :]
    return u, k0, pv_noise_sd(pv) * float(np.sqrt(np.sum(c * c)))


def read_paths(pv: np.ndarray, dynamics: list[Dynamics], ts_s: float) -> list[StemPath]:
    """One stem path per hypothesis; the segmentations run as one batch where lengths agree."""
    estimates = [input_estimate(pv, d, ts_s) for d in dynamics]
    out: list[StemPath | None] = [None] * len(dynamics)
    groups: dict[int, list[int]] = {}
    for i, (u, _, _) in enumerate(estimates):
        groups.setdefault(u.size, []).append(i)
    for idx in groups.values():
        u = np.stack([estimates[i][0] for i in idx])
        # a floor for noise-free records: steps of a millionth of the signal's range are no slips
        sd = np.maximum([estimates[i][2] for i in idx], 1e-6 * np.ptp(u, axis=1))
        ends = segment_ends(u, SEGMENT_PENALTY * sd**2 * np.log(u.shape[1]) + 1e-12)
        for row, i in enumerate(idx):
            out[i] = _path(u[row], estimates[i][1], ends[row], float(sd[row]))
    return out


def _path(u: np.ndarray, k0: int, ends: list[int], noise_sd: float) -> StemPath:
    bounds = [0, *ends]
    # the interval in which the stem slips carries a mean between the two levels: a piece of one
    # sample between its neighbours belongs to the piece after it (the slip happened in it)
    drop = set()
    for i in range(1, len(bounds) - 2):
        a, b = bounds[i], bounds[i + 1]
        if b - a == 1 and min(u[a - 1], u[b]) < u[a] < max(u[a - 1], u[b]):
            drop.add(b)
    bounds = [x for x in bounds if x not in drop]
    starts, levels = [bounds[0]], [u[: bounds[1]].mean()]
    for a, b in zip(bounds[1:-1], bounds[2:], strict=True):
        level = u[a:b].mean()
        # a split of one still stretch (drift, noise) is no slip: merge it into the piece before
        se = noise_sd * np.sqrt(1.0 / (b - a) + 1.0 / (a - starts[-1]))
        if abs(level - levels[-1]) < MIN_JUMP_SD * se:
            levels[-1] = u[starts[-1] : b].mean()
            continue
        starts.append(a)
        levels.append(level)
    slips = np.array(starts[1:], dtype=int) + k0
    levels = np.array(levels)
    return StemPath(slips, np.sign(np.diff(levels)).astype(int), levels, noise_sd)
