"""The physical reading: MV from PV, and the segmented reading against simple references."""

import numpy as np
import pytest

from stiction.quantify import physical
from stiction.sim.disturbance import Disturbance
from stiction.sim.grid import case_specs
from stiction.sim.loop import LoopSpec, simulate


def test_mv_follows_from_pv_for_the_level_loop():
    r = simulate(list(case_specs().values())[:10]).kept()
    mv = physical.reconstruct_mv(r.pv)
    np.testing.assert_allclose(mv[:, physical.SETTLE_SAMPLES :], r.mv[:, physical.SETTLE_SAMPLES :], atol=1e-6)


def test_a_stem_that_moves_at_every_sample_is_read_without_a_bracket_and_the_batch_goes_on():
    # PV a parabola: the level loop's stem, read from PV's slope, moves the same at every sample, so
    # every sample passes as a slip and none as stuck (a healthy loop under a smooth load did this)
    t = np.arange(1000.0)
    op = np.vstack([np.linspace(0.0, 50.0, t.size), np.sin(t / 40)])
    pv = np.vstack([1e-4 * t**2, np.cos(t / 40)])
    reading = physical.read(op, pv)
    assert not reading.bracketed[0]
    assert reading.slips[0] > 0.9 * (t.size - physical.SETTLE_SAMPLES)


def _white_noise_loops(where, coefficient):
    specs = [
        LoopSpec(fs, fd, disturbance=Disturbance("gaussian", where, coefficient), seed=s)
        for s, (fs, fd) in enumerate([(46.8, 4.0), (29.0, 16.0), (70.0, 30.0), (17.8, 8.0)])
    ]
    return specs, simulate(specs).kept()


def test_segmented_reading_sees_through_white_input_noise():
    specs, r = _white_noise_loops("input", 0.3)
    truth = np.array([[s.fs_pct, s.fd_pct] for s in specs])
    seg = physical.read_segmented(r.op, r.pv)
    sample_wise = physical.read(r.op, r.pv)
    err_seg = np.abs(np.column_stack([seg.fs_pct, seg.fd_pct]) - truth).mean()
    err_sample = np.abs(np.column_stack([sample_wise.fs_pct, sample_wise.fd_pct]) - truth).mean()
    assert err_seg < 0.6 and err_seg < 0.5 * err_sample
    assert physical.read_best(r.op, r.pv).segmented.all()


@pytest.mark.parametrize("coefficient", [0.1, 0.2])
def test_segmented_reading_abstains_or_is_right_under_white_output_noise(coefficient):
    from stiction.quantify.policy import SEGMENTED_MAX_SE_PCT

    specs, r = _white_noise_loops("output", coefficient)
    seg = physical.read_segmented(r.op, r.pv)
    for i, spec in enumerate(specs):
        trusted = max(seg.fs_se_pct[i], seg.fd_se_pct[i]) <= SEGMENTED_MAX_SE_PCT
        if trusted:  # a reading the pipeline would use must be right
            assert abs(seg.fs_pct[i] - spec.fs_pct) < 1.5 and abs(seg.fd_pct[i] - spec.fd_pct) < 1.5


def test_the_compiled_stem_recursion_and_piece_means_follow_numpy():
    from stiction.quantify import physical_kernel

    rng = np.random.default_rng(5)
    flow = rng.normal(size=(3, 400)) * 10
    c = 0.3
    mv = np.empty((3, 401))
    mv[:, 0] = flow[:, 0]
    for k in range(400):  # the recursion as written, vectorised over windows
        mv[:, k + 1] = (flow[:, k] - c * mv[:, k]) / (1 - c)
    np.testing.assert_array_equal(physical_kernel.stem_from_flow(flow, c), mv)
    ends = np.array([1, 7, 8, 150, 151, 399, 400])
    want = [flow[0, a:b].mean() for a, b in zip([0, *ends[:-1]], ends, strict=True)]
    np.testing.assert_allclose(physical_kernel.piece_means(flow[0], ends), want, rtol=1e-13, atol=1e-13)
