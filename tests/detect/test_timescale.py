"""The record's time scale and the sampling the verdict reads it at (``detect.timescale``)."""

from dataclasses import replace

import numpy as np
import pytest

from stiction.detect.timescale import (
    HALF_AT,
    HALF_LIFE_MAX,
    WINDOW_SAMPLES,
    half_life,
    thinned,
    verdict_steps,
)


def _reference_half_life(pv: np.ndarray) -> float:
    """The definition, sample by sample: PV median-filtered over 5 samples (the ends over what the window holds),
    its least-squares line removed, and the first lag whose autocorrelation falls below ``HALF_AT``."""
    n = pv.size
    y = np.array([np.median(pv[max(0, i - 2) : i + 3]) for i in range(n)])
    t = np.arange(n, dtype=float)
    y = y - np.polyval(np.polyfit(t, y, 1), t)
    a0 = float(y @ y)
    if a0 <= 0:
        return float("nan")
    for lag in range(n // 2):
        if float(y[: n - lag] @ y[lag:]) < HALF_AT * a0:
            return float(lag)
    return float(n // 2)


def test_the_half_life_is_its_definition():
    rng = np.random.default_rng(5)
    rows = []
    for period, noise in ((40.0, 0.1), (300.0, 0.5), (900.0, 0.05), (12.0, 1.0)):
        t = np.arange(1500)
        rows.append(np.sin(2 * np.pi * t / period) + noise * rng.standard_normal(t.size) + 0.001 * t)
    rows.append(np.cumsum(rng.standard_normal(1500)))
    fast = half_life(np.stack(rows))
    assert fast == pytest.approx([_reference_half_life(r) for r in rows])
    assert np.isnan(half_life(np.full((1, 800), 3.0))[0])


def test_only_a_long_slow_record_is_thinned():
    t = np.arange(3600)
    rng = np.random.default_rng(1)
    slow = np.sin(2 * np.pi * t / 1200) + 0.05 * rng.standard_normal(t.size)
    fast = np.sin(2 * np.pi * t / 60) + 0.05 * rng.standard_normal(t.size)
    steps = verdict_steps(np.stack([slow, fast]))
    assert steps[1] == 1
    assert 2 <= steps[0] <= 3600 // WINDOW_SAMPLES
    assert half_life(thinned(slow, int(steps[0]))[None])[0] < HALF_LIFE_MAX  # as slow as the training windows
    assert verdict_steps(slow[-1000:][None])[0] == 1  # an agent's window: too short to thin
    assert thinned(np.arange(10), 3).tolist() == [0, 3, 6, 9]
    assert thinned(np.arange(11), 3).tolist() == [1, 4, 7, 10]  # the newest sample kept


def _log_odds(p: np.ndarray) -> np.ndarray:
    p = np.clip(p, 1e-3, 1 - 1e-3)
    return np.log(p / (1 - p))


def test_a_loop_recorded_five_times_faster_reads_as_at_its_usual_sampling():
    """Hidden effect: the historian's sample time against the loop's pace.  The families' slow, level and
    detuned loops (design seed 3234, neither compressed nor stepped) recorded every 1-12 s where the families
    record them every 5-60 s: 3,000 samples over the same span.  Read at every sample, the verdict's log-odds
    moved by 0.9-1.0 in median from the same loop's usual record (seeds 3234 and 3235); read thinned, 0.4-0.5."""
    from stiction.quantify.pipeline import Quantifier
    from stiction.quantify.window import Window
    from stiction.sim.plant_families import family_loops, simulate_families, stable

    loops = [
        loop
        for loop in family_loops(3, 3234, families=("slow", "level", "detuned"), bands="plant")
        if loop.every in (5, 10, 30, 60) and loop.compression_pct == 0 and loop.quantum_pct == 0
    ]

    def records(batch, samples):
        out = [None] * len(batch)
        for every in {loop.every for loop in batch}:
            idx = [i for i, loop in enumerate(batch) if loop.every == every]
            simulated = simulate_families([batch[i] for i in idx], samples=samples, start="operating_point")
            for i, rec in zip(idx, simulated, strict=True):
                out[i] = rec
        return out

    usual = records(loops, WINDOW_SAMPLES)
    fast = records([replace(loop, every=loop.every // 5) for loop in loops], 5 * WINDOW_SAMPLES)
    keep = [i for i in range(len(loops)) if stable(usual[i]) and stable(fast[i])]
    assert len(keep) >= 25
    q = Quantifier(fit_valve=False)

    def probabilities(recs):
        reports = q.quantify([Window(f"w{i}", recs[i].op, recs[i].pv, recs[i].ts_s, sp=recs[i].sp) for i in keep])
        p = [np.nan if r.stiction_probability is None else r.stiction_probability for r in reports]
        return np.array(p), reports

    p_usual, _ = probabilities(usual)
    p_fast, reports = probabilities(fast)
    assert np.nanmedian(np.abs(_log_odds(p_usual) - _log_odds(p_fast))) < 0.7
    said = ["one sample in" in " ".join(r.warnings) for r in reports]
    assert 0 < sum(said) < len(said)  # a record as fast as the families' is read as it is
