"""The published tests and the oscillation detector on signals whose answer is known."""

import numpy as np
import pytest

from stiction.detect import bicoherence, horch, oscillation, shape


def _triangle(t, period):
    phase = (t / period) % 1.0
    return 4 * np.abs(phase - 0.5) - 1


def test_a_slow_cycle_of_two_and_a_half_periods_is_found_with_its_period():
    rng = np.random.default_rng(0)
    t = np.arange(751.0)
    x = np.sin(2 * np.pi * t / 300) + 0.3 * rng.standard_normal(t.size)
    o = oscillation.detect(x, ts_s=10.0)
    assert o.oscillating and o.cycles < 3
    assert o.period_s == pytest.approx(3000.0, rel=0.1)
    assert o.amplitude_pct == pytest.approx(1.0, rel=0.3)


def _cycle_with_pauses(seed: int) -> np.ndarray:
    """Bursts of a 12-sample triangle cycle, each followed by a pause of 20-40 samples, under light noise: a
    stick-slip cycle that the noise breaks early now and then, or that stops for a while, sampled coarsely."""
    rng = np.random.default_rng(seed)
    parts = []
    for _ in range(8):
        t = np.arange(12 * rng.integers(4, 7))
        parts += [2 * np.abs((t / 12) % 1.0 - 0.5) * 2 - 1, np.zeros(rng.integers(20, 40))]
    x = np.concatenate(parts)[:600]
    return x + 0.05 * rng.standard_normal(x.size)


@pytest.mark.parametrize("seed", range(4))
def test_a_cycle_that_pauses_now_and_then_is_still_a_cycle(seed):
    """Read by the mean and standard deviation of its periods alone, the pauses' few long intervals made these
    irregular (r 0.5-0.95): their swing is steady, and by the median of the periods they are regular."""
    o = oscillation.detect(_cycle_with_pauses(seed), ts_s=10.0)
    assert o.oscillating and np.isfinite(o.regularity)
    assert 100.0 <= o.period_s <= 200.0  # the mean period: 12 samples, and the pauses' few longer ones


def test_noise_ringing_at_its_own_period_is_not_read_by_the_median_of_its_periods():
    """Narrow-band noise (a loop ringing under noise, as an aggressive controller makes it) crosses zero at its
    own period most of the time: read by the median of its periods alone, 10 of these 10 would oscillate.  Its
    swing is not steady, so only the mean and standard deviation read it."""
    from scipy.signal import lfilter

    from stiction.detect import kernels

    called, by_median = 0, 0
    for seed in range(10):
        rng = np.random.default_rng(seed)
        radius, omega = 0.97, 2 * np.pi / 15
        x = lfilter([1.0], [1.0, -2 * radius * np.cos(omega), radius**2], rng.standard_normal(800))[200:]
        d = oscillation.detrended(x)
        by_median += kernels.robust_regularity(oscillation.half_cycles(d.y, d.sd)[1])[0] > oscillation.REGULAR
        called += oscillation.detect(x).oscillating
    assert by_median >= 8 and called <= 2


def test_noise_and_random_walks_are_rarely_called_oscillating():
    rng = np.random.default_rng(1)
    called = 0
    for k in range(30):
        e = rng.standard_normal(751)
        x = np.cumsum(e) if k % 3 == 0 else np.convolve(e, np.ones(20) / 20, "same") if k % 3 == 1 else e
        called += oscillation.detect(x).oscillating
    assert called <= 3


def test_crossings_with_hysteresis_ignore_noise_near_zero():
    x = np.array([1.0, 0.1, -0.1, 0.1, -1.0, -0.5, 0.05, 1.0])
    assert list(oscillation._crossings(x, 0.5)) == [4, 6]  # the last zero crossing before the band is left


def test_horch_reads_an_odd_ccf_as_stiction_and_an_even_one_as_not():
    t = np.arange(1000.0)
    pv_square = np.sign(np.sin(2 * np.pi * t / 100))  # a sticky flow loop: PV square, OP its integral
    op_triangle = np.cumsum(-pv_square)
    assert horch.test(op_triangle, pv_square, np.zeros_like(t), 100).verdict == "stiction"
    pv_sine = np.sin(2 * np.pi * t / 100)  # a load the controller fights: OP mirrors PV
    assert horch.test(-2 * pv_sine, pv_sine, np.zeros_like(t), 100).verdict == "no_stiction"


def test_shape_index_tells_a_triangle_from_a_sine():
    rng = np.random.default_rng(2)
    t = np.arange(1000.0)
    noise = 0.02 * rng.standard_normal(t.size)
    assert shape.stiction_index(_triangle(t, 120) + noise) > shape.STICTION
    assert shape.stiction_index(np.sin(2 * np.pi * t / 120) + noise) < shape.NO_STICTION


def test_bicoherence_calls_gaussian_noise_linear_and_a_phase_coupled_signal_nonlinear():
    rng = np.random.default_rng(3)
    assert not bicoherence.test(rng.standard_normal(2048)).nonlinear
    t = np.arange(2048.0)
    sawtooth = (t / 40.0) % 1.0  # every harmonic, each phase-locked to the others: a limit cycle's signature
    assert bicoherence.test(sawtooth + 0.05 * rng.standard_normal(t.size)).nonlinear


def test_bicoherence_excess_reads_a_linear_signal_as_zero_at_any_length():
    """Choudhury's NGI of a linear signal is about -2/K over K segments (it follows the window's length);
    the excesses over the null's own expectation stay near 0 from 600 to 3,600 samples, and a phase-coupled
    signal stands out at both lengths."""
    rng = np.random.default_rng(4)
    for n in (600, 3600):
        linear = [bicoherence.test(np.convolve(rng.standard_normal(n), [1, 0.8, 0.5], "same")) for _ in range(20)]
        assert abs(np.median([b.excess for b in linear])) < 0.01
        assert abs(np.median([b.peak_excess for b in linear])) < 0.05
        t = np.arange(float(n))
        coupled = bicoherence.test((t / 40.0) % 1.0 + 0.05 * rng.standard_normal(n))
        assert coupled.excess > 0.05 and coupled.peak_excess > 0.2
    short, long = (bicoherence.test(rng.standard_normal(n)).ngi for n in (600, 3600))
    assert short < long - 0.1  # what the excess corrects


def test_the_evidence_does_not_change_with_pv_in_other_units_or_offset():
    """Hidden effect: PV and OP exported in engineering units (scaled, offset), on records a historian
    compressed into straight stretches.  A straight line's remainder after detrending is rounding noise
    (1e-15) whose crossings read as a perfectly regular cycle, and whose steps' kurtosis is arbitrary;
    the evidence must read the same loop whatever the units."""
    from stiction.detect.features import evidence
    from stiction.sim.plant_families import family_loops, simulate_families, stable

    loops = [loop for loop in family_loops(2, 999, bands="plant") if loop.compression_pct > 0 or loop.fault][:24]
    checked = 0
    for rec in simulate_families(loops):
        if not stable(rec):
            continue
        a = evidence(rec.op, rec.pv, rec.ts_s, rec.sp)
        for k_op, k_pv, offset in ((3.0, 0.01, 300.0), (1.0, 1.0, 300.0), (0.2, 50.0, -7.0)):
            b = evidence(rec.op * k_op, rec.pv * k_pv + offset, rec.ts_s, rec.sp * k_pv + offset)
            assert np.allclose(a.vector, b.vector, atol=1e-6), (k_op, k_pv, offset)
            assert a.oscillation.oscillating == b.oscillation.oscillating
        checked += 1
    assert checked >= 15
    line = 50 + 0.01 * np.arange(600.0)  # one straight stretch: no oscillation, whatever its offset
    assert not oscillation.detect(line + 300).oscillating and oscillation.detect(line + 300).regularity == 0


def test_ellipse_band_is_the_plot_width_at_mean_pv():
    t = np.linspace(0, 20 * np.pi, 4000, endpoint=False)
    a, b, phase = 3.0, 1.0, 0.4
    s = bicoherence.ellipse_band_pct(a * np.sin(t + phase), b * np.sin(t))
    assert s == pytest.approx(2 * a * abs(np.sin(phase)), rel=1e-3)


@pytest.mark.parametrize("seed", range(6))
def test_compiled_amplitude_and_shape_index_equal_the_per_half_cycle_loops(seed):
    from stiction.detect.oscillation import _amplitude, detrend, half_cycles
    from stiction.detect.shape import stiction_index
    from tests.detect import reference

    rng = np.random.default_rng(seed)
    n = int(rng.integers(200, 1500))
    t = np.arange(n)
    x = np.sin(2 * np.pi * t / rng.uniform(20, 200)) + rng.uniform(0, 0.6) * rng.standard_normal(n)
    if seed % 2:
        x = np.sign(x) * np.abs(x) ** 0.3 + 0.1 * rng.standard_normal(n)  # squarer, noisier
    y = detrend(x)
    smooth, zc = half_cycles(y, float(np.std(y)))
    assert zc.size >= 3
    assert _amplitude(smooth, zc) == pytest.approx(reference.amplitude(smooth, zc), rel=1e-12)
    assert stiction_index(x) == pytest.approx(reference.stiction_index(x), rel=1e-7, abs=1e-9)


@pytest.mark.parametrize("seed", range(6))
def test_compiled_crossings_regularity_detrend_and_bicoherence_equal_the_plain_loops(seed):
    from stiction.detect import kernels
    from stiction.detect.bicoherence import squared_bicoherence
    from stiction.detect.oscillation import _crossings, _regularity, detrend
    from tests.detect import reference

    rng = np.random.default_rng(seed)
    n = int(rng.integers(100, 1200))
    x = np.sin(np.arange(n) / rng.uniform(3, 30)) * rng.uniform(0.5, 3) + rng.standard_normal(n) * rng.uniform(0, 1)
    x += rng.uniform(-0.01, 0.01) * np.arange(n)
    if seed == 0:
        x[::7] = 0.0  # exact zeros: np.sign 0 ends a run
    for h in (0.0, 0.3, 1.0):
        np.testing.assert_array_equal(_crossings(x, h), reference.crossings(x, h))
        zc = _crossings(x, h)
        for few in (zc, zc[:3], zc[:4], np.arange(0, 50, 5)):  # irregular, too few, just enough, perfectly even
            r, period = _regularity(few)
            want_r, want_period = reference.regularity(few)
            assert r == pytest.approx(want_r, rel=1e-12) and period == pytest.approx(
                want_period, rel=1e-12, nan_ok=True
            )
            r, period = kernels.robust_regularity(np.asarray(few, dtype=np.int64))
            want_r, want_period = reference.robust_regularity(few)
            assert r == pytest.approx(want_r, rel=1e-12) and period == pytest.approx(
                want_period, rel=1e-12, nan_ok=True
            )
            spread = kernels.swing_spread(np.ascontiguousarray(x), np.asarray(few, dtype=np.int64))
            assert spread == pytest.approx(reference.swing_spread(x, few), rel=1e-12, nan_ok=True)
    np.testing.assert_allclose(detrend(x), reference.detrend_polyfit(x), atol=1e-9)
    b2, k = squared_bicoherence(x, 32)
    ref, k_ref = reference.squared_bicoherence(x, 32)
    assert k == k_ref
    np.testing.assert_allclose(b2, ref, rtol=1e-9, atol=1e-12, equal_nan=True)


@pytest.mark.parametrize("seed", range(6))
def test_compiled_stick_slip_shares_equal_the_plain_loops(seed):
    from stiction.detect import kernels
    from stiction.detect.features import EDGE_MEDIAN, TOP_SHARE, _edges
    from tests.detect import reference

    rng = np.random.default_rng(seed)
    n = int(rng.integers(120, 1500))
    op = np.cumsum(rng.standard_normal(n)) * rng.uniform(0.1, 2)
    pv = np.round(op / rng.uniform(0.5, 5)) + rng.uniform(0, 0.3) * rng.standard_normal(n)  # stands still, jumps
    if seed == 0:
        pv[:] = 1.0  # no steps at all
    y, u = _edges(pv[None])[0], _edges(op[None])[0]
    for x in (y, u):
        assert kernels.jump_share(x, TOP_SHARE) == pytest.approx(reference.jump_share(x, TOP_SHARE), rel=1e-12)
        rel = oscillation.ROUNDING_REL
        assert kernels.step_kurtosis(x, rel) == pytest.approx(reference.step_kurtosis(x, rel), rel=1e-9)
    assert kernels.still_share(y, pv, op, EDGE_MEDIAN) == reference.still_share(y, pv, op, EDGE_MEDIAN)


@pytest.mark.parametrize("seed", range(6))
def test_compiled_stuck_ramp_equals_the_plain_loop(seed):
    from stiction.detect import kernels
    from stiction.detect.features import _edges
    from tests.detect import reference

    rng = np.random.default_rng(seed)
    n = int(rng.integers(120, 1500))
    ramp = np.abs(((np.arange(n) * rng.uniform(2, 4) / n) % 2) - 1)  # OP winds up and down, 1-2 times
    op = 10 * ramp + rng.uniform(0, 0.2) * rng.standard_normal(n)
    pv = np.round(op / rng.uniform(5, 8)) + rng.uniform(0.05, 0.2) * rng.standard_normal(n)  # stands still, jumps
    if seed == 0:
        pv[:] = 1.0  # PV never moves: nothing to read
    y, u = _edges(pv[None])[0], _edges(op[None])[0]
    for args in ((8, 0.25, 0.15, 2.5, 0.95), (4, 0.1, 0.3, 1.0, 0.5)):
        assert kernels.stuck_ramp(y, pv, u, *args) == pytest.approx(reference.stuck_ramp(y, pv, u, *args), abs=1e-12)
    share, travel = kernels.stuck_ramp(y, pv, u, 8, 0.25, 0.15, 2.5, 0.95)
    assert seed == 0 or (share > 0 and 2.5 <= travel <= np.ptp(u))  # a quarter of OP's range at least


@pytest.mark.parametrize("seed", [0, 1])
def test_the_batched_evidence_equals_each_test_run_on_its_own_signal(seed):
    """``features.evidence_rows`` detrends OP, PV and the error once for a batch and hands them to
    every test; the tests run alone (detrending for themselves) must read the same."""
    from stiction.detect import features

    rng = np.random.default_rng(seed)
    t = np.arange(600.0)
    op = np.stack([np.sign(np.sin(t / 19 + k)) + 0.1 * t / 600 + rng.normal(0, 0.05, t.size) for k in range(4)])
    pv = np.stack([np.cumsum(o) / 20 + rng.normal(0, 0.02, t.size) for o in op])
    sps = [None, np.full(t.size, 1.0), None, 0.5 + 0.01 * t]
    batched = features.evidence_rows(op, pv, 2.0, sps)
    for i, ev in enumerate(batched):
        error = pv[i] if sps[i] is None else pv[i] - sps[i]
        osc = oscillation.detect(error, 2.0)
        assert osc.period_s == pytest.approx(ev.oscillation.period_s, rel=1e-9)
        assert osc.regularity == pytest.approx(ev.oscillation.regularity, rel=1e-9)
        h = horch.test(op[i], pv[i], sps[i], osc.period_s / 2.0 if osc.period_s else None)
        assert h.phase == pytest.approx(ev.horch.phase, rel=1e-9, nan_ok=True)
        assert shape.stiction_index(op[i]) == pytest.approx(ev.shape_op, rel=1e-9, nan_ok=True)
        assert shape.stiction_index(pv[i]) == pytest.approx(ev.shape_pv, rel=1e-9, nan_ok=True)
        b = bicoherence.test(error)
        assert (b.ngi, b.nli) == pytest.approx((ev.bicoherence.ngi, ev.bicoherence.nli), rel=1e-9, nan_ok=True)


@pytest.mark.parametrize("n", [1, 3, 4, 1000])
def test_compiled_edge_filter_is_scipys_median_filter(n):
    from scipy.ndimage import median_filter

    from stiction.detect import kernels
    from stiction.detect.features import EDGE_MEDIAN

    rng = np.random.default_rng(n)
    x = np.round(rng.normal(size=(3, n)) * 4) / 4  # ties, as a quantised signal has them
    x[1] = np.sign(np.sin(np.arange(n) / 9)) + rng.normal(0, 0.1, n)  # a slip's edge among noise
    want = median_filter(x, size=(1, EDGE_MEDIAN), mode="nearest")
    np.testing.assert_array_equal(kernels.running_median_rows(x, EDGE_MEDIAN), want)


@pytest.mark.parametrize("noise_pct", [0.1, 0.2])
def test_a_flow_valve_stuck_while_op_ramps_reads_as_stuck_under_white_noise_as_without(noise_pct):
    """A flow loop's stick-slip cycle (OP a triangle, PV a square of +-0.5 % standing still between slips)
    under white noise up to a fifth of the square's amplitude: over six windows, the stuck-ramp test sees the
    stand-stills in nine tenths of the spans it sees them in without noise, or more.  Its bound on PV's level
    is 2.5 noises; with the noise read too small (0.73 of it, from the distance to the median-filtered level)
    a still level broke it in a third to half of the spans at any noise."""
    from stiction.detect.features import evidence
    from stiction.detect.verdict import STUCK_AT

    clean, noisy = [], []
    for seed in range(6):
        rng = np.random.default_rng(seed)
        n = 750
        phase = ((np.arange(n) + rng.integers(300)) / 300.0) % 1.0  # 2.5 cycles a window
        op = 24.0 + 2.0 * np.where(phase < 0.5, 2 * phase, 2 - 2 * phase) + 0.03 * rng.standard_normal(n)
        square = 100.0 + np.where(phase < 0.5, -0.5, 0.5)
        clean.append(evidence(op, square, 10.0).stuck_ramp)
        noisy.append(evidence(op, square + noise_pct * rng.standard_normal(n), 10.0).stuck_ramp)
    assert min(clean) >= STUCK_AT and sum(noisy) >= 0.9 * sum(clean), (clean, noisy)


@pytest.mark.parametrize("seed", range(8))
def test_the_half_cycles_percentiles_by_selection_equal_those_of_a_sort(seed):
    """``kernels._swings`` keeps only a half cycle's largest tenth as it walks it; its percentiles must be the sorted
    half cycle's to the bit: half cycles of one to hundreds of samples, ties (a quantised signal), empty half cycles
    (repeated crossings), a nan, and both ends in or out."""
    from stiction.detect import kernels
    from tests.detect import reference

    rng = np.random.default_rng(seed)
    n = int(rng.integers(50, 1200))
    y = rng.standard_normal(n) * rng.uniform(0.1, 10)
    if seed % 2:
        y = np.round(y, 1)  # ties
    if seed == 5:
        y[int(rng.integers(0, n))] = np.nan
    cuts = np.sort(rng.integers(0, n, int(rng.integers(2, 60))))
    cuts = np.r_[0, cuts, cuts[:3], n - 1]  # some repeated: empty half cycles
    cuts = np.sort(cuts).astype(np.int64)
    for through in (0, 1):
        got = kernels._swings(np.ascontiguousarray(y), cuts, through)
        np.testing.assert_array_equal(got, reference.swings_sorted(y, cuts, through))


@pytest.mark.parametrize("n", [0, 1, 2, 5, 7, 10, 40, 501])
def test_the_compiled_median_is_numpys(n):
    """``kernels.median`` (the physical reading's medians over slips, the stuck setpoint step's over a few samples)
    is numpy's median to the bit, ties included, and nan where a value is."""
    from stiction.detect import kernels

    x = np.random.default_rng(n).normal(size=n).round(1) * 3  # rounded: ties
    want = np.median(x) if n else np.nan
    assert kernels.median(x) == want or (np.isnan(want) and np.isnan(kernels.median(x)))
    if n:
        x[n // 2] = np.nan
        assert np.isnan(kernels.median(x))
