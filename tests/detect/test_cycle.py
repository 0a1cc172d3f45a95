"""The cycle model: among windows that oscillate regularly, a plant-scale sticky valve's limit cycle is
called stiction and an external cycle of the same loops is not; it speaks for those windows only."""

from dataclasses import replace

import numpy as np

from stiction.detect.features import evidence
from stiction.detect.verdict import Detector, decide
from stiction.sim.plant_families import WINDOW_SAMPLES, family_loops, simulate_families, stable
from stiction.sim.valve import friction_pct

SEEDS = (5151, 5152)
"""Neither the shipped detector's training seeds (7, 8, 9, 10) nor the benchmark's (2026)."""


def _clean(loop, **changes):
    """The loop with little noise, no load wander, no setpoint move and a plain record."""
    plain = {"noise_pct": 0.05, "noise_ar": 0.0, "load_pct": 0.1, "sp_steps": (), "quantum_pct": 0.0,
             "compression_pct": 0.0}  # fmt: skip
    return replace(loop, **(plain | changes))


def _hidden_cycles():
    """Flow and level loops of the families with a plant-scale sticky valve (S 2 and 3 %, J 1 %), and
    the same loops with a linear valve under an external sine, triangle or square load."""
    sticky, external = [], []
    for seed in SEEDS:
        for loop in family_loops(6, seed, ("level", "flow"), bands="plant"):
            if loop.cause != "stick_slip":
                continue
            for s_pct in (2.0, 3.0):
                fs, fd = (float(v) for v in friction_pct(s_pct, 1.0))
                sticky.append(_clean(loop, spec=replace(loop.spec, fs_pct=fs, fd_pct=fd), s_pct=s_pct, j_pct=1.0))
            linear = replace(loop.spec, fs_pct=0.0, fd_pct=0.0)
            period_s = WINDOW_SAMPLES * loop.every / 8
            for shape in ("sine", "triangle", "square"):
                external.append(_clean(loop, spec=linear, s_pct=0.0, j_pct=0.0, cause=shape, load_shape=shape,
                                       load_pct=2.0, load_period_s=period_s,
                                       load_filter_s=0.1 * period_s if shape != "sine" else 0.0))  # fmt: skip
    return sticky, external


def _called_when_cycling(detector, loops) -> list[bool]:
    called = []
    for rec in simulate_families(loops):
        if stable(rec):
            ev = evidence(rec.op, rec.pv, rec.ts_s, rec.sp)
            if ev.oscillation.oscillating:
                called.append(decide(detector, ev, []).verdict == "stiction")
    return called


def test_a_plant_scale_sticky_limit_cycle_is_called_and_an_external_cycle_of_the_same_loops_is_not(detector):
    """Without the cycle model the shipped detector called 19 of these 24 sticky cycles and 8 of the 72
    external ones."""
    assert detector.cycle is not None
    sticky, external = _hidden_cycles()
    called_sticky, called_external = _called_when_cycling(detector, sticky), _called_when_cycling(detector, external)
    assert len(called_sticky) >= 16 and len(called_external) >= 48  # most of them cycle regularly
    assert np.mean(called_sticky) >= 0.85, (sum(called_sticky), len(called_sticky))
    assert np.mean(called_external) <= 0.08, (sum(called_external), len(called_external))


def test_the_cycle_model_speaks_for_oscillating_windows_only(detector):
    x = np.random.default_rng(3).normal(size=(4, detector.stiction.mean.size))
    oscillating = np.array([True, False, True, False])
    p = detector.stiction_probability(x, None, oscillating)
    general = replace(detector, cycle=None).stiction_probability(x)
    cycle = detector.cycle.probabilities(x)[:, 1]
    assert np.allclose(p[~oscillating], general[~oscillating]) and np.allclose(p[oscillating], cycle[oscillating])
    assert np.allclose(detector.stiction_probability(x), general)  # nothing said of oscillation: the general model


def test_the_cycle_model_is_saved_and_a_file_without_it_still_loads(tmp_path, detector):
    path = tmp_path / "detector.json"
    detector.save(path)
    loaded = Detector.load(path)
    assert loaded.cycle is not None and np.allclose(loaded.cycle.weights, detector.cycle.weights)
    replace(detector, cycle=None).save(path)
    assert Detector.load(path).cycle is None

