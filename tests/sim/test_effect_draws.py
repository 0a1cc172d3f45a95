"""The diagnose benchmark's loops: each effect drawn within the ranges named, the catalogue's or the wide ones."""

import pytest

from stiction.sim.grid import DRAWS, EFFECT_RANGES, WIDE_EFFECT_RANGES, effect_loops


@pytest.mark.parametrize("draws", sorted(DRAWS))
def test_every_effect_is_drawn_within_its_ranges_and_outside_the_nominal_gain(draws):
    for cause, ranges in DRAWS[draws].items():
        for spec in effect_loops(cause, 12, 3, draws=draws):
            active = spec.extensions.active()
            assert set(active) == set(ranges), (cause, active)
            for name, (lo, hi) in ranges.items():
                assert lo <= active[name] <= hi, (draws, cause, name, active[name])
            if cause == "process_gain":
                assert not 0.8 < active["gain_ratio"] < 1.25


def test_the_wide_draws_reach_past_the_catalogues_at_the_hard_ends():
    for cause, wide in WIDE_EFFECT_RANGES.items():
        for name, (lo, hi) in wide.items():
            c_lo, c_hi = EFFECT_RANGES[cause][name]
            assert lo <= c_lo and hi >= c_hi and (lo, hi) != (c_lo, c_hi), (cause, name)
    small = [s.extensions.active()["dead_time_s"] for s in effect_loops("dead_time", 40, 1, draws="wide")]
    assert min(small) < 1.0  # below the catalogue's smallest, where naming is hardest


def test_unknown_draws_are_named():
    with pytest.raises(ValueError, match="draws 'narrow'"):
        effect_loops("dead_time", 1, 1, draws="narrow")
