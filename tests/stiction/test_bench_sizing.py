"""``stiction bench sizing``'s loops: the sticky loops of either simulator, with the S and J they were given."""

import pytest

from stiction.bench.sizing import _items


def test_the_independent_simulators_loops_are_the_sticky_ones_whose_record_shows_the_fault():
    from stiction.sim import two_parameter

    items = _items("two_parameter", 4, 2030)
    loops = [loop for loop in two_parameter.draw(4, 2030) if loop.cause in ("stiction", "backlash")]
    records = two_parameter.simulate(loops)
    shown = [(loop.s_pct, loop.j_pct) for loop, rec in zip(loops, records, strict=True) if rec.shows_fault]
    # backlash (J = 0) among them: a valve fault by the report's definition (spec/interfaces.md)
    hidden = {(loop.s_pct, loop.j_pct) for loop, rec in zip(loops, records, strict=True) if not rec.shows_fault}
    read = {(s, j) for s, j, _, _ in items}
    assert read and read <= set(shown) and not read & hidden and any(j == 0 for _, j in read)
    for _, _, _, (op, pv, sp, ts_s) in items:
        assert op.shape == pv.shape == sp.shape and ts_s in two_parameter.SAMPLE_TIMES_S
    with pytest.raises(ValueError, match="one of plant, two_parameter, families"):
        _items("thesis", 1, 1)


def test_the_bench_names_each_reason_a_band_was_withheld_as_the_report_gives_it():
    from stiction.bench.sizing import _reason
    from stiction.ident.friction import Friction
    from stiction.ident.trust import band_bound, dragged
    from stiction.sim.valve import PCT_OF_500LBF_PER_PCT_OF_SPAN

    # the dragged valve's warning speaks of slips too, and so does the stop held at its bound: neither is counted as
    # too few of them
    assert _reason(dragged(0, 1500, 2000)) == "a dragged valve: no stuck phase"
    nan = float("nan")
    pinned = Friction(3.0, 3.0, nan, nan, 3.0 * PCT_OF_500LBF_PER_PCT_OF_SPAN, 0.0, 0.5, nan, 20)
    assert _reason(band_bound(pinned)) == "S, J not separable"
    assert _reason("1 slip(s) read in the record: too few to bracket the band") == "too few slips"
    assert _reason(None) == "other"


def test_the_families_loops_are_their_faults_whose_record_shows_them():
    from stiction.bench.sizing import FAMILY_SAMPLES
    from stiction.sim.plant_families import FAULTS, family_loops, simulate_families

    loops = [loop for loop in family_loops(1, 2030) if loop.cause in FAULTS]
    records = simulate_families(loops, samples=FAMILY_SAMPLES)
    shown = {(loop.s_pct, loop.j_pct) for loop, rec in zip(loops, records, strict=True) if rec.shows_fault}
    hidden = {(loop.s_pct, loop.j_pct) for loop, rec in zip(loops, records, strict=True) if not rec.shows_fault}
    items = _items("families", 1, 2030)
    read = {(s, j) for s, j, _, _ in items}
    assert read and read <= shown and not read & hidden
    for _, _, every, (op, pv, _, ts_s) in items:
        assert op.shape == pv.shape == (FAMILY_SAMPLES,) and every >= 1 and ts_s > 0
