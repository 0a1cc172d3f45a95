"""Static PNGs for people who will not open a viewer: ``stiction quantify --plot DIR``."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def _title(report) -> str:
    if report.fs_pct is None:
        return f"{report.loop_id}: no estimate ({'; '.join(report.warnings)[:80]})"
    se = f" +- {report.fs_se_pct:.2f}/{report.fd_se_pct:.2f}" if report.fs_se_pct is not None else ""
    return (
        f"{report.loop_id}: fs {report.fs_pct:.1f} %, fd {report.fd_pct:.1f} % of 500 lbf{se} "
        f"(S {report.s_pct:.1f} %, J {report.j_pct:.1f} % of span; {report.method})"
    )


def plot_loop(out: Path, window, report, details) -> Path:
    """OP and PV over time; the OP-PV curve before and after denoising; the estimate in the title."""
    t = (window.t_end_s or 0.0) - window.ts_s * np.arange(len(window.op))[::-1]
    fig, (ax_t, ax_c) = plt.subplots(1, 2, figsize=(13, 4.5), gridspec_kw={"width_ratios": [1.6, 1]})
    ax_t.plot(t, window.op, lw=0.9, label="OP")
    ax_t.plot(t, window.pv, lw=0.9, label="PV")
    ax_t.set_xlabel("time, s")
    ax_t.set_ylabel("percent")
    ax_t.legend(loc="upper right")
    ax_c.plot(window.op, window.pv, ".", ms=2.5, color="0.6", label="measured")
    ax_c.plot(
        details.denoised[:, 0],
        details.denoised[:, 1],
        ".",
        ms=2.5,
        color="tab:blue",
        label="denoised (each sample on the curve)",
    )
    ax_c.plot(details.curve[:, 0], details.curve[:, 1], "-", lw=1.5, color="tab:red", label="INLPCA curve")
    ax_c.set_xlabel("OP, percent")
    ax_c.set_ylabel("PV")
    ax_c.legend(loc="best", fontsize=8)
    fig.suptitle(_title(report), fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    plt.close(fig)
    return out
