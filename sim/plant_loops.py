"""Plant-like loops for telling stiction from its look-alikes (``stiction bench detect``, the detector).

Flow, pressure and level loops are not the thesis's: a self-regulating or integrating
process of random gain, time constant and dead time, tuned by SIMC (Skogestad 2003), with
one cause of oscillation or none:

- ``stiction``: the physical valve with fs 6-60 % of 500 lbf, a band S of 2.5-25 % of span;
- ``external_oscillation``: a linear valve and a sinusoidal load of 2-15 cycles per window;
- ``tuning``: a linear valve and a controller 1.5-2.5 times too aggressive for the dead time (runs that
  diverge are dropped by ``stable``: a real loop would saturate and be bad data);
- ``deadband``, ``quantization``: a linear valve with backlash or a stepped record;
- ``noise``: a linear valve, the loop wandering with measurement and load noise.

Each comes with the historian's sample interval (1-10 s, one recorded sample every so many
controller periods of 1 s).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stiction.sim.disturbance import unit_shape
from stiction.sim.extensions import Extensions
from stiction.sim.loop import LoopSpec, build_batch, external_oscillation, run_batch
from stiction.sim.process import ProcessModel
from stiction.sim.valve import band_and_jump_pct

CLASSES = ("stiction", "external_oscillation", "tuning", "deadband", "quantization", "noise")
WINDOW_SAMPLES = 600
"""Recorded samples per generated window: 10 min at 1 s to 100 min at 10 s."""


@dataclass(frozen=True)
class PlantLoop:
    spec: LoopSpec
    cause: str
    every: int
    """Controller periods (1 s) per recorded sample."""
    s_pct: float
    """True band S in % of span (0 without stiction)."""
    j_pct: float
    noise_pct: float
    """White measurement noise on PV, standard deviation in % of span."""
    load_pct: float
    """Slow (brown) load on the process input, RMS in % of span."""
    sp_steps: tuple[tuple[float, float], ...] = ()
    """Setpoint moves ``(share of the recorded window, step in % of span)``: operators move setpoints."""

    @property
    def duration_s(self) -> float:
        return float(WINDOW_SAMPLES * self.every)


def _process(rng: np.random.Generator, aggressive: float | None = None) -> tuple[ProcessModel, float]:
    """A random process and its SIMC tuning, and its dead time [s].

    ``aggressive`` multiplies the SIMC gain; without it the controller is detuned as plants run
    them (gain 0.2-1 times SIMC's, integral time 1-10 times), so slow limit cycles are common."""
    integrating = rng.random() < 0.3
    dead_time_s = float(rng.uniform(0.0, 8.0))
    slower = 1.0 if aggressive is not None else float(np.exp(rng.uniform(0.0, np.log(10.0))))
    aggressive = aggressive if aggressive is not None else float(rng.uniform(0.2, 1.0))
    closed_s = max(dead_time_s, float(rng.uniform(3.0, 20.0)))  # SIMC's tau_c
    if integrating:
        gain = float(np.exp(rng.uniform(np.log(0.01), np.log(0.1))))
        kc = 1.0 / (gain * (closed_s + dead_time_s))
        ti = 4.0 * (closed_s + dead_time_s) * slower
        model = ProcessModel(gain=gain, time_constant_s=None, controller_gain=kc * aggressive, integral_time_s=ti)
    else:
        gain = float(np.exp(rng.uniform(np.log(0.5), np.log(2.0))))
        tau = float(np.exp(rng.uniform(np.log(3.0), np.log(60.0))))
        kc = tau / (gain * (closed_s + dead_time_s))
        ti = min(tau, 4.0 * (closed_s + dead_time_s)) * slower
        model = ProcessModel(gain=gain, time_constant_s=tau, controller_gain=kc * aggressive, integral_time_s=ti)
    return model, dead_time_s


def plant_loops(n_per_class: int, seed: int) -> list[PlantLoop]:
    """``n_per_class`` loops of every class of ``CLASSES``, magnitudes drawn at random."""
    rng = np.random.default_rng(seed)
    out = []
    for cause in CLASSES:
        for _ in range(n_per_class):
            every = int(rng.choice([1, 2, 5, 10]))
            aggressive = float(rng.uniform(1.5, 2.5)) if cause == "tuning" else None
            model, dead_time_s = _process(rng, aggressive)
            if cause == "tuning":
                dead_time_s = max(dead_time_s, 3.0)
            fs = float(rng.uniform(6.0, 60.0)) if cause == "stiction" else 0.0
            j_share = float(rng.uniform(0.1, 0.9))
            fd = fs * (1 - j_share)
            params: dict = {"dead_time_s": dead_time_s}
            if cause == "external_oscillation":
                cycles = float(rng.uniform(2.0, 15.0))
                params |= {
                    "osc_period_s": WINDOW_SAMPLES * every / cycles,
                    "osc_amplitude_pct": float(rng.uniform(1, 5)),
                }
            if cause == "deadband":
                params["deadband_pct"] = float(rng.uniform(1.0, 5.0))
            if cause == "quantization":
                params["quantum_pct"] = float(rng.uniform(0.2, 1.0))
            noise_pct = float(rng.uniform(0.02, 0.3))
            load_pct = float(rng.uniform(0.5, 3.0)) if cause in ("noise", "deadband", "quantization") else 0.0
            load_pct = load_pct or float(rng.uniform(0.0, 0.5))
            spec = LoopSpec(
                fs, fd, process=model, extensions=Extensions(**params), seed=int(rng.integers(2**31)), sp_pct=50.0
            )
            s_pct, j_pct = (float(v) for v in band_and_jump_pct(fs, fd))
            steps = int(rng.integers(0, 4)) if rng.random() < 0.5 else 0
            sp_steps = tuple(
                (float(rng.uniform(0.05, 0.95)), float(rng.choice([-1, 1]) * rng.uniform(1.0, 5.0)))
                for _ in range(steps)
            )
            out.append(PlantLoop(spec, cause, every, s_pct, j_pct, noise_pct, load_pct, sp_steps))
    return out


def by_sample_interval(loops) -> dict[int, list[int]]:
    """Indices of ``loops`` grouped by their controller periods per recorded sample (``every``): each
    group is simulated as one batch of the same length."""
    groups: dict[int, list[int]] = {}
    for i, loop in enumerate(loops):
        groups.setdefault(loop.every, []).append(i)
    return groups


def simulate_plant(
    loops: list[PlantLoop], warmup_windows: float = 1.0, samples: int = WINDOW_SAMPLES
) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, float]]:
    """``(op, pv, sp, ts_s)`` of each loop as its historian records it: ``samples`` samples after a
    warm-up of ``warmup_windows`` times as many, noise and load in absolute % of span (the loop's
    controller sees both).

    A setpoint move of ``d`` enters as an output offset of ``-d`` that the record does not show: the
    controller sees the same error either way."""
    out: list = [None] * len(loops)
    for every, idx in by_sample_interval(loops).items():
        n = int(samples * every * (1 + warmup_windows))
        t_s = np.arange(n, dtype=float)
        specs = [loops[i].spec for i in idx]
        w = external_oscillation(specs, t_s)
        z = np.zeros_like(w)
        moves = np.zeros_like(w)
        start = n - samples * every
        for row, i in enumerate(idx):
            rng = np.random.default_rng(loops[i].spec.seed)
            z[row] = loops[i].noise_pct * unit_shape("gaussian", n, 1.0, rng)
            w[row] += loops[i].load_pct * unit_shape("brownian", n, 1.0, rng)
            for share, step_pct in loops[i].sp_steps:
                moves[row, start + int(share * samples * every) :] += step_pct
        op, pv, _ = run_batch(build_batch(specs), w, z - moves)
        pv = pv + moves
        keep = slice(start + every - 1, n, every)
        for row, i in enumerate(idx):
            q = loops[i].spec.extensions.quantum_pct
            o, p = op[row, keep], pv[row, keep]
            sp = loops[i].spec.sp_pct + moves[row, keep]
            if q > 0:
                o, p = np.round(o / q) * q, np.round(p / q) * q
            out[i] = (o, p, sp, float(every))
    return out


def stable(op: np.ndarray, pv: np.ndarray) -> bool:
    """Whether a generated loop stayed within the span's reach (an unstable tuning diverges)."""
    return bool(np.all(np.isfinite(op)) and np.all(np.isfinite(pv)) and np.ptp(pv) < 100 and np.ptp(op) < 1000)
