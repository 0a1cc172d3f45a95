"""The training grid and the 20 test cases of thesis 4.2 (spec/thesis-loop.md)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from stiction.sim.disturbance import Disturbance
from stiction.sim.extensions import Extensions
from stiction.sim.loop import LoopSpec
from stiction.sim.valve import lbf_to_pct


def training_grid_lbf() -> list[tuple[float, float]]:
    """``for fs in 500, 490, ..., 10: for fd in fs-10, fs-20, ..., 0``: 1275 (fs, fd) pairs in lbf."""
    return [(float(fs), float(fd)) for fs in range(500, 0, -10) for fd in range(fs - 10, -1, -10)]


def training_specs(
    loop: str = "level", valve: str = "physical", extensions: Extensions | None = None
) -> list[LoopSpec]:
    """The training grid; ``extensions`` puts every grid point on an extended loop (``stiction train --extension``)."""
    ext = Extensions() if extensions is None else extensions
    return [
        LoopSpec(float(lbf_to_pct(fs)), float(lbf_to_pct(fd)), loop=loop, valve=valve, extensions=ext)
        for fs, fd in training_grid_lbf()
    ]


NOISE_FREE_CASES: dict[str, tuple[float, float]] = {
    "C1": (97.40, 64.40),
    "C2": (47.20, 4.60),
    "C3": (73.80, 69.00),
    "C4": (70.40, 21.00),
    "C5": (62.60, 16.80),
    "C6": (10.60, 4.80),
    "C7": (16.00, 11.20),
    "C8": (9.40, 6.00),
    "C9": (33.20, 19.40),
    "C10": (64.80, 7.20),
}

NOISY_CASES: dict[str, tuple[float, float, Disturbance]] = {
    "N1": (91.40, 20.40, Disturbance("sine", "output", 0.1, 4.0)),
    "N2": (13.20, 8.80, Disturbance("sine", "output", 0.06, 0.1)),
    "N3": (17.40, 13.00, Disturbance("sine", "input", 0.15, 0.2)),
    "N4": (46.80, 4.00, Disturbance("gaussian", "output", 0.1)),
    "N5": (29.00, 16.00, Disturbance("gaussian", "output", 0.2)),
    "N6": (17.80, 8.00, Disturbance("gaussian", "input", 0.3)),
    "N7": (86.00, 42.00, Disturbance("brownian", "output", 0.1)),
    "N8": (100.00, 67.60, Disturbance("brownian", "output", 0.1)),
    "N9": (47.20, 10.40, Disturbance("brownian", "input", 0.1)),
    "N10": (57.80, 22.20, Disturbance("brownian", "output", 0.1)),
}


def case_specs(seed: int = 0, extensions: Extensions | None = None) -> dict[str, LoopSpec]:
    """C1-C10 and N1-N10 of thesis Figures 4.2 and 4.5, fs/fd in percent of 500 lbf (on an extended loop if given)."""
    ext = Extensions() if extensions is None else extensions
    cases = {name: LoopSpec(fs, fd, extensions=ext) for name, (fs, fd) in NOISE_FREE_CASES.items()}
    cases.update(
        {name: LoopSpec(fs, fd, disturbance=d, seed=seed, extensions=ext) for name, (fs, fd, d) in NOISY_CASES.items()}
    )
    return cases


def random_disturbance(rng: np.random.Generator) -> Disturbance:
    """The families of thesis 4.2 with coefficients and frequencies around the test cases'."""
    shape = rng.choice(["sine", "gaussian", "brownian"])
    where = rng.choice(["input", "output"])
    coefficient = float(rng.uniform(0.03, 0.3))
    omega = float(np.exp(rng.uniform(np.log(0.05), np.log(4.0)))) if shape == "sine" else None
    return Disturbance(str(shape), str(where), coefficient, omega)


def random_loops(n: int, seed: int, noisy: bool = True) -> list[LoopSpec]:
    """Random loops (continuous fs, fd) with random disturbances: the holdout no model is tuned on."""
    rng = np.random.default_rng(seed)
    specs = []
    for _ in range(n):
        fs = float(rng.uniform(4, 100))
        fd = float(fs * rng.uniform(0, 0.95))
        d = random_disturbance(rng) if noisy else None
        specs.append(LoopSpec(fs, fd, disturbance=d, seed=int(rng.integers(2**31))))
    return specs


EFFECT_RANGES: dict[str, dict[str, tuple[float, float]]] = {
    "none": {},
    "dead_time": {"dead_time_s": (1.0, 5.0)},
    "deadband": {"deadband_pct": (2.0, 10.0)},
    "actuator_lag": {"actuator_tau_s": (1.5, 8.0)},
    "sensor_lag": {"sensor_tau_s": (1.5, 8.0)},
    "quantization": {"quantum_pct": (0.1, 0.3)},
    "process_gain": {"gain_ratio": (0.5, 2.0)},
    "external_oscillation": {"osc_period_s": (25.0, 200.0), "osc_amplitude_pct": (0.5, 3.0)},
    "process_type": {"time_constant_s": (20.0, 200.0)},
}
"""Magnitudes of each catalogue cause in generated loops: large enough to matter, within the level loop's reach
(its delay margin is about 6 s; lags past 10 s leave it lightly damped, spec/thesis-loop.md)."""

WIDE_EFFECT_RANGES: dict[str, dict[str, tuple[float, float]]] = {
    "none": {},
    "dead_time": {"dead_time_s": (0.5, 5.5)},
    "deadband": {"deadband_pct": (1.0, 12.0)},
    "actuator_lag": {"actuator_tau_s": (0.5, 10.0)},
    "sensor_lag": {"sensor_tau_s": (0.5, 10.0)},
    "quantization": {"quantum_pct": (0.02, 0.3)},
    "process_gain": {"gain_ratio": (1 / 3, 3.0)},
    "external_oscillation": {"osc_period_s": (10.0, 500.0), "osc_amplitude_pct": (0.2, 4.0)},
    "process_type": {"time_constant_s": (10.0, 500.0)},
}
"""The same causes drawn as a plant has them, not as the fit finds them easiest (``stiction bench diagnose
--draws wide``): dead times from half a sample to just inside the delay margin, lags from half a sample to
10 s (past 8 s the sticky level loop's cycle grows to OP swings over 100 % of span: no plant runs so), process
gains a third to three times the nominal, external cycles from faster to far slower than the loop's own
(10-500 s), quanta at and below the noise, self-regulating processes from ten to five hundred seconds.  The
small ends are where naming is hardest: an effect near half a sample hides in the noise."""
DRAWS = {"catalogue": EFFECT_RANGES, "wide": WIDE_EFFECT_RANGES}


HEALTHY_LOAD = WIDE_EFFECT_RANGES["external_oscillation"]
"""The external load of ``healthy_loops``: the wide draws' external oscillation."""


def healthy_loops(n: int, seed: int, noisy: bool = True, shapes: Sequence[str] = ("sine",)) -> list[LoopSpec]:
    """The canonical loop with a healthy valve (fs = fd = 0) that still cycles: an external load at the
    process input (period and amplitude log-uniform over ``HEALTHY_LOAD``'s ranges), the loops taking
    ``shapes`` in turn (``sim.extensions.OSC_SHAPES``; the draws are the same whatever the shapes),
    under the thesis's disturbances (``random_disturbance``; none where not ``noisy``).  Without the load a
    healthy canonical loop is still: the thesis's disturbances are sized on the clean signal's RMS, then zero."""
    rng = np.random.default_rng(seed)
    specs = []
    for i in range(n):
        period = float(np.exp(rng.uniform(*np.log(HEALTHY_LOAD["osc_period_s"]))))
        amplitude = float(np.exp(rng.uniform(*np.log(HEALTHY_LOAD["osc_amplitude_pct"]))))
        ext = Extensions(osc_period_s=period, osc_amplitude_pct=amplitude, osc_shape=shapes[i % len(shapes)])
        disturbance = random_disturbance(rng) if noisy else None
        specs.append(LoopSpec(0.0, 0.0, disturbance=disturbance, extensions=ext, seed=int(rng.integers(2**31))))
    return specs


def effect_loops(
    cause: str, n: int, seed: int, noise: tuple[float, float] = (0.01, 0.04), draws: str = "catalogue"
) -> list[LoopSpec]:
    """Canonical loops with one hidden effect of ``cause`` each, at random magnitudes (over the ranges
    ``DRAWS[draws]`` names), fs/fd and noise.

    The noise is white on PV at ``noise`` times its clean RMS (the controller sees it too).
    A process gain is drawn log-uniformly outside 0.8..1.25, so that there is an effect to find.
    """
    if draws not in DRAWS:
        raise ValueError(f"draws {draws!r}: one of {', '.join(DRAWS)}")
    ranges = DRAWS[draws][cause]
    rng = np.random.default_rng(seed)
    specs = []
    for _ in range(n):
        fs = float(rng.uniform(15, 90))
        fd = float(fs * rng.uniform(0.1, 0.8))
        params = {}
        for name, (lo, hi) in ranges.items():
            if name == "gain_ratio":
                v = float(np.exp(rng.uniform(np.log(0.8), np.log(max(2.0, hi)))))
                params[name] = v if rng.random() < 0.5 else 1.0 / v
                params[name] = float(np.clip(params[name], lo, hi))
                if 0.8 < params[name] < 1.25:
                    params[name] = 1.25 if params[name] > 1 else 0.8
            else:
                params[name] = float(rng.uniform(lo, hi))
        coefficient = float(rng.uniform(*noise))
        specs.append(
            LoopSpec(
                fs,
                fd,
                disturbance=Disturbance("gaussian", "output", coefficient) if coefficient > 0 else None,
                extensions=Extensions(**params),
                seed=int(rng.integers(2**31)),
            )
        )
    return specs
