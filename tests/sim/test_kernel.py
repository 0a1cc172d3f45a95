"""The compiled record (``sim.kernel``, behind ``run_batch``) against its definition, ``advance`` repeated."""

from dataclasses import replace

import numpy as np
import pytest

from stiction.sim.extensions import Extensions
from stiction.sim.grid import case_specs
from stiction.sim.loop import LoopState, advance, build_batch, run_batch

EXTENSIONS = {
    "canonical": Extensions(),
    "dead time of whole samples": Extensions(dead_time_s=3.0),
    "dead time between samples": Extensions(dead_time_s=2.5),
    "deadband": Extensions(deadband_pct=1.0),
    "slow actuator": Extensions(actuator_tau_s=4.0),
    "fast actuator": Extensions(actuator_tau_s=0.3),
    "sensor lag": Extensions(sensor_tau_s=5.0),
    "self-regulating": Extensions(time_constant_s=40.0),
    "all at once": Extensions(deadband_pct=0.7, actuator_tau_s=2.0, dead_time_s=1.5),
}


def _reference(batch, w, z, state=None):
    """``advance`` sample by sample: the definition ``run_batch`` compiles."""
    state = LoopState.at_rest(batch) if state is None else state
    records = [np.empty(w.shape) for _ in range(3)]
    for k in range(w.shape[1]):
        records[2][:, k] = state.mv
        state, records[0][:, k], records[1][:, k] = advance(batch, state, w[:, k], z[:, k])
    return records, state


def _mixed_loops():
    cases = case_specs()
    specs = [replace(cases[name], extensions=e, valve=valve)
             for name in ("C2", "C8", "N3") for e in EXTENSIONS.values() for valve in ("physical", "he", "kano")
             if valve != "kano" or e.actuator_tau_s == 0]  # fmt: skip
    return specs, build_batch(specs)


def _loads(n_loops, n_samples, seed=1):
    rng = np.random.default_rng(seed)
    return rng.normal(size=(n_loops, n_samples)) * 0.2, rng.normal(size=(n_loops, n_samples)) * 0.1


def test_every_loop_of_a_mixed_batch_follows_advance():
    specs, batch = _mixed_loops()
    w, z = _loads(len(specs), 600)
    (op_ref, pv_ref, mv_ref), _ = _reference(batch, w, z)
    op, pv, mv = run_batch(batch, w, z)
    slipped = np.sum(np.abs(np.diff(mv_ref, axis=1)) > 0, axis=1)
    assert np.all(slipped >= 3), "a loop whose stem never moved would make the comparison vacuous"
    lagged = batch.actuator_tau_s > 0
    # without the actuator's lag the step is additions, products and comparisons: the same to the bit
    for got, want in ((op, op_ref), (pv, pv_ref), (mv, mv_ref)):
        np.testing.assert_array_equal(got[~lagged], want[~lagged])
        # the lag's exp and log may differ in the last bit between numpy's and the compiled libm; the loop
        # is chaotic (spec), so only the first cycles are compared, tightly
        np.testing.assert_allclose(got[lagged, :300], want[lagged, :300], rtol=0, atol=1e-8)


def test_a_record_continues_from_a_given_state():
    specs, batch = _mixed_loops()
    w, z = _loads(len(specs), 120, seed=2)
    (_, _, _), state = _reference(batch, w[:, :70], z[:, :70])
    (op_ref, pv_ref, mv_ref), _ = _reference(batch, w[:, 70:], z[:, 70:], state)
    loads = w.copy(), z.copy()
    op, pv, mv = run_batch(batch, w[:, 70:], z[:, 70:], state=state)
    assert np.array_equal(w, loads[0]) and np.array_equal(z, loads[1]), "run_batch must not change the loads"
    for got, want in ((op, op_ref), (pv, pv_ref), (mv, mv_ref)):
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-10)
    assert state.k == 70 and np.all(state.error_sum == _reference(batch, w[:, :70], z[:, :70])[1].error_sum), (
        "run_batch must not change the state it was given"
    )


def test_a_loop_started_at_its_operating_point_stays_there_without_loads():
    """Every kind of loop (integrating and self-regulating, dead time, deadband, actuator lag, sensor lag; every
    valve) started at its operating point under a constant load reads its setpoint at every sample and its stem
    never moves, in the definition (``advance``) and the compiled record alike; from rest the same loops move."""
    specs = [replace(s, sp_pct=40.0) for s in _mixed_loops()[0]]
    batch = build_batch(specs)
    load = np.linspace(-2.0, 2.0, len(specs))
    w, z = np.repeat(load[:, None], 200, axis=1), np.zeros((len(specs), 200))
    state = LoopState.at_operating_point(batch, load)
    (op_ref, pv_ref, mv_ref), _ = _reference(batch, w, z, state)
    op, pv, mv = run_batch(batch, w, z, state=state)
    for got in (pv, pv_ref):
        np.testing.assert_allclose(got, 40.0, rtol=0, atol=1e-9)
    for got in (mv, mv_ref, op, op_ref):
        np.testing.assert_allclose(got, np.broadcast_to(got[:, :1], got.shape), rtol=0, atol=1e-9)
    _, pv_rest, _ = run_batch(batch, w, z)
    assert np.all(np.ptp(pv_rest, axis=1) > 1.0)


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_a_non_finite_load_stays_in_its_own_loop(bad):
    specs, batch = _mixed_loops()
    w, z = _loads(len(specs), 50, seed=3)
    w[4, 10] = bad
    op, pv, mv = run_batch(batch, w, z)
    others = np.arange(len(specs)) != 4
    assert np.all(np.isfinite(op[others])) and np.all(np.isfinite(pv[others]))
    assert not np.all(np.isfinite(pv[4]))
