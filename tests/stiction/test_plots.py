"""The plots a plant engineer reads: every warning whole in the title, the identified model drawn."""

from types import SimpleNamespace

import numpy as np
import pytest

from stiction.plots import TITLE_WIDTH, _diagnosis_title, _title, plot_loop


def _report(warnings):
    return SimpleNamespace(
        loop_id="FIC1", verdict="stiction", likely_cause="stiction", stiction_probability=0.9, s_pct=2.0,
        s_se_pct=0.4, j_pct=0.5, j_se_pct=0.6, fs_pct=4.8, fd_pct=3.6, method="identified", warnings=warnings,
    )  # fmt: skip


def test_s_read_alone_is_titled_without_j():
    # a report that gives S without J, fs and fd (the schema allows it)
    report = _report(["J not read: ..."])
    report.j_pct = report.j_se_pct = report.fs_pct = report.fd_pct = None
    head = _title(report).splitlines()[0]
    assert "S 2.00 +- 0.40 % of span, J not read (identified)" in head


def test_a_long_warning_is_wrapped_not_cut():
    long = "process identified from OP and PV (stiction diagnose): " + "first order, T 9.2 s; " * 20 + "THE END"
    title = _title(_report([long, "short one"]))
    lines = title.splitlines()
    assert all(len(line) <= TITLE_WIDTH for line in lines[1:])
    assert "THE END" in title and "short one" in lines[-1]
    assert " ".join(line.strip() for line in lines[1:-1]) == long



def test_a_diagnosis_title_wraps_its_causes_and_carries_the_reports_warnings_whole():
    doubt = "the band S 0.117 +- 0.54 % of span: its interval of two standard errors holds 0, " * 3 + "THE END"
    report = SimpleNamespace(
        loop_id="LIC1", causes=["sensor_lag", "process_gain", "dead_time", "external_oscillation"] * 3,
        parameters={"sensor_tau_s": 45.4, "gain_ratio": 0.649, "dead_time_s": 2.92, "osc_period_s": 864.0},
        parameter_ranges={"dead_time_s": (2.2, 3.8)},
        base_error=1.71, extended_error=0.661, gain_pct=61.0, s_pct=0.12, s_se_pct=0.54, j_pct=0.09, j_se_pct=0.08,
        process=SimpleNamespace(description="integrating, dead time 2.92 s"), warnings=[doubt], cannot_tell=[],
    )  # fmt: skip
    lines = _diagnosis_title(report).splitlines()
    assert all(len(line) <= TITLE_WIDTH for line in lines) and len(lines) >= 4
    assert lines[0].startswith("LIC1: sensor_lag") and "THE END" in lines[-1]
    assert doubt in " ".join(line.strip() for line in lines)  # read whole, never cut
    joined = " ".join(lines)
    assert "dead_time_s 2.92 (2.2-3.8)" in joined and "(gain_ratio 0.649)" in joined  # a range where one is given

def test_a_diagnosis_title_gives_the_line_along_which_an_actuators_lag_and_the_band_trade():
    """Where an actuator lag is named, S's error holds its doubt: the title says how a stroke test's lag reads S."""
    line = SimpleNamespace(named="actuator_lag", alternative="actuator_lag", delta_criterion=None,
                           parameters={"s_pct_at_no_lag": 41.6, "s_pct_per_lag_s": 4.04}, note="line")  # fmt: skip
    report = SimpleNamespace(
        loop_id="LIC2", causes=["actuator_lag"], parameters={"actuator_tau_s": 7.41},
        parameter_ranges={"actuator_tau_s": (2.73, 20.1)}, base_error=1.37, extended_error=0.369, gain_pct=73.0,
        s_pct=11.7, s_se_pct=15.16, j_pct=11.1, j_se_pct=3.51, process=SimpleNamespace(description="integrating"),
        warnings=[], cannot_tell=[line],
    )  # fmt: skip
    joined = " ".join(line.strip() for line in _diagnosis_title(report).splitlines())
    assert "S 11.70 ± 15.16 %" in joined and "S about 41.6 - 4.04 x the actuator's lag in s" in joined
    report.cannot_tell = []
    assert "actuator's lag" not in _diagnosis_title(report)


def test_the_identified_models_pv_is_drawn_and_the_title_fits(tmp_path):
    import matplotlib.image as mpimg

    n = 600
    t = np.arange(n, dtype=float)
    op = 50 + 5 * np.sign(np.sin(t / 40))
    pv = 50 + np.sin(t / 40)
    details = SimpleNamespace(curve=np.c_[op[:50], pv[:50]], denoised=np.c_[op, pv], model_pv=pv[-400:] + 0.1)
    window = SimpleNamespace(op=op, pv=pv, ts_s=1.0, t_end_s=float(n), sp=None)
    short = plot_loop(tmp_path / "a.png", window, _report([]), details)
    tall = plot_loop(tmp_path / "b.png", window, _report(["w " * 400]), details)
    a, b = mpimg.imread(short), mpimg.imread(tall)
    assert b.shape[0] > a.shape[0]  # room for every title line
    green = (a[..., 1] > 0.4) & (a[..., 0] < 0.3) & (a[..., 2] < 0.3)  # tab:green, the model's PV
    assert green.sum() > 200


def test_the_inlpca_curve_is_drawn_only_over_a_cycle(tmp_path):
    import matplotlib.image as mpimg

    n = 600
    t = np.arange(n, dtype=float)
    op, pv = 50 + 5 * np.sign(np.sin(t / 40)), 50 + np.sin(t / 40)
    ring = np.linspace(0, 2 * np.pi, 129)
    details = SimpleNamespace(curve=np.c_[50 + 5 * np.cos(ring), 50 + np.sin(ring)], denoised=np.c_[op, pv],
                              model_pv=None)  # fmt: skip
    window = SimpleNamespace(op=op, pv=pv, ts_s=1.0, t_end_s=float(n), sp=None)
    red = {}
    for oscillating in (True, False):
        report = _report([])
        report.oscillating = oscillating
        img = mpimg.imread(plot_loop(tmp_path / f"{oscillating}.png", window, report, details))
        red[oscillating] = int(((img[..., 0] > 0.7) & (img[..., 1] < 0.3) & (img[..., 2] < 0.3)).sum())  # tab:red
    assert red[True] > 200 and red[False] == 0


def test_a_model_gone_wild_does_not_flatten_the_measured_pv():
    from stiction.plots import pv_limits

    measured = 0.3 * np.exp(-np.arange(700) / 30)  # a flow that fell to nothing, 0-0.3 %
    near = measured + 0.05
    wild = np.linspace(1200, -800, 700)  # a canonical model off by a thousand percent
    assert pv_limits(measured, [near]) is None  # models near the data: the axis is left to matplotlib
    lo, hi = pv_limits(measured, [near, wild])
    assert lo == pytest.approx(-0.15, abs=1e-6) and hi == pytest.approx(0.45, abs=1e-6)
    flat = np.full(700, 48.0)  # a measured PV that never moves: an axis around it, not one of zero height
    lo, hi = pv_limits(flat, [flat + 5.0])
    assert lo < 48.0 < hi
