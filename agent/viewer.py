"""The agent's rerun sink: the only module that imports rerun.

Per loop: the window's raw OP-PV points, the INLPCA curve, each sample's projection
onto it (the clean loop), OP and PV over time, the fs/fd estimates over time with
the truth where the simulator publishes it, and the report's flags.  Entity paths
come from ``path``; history goes in with ``send_columns``, live values with
``set_time`` + ``log``; static styling is logged once per loop.

PV is plotted upwards: a 2D view's y axis points down, so points are logged as
``(OP, -PV)``.

A recording you can keep (at most about 10 MB a minute for the demo's 40 loops): the OP-PV
clouds are thinned to ``max_cloud_points`` and logged at most every ``min_cloud_interval_s``
of wall clock per loop, the INLPCA curve only when it has moved, the flags when they change,
and OP and PV history on a uniform sub-grid of at most ``max_series_points`` new samples a
report.  Estimates go in with every report.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Sequence
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


MAX_CLOUD_POINTS = 250
MIN_CLOUD_INTERVAL_S = 5.0
MAX_SERIES_POINTS = 30
FLUSH_TICK_S = 2.0
CURVE_MOVED = 0.01
"""The curve is logged again once a point of it moved by this share of its extent."""


def thin(n: int, max_points: int) -> slice:
    """Every k-th of ``n`` samples, ending at the last, so that at most ``max_points`` remain."""
    k = max(1, math.ceil(n / max_points))
    return slice((n - 1) % k, n, k)


class RerunSink:
    """``mode``: ``save:PATH`` (a recording file), ``spawn`` (a native viewer) or ``serve`` (web viewer)."""

    def __init__(
        self,
        mode: str,
        application_id: str = "stiction",
        web_port: int = 9090,
        grpc_port: int = 9876,
        max_cloud_points: int = MAX_CLOUD_POINTS,
        min_cloud_interval_s: float = MIN_CLOUD_INTERVAL_S,
        max_series_points: int = MAX_SERIES_POINTS,
        clock: Callable[[], float] = time.monotonic,
    ):
        self.mode = mode
        self.max_cloud_points = max_cloud_points
        self.min_cloud_interval_s = min_cloud_interval_s
        self.max_series_points = max_series_points
        self.clock = clock
        self._cloud_at: dict[str, float] = {}
        self._curve: dict[str, np.ndarray] = {}
        self._flags: dict[str, str] = {}
        self._stride: dict[str, int] = {}
        self._buffers: dict[str, dict[str, list]] = {}
        self.url: str | None = None
        self.web_port = web_port
        self._styled: set[str] = set()
        self._last_t: dict[str, float] = {}
        self._loops: list[str] = []
        # rows of one entity logged within a flush tick share a chunk: per-chunk overhead, not data,
        # was most of a recording of many small logs
        batcher = rr.ChunkBatcherConfig(flush_tick=FLUSH_TICK_S, flush_num_bytes=8 * 1024 * 1024)
        self.recording = rr.RecordingStream(application_id, batcher_config=batcher)
        self._truth: dict[str, tuple[float, float]] = {}
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
        """One report with its window (``quantify.pipeline.Window``) and ``Details``; ``truth``: (fs, fd) if known.

        History (OP, PV, the estimates) is buffered per loop and sent with the loop's clouds."""
        loop_id, rec = report.loop_id, self.recording
        self._style(loop_id)
        buf = self._buffers.setdefault(loop_id, {"t": [], "op": [], "pv": [], "est_t": [], "fs": [], "fd": []})
        t_end = float(window.t_end_s if window.t_end_s is not None else len(window.op) - 1)
        t = t_end - window.ts_s * np.arange(len(window.op))[::-1]
        new = t > self._last_t.get(loop_id, -np.inf)
        if new.any():
            # a uniform sub-grid of the stream (sample index a multiple of the loop's stride), the same every report
            stride = self._stride.setdefault(loop_id, max(1, math.ceil(int(new.sum()) / self.max_series_points)))
            keep = new & (np.round(t / window.ts_s).astype(np.int64) % stride == 0)
            buf["t"].append(t[keep])
            buf["op"].append(np.asarray(window.op, float)[keep])
            buf["pv"].append(np.asarray(window.pv, float)[keep])
            self._last_t[loop_id] = float(t[-1])
        if report.fs_pct is not None:
            buf["est_t"].append(t_end)
            buf["fs"].append(report.fs_pct)
            buf["fd"].append(report.fd_pct)
        rec.set_time(TIMELINE, duration=t_end)
        if truth is not None and self._truth.get(loop_id) != tuple(truth):  # the truth is logged where it changes
            self._truth[loop_id] = tuple(truth)
            rec.log(path(loop_id, "fs_true"), rr.Scalars(truth[0]))
            rec.log(path(loop_id, "fd_true"), rr.Scalars(truth[1]))
        now = self.clock()
        if now - self._cloud_at.get(loop_id, -math.inf) >= self.min_cloud_interval_s:
            self._cloud_at[loop_id] = now
            self._log_clouds(loop_id, window, details, bool(getattr(report, "oscillating", True)))
            flags = _flags_markdown(report)
            if self._flags.get(loop_id) != flags:  # the flags with the clouds they describe
                self._flags[loop_id] = flags
                rec.log(path(loop_id, "flags"), rr.TextDocument(flags, media_type="text/markdown"))
            self._flush(loop_id)

    def _flush(self, loop_id: str) -> None:
        """A loop's buffered history, one chunk per entity."""
        buf, rec = self._buffers.get(loop_id), self.recording
        if not buf:
            return
        if buf["t"]:
            times = rr.TimeColumn(TIMELINE, duration=np.concatenate(buf["t"]))
            for what in ("op", "pv"):
                values = rr.Scalars.columns(scalars=np.concatenate(buf[what]))
                rec.send_columns(path(loop_id, what), indexes=[times], columns=values)
        if buf["est_t"]:
            times = rr.TimeColumn(TIMELINE, duration=np.asarray(buf["est_t"]))
            rec.send_columns(path(loop_id, "fs_est"), indexes=[times], columns=rr.Scalars.columns(scalars=buf["fs"]))
            rec.send_columns(path(loop_id, "fd_est"), indexes=[times], columns=rr.Scalars.columns(scalars=buf["fd"]))
        for v in buf.values():
            v.clear()

    def _log_clouds(self, loop_id: str, window, details, oscillating: bool = True) -> None:
        """The OP-PV points thinned, and the curve where it moved since it was last logged; over a
        window without a cycle the raw points alone (the curve and its points cleared once: a closed
        curve through a record with no cycle draws a shape the data do not have)."""
        rec, sl = self.recording, thin(len(window.op), self.max_cloud_points)
        op, pv = np.asarray(window.op, np.float32)[sl], np.asarray(window.pv, np.float32)[sl]
        rec.log(path(loop_id, "raw"), rr.Points2D(np.column_stack([op, -pv]), radii=0.08, colors=[150, 150, 150]))
        if not oscillating:
            if self._curve.pop(loop_id, None) is not None:
                rec.log(path(loop_id, "clean"), rr.Clear(recursive=False))
                rec.log(path(loop_id, "curve"), rr.Clear(recursive=False))
            return
        clean = np.asarray(details.denoised, np.float32)[sl]
        rec.log(
            path(loop_id, "clean"),
            rr.Points2D(np.column_stack([clean[:, 0], -clean[:, 1]]), radii=0.12, colors=[31, 119, 180]),
        )
        curve = np.column_stack([details.curve[:, 0], -details.curve[:, 1]]).astype(np.float32)
        last = self._curve.get(loop_id)
        extent = float(np.ptp(curve, axis=0).max()) if curve.size else 0.0
        if last is None or last.shape != curve.shape or np.abs(curve - last).max() > CURVE_MOVED * max(extent, 1e-9):
            self._curve[loop_id] = curve
            rec.log(path(loop_id, "curve"), rr.LineStrips2D([curve], colors=[214, 39, 40], radii=0.06))

    def close(self) -> None:
        for loop_id in list(self._buffers):
            self._flush(loop_id)
        self.recording.flush()
        self.recording.disconnect()
