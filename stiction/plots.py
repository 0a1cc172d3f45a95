"""Static PNGs for people who will not open a viewer: ``stiction quantify --plot DIR``."""

from __future__ import annotations

import textwrap
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from stiction.ident.trust import course_share  # noqa: E402

TITLE_WIDTH = 150
"""Characters per title line at the plots' size."""
TITLE_LINE_IN = 0.2


def _title(report) -> str:
    """The verdict first, then S and J with their uncertainty, then every warning, wrapped whole."""
    p = "" if report.stiction_probability is None else f" (p {report.stiction_probability:.2f})"
    cause = f", likely {report.likely_cause}" if report.verdict == "other_cause" and report.likely_cause else ""
    head = f"{report.loop_id}: {report.verdict.replace('_', ' ')}{cause}{p}"
    if report.s_pct is not None:
        sj = _band(report.s_pct, report.s_se_pct, report.j_pct, report.j_se_pct, "+-")
        thesis = f"fs {report.fs_pct:.1f}, fd {report.fd_pct:.1f} % of 500 lbf; " if report.fs_pct is not None else ""
        head += f"; {sj} ({thesis}{report.method})"
    return _with_warnings([head], report.warnings)


def _band(s_pct, s_se_pct, j_pct, j_se_pct, pm: str) -> str:
    """S and J with their errors (``pm`` between, an error left out where there is none); S alone where a report
    gives it without J (the schema allows it; the sizing did from 2026-11-27 to 2026-11-29)."""

    def err(se) -> str:
        return f" {pm} {se:.2f}" if se is not None else ""

    if j_pct is None:
        return f"S {s_pct:.2f}{err(s_se_pct)} % of span, J not read"
    return f"S {s_pct:.2f}{err(s_se_pct)} %, J {j_pct:.2f}{err(j_se_pct)} % of span"


def _with_warnings(lines: list[str], warnings) -> str:
    """The title's lines, then every warning, each wrapped whole: a warning is read whole, never cut."""
    for w in warnings:
        lines = lines + textwrap.wrap(w, TITLE_WIDTH, subsequent_indent="    ")
    return "\n".join(lines)


def plot_loop(out, window, report, details, title: bool = True, dpi: int = 90):
    """OP and PV over time; the OP-PV curve before and after denoising; the estimate in the title
    (``title=False``: none, where the page around the figure says it).  ``out``: a path or a binary file."""
    t = (window.t_end_s or 0.0) - window.ts_s * np.arange(len(window.op))[::-1]
    title = _title(report) if title else ""
    title_in = TITLE_LINE_IN * (title.count("\n") + 1) + 0.1 if title else 0.0
    height_in = 4.2 + title_in
    fig, (ax_t, ax_c) = plt.subplots(1, 2, figsize=(13, height_in), gridspec_kw={"width_ratios": [1.6, 1]})
    ax_t.plot(t, window.op, lw=0.9, color="tab:blue", label="OP")
    ax_t.set_xlabel("time, s")
    ax_t.set_ylabel("OP, percent", color="tab:blue")
    ax_pv = ax_t.twinx()  # each on its own axis: a 1 % slip of PV is invisible on OP's 20 % scale
    ax_pv.plot(t, window.pv, lw=0.9, color="tab:orange", label="PV")
    if getattr(window, "sp", None) is not None:
        ax_pv.plot(t, window.sp, lw=0.8, ls="--", color="0.3", label="SP")
    model_pv = getattr(details, "model_pv", None) if details is not None else None
    if model_pv is not None:
        share = getattr(getattr(report, "process", None), "pv_explained_share", None)
        label = f"PV, identified model from OP ({course_share(share)})"
        ax_pv.plot(t[-len(model_pv) :], model_pv, lw=1.0, color="tab:green", label=label)
    ax_pv.set_ylabel("PV, percent", color="tab:orange")
    handles = ax_t.get_legend_handles_labels()[0] + ax_pv.get_legend_handles_labels()[0]
    ax_t.legend(handles=handles, loc="lower center", bbox_to_anchor=(0.5, 1.0), ncol=len(handles), fontsize=8)
    ax_c.plot(window.op, window.pv, ".", ms=2.5, color="0.6", label="measured")
    if getattr(report, "oscillating", True) and details is not None:
        ax_c.plot(details.denoised[:, 0], details.denoised[:, 1], ".", ms=2.5, color="tab:blue",
                  label="denoised (each sample on the curve)")  # fmt: skip
        ax_c.plot(details.curve[:, 0], details.curve[:, 1], "-", lw=1.5, color="tab:red", label="INLPCA curve")
    else:  # a closed curve through a record with no cycle would draw a shape the data do not have
        ax_c.set_title("no regular cycle: no INLPCA curve", fontsize=9)
    ax_c.set_xlabel("OP, percent")
    ax_c.set_ylabel("PV")
    ax_c.legend(loc="best", fontsize=8)
    if title:
        fig.suptitle(title, fontsize=10)
        fig.tight_layout()  # makes room for the suptitle (matplotlib >= 3.3)
    else:  # fixed margins: tight_layout draws the figure once more to measure it (half the cost of a page's figure)
        fig.subplots_adjust(left=0.06, right=0.97, bottom=0.13, top=0.88, wspace=0.3)
    fig.savefig(out, dpi=dpi, format="png")
    plt.close(fig)
    return out


def _diagnosis_title(report) -> str:
    from stiction.ident.models import is_lag_line
    from stiction.ident.report import causes_text

    causes = causes_text(report)
    if report.s_pct is not None and report.s_se_pct is not None:  # J without its error: not read
        j_pct = report.j_pct if report.j_se_pct is not None else None
        sj = _band(report.s_pct, report.s_se_pct, j_pct, report.j_se_pct, "±")
    else:
        sj = "no friction read"
    # S's error holds the actuator lag's doubt: the line it trades along says how a stroke test's lag narrows it
    sj += "".join(
        f" (S about {t.parameters['s_pct_at_no_lag']:.3g} - {t.parameters['s_pct_per_lag_s']:.3g} x the actuator's "
        "lag in s: a stroke test's lag reads it off)"
        for t in report.cannot_tell
        if is_lag_line(t)
    )
    head = (
        f"{report.loop_id}: {causes or 'no cause beyond the canonical loop'}; "
        f"fit error {report.base_error:.3g} → {report.extended_error:.3g} % (gain {report.gain_pct:.0f} %)"
    )
    # wrapped like the warnings after it: a long list of causes ran off both sides of the figure
    return _with_warnings(textwrap.wrap(head, TITLE_WIDTH) + textwrap.wrap(f"{report.process.description}; {sj}",
                                                                           TITLE_WIDTH), report.warnings)  # fmt: skip


MODEL_REACH = 1.0
"""A model's PV is drawn on the measured PV's axis while it stays within this many measured ranges of it."""


def pv_limits(measured: np.ndarray, models: list[np.ndarray]) -> tuple[float, float] | None:
    """The PV axis when a model strays more than ``MODEL_REACH`` measured ranges beyond the measured PV:
    the measured range with half a range either side, so that a model gone wild (a canonical model off by
    hundreds of percent) does not flatten the measured PV into a line; None while every model stays near."""
    lo, hi = float(np.min(measured)), float(np.max(measured))
    span = max(hi - lo, 1e-9 * max(1.0, abs(hi)))
    far = [m for m in models if np.min(m) < lo - MODEL_REACH * span or np.max(m) > hi + MODEL_REACH * span]
    return (lo - span / 2, hi + span / 2) if far else None


SPECTRUM_FLOOR = 1e-3
"""The residuals' spectra are shown down to this share of the lower model's median power."""


def plot_diagnosis(out: Path, record, d, report) -> Path:
    """Measured PV against the canonical and the extended model; OP and the model's stem; the OP-PV
    overlay; the residuals' spectra.  The causes, the gain and the report's warnings in the title."""
    from stiction.ident.friction import simulated_pv, stem_path

    t = record.t_s
    title = _diagnosis_title(report)
    fig, axes = plt.subplots(2, 2, figsize=(14, 7.6 + TITLE_LINE_IN * (title.count("\n") + 1)),
                             gridspec_kw={"width_ratios": [1.7, 1]})  # fmt: skip
    ax = axes[0, 0]
    extended = simulated_pv(d.extended.fit, record)
    models = {
        "canonical model": simulated_pv(d.base.fit, record),
        f"extended model ({course_share(report.process.pv_explained_share)})": extended,
    }
    ax.plot(t, record.pv_pct, color="0.35", lw=0.8, label="PV measured")
    for (label, pv), color in zip(models.items(), ("tab:red", "tab:blue"), strict=True):
        ax.plot(t, pv, color=color, lw=1.0, label=label)
    limits = pv_limits(record.pv_pct, list(models.values()))
    if limits is not None:
        ax.set_ylim(*limits)
        ax.text(0.01, 0.02, "a model runs off this axis: its fit error is in the title", transform=ax.transAxes,
                fontsize=8, color="tab:red")  # fmt: skip
    ax.set_ylabel("PV, %")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title("PV: the models driven by the measured OP", fontsize=9)
    ax = axes[1, 0]
    ax.plot(t, record.op_pct, color="tab:green", lw=0.8, label="OP")
    stem = stem_path(d.extended.fit, record)
    ax.plot(t, stem, color="tab:blue", lw=1.0, label="stem (extended model)")
    slips = d.extended.fit.slips
    if slips.at.size:
        ax.plot(t[slips.at], stem[slips.at], "|", color="k", ms=8, label="slips")
    ax.set_xlabel("time, s")
    ax.set_ylabel("OP, stem, %")
    ax.legend(loc="upper right", fontsize=8)
    ax = axes[0, 1]
    # the model behind, the measured loop drawn over it: where they differ the measured one must stay readable
    ax.plot(record.op_pct, extended, "-", lw=0.6, color="tab:blue", alpha=0.45,
            label="extended model")  # fmt: skip
    ax.plot(record.op_pct, record.pv_pct, ".", ms=2, color="0.15", label="measured")
    ax.set_xlabel("OP, %")
    ax.set_ylabel("PV, %")
    ax.legend(loc="best", fontsize=8)
    ax.set_title("OP-PV", fontsize=9)
    ax = axes[1, 1]
    levels = []
    for model, color, label in ((d.base, "tab:red", "canonical"), (d.extended, "tab:blue", "extended")):
        resid = record.target - model.fit.fit.prediction
        spec = np.abs(np.fft.rfft(resid - resid.mean())) ** 2 / resid.size
        freq = np.fft.rfftfreq(resid.size, record.ts_s)
        shown = spec[1:] > 0  # a flat PV leaves nothing to show on a log scale
        if shown.any():
            ax.loglog(1 / freq[1:][shown], spec[1:][shown], lw=0.8, color=color, label=f"{label} residual")
            levels.append(np.median(spec[1:][shown]))
    if levels:  # a sine fitted exactly leaves a bin at rounding (1e-28): no finding, kept off the scale
        ax.set_ylim(bottom=SPECTRUM_FLOOR * min(levels))
    ax.set_xlabel("period, s")
    ax.set_ylabel("power of the one-sample error")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="best", fontsize=8)
    else:
        ax.text(0.5, 0.5, "no error left to show: PV does not move", ha="center", transform=ax.transAxes)
    ax.set_title("where the models fail, by period", fontsize=9)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(out, dpi=80)
    plt.close(fig)
    return out
