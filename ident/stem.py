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
from functools import lru_cache

import numpy as np

from stiction.ident import kernels, lattice
from stiction.ident.process import Dynamics, transfer_function
from stiction.ident.segment import segment_ends

SEGMENT_PENALTY = 2.0
"""Penalty per piece in units of the input estimate's noise variance times log(N) (BIC: level and place)."""
MIN_JUMP_SD = 3.0
"""A piece whose level differs from its predecessor's by less than this many standard errors is no slip."""
SENSOR_SHARPEN = 0.5


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


def second_difference_sd(x: np.ndarray) -> float:
    """A white noise's standard deviation in ``x``, from the MAD of its second differences (ramps and levels cancel,
    and a slip is one sample in many; a white noise's second differences have six times its variance)."""
    d2 = np.diff(np.asarray(x, float), n=2)
    return float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / np.sqrt(6.0))


def pv_noise_sd(pv: np.ndarray) -> float:
    """White measurement noise on PV (``second_difference_sd``).

    A record stored in steps has most second differences exactly zero: its noise is at least the
    rounding's, a step over the square root of 12.
    """
    sd = second_difference_sd(pv)
    q = lattice.resolution(pv)
    return max(sd, q / np.sqrt(12.0)) if q else sd


@lru_cache(maxsize=4096)
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
    return c, _half_way(dynamics, ts_s, c)


def _half_way(dynamics: Dynamics, ts_s: float, c: np.ndarray) -> int:
    """The shift that puts a step of the input where the recovered input is half way up.

    A segmentation places a smeared jump at the first sample past half its height (``_path``),
    so this is where the recovered input shows a slip in interval k.
    """
    start = c.size + 5  # past the filter's own warm-up
    lag = dynamics.dead_time_s + 5 * (dynamics.sensor_tau_s + (dynamics.time_constant_s or 0.0))
    n = start + c.size + int(np.ceil(lag / ts_s)) + 20
    u = np.zeros(n)
    u[start:] = 1.0
    pv = transfer_function(dynamics, ts_s).response(u[None, :])[0]
    v = np.convolve(pv, c, mode="valid")
    first = int(np.argmax(v >= 0.5 * v[-1]))
    return first + c.size - 1 - start


def input_estimate(pv: np.ndarray, dynamics: Dynamics, ts_s: float) -> tuple[np.ndarray, int, float]:
    """``(u_hat, k0, noise_sd)``: the input of intervals ``k0 ..`` recovered from PV [N], and its noise."""
    c, shift = inverse_filter(dynamics, ts_s)
    filtered = np.convolve(pv, c, mode="valid")  # filtered[i] = sum_j c_j PV[i + len(c) - 1 - j]
    k0 = max(0, c.size - 1 - shift)
    u = filtered[k0 + shift - (c.size - 1) :]
    return u, k0, pv_noise_sd(pv) * float(np.sqrt(np.sum(c * c)))


def without_sine(u: np.ndarray, period_s: float, ts_s: float) -> np.ndarray:
    """``u`` less its least-squares sine of ``period_s``: an external load is no movement of the stem."""
    t = np.arange(u.size) * ts_s
    x = np.stack([np.sin(2 * np.pi * t / period_s), np.cos(2 * np.pi * t / period_s), np.ones(u.size)], axis=1)
    coef, *_ = np.linalg.lstsq(x, u, rcond=None)
    return u - x[:, :2] @ coef[:2]


LOAD_ITERATIONS = 3


def _pieces(u: np.ndarray, sd: float) -> np.ndarray:
    """The optimal piecewise-constant approximation of ``u``."""
    sd = max(sd, 1e-6 * float(np.ptp(u)))
    ends = np.array(segment_ends(u[None, :], np.array([SEGMENT_PENALTY * sd**2 * np.log(u.size) + 1e-12]))[0])
    starts = np.concatenate([[0], ends[:-1]])
    lengths = ends - starts
    return np.repeat(np.add.reduceat(u, starts) / lengths, lengths)  # each piece's mean, on its samples


def _without_load(u: np.ndarray, k0: int, sd: float, period_s: float, ts_s: float):
    """The input estimate less an external sine load, separated from the stem's pieces by alternation.

    Removing the sine from ``u`` directly would take the stem's own square wave with it when the
    load has entrained the limit cycle; fitting it to what the pieces leave does not.
    """
    load = np.zeros_like(u)
    for _ in range(LOAD_ITERATIONS):
        pieces = _pieces(u - load, sd)
        load = (u - pieces) - without_sine(u - pieces, period_s, ts_s)
    return u - load, k0, sd


class StemReader:
    """Stem paths of one record under many hypotheses.

    The inverse filter depends on the process's and the sensor's poles only; a dead time just
    shifts the recovered input, so one segmentation serves every dead time (rounded to samples).
    """

    def __init__(self, pv: np.ndarray, ts_s: float):
        self.pv, self.ts_s = np.asarray(pv, float), ts_s
        self.noise_sd = pv_noise_sd(self.pv)
        self._segmented: dict[tuple, tuple[np.ndarray, list[int], float, int]] = {}

    def paths(self, keys: list[tuple[Dynamics, float | None]]) -> list[StemPath]:
        """One path per (dynamics, external oscillation period or None)."""
        seg_keys = [(d.time_constant_s, d.sensor_tau_s, p) for d, p in keys]
        missing = list(dict.fromkeys(k for k in seg_keys if k not in self._segmented))
        if missing:
            self._segment(missing)
        out = []
        for (d, _), sk in zip(keys, seg_keys, strict=True):
            filtered, ends, sd, taps = self._segmented[sk]
            _, shift = inverse_filter(d, self.ts_s)
            out.append(_path(filtered, taps - 1 - shift, ends, sd, self.pv.size))
        return out

    def _segment(self, keys: list[tuple]) -> None:
        rows = []
        for tau, sensor, period in keys:
            c, _ = inverse_filter(Dynamics(tau, 0.0, sensor), self.ts_s)
            # filtered[i] holds the input of interval i + len(c) - 1 - shift
            filtered = np.convolve(self.pv, c, mode="valid")
            sd = self.noise_sd * float(np.sqrt(np.sum(c * c)))
            if period:
                filtered = _without_load(filtered, 0, sd, period, self.ts_s)[0]
            # a floor for noise-free records: steps of a millionth of the signal's range are no slips
            rows.append((filtered, max(sd, 1e-6 * float(np.ptp(filtered))), c.size))
        # one batch: shorter rows padded with their last value (a constant tail joins the last piece)
        width = max(f.size for f, _, _ in rows)
        u = np.stack([np.pad(f, (0, width - f.size), mode="edge") for f, _, _ in rows])
        sd = np.array([r[1] for r in rows])
        ends = segment_ends(u, SEGMENT_PENALTY * sd**2 * np.log(u.shape[1]) + 1e-12)
        for i, (f, _, taps) in enumerate(rows):
            self._segmented[keys[i]] = (
                f,
                [min(e, f.size) for e in ends[i] if e < f.size] + [f.size],
                float(sd[i]),
                taps,
            )


def read_paths(
    pv: np.ndarray, dynamics: list[Dynamics], ts_s: float, osc_periods_s: list[float | None] | None = None
) -> list[StemPath]:
    """One stem path per hypothesis (see ``StemReader``)."""
    periods = osc_periods_s or [None] * len(dynamics)
    return StemReader(pv, ts_s).paths(list(zip(dynamics, periods, strict=True)))


def _path(u: np.ndarray, k0: int, ends: list[int], noise_sd: float, n: int | None = None) -> StemPath:
    """Slips from a segmentation of ``u``, whose sample i is the input of interval ``i + k0`` (of ``n``)."""
    # a jump smeared over two samples (a slip within an interval, a fractional dead time) leaves a
    # piece of one sample between the two levels: it joins the level it is nearer to, so that the
    # slip is placed where the jump is half done, whether or not noise split it off; a split of one
    # still stretch (drift, noise) is no slip: it merges into the piece before (compiled: ``ident.kernels``)
    bounds = np.array([0, *ends], dtype=np.int64)
    starts, levels = kernels.path_pieces(np.ascontiguousarray(u, dtype=float), bounds, float(noise_sd), MIN_JUMP_SD)
    slips = starts[1:] + k0
    keep = (slips >= 1) & (slips < (n if n is not None else np.inf))
    # pieces whose slip falls outside the record merge into their neighbour
    first = int(np.argmax(keep)) if keep.any() else slips.size
    levels = np.concatenate([levels[first : first + 1], levels[1:][keep]]) if keep.any() else levels[:1]
    slips = slips[keep]
    return StemPath(slips, np.sign(np.diff(levels)).astype(int), levels, noise_sd)
