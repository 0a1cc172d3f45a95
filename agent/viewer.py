"""The agent's rerun sink: the only module that imports rerun.

Per loop: the window's raw OP-PV points, the INLPCA curve, each sample's projection
onto it (the clean loop), OP and PV over time, the fs/fd estimates over time with
the truth where the simulator publishes it, and the report's flags.  Entity paths
come from ``path``; history goes in with ``send_columns``, live values with
``set_time`` + ``log``; static styling is logged once per loop.

PV is plotted upwards: a 2D view's y axis points down, so points are logged as
``(OP, -PV)``.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from urllib.parse import quote

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

log = logging.getLogger(__name__)

TIMELINE = "stream_time"
ENTITIES = {
    "raw": "op_pv/raw",
    "curve": "op_pv/inlpca_curve",
    "clean": "op_pv/clean",
    "op": "signals/op",
    "pv": "signals/pv",
    "fs_est": "estimates/fs_pct",
    "fd_est": "estimates/fd_pct",
    "fs_true": "estimates/fs_true_pct",
    "fd_true": "estimates/fd_true_pct",
    "flags": "flags",
}


def path(loop_id: str, what: str) -> str:
    """The one place entity paths are made: ``loops/{loop_id}/{...}``."""
    return f"loops/{loop_id}/{ENTITIES[what]}"


# blueprint: small pure functions ------------------------------------------------------------------
def op_pv_view(loop_id: str) -> rrb.Spatial2DView:
    return rrb.Spatial2DView(origin=f"loops/{loop_id}/op_pv", name=f"{loop_id}: OP (right) vs PV (up)")


def overview(loop_ids: Sequence[str]) -> rrb.Grid:
    return rrb.Grid(*[op_pv_view(i) for i in loop_ids], name="overview")


def detail(loop_id: str) -> rrb.Vertical:
    return rrb.Vertical(
        rrb.Horizontal(
            op_pv_view(loop_id),
            rrb.TextDocumentView(origin=f"loops/{loop_id}/flags", name="flags"),
            column_shares=[3, 1],
        ),
        rrb.TimeSeriesView(origin=f"loops/{loop_id}/signals", name=f"{loop_id}: OP and PV"),
        rrb.TimeSeriesView(origin=f"loops/{loop_id}/estimates", name=f"{loop_id}: fs, fd estimated and true"),
        name=f"detail {loop_id}",
    )


def blueprint(loop_ids: Sequence[str], detail_loop: str | None = None) -> rrb.Blueprint:
    shown = list(loop_ids)[:16]
    tabs = [overview(shown)] if shown else []
    if detail_loop or shown:
        tabs.append(detail(detail_loop or shown[0]))
    return rrb.Blueprint(rrb.Tabs(*tabs), collapse_panels=True)


def _flags_markdown(report) -> str:
    lines = [
        f"**{report.loop_id}**: method `{report.method}`, denoised {'yes' if report.denoised else 'no'}",
        f"- oscillating: {'yes' if report.oscillating else 'no'}",
        f"- ood score: {report.ood_score:.2f}" if report.ood_score is not None else "- ood score: -",
    ]
    lines += [f"- warning: {w}" for w in report.warnings]
    return "\n".join(lines)


class RerunSink:
    """``mode``: ``save:PATH`` (a recording file), ``spawn`` (a native viewer) or ``serve`` (web viewer)."""

    def __init__(self, mode: str, application_id: str = "stiction", web_port: int = 9090, grpc_port: int = 9876):
        self.mode = mode
        self.url: str | None = None
        self.web_port = web_port
        self._styled: set[str] = set()
        self._last_t: dict[str, float] = {}
        self._loops: list[str] = []
        self.recording = rr.RecordingStream(application_id)
        if mode.startswith("save:"):
            self.recording.save(mode[5:])
        elif mode == "spawn":
            self.recording.spawn()
        elif mode == "serve":
            self.url = self.recording.serve_grpc(grpc_port=grpc_port)
            rr.serve_web_viewer(web_port=web_port, open_browser=False, connect_to=self.url)
            log.info("rerun web viewer on http://127.0.0.1:%d (data %s)", web_port, self.url)
        else:
            raise ValueError(f"--rerun {mode!r}: expected save:PATH, spawn or serve")

    def web_url(self) -> str:
        """The served web viewer, already pointed at this sink's data."""
        return f"http://127.0.0.1:{self.web_port}/?url={quote(self.url, safe='')}"

    def _style(self, loop_id: str) -> None:
        if loop_id in self._styled:
            return
        self._styled.add(loop_id)
        self._loops.append(loop_id)
        rec = self.recording
        rec.log(path(loop_id, "op"), rr.SeriesLines(names="OP %", colors=[31, 119, 180]), static=True)
        rec.log(path(loop_id, "pv"), rr.SeriesLines(names="PV %", colors=[214, 39, 40]), static=True)
        rec.log(path(loop_id, "fs_est"), rr.SeriesLines(names="fs estimated", colors=[31, 119, 180]), static=True)
        rec.log(path(loop_id, "fd_est"), rr.SeriesLines(names="fd estimated", colors=[255, 127, 14]), static=True)
        rec.log(
            path(loop_id, "fs_true"),
            rr.SeriesPoints(names="fs true", colors=[31, 119, 180], marker_sizes=2),
            static=True,
        )
        rec.log(
            path(loop_id, "fd_true"),
            rr.SeriesPoints(names="fd true", colors=[255, 127, 14], marker_sizes=2),
            static=True,
        )
        if len(self._loops) in (1, 4, 16):  # the overview grows with the first loops, not on every one
            self.recording.send_blueprint(blueprint(self._loops))

    def log_report(self, report, window, details, truth=None) -> None:
        """One report with its window (``agent.pipeline.Window``) and ``Details``; ``truth``: (fs, fd) if known."""
        loop_id, rec = report.loop_id, self.recording
        self._style(loop_id)
        t_end = float(window.t_end_s if window.t_end_s is not None else len(window.op) - 1)
        t = t_end - window.ts_s * np.arange(len(window.op))[::-1]
        new = t > self._last_t.get(loop_id, -np.inf)
        if new.any():
            times = rr.TimeColumn(TIMELINE, duration=t[new])
            rec.send_columns(path(loop_id, "op"), indexes=[times], columns=rr.Scalars.columns(scalars=window.op[new]))
            rec.send_columns(path(loop_id, "pv"), indexes=[times], columns=rr.Scalars.columns(scalars=window.pv[new]))
            self._last_t[loop_id] = float(t[-1])
        rec.set_time(TIMELINE, duration=t_end)
        rec.log(
            path(loop_id, "raw"),
            rr.Points2D(np.column_stack([window.op, -window.pv]), radii=0.08, colors=[150, 150, 150]),
        )
        rec.log(
            path(loop_id, "clean"),
            rr.Points2D(
                np.column_stack([details.denoised[:, 0], -details.denoised[:, 1]]), radii=0.12, colors=[31, 119, 180]
            ),
        )
        rec.log(
            path(loop_id, "curve"),
            rr.LineStrips2D(
                [np.column_stack([details.curve[:, 0], -details.curve[:, 1]])], colors=[214, 39, 40], radii=0.06
            ),
        )
        if report.fs_pct is not None:
            rec.log(path(loop_id, "fs_est"), rr.Scalars(report.fs_pct))
            rec.log(path(loop_id, "fd_est"), rr.Scalars(report.fd_pct))
        if truth is not None:
            rec.log(path(loop_id, "fs_true"), rr.Scalars(truth[0]))
            rec.log(path(loop_id, "fd_true"), rr.Scalars(truth[1]))
        rec.log(path(loop_id, "flags"), rr.TextDocument(_flags_markdown(report), media_type="text/markdown"))

    def close(self) -> None:
        self.recording.flush()
        self.recording.disconnect()
