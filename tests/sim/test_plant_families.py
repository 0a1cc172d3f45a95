"""The families' sticky valves at the two band scales: the same loops but for their bands, and the
plant-scale bands are the gaps their stems break at."""

from dataclasses import replace

import numpy as np
import pytest

from stiction.sim.loop import build_batch, run_batch
from stiction.sim.plant_families import (
    FAULT_EVENTS,
    FAULTS,
    PLANT_BAND_PCT,
    VISIBLE_EFFECT,
    family_loops,
    healthy,
    simulate_families,
)


def test_plant_scale_bands_are_drawn_over_the_plant_range_and_the_thesis_scale_is_wider():
    plant = [loop for loop in family_loops(8, 5, bands="plant") if loop.cause in ("stick_slip", "he")]
    thesis = [loop for loop in family_loops(8, 5, bands="thesis") if loop.cause in ("stick_slip", "he")]
    s_plant = np.array([loop.s_pct for loop in plant])
    s_thesis = np.array([loop.s_pct for loop in thesis])
    assert np.all((s_plant >= PLANT_BAND_PCT[0]) & (s_plant <= PLANT_BAND_PCT[1]))
    assert np.median(s_plant) < 0.5 * np.median(s_thesis) and s_thesis.min() >= 4.0
    assert all(0 < loop.j_pct < loop.s_pct for loop in plant)


def test_both_band_scales_give_the_same_loops_but_for_the_valves_bands():
    plant, thesis = family_loops(3, 9, bands="plant"), family_loops(3, 9, bands="thesis")
    assert [(a.family, a.cause) for a in plant] == [(b.family, b.cause) for b in thesis]
    for a, b in zip(plant, thesis, strict=True):
        assert a.spec.process == b.spec.process and a.spec.seed == b.spec.seed and a.sp_steps == b.sp_steps
        assert (a.noise_pct, a.load_pct, a.load_period_s) == (b.noise_pct, b.load_pct, b.load_period_s)
        if a.cause not in FAULTS:
            assert a.s_pct == b.s_pct == 0.0


def test_a_plant_scale_valve_breaks_away_at_half_its_band_and_slip():
    """The physical valve's stem breaks away when OP is (S + J)/2 from it: the bands drawn in % of span
    reach the valve as the friction that makes them."""
    loops = [loop for loop in family_loops(4, 13, bands="plant") if loop.cause == "stick_slip"]
    w = np.zeros((len(loops), 3000))
    op, _, mv = run_batch(build_batch([loop.spec for loop in loops]), w, np.zeros_like(w))
    checked = 0
    for i, loop in enumerate(loops):
        moving = np.abs(np.diff(mv[i])) > 1e-6
        breaks = np.flatnonzero(moving[1:] & ~moving[:-1]) + 1
        if breaks.size < 3:  # a slow loop that did not cycle in 3000 s
            continue
        gap = np.median(np.abs(op[i, breaks] - mv[i, breaks]))
        static = (loop.s_pct + loop.j_pct) / 2
        # the stem is seen to move a sample after OP passed the break-away point: up to one OP step late
        late = np.median(np.abs(op[i, breaks] - op[i, breaks - 1]))
        assert 0.97 * static <= gap <= 1.03 * static + late, (loop.family, static, gap, late)
        checked += 1
    assert checked >= len(loops) // 2


def test_an_unknown_band_scale_is_named():
    with pytest.raises(ValueError, match="bands 'huge'"):
        family_loops(1, 1, bands="huge")


def test_a_faults_effect_is_pv_against_the_same_loop_with_a_healthy_valve():
    """The label's effect, computed beside many loops in one batch, equals the loop simulated alone
    against its healthy twin simulated alone (the same loads, noise and setpoint moves)."""
    loops = [
        loop
        for loop in family_loops(2, 21, bands="plant")
        if loop.fault and loop.quantum_pct == 0 and loop.compression_pct == 0
    ][:6]
    batch = simulate_families(loops)
    for loop, rec in zip(loops, batch, strict=True):
        (alone,) = simulate_families([loop])
        (twin,) = simulate_families([replace(loop, cause="noise", spec=healthy(loop.spec))])
        expected = np.sqrt(np.mean((alone.pv - twin.pv) ** 2)) / loop.noise_pct
        assert rec.effect_noise == pytest.approx(expected, rel=1e-9, abs=1e-12)
        assert twin.effect_noise == 0.0 and not twin.shows_fault


def test_a_stem_that_slips_under_noise_that_hides_it_is_no_fault_the_window_shows():
    """The same sticky flow valve, exercised either way: under its own noise the slips change PV by more
    than the noise (a fault shown); under thirty times the noise the stem slips hundreds of times but
    the record is the healthy valve's within the noise, and is labelled healthy-looking."""
    loops = [loop for loop in family_loops(3, 11, ("flow",), bands="plant") if loop.cause == "stick_slip"]
    shown = []
    for loop in loops:
        quiet, loud = simulate_families([loop, replace(loop, noise_pct=30 * loop.noise_pct)])
        assert loud.stuck_events >= FAULT_EVENTS and loud.effect_noise < VISIBLE_EFFECT and not loud.shows_fault
        shown.append(quiet.shows_fault)
        assert quiet.shows_fault == (quiet.stuck_events >= FAULT_EVENTS and quiet.effect_noise >= VISIBLE_EFFECT)
    assert any(shown)


def test_kanos_stems_follow_op_between_sticks_where_hes_stick_after_every_slip():
    """The ``kano`` cause's valve keeps moving with OP once it slipped; He's (and the physical valve) stick at
    the end of every slip: without loads or noise, the stems' moves on consecutive samples tell them apart."""
    runs = {}
    for cause in ("he", "kano"):
        loops = [loop for loop in family_loops(4, 13, bands="plant") if loop.cause == cause]
        assert all(loop.spec.valve == cause for loop in loops)
        w = np.zeros((len(loops), 2000))
        _, _, mv = run_batch(build_batch([loop.spec for loop in loops]), w, np.zeros_like(w))
        moved = np.abs(np.diff(mv[:, 1000:], axis=1)) > 1e-9
        runs[cause] = (np.sum(moved[:, 1:] & moved[:, :-1], axis=1), moved.sum(axis=1))
    assert np.all(runs["he"][0] == 0) and runs["he"][1].sum() > 0
    together, moves = runs["kano"]
    assert np.sum((moves > 10) & (together > moves / 2)) >= 4, runs["kano"]


def test_a_detuned_loop_started_at_its_operating_point_is_recorded_in_operation_where_from_rest_it_climbs():
    """A controller 3-20 times slower than its process asks takes many windows to bring a loop from rest to its
    setpoint: from rest (the shipped models' training), most detuned windows still climb towards SP; started at
    their operating point, every one is recorded in operation around it."""
    loops = [loop for loop in family_loops(4, 17, ("detuned",), bands="plant") if loop.cause in ("noise", "sine")]
    at_sp = simulate_families(loops, start="operating_point")
    off = np.array([abs(np.mean(r.pv[:100] - r.sp[:100])) for r in at_sp])
    assert np.all(off < 3.0), off
    assert np.all(np.array([np.ptp(r.pv) for r in at_sp]) < 20.0)
    from_rest = simulate_families(loops)
    off_rest = np.array([abs(np.mean(r.pv[:100] - r.sp[:100])) for r in from_rest])
    assert np.mean(off_rest > 3.0) > 0.5, off_rest


def test_both_starts_give_every_other_loop_as_it_runs_settled_and_the_others_as_from_rest():
    """The mixed start against the two plain ones run on their own (a simple reference): each loop's record, and the
    effect its fault had on PV against the healthy twin, is the one its own start gives."""
    loops = family_loops(3, 23, ("detuned", "flow"), bands="plant")
    loops = [loop for loop in loops if loop.cause in ("noise", "sine")]
    loops += [loop for loop in family_loops(2, 29, ("level",), bands="plant") if loop.fault][:4]
    mixed = simulate_families(loops, start="both")
    plain = {start: simulate_families(loops, start=start) for start in ("rest", "operating_point")}
    for i, rec in enumerate(mixed):
        ref = plain["operating_point" if i % 2 else "rest"][i]
        np.testing.assert_array_equal(rec.op, ref.op)
        np.testing.assert_array_equal(rec.pv, ref.pv)
        assert (rec.stuck_events, rec.effect_noise) == (ref.stuck_events, ref.effect_noise)


def test_an_unknown_start_is_named():
    with pytest.raises(ValueError, match="start 'cold'"):
        simulate_families(family_loops(1, 1, ("flow",)), start="cold")
