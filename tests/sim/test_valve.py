"""Valve physics: stuck stems, sticking, slips, He's model, actuator lag."""

from dataclasses import replace

import numpy as np

from stiction.sim.loop import LoopSpec, simulate
from stiction.sim.reference import IN_PER_PCT, RefState, reference_interval
from stiction.sim.valve import (
    VALVE,
    Friction,
    band_and_jump_pct,
    fault_kind,
    friction_pct,
    lagged_valve_step,
    pct_to_lbf,
    stop_residual_in,
    valve_step,
)


def test_stuck_stem_does_not_move_while_force_within_static_friction():
    rng = np.random.default_rng(0)
    fs_lbf = rng.uniform(10, 500, 1000)
    fd_lbf = fs_lbf * rng.uniform(0, 0.99, 1000)
    mv = rng.uniform(-20, 20, 1000)
    band_pct = fs_lbf / VALVE.lbf_per_pct
    drive = mv + rng.uniform(-1, 1, 1000) * band_pct  # |F| <= Fs
    slip = valve_step(drive, mv, Friction.physical(fs_lbf, fd_lbf))
    assert not slip.slipped.any()
    np.testing.assert_array_equal(slip.mv_pct, mv)
    np.testing.assert_array_equal(slip.deficit_pct_s, 0.0)


def test_reference_stem_moving_with_force_within_fs_sticks_at_zero_crossing():
    # moving up at 0.5 in/s, spring force pulls down but |F| <= Fs: it decelerates, crosses zero, sticks
    start = RefState(x_in=0.2, v_in_s=0.5, y_pct=0.0)
    op_pct = 0.2 / IN_PER_PCT  # F = 0 at x = 0.2 in
    end = reference_interval(start, op_pct, 0.0, fs_lbf=200.0, fd_lbf=100.0)
    assert end.v_in_s == 0.0
    assert 0.2 < end.x_in < 0.21
    again = reference_interval(end, op_pct, 0.0, fs_lbf=200.0, fd_lbf=100.0)
    assert again.x_in == end.x_in and again.v_in_s == 0.0


def test_reference_stem_crossing_zero_with_force_above_fs_breaks_away_backwards():
    start = RefState(x_in=0.0, v_in_s=0.5, y_pct=0.0)
    op_pct = -30.0  # F = -360 lbf < -Fs
    end = reference_interval(start, op_pct, 0.0, fs_lbf=200.0, fd_lbf=100.0)
    assert end.v_in_s == 0.0
    # slips back to where the force left is about -Fc
    force_end = 12.0 * (op_pct - end.x_in / IN_PER_PCT)
    assert -110.0 < force_end < -100.0


def test_slip_ends_at_dynamic_friction_plus_stop_residual():
    fs, fd = pct_to_lbf([60.0]), pct_to_lbf([20.0])
    slip = valve_step(np.array([40.0]), np.array([0.0]), Friction.physical(fs, fd))
    force_left = VALVE.lbf_per_pct * (40.0 - slip.mv_pct)
    residual_lbf = VALVE.spring_lbf_per_in * stop_residual_in(fs - fd)
    np.testing.assert_allclose(force_left, fd + residual_lbf)
    assert 0.0 < residual_lbf[0] < 0.1  # the Stribeck catch is a small fraction of a lbf
    assert force_left[0] < fs[0]  # so the stem stays stuck


def test_stop_residual_matches_reference_slips():
    for fs, fd in [(250.0, 100.0), (250.0, 240.0), (50.0, 0.0), (500.0, 10.0)]:
        op = (fs + 1.0) / 12.0
        ref = reference_interval(RefState(0.0, 0.0, 0.0), op, 0.0, fs, fd)
        residual_ref_in = (op * 12.0 - fd) / VALVE.spring_lbf_per_in - ref.x_in
        np.testing.assert_allclose(stop_residual_in(np.array([fs - fd]))[0], residual_ref_in, rtol=2e-3)


def test_he_model_matches_its_published_algorithm():
    """He et al. (2007): if |u - u_r| > fs: u_r = u - sign(u - u_r) fd, else hold."""
    rng = np.random.default_rng(3)
    op = np.cumsum(rng.normal(0, 2, 400))
    fs_op, fd_op = 5.0, 2.0
    expected, u_r = [], 0.0
    for u in op:
        if abs(u - u_r) > fs_op:
            u_r = u - np.sign(u - u_r) * fd_op
        expected.append(u_r)
    mv, got = np.zeros(1), []
    friction = Friction.he(np.array([fs_op]), np.array([fd_op]))
    for u in op:
        mv = valve_step(np.array([u]), mv, friction).mv_pct
        got.append(mv[0])
    np.testing.assert_allclose(got, expected)


def _kano_reference(op, s, j):
    """Kano et al. (2004)'s valve one sample at a time, as published: moving, the stem follows its input less
    (S - J) / 2 while the input keeps its direction; it sticks where the input stops or turns, at u_s, and moves
    again once the input is J beyond u_s the way it was going, or S the other way.  Starts moving upwards."""
    y, moving, d_move, u_prev = op[0] - (s - j) / 2, True, 1.0, op[0]
    u_s = d_s = 0.0
    out = [y]
    for u in op[1:]:
        v = np.sign(u - u_prev)
        if moving and v != d_move:
            moving, u_s, d_s = False, u_prev, d_move
        if not moving and (d_s * (u - u_s) > j or -d_s * (u - u_s) > s):
            moving, d_move = True, np.sign(u - u_s)
        if moving:
            y = u - d_move * (s - j) / 2
        out.append(y)
        u_prev = u
    return np.array(out)


def test_kano_model_matches_its_published_algorithm():
    """The valve that ``tracks`` (``kano``): He's fs, fd from S and J, carried along by an input that keeps moving."""
    rng = np.random.default_rng(4)
    op = 10.0 + np.cumsum(rng.normal(0.3, 1.0, 600))  # runs of rises and falls
    s_pct, j_pct = 3.0, 1.0
    expected = _kano_reference(op, s_pct, j_pct)
    friction = replace(Friction.he(np.array([(s_pct + j_pct) / 2]), np.array([(s_pct - j_pct) / 2])), tracks=True)
    mv, drive, got = np.zeros(1), np.zeros(1), []
    for u in op:
        mv = valve_step(np.array([u]), mv, friction, drive).mv_pct
        drive = np.array([u])
        got.append(mv[0])
    np.testing.assert_allclose(got, expected, atol=1e-9)
    moved = np.abs(np.diff(expected)) > 0
    assert np.sum(moved[1:] & moved[:-1]) > 50, "the input must carry the stem over runs, or the check is He's"
    assert np.sum(~moved) > 50, "and the stem must stick where the input turns"
    he = np.zeros(1)
    he_path = []
    for u in op:
        he = valve_step(np.array([u]), he, Friction.he(friction.fs_lbf, friction.stop_lbf)).mv_pct
        he_path.append(he[0])
    assert np.max(np.abs(np.array(he_path) - expected)) > 0.5, "He's valve sticks again within a run: not the same"


def test_band_and_jump_for_this_valve():
    s, j = band_and_jump_pct(60.0, 20.0)
    np.testing.assert_allclose([s, j], [400.0 / 12.0, 200.0 / 12.0])
    np.testing.assert_allclose(friction_pct(s, j), [60.0, 20.0])


def _reversal_travels_pct(op: np.ndarray, mv: np.ndarray) -> np.ndarray:
    """OP's travel from its extreme after each stem move until the stem moves back (a reversal).

    The stem can only break away at a sample: the travel is taken halfway between the last sample
    it stayed and the one it moved (a bracket of one OP step)."""
    step = np.diff(mv)
    moves = np.flatnonzero(np.abs(step) > 1e-9)
    out = []
    for a, b in zip(moves[:-1], moves[1:], strict=True):
        d = np.sign(step[a])
        if np.sign(step[b]) != -d:
            continue
        extreme = a + int(np.argmax(d * op[a : b + 1]))
        before = abs(op[b - 1] - op[extreme]) if b - 1 >= extreme else 0.0
        out.append(0.5 * (before + abs(op[b] - op[extreme])))
    return np.array(out)


def test_band_is_the_op_travel_after_a_reversal_before_the_stem_moves():
    """Choudhury's S measured on the canonical loop as a valve travel test reads it, and J as the
    smallest slip (one that starts just past the band; later ones overshoot by OP's last step)."""
    grid = [(fs, fd) for fs in (10.0, 30.0, 55.0, 80.0, 100.0) for fd in (0.1 * fs, 0.5 * fs, 0.9 * fs)]
    r = simulate([LoopSpec(fs, fd) for fs, fd in grid], duration_s=4000.0).kept()
    s_err, j_err = [], []
    for i, (fs, fd) in enumerate(grid):
        s, j = band_and_jump_pct(fs, fd)
        travels = _reversal_travels_pct(r.op[i], r.mv[i])
        assert travels.size >= 10, (fs, fd)
        s_err.append(np.median(travels) / s - 1)
        jumps = np.abs(np.diff(r.mv[i]))
        j_err.append(jumps[jumps > 1e-9].min() / j - 1)
    assert abs(np.median(s_err)) < 0.03 and np.max(np.abs(s_err)) < 0.05, s_err
    assert abs(np.median(j_err)) < 0.03 and np.max(np.abs(j_err)) < 0.05, j_err
    # the static band alone (fs / 12, the convention before) is far from what a travel test measures
    static = [fs / 12 * 5 for fs, _ in grid]
    assert np.median([np.median(_reversal_travels_pct(r.op[i], r.mv[i])) / static[i] for i in range(len(grid))]) > 1.3


def _lagged_by_substeps(p0, op, tau, mv, friction, n=50000):
    """Simple reference: the drive sampled finely, the constant-drive step applied at each sub-step.

    Each slip is found up to one sub-step late; returns the end MV, the mean MV
    and that lateness bound in percent of drive travel.
    """
    t = (np.arange(n) + 1) / n
    total = np.zeros_like(mv)
    slips = np.zeros_like(mv)
    for ti in t:
        drive = op + (p0 - op) * np.exp(-ti / tau)
        slip = valve_step(drive, mv, friction)
        mv, slips = slip.mv_pct, slips + slip.slipped
        total += mv
    lateness = (slips + 1) * np.abs(op - p0) / tau / n
    return mv, total / n, lateness


def test_lagged_drive_matches_fine_substepping():
    rng = np.random.default_rng(5)
    n = 200
    fs = rng.uniform(20, 400, n)
    fd = fs * rng.uniform(0, 0.9, n)
    friction = Friction.he(fs / 12, fd / 12)  # instant slips, so sub-stepping converges to the exact answer
    p0 = rng.uniform(-5, 5, n)
    mv = p0 - rng.uniform(-1, 1, n) * fs / 12  # stuck at the start
    op = p0 + rng.normal(0, 30, n)
    tau = rng.uniform(0.2, 5, n)
    slip, drive_end = lagged_valve_step(p0, op, tau, 1.0, mv, friction)
    np.testing.assert_allclose(drive_end, op + (p0 - op) * np.exp(-1.0 / tau))
    mv_ref, mean_ref, lateness = _lagged_by_substeps(p0, op, tau, mv, friction)
    # where the end of the drive's travel lies within the reference's lateness of a threshold, the
    # reference may miss the last slip: leave those few loops out
    step = (fs - fd) / 12
    gap_to_threshold = np.abs(slip.mv_pct - mv_ref)
    clear = ~((gap_to_threshold > 1e-6) & (np.abs(gap_to_threshold - step) < 1e-6 + lateness))
    assert clear.mean() > 0.95
    assert np.all(gap_to_threshold[clear] <= lateness[clear] + 1e-9)
    # the stair after the first slip is integrated as its mean line: within half a step on average
    mean_fast = slip.mv_pct - slip.deficit_pct_s
    assert np.all(np.abs(mean_fast - mean_ref)[clear] <= 0.5 * step[clear] + 0.01)


def test_the_kind_of_fault_is_named_only_where_j_and_its_error_tell():
    assert fault_kind(4.0, 1.0, 0.2) == "stick_slip"  # J surely above zero
    assert fault_kind(4.0, 0.1, 0.3) == "deadband"  # J surely below a quarter of S
    assert fault_kind(4.0, 0.5, 0.5) is None  # could be either
    assert fault_kind(None, 0.5, 0.1) is None and fault_kind(4.0, 0.5, None) is None and fault_kind(0.0, 0, 0) is None


def test_a_lagged_slip_withholds_flow_the_same_way_up_and_down():
    """A slip's interval passes the old position until the break and the new one after it, less the
    flow the moving stem withholds: the flow lies between the two positions, and a mirrored interval
    (every position negated) gives the mirrored flow.  A downward slip once added the withheld flow
    beyond the new position instead (an actuator-lag loop's PV a hair off on every second slip)."""
    rng = np.random.default_rng(11)
    n = 400
    fs = rng.uniform(20, 400, n)
    fd = fs * rng.uniform(0, 0.9, n)
    friction = Friction.physical(fs, fd)
    p0 = rng.uniform(-5, 5, n)
    mv = p0 - rng.uniform(-1, 1, n) * fs / 12
    op = p0 + rng.normal(0, 30, n)
    tau = rng.uniform(0.2, 8, n)
    up, _ = lagged_valve_step(p0, op, tau, 1.0, mv, friction)
    down, _ = lagged_valve_step(-p0, -op, tau, 1.0, -mv, friction)
    np.testing.assert_allclose(down.mv_pct, -up.mv_pct, atol=1e-9)
    np.testing.assert_allclose(down.deficit_pct_s, -up.deficit_pct_s, atol=1e-9)
    moved = up.slipped & (np.abs(up.mv_pct - mv) > 1e-6)
    assert moved.sum() > 50
    for r, start in ((up, mv), (down, -mv)):
        flow, d = r.mv_pct - r.deficit_pct_s, np.sign(r.mv_pct - start)
        assert np.all(d[moved] * (r.mv_pct - flow)[moved] > 0)  # short of the new position, never past it
