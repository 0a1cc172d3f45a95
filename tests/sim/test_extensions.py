"""Each extension changes the loop the way its name says."""

import numpy as np
import pytest

from stiction.sim.extensions import CATALOGUE, Extensions, backlash
from stiction.sim.loop import LoopSpec, simulate
from stiction.sim.process import LOOPS, continuous_plant, discretise
from stiction.sim.valve import Friction, lagged_valve_step, pct_to_lbf


def _plant_response(ext: Extensions, flow: np.ndarray, loop="level") -> np.ndarray:
    """Open-loop PV for a held flow sequence, through the loop's discretised plant."""
    A, B, C = continuous_plant(LOOPS[loop], ext.gain_ratio, ext.time_constant_s, ext.sensor_tau_s)
    p = discretise(A, B, C, 1.0, ext.dead_time_s)
    x, y = np.zeros(2), []
    padded = np.concatenate([np.zeros(p.delay_samples + 1), flow])
    for k in range(flow.size):
        y.append(p.c @ x)
        now, prev = padded[k + 1], padded[k]  # u[k - delay], u[k - delay - 1]
        x = p.phi @ x + p.gamma_now * now + p.gamma_prev * prev
    return np.array(y)


@pytest.mark.parametrize("loop", ["level", "concentration"])
@pytest.mark.parametrize(
    "ext",
    [
        Extensions(),
        Extensions(sensor_tau_s=7.0),
        Extensions(time_constant_s=40.0),
        Extensions(gain_ratio=1.7, sensor_tau_s=3.0),
    ],
)
def test_discretisation_matches_python_control(loop, ext):
    import control

    A, B, C = continuous_plant(LOOPS[loop], ext.gain_ratio, ext.time_constant_s, ext.sensor_tau_s)
    sysd = control.c2d(control.ss(A, B[:, None], C[None, :], 0), 1.0, method="zoh")
    p = discretise(A, B, C, 1.0)
    np.testing.assert_allclose(p.phi, sysd.A, atol=1e-12)
    np.testing.assert_allclose(p.gamma_now, sysd.B[:, 0], atol=1e-12)


@pytest.mark.parametrize("dead_time_s", [3.0, 4.4])
def test_dead_time_delays_pv(dead_time_s):
    flow = np.zeros(40)
    flow[5:] = 1.0  # unit flow from t = 5 s
    y0 = _plant_response(Extensions(), flow)
    y = _plant_response(Extensions(dead_time_s=dead_time_s), flow)
    t = np.arange(40.0)
    # the integrating level process: PV ramps at 1/15 %/s, starting dead_time_s later
    np.testing.assert_allclose(y0, np.maximum(t - 5, 0) / 15, atol=1e-12)
    np.testing.assert_allclose(y, np.maximum(t - 5 - dead_time_s, 0) / 15, atol=1e-12)


def test_dead_time_delays_pv_against_python_control_pade_free_shift():
    """A whole-sample delay is a pure shift of the undelayed response."""
    flow = np.random.default_rng(2).normal(size=60)
    y0 = _plant_response(Extensions(), flow, loop="concentration")
    y = _plant_response(Extensions(dead_time_s=6.0), flow, loop="concentration")
    np.testing.assert_allclose(y[6:], y0[:-6], atol=1e-12)


def test_sensor_lag_filters_pv():
    flow = np.ones(200)
    tau = 8.0
    y = _plant_response(Extensions(sensor_tau_s=tau), flow)
    t = np.arange(200.0)
    # a ramp of slope 1/15 seen through a first-order filter: (t - tau (1 - e^{-t/tau})) / 15
    np.testing.assert_allclose(y, (t - tau * (1 - np.exp(-t / tau))) / 15, atol=1e-12)


def test_process_gain_scales_the_process():
    flow = np.random.default_rng(1).normal(size=50)
    np.testing.assert_allclose(
        _plant_response(Extensions(gain_ratio=2.5), flow), 2.5 * _plant_response(Extensions(), flow), atol=1e-12
    )


def test_process_type_makes_the_level_process_self_regulating():
    t_c = 20.0
    y = _plant_response(Extensions(time_constant_s=t_c), np.ones(300))
    t = np.arange(300.0)
    # (T/15) / (T s + 1): same initial slope as 1/(15 s), settles at T/15
    np.testing.assert_allclose(y, t_c / 15 * (1 - np.exp(-t / t_c)), atol=1e-12)


def test_deadband_backlash_takes_up_play_before_moving():
    drive = np.concatenate([np.linspace(0, 10, 11), np.linspace(9, 0, 10)])
    out, path = np.zeros(1), []
    for d in drive:
        out = backlash(np.array([d]), out, np.array([4.0]))
        path.append(out[0])
    path = np.array(path)
    np.testing.assert_allclose(path[:11], np.maximum(drive[:11] - 2, 0))
    # after the reversal at 10 the output holds at 8 until the drive is back at 6
    np.testing.assert_allclose(path[11:], np.minimum(drive[11:] + 2, 8))


def test_deadband_widens_the_band_seen_in_op():
    base = simulate([LoopSpec(30, 10, valve="he")]).kept()
    wide = simulate([LoopSpec(30, 10, valve="he", extensions=Extensions(deadband_pct=6.0))]).kept()

    def band_at_slips(r):
        slipped = np.diff(r.mv[0]) != 0
        return np.median(np.abs(r.op[0, :-1] - r.mv[0, :-1])[slipped])

    widened = band_at_slips(wide) - band_at_slips(base)
    assert 2.5 < widened < 3.5  # half the deadband's width: the play sits on either side of the drive


def test_actuator_lag_is_a_first_order_lag_for_a_frictionless_valve():
    tau = 6.0
    frictionless = Friction.he(np.zeros(1), np.zeros(1))
    drive, mv, path = np.zeros(1), np.zeros(1), []
    for _ in range(30):
        slip, drive = lagged_valve_step(drive, np.ones(1), np.array([tau]), 1.0, mv, frictionless)
        mv = slip.mv_pct
        path.append(mv[0])
    np.testing.assert_allclose(path, 1 - np.exp(-np.arange(1, 31) / tau), atol=1e-6)


def test_actuator_lag_makes_op_run_past_the_band_before_a_slip():
    def gap_at_slips(r):
        # where a stuck stem breaks away (a lagged one then slides along its drive for a few samples)
        moved = np.diff(r.mv[0]) != 0
        breaks = np.flatnonzero(moved[1:] & ~moved[:-1]) + 1
        return np.median(np.abs(r.op[0] - r.mv[0])[breaks])

    band_pct = pct_to_lbf(20) / 12
    base = simulate([LoopSpec(20, 5)]).kept()
    lagged = simulate([LoopSpec(20, 5, extensions=Extensions(actuator_tau_s=8.0))]).kept()
    assert gap_at_slips(base) < band_pct + 0.5
    assert gap_at_slips(lagged) > band_pct + 2.0


def test_quantization_leaves_steps_of_the_given_size():
    q = 0.25
    r = simulate([LoopSpec(30, 10, extensions=Extensions(quantum_pct=q))]).kept()
    for signal in (r.pv[0], r.op[0]):
        np.testing.assert_allclose(signal / q, np.round(signal / q), atol=1e-9)
        steps = np.abs(np.diff(signal))
        assert steps[steps > 0].min() == pytest.approx(q)
    # the loop itself is unaffected: only storage is quantised
    plain = simulate([LoopSpec(30, 10)]).kept()
    np.testing.assert_array_equal(r.mv, plain.mv)


def test_external_oscillation_shows_at_its_period():
    period = 23.0  # away from the limit cycle's harmonics
    r = simulate([LoopSpec(30, 10, extensions=Extensions(osc_period_s=period, osc_amplitude_pct=1.0))]).kept()
    base = simulate([LoopSpec(30, 10)]).kept()

    def power_at(x, f_hz):
        t = np.arange(x.size)
        return abs(np.sum((x - x.mean()) * np.exp(-2j * np.pi * f_hz * t))) / x.size

    seen = power_at(r.pv[0], 1 / period)
    # between slips the load reaches PV through the integrator alone: amplitude A P / (2 pi 15)
    through_integrator = 1.0 * period / (2 * np.pi * 15) / 2
    assert seen > 0.5 * through_integrator
    assert seen > 5 * power_at(base.pv[0], 1 / period)


@pytest.mark.parametrize("shape", ["square", "triangle"])
def test_a_square_or_triangle_load_is_its_wave_through_a_lag_of_a_tenth_of_its_period(shape):
    from stiction.sim.loop import load_wave

    period, t = 40.0, np.arange(0.0, 400.0, 0.5)
    wave = load_wave(shape, t, period)
    phase = (t / period) % 1
    raw = np.where(phase < 0.5, 1.0, -1.0) if shape == "square" else 4 * np.abs(phase - 0.5) - 1
    ref, y = np.empty_like(raw), raw[0]  # the lag, sample by sample, by its exact step response
    for k in range(raw.size):
        y = raw[k] + (y - raw[k]) * np.exp(-(t[k] - t[k - 1] if k else 0.0) / (0.1 * period))
        ref[k] = y
    np.testing.assert_allclose(wave, ref, atol=1e-12)
    if shape == "square":  # five lags a half period, settled: 2 exp(-5) / (1 + exp(-5)) short of each level
        ends = np.flatnonzero(np.isclose(phase, 0.5 - 0.5 / period) | np.isclose(phase, 1 - 0.5 / period))
        np.testing.assert_allclose(np.abs(wave[ends[2:]]), 1 - 2 * np.exp(-5) / (1 + np.exp(-5)), atol=1e-3)
    with_load = simulate([LoopSpec(0, 0, extensions=Extensions(osc_period_s=period, osc_amplitude_pct=1.0,
                                                               osc_shape=shape))]).kept()  # fmt: skip
    sine = simulate([LoopSpec(0, 0, extensions=Extensions(osc_period_s=period, osc_amplitude_pct=1.0))]).kept()
    assert np.ptp(with_load.pv) > 0.1 and not np.allclose(with_load.pv, sine.pv, atol=1e-3)


def test_catalogue_names_match_extension_fields():
    fields = set(Extensions.__dataclass_fields__)
    for cause, params in CATALOGUE.items():
        assert set(params) <= fields, cause
    assert Extensions(dead_time_s=2, quantum_pct=0.1).causes() == ["dead_time", "quantization"]
    with pytest.raises(ValueError, match="dead_time_s"):
        Extensions(dead_time_s=-1)
    with pytest.raises(ValueError, match="both"):
        Extensions(osc_period_s=30)
    with pytest.raises(ValueError, match="osc_shape 'saw'"):
        Extensions(osc_period_s=30, osc_amplitude_pct=1, osc_shape="saw")
    with pytest.raises(ValueError, match="needs an external oscillation"):
        Extensions(osc_shape="square")
    assert "osc_shape" not in Extensions(osc_period_s=30, osc_amplitude_pct=1).active()
    assert Extensions(osc_period_s=30, osc_amplitude_pct=1, osc_shape="square").causes() == ["external_oscillation"]
