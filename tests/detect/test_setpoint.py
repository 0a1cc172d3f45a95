"""The stuck setpoint step (``detect.setpoint``): a valve that sticks through an operator's
setpoint step is found; a valve that moves, with or without a deadband smaller than the step, is not."""


import numpy as np
import pytest

from stiction.detect.features import evidence
from stiction.detect.verdict import DETECTOR_FILE, STEP_AT, STICTION_AT, Detector, decide
from stiction.quantify.predictor import DEFAULT_MODELS_DIR

STEPS = ((0.3, 2.0), (0.65, -2.0))
"""The operator raises the setpoint by 2 % of span a third into the window and lowers it again later."""


def _flow_loop(fs_pct: float, seed: int, controller_gain: float, deadband_pct: float = 0.0, load_pct: float = 0.0):
    """The slow flow loop with the two setpoint steps; a sticky valve of fs ``fs_pct`` with fd 0.3 fs
    (S 2.5 %, J 1.75 % of span at fs 6)."""
    from tests.detect.loops import slow_flow_loop

    return slow_flow_loop(fs_pct, seed, fd_share=0.3, controller_gain=controller_gain, deadband_pct=deadband_pct,
                          load_pct=load_pct, sp_steps=STEPS)  # fmt: skip


@pytest.fixture(scope="module", autouse=True)
def _simulated_together():
    """Every loop of this module simulated in one vectorised run (``_flow_loop`` then reads them)."""
    from tests.detect.loops import slow_flow_loops

    common = dict(fd_share=0.3, sp_steps=STEPS)
    sticky = [dict(fs_pct=6.0, seed=s, controller_gain=g, **common) for s in range(3) for g in (0.2, 0.5)]
    moving = [dict(fs_pct=0.0, seed=s, controller_gain=g, deadband_pct=d, load_pct=0.3, **common)
              for s in range(3) for g in (0.2, 0.5) for d in (0.0, 1.0, 2.0)]  # fmt: skip
    slow_flow_loops(sticky + moving)


@pytest.fixture(scope="module")
def detector():
    return Detector.load(DEFAULT_MODELS_DIR / DETECTOR_FILE)


@pytest.mark.parametrize("controller_gain", [0.2, 0.5])
def test_a_valve_stuck_through_a_setpoint_step_is_found_and_named(detector, controller_gain):
    assert detector.step is not None and detector.step.probability >= STICTION_AT  # the test can call it alone
    for seed in range(3):
        op, pv, sp, ts_s = _flow_loop(6.0, seed, controller_gain)
        ev = evidence(op, pv, ts_s, sp)
        st = ev.stuck_step
        assert st is not None and st.travel_share >= STEP_AT
        assert st.step in {int(0.3 * op.size), int(0.65 * op.size)}  # at one of the hidden steps
        assert 1.25 <= st.travel <= 5.0  # OP travelled of the order of the band (2.5 %) before the valve moved
        v = decide(detector, ev, [])
        assert v.verdict == "stiction" and v.stiction_probability >= detector.step.probability
        assert "setpoint step" in v.stuck_valve


@pytest.mark.parametrize("controller_gain", [0.2, 0.5])
def test_a_moving_valve_follows_its_setpoint_steps_deadband_or_not(controller_gain):
    from tests.detect.loops import slow_flow_loops

    cases = [
        dict(fs_pct=0.0, seed=seed, fd_share=0.3, controller_gain=controller_gain, deadband_pct=deadband_pct,
             load_pct=0.3, sp_steps=STEPS)
        for seed in range(3)
        for deadband_pct in (0.0, 1.0, 2.0)
    ]  # fmt: skip
    for case, (op, pv, sp, ts_s) in zip(cases, slow_flow_loops(cases), strict=True):
        assert evidence(op, pv, ts_s, sp).stuck_step is None, (case["seed"], case["deadband_pct"])


def test_no_setpoint_record_or_a_cascades_moving_setpoint_speaks_for_nothing():
    op, pv, sp, ts_s = _flow_loop(6.0, 0, 0.5)
    assert evidence(op, pv, ts_s, None).stuck_step is None
    wandering = sp + np.random.default_rng(0).normal(0.0, 0.5, sp.size)  # a setpoint that moves every sample
    assert evidence(op, pv, ts_s, wandering).stuck_step is None
    assert evidence(op, pv, ts_s, np.full(sp.size, np.nan)).stuck_step is None  # a setpoint tag never recorded
    gappy = sp.copy()
    gappy[::7] = np.nan  # an archive with holes: the steps next to a hole are not read, nothing breaks
    st = evidence(op, pv, ts_s, gappy).stuck_step
    assert st is None or st.step in {int(0.3 * op.size), int(0.65 * op.size)}


def test_measured_the_sticky_flow_valve_sticks_through_setpoint_steps_its_healthy_neighbour_follows(measured_evidence):
    sticky = [ev.stuck_step for ev in measured_evidence("stic_2411FIC20102_*.csv")]
    healthy = [ev.stuck_step for ev in measured_evidence("*_2111FIC46002_*.csv")]
    assert sum(s is not None for s in sticky) >= len(sticky) // 2
    assert healthy and all(s is None for s in healthy)


def test_the_stuck_steps_travel_bounds_the_band_where_the_setpoint_is_known():
    from stiction.detect.features import stuck_travel

    for seed in range(3):
        op, pv, sp, ts_s = _flow_loop(6.0, seed, 0.5)
        step = evidence(op, pv, ts_s, sp).stuck_step
        with_sp, without = stuck_travel(op, pv, sp), stuck_travel(op, pv)
        assert with_sp >= without and with_sp == pytest.approx(max(without, step.travel))
        op, pv, sp, ts_s = _flow_loop(0.0, seed, 0.5, 1.0, load_pct=0.3)  # a moving valve: no step to add
        assert stuck_travel(op, pv, sp) == stuck_travel(op, pv)


def test_the_row_batch_finds_the_same_steps_as_one_window_at_a_time():
    """``stuck_steps_rows`` (the noise medians and OP's percentiles taken once for the batch) gives each row
    exactly what the window alone gives with numpy's per-row statistics (``reference.stuck_steps_alone``): sticky
    and moving valves, no setpoint, a setpoint that never moves, a cascade's, a gappy one, a flat OP (no range),
    and a window shorter than the setpoint."""
    from stiction.detect import setpoint
    from stiction.detect.features import _edges
    from tests.detect import reference

    windows = [_flow_loop(6.0, s, g) for s in range(3) for g in (0.2, 0.5)]
    windows += [_flow_loop(0.0, s, 0.5, d, load_pct=0.3) for s in range(2) for d in (0.0, 2.0)]
    flat_op = np.full(windows[0][0].size, 40.0)
    op = np.stack([w[0] for w in windows] + [windows[0][0], windows[1][0], windows[2][0], flat_op])
    pv = np.stack([w[1] for w in windows] + [windows[0][1], windows[1][1], windows[2][1], windows[3][1]])
    sp0 = windows[0][2]
    gappy = sp0.copy()
    gappy[::7] = np.nan
    wandering = sp0 + np.random.default_rng(0).normal(0.0, 0.5, sp0.size)
    sps = [w[2] for w in windows] + [None, np.full(sp0.size, sp0[0]), wandering, windows[3][2]]
    sps[1] = gappy
    sps[2] = sp0[:-3]  # a setpoint record that does not match the window: not read
    edges_op, edges_pv = _edges(op), _edges(pv)
    alone = [reference.stuck_steps_alone(edges_op[i], edges_pv[i], pv[i], sps[i]) for i in range(len(sps))]
    assert setpoint.stuck_steps_rows(edges_op, edges_pv, pv, sps) == alone
    assert [setpoint.stuck_steps(edges_op[i], edges_pv[i], pv[i], sps[i]) for i in range(len(sps))] == alone
    assert sum(bool(found) for found in alone) >= 3  # the comparison covers steps found, not only empty lists
    assert setpoint.stuck_steps_rows(edges_op[:0], edges_pv[:0], pv[:0], []) == []
