"""The data checks of a batch of windows (``data_checks_rows``, which screens clean rows out together)
against the checks of each window alone, on windows that trip every check and on clean ones."""

from __future__ import annotations

import re

import numpy as np

from stiction.ident.checks import data_checks, data_checks_rows


def _windows(n: int = 400) -> tuple[np.ndarray, np.ndarray, list[str]]:
    rng = np.random.default_rng(3)
    t = np.arange(n)
    clean_op = 50 + 5 * np.sin(t / 20) + rng.normal(0, 0.3, n)
    clean_pv = 40 + 2 * np.sin(t / 20 - 1) + rng.normal(0, 0.1, n)
    rows = {"clean": (clean_op, clean_pv)}
    rows["flat_pv"] = (clean_op, np.full(n, 3.5e-44))
    frozen = clean_pv.copy()
    frozen[100 : 100 + n // 2 + 5] = frozen[100]
    rows["frozen_pv"] = (clean_op, frozen)
    almost = clean_pv.copy()
    almost[100 : 100 + n // 2 - 5] = almost[100]  # a run just short of half the window: no check
    rows["almost_frozen"] = (clean_op, almost)
    rows["stepped_pv"] = (clean_op, np.where(np.sin(t / 20) > 0, 41.0, 39.0) + (t % 50 == 0))
    rows["three_values"] = (clean_op, np.choose(t % 3, [1.0, 2.0, 3.0]))
    rows["four_values"] = (clean_op, np.choose(t % 4, [1.0, 2.0, 3.0, 4.0]))
    rows["manual"] = (np.full(n, 42.0), clean_pv)
    rows["saturated_op"] = (np.minimum(clean_op, 53.0), clean_pv)
    rows["saturated_low"] = (np.maximum(clean_op, 47.0), clean_pv)
    rows["held_op"] = (np.repeat(clean_op[::20], 20)[:n], clean_pv)
    rows["held_and_clipped"] = (np.clip(np.repeat(clean_op[::10], 10)[:n], 46, 54), clean_pv)
    kept = np.r_[np.arange(0, n, 8), n - 1]
    rows["compressed_pv"] = (clean_op, np.interp(t, kept, clean_pv[kept]))
    rows["compressed_op"] = (np.interp(t, kept, clean_op[kept]), clean_pv)
    names = list(rows)
    op = np.stack([rows[k][0] for k in names])
    pv = np.stack([rows[k][1] for k in names])
    return op, pv, names


def test_a_batch_is_checked_as_each_window_alone():
    op, pv, names = _windows()
    got = data_checks_rows(op, pv)
    for i, name in enumerate(names):
        assert got[i] == data_checks(op[i], pv[i]), name
    fired = {name: [c.name for c in got[i]] for i, name in enumerate(names)}
    # every check is tripped somewhere in the batch, and the clean windows trip none
    assert {c for cs in fired.values() for c in cs} >= {
        "flat_pv", "frozen_pv", "stepped_pv", "manual", "saturated_op", "held_op", "compressed_pv", "compressed_op",
    }  # fmt: skip
    assert fired["clean"] == [] and fired["almost_frozen"] == [] and fired["four_values"] == []


def test_random_batches_agree_with_the_row_by_row_checks():
    rng = np.random.default_rng(11)
    for _ in range(20):
        w, n = 30, int(rng.integers(20, 300))
        op = np.round(rng.normal(50, 5, (w, n)), int(rng.integers(0, 3)))  # rounding: repeats and plateaus
        pv = np.round(rng.normal(40, 1, (w, n)), int(rng.integers(0, 3)))
        op[::3] = np.clip(op[::3], 48, 52)
        pv[::4, : n // 2] = pv[::4, :1]
        got = data_checks_rows(op, pv)
        assert got == [data_checks(op[i], pv[i]) for i in range(w)]


def test_a_pv_frozen_while_op_winds_one_way_names_a_valve_that_does_not_move_beside_the_sensor():
    n = 600
    t = np.arange(n)
    pv = np.r_[np.linspace(0.3, 0.0, 100), np.zeros(n - 100)]  # a flow that fell to nothing and stayed there
    ramp = 5 + 0.1 * t + np.random.default_rng(2).normal(0, 0.2, n)  # winding up, 50 % of span, with noise
    (frozen,) = [c for c in data_checks(ramp, pv) if c.name == "frozen_pv"]
    assert frozen.blocks and "a valve that does not move at all" in frozen.message
    assert "a sensor or archive that stopped updating" in frozen.message and "cannot tell which" in frozen.message
    # OP that wanders both ways over the same frozen PV: no reason to think of the valve
    wander = 50 + 10 * np.sin(t / 30)
    (frozen,) = [c for c in data_checks(wander, pv) if c.name == "frozen_pv"]
    assert "valve" not in frozen.message and "a sensor or archive that stopped updating" in frozen.message


def test_a_historians_compressed_archive_is_named_with_its_factor_and_the_raw_record_is_not():
    """Thornhill, Choudhury & Shah (2004): a record stored as straight lines between values kept when they moved by
    more than a deadband (``sim.plant_families.compress``) misleads oscillation and nonlinearity tests.  The same
    loop's record raw, rounded as an export rounds it, or held between changes, is not called compressed."""
    from stiction.ident.checks import compression_factor
    from stiction.sim.plant_families import compress

    rng = np.random.default_rng(5)
    n = 600
    t = np.arange(n)
    op = 50 + 4 * np.sin(t / 30) + np.cumsum(rng.normal(0, 0.05, n))
    pv = 40 + 2 * np.sin(t / 30 - 1) + rng.normal(0, 0.05, n)
    stored = compress(pv, 0.5)
    (check,) = [c for c in data_checks(op, stored) if c.name == "compressed_pv"]
    assert not check.blocks and "compressed archive" in check.message and "without noise" in check.message
    assert compression_factor(stored) >= 3
    assert compression_factor(pv) < 1.1 and compression_factor(np.round(pv, 3)) < 1.1
    assert compression_factor(np.repeat(pv[::10], 10)) < 1.1  # held, not interpolated: held_op's and frozen's
    assert not [c for c in data_checks(op, np.round(pv, 6)) if c.name.startswith("compressed")]


def test_a_record_whose_op_is_a_compressed_archive_gets_no_verdict_and_its_raw_record_does():
    """OP in straight lines is an archive (no controller writes it so): the verdict, which reads such records little
    better than chance, is not given (bad_data, naming the archive); the same loop raw, and a record whose PV alone
    runs straight (a noise-free simulation's integrating PV), are read."""
    from stiction.ident.checks import COMPRESSED_FACTOR, compression_factor
    from stiction.quantify.pipeline import Quantifier, Window
    from stiction.sim.plant_families import compress
    from stiction.sim.plant_loops import plant_loops, simulate_plant, stable

    loops = [loop for loop in plant_loops(3, 7) if loop.cause in ("stiction", "external_oscillation")]
    made = [(op, pv) for op, pv, _, _ in simulate_plant(loops, 0.5, 1000) if stable(op, pv)]
    assert len(made) >= 4
    windows = []
    for i, (op, pv) in enumerate(made):
        stored_op, stored_pv = compress(op, 0.2 * float(np.ptp(op))), compress(pv, 0.2 * float(np.ptp(pv)))
        assert compression_factor(stored_op) >= COMPRESSED_FACTOR > compression_factor(op)
        windows += [Window(f"raw-{i}", op, pv), Window(f"archive-{i}", stored_op, stored_pv),
                    Window(f"pv-only-{i}", op, stored_pv)]  # fmt: skip
    reports = {r.loop_id: r for r in Quantifier().quantify(windows)}
    for i in range(len(made)):
        archive = reports[f"archive-{i}"]
        assert archive.verdict == "bad_data" and archive.stiction_probability is None
        assert "compressed_op" in archive.checks and any("compressed archive" in w for w in archive.warnings)
        for kind in ("raw", "pv-only"):
            assert reports[f"{kind}-{i}"].verdict != "bad_data" and "compressed_op" not in reports[f"{kind}-{i}"].checks


def test_a_pv_that_never_moves_while_op_winds_one_way_names_the_stuck_shut_valve_as_well_as_the_sensor():
    """Flat or frozen, a PV that stays put while OP travels far one way may be a valve stuck shut as much as a dead
    transmitter: the message says both and picks neither; OP that only wanders names the sensor alone."""
    n = 400
    rng = np.random.default_rng(5)
    winding = np.linspace(20.0, 45.0, n) + rng.normal(0, 0.2, n)  # +25 % one way
    wandering = 30 + 5 * np.sin(np.arange(n) / 20) + rng.normal(0, 0.2, n)
    flat = np.full(n, 3.5e-44)  # a flow transmitter reading zero
    frozen = 40 + rng.normal(0, 0.1, n)
    frozen[50:] = frozen[50]

    def message(op, pv):
        (check,) = [c for c in data_checks(op, pv) if c.name in ("flat_pv", "frozen_pv")]
        return check.message

    for pv in (flat, frozen):
        assert "stuck, or shut" in message(winding, pv) and "transmitter" in message(winding, pv)
        travel = float(re.search(r"OP moved ([+-][\d.]+) % one way", message(winding, pv)).group(1))
        assert 20.0 <= travel <= 26.0  # OP's net travel over the still stretch (from sample 50 for the frozen PV)
        assert "stuck" not in message(wandering, pv)
    assert "dead or disconnected sensor" in message(wandering, flat)
    assert "stopped updating" in message(wandering, frozen)
