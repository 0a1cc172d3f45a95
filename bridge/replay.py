"""Historian exports replayed as streams: the exports read into tracks (``read_tracks``), and which
samples of which loop are due after how long (``Schedule``, pure).

Every export becomes one loop (its id from the file name), all starting together; after
``elapsed_s`` of wall clock at ``speed`` times real time, a loop has sent every sample up to
``elapsed_s * speed`` seconds into its file.  Batches carry the file's own times (``t0_s``) and
``seq`` counts samples from the file's first, so the agent sees the recorded loop as it ran.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from stiction.bridge.historian import Export, expand_paths, read_export
from stiction.schemas.errors import InputError, StictionError
from stiction.schemas.messages import MAX_BATCH_SAMPLES

_NOT_IN_ID = re.compile(r"[^A-Za-z0-9_.:=+#-]")


@dataclass(frozen=True)
class Track:
    """One export as a stream: evenly spaced samples (an export's stretch after its last gap in time: ``notes``)."""

    loop_id: str
    ts_s: float
    t0_s: float
    op: np.ndarray
    pv: np.ndarray
    sp: np.ndarray | None = None
    mv: np.ndarray | None = None
    mode: np.ndarray | None = None
    process: str | None = None
    source: str | None = None
    """The export it was read from."""
    notes: tuple[str, ...] = ()
    """What the reader left out of the export (a gap in its time column, and what came before it)."""

    @property
    def duration_s(self) -> float:
        return self.op.size * self.ts_s


def loop_ids(paths: Sequence[Path]) -> list[str]:
    """A key-safe loop id per file, from its name: characters a key cannot hold become '_', and
    files of the same name in different folders get ``-2``, ``-3``..."""
    out, seen = [], {}
    for p in paths:
        base = _NOT_IN_ID.sub("_", Path(p).stem)[:190] or "loop"
        if base[0] == "#":
            base = "_" + base[1:]
        n = seen[base] = seen.get(base, 0) + 1
        out.append(base if n == 1 else f"{base}-{n}")
    return out


def track(loop_id: str, export: Export, process: str | None = None) -> Track:
    t0 = float(export.t_s[0]) if export.t_s is not None and len(export.t_s) else 0.0
    gaps = () if export.gap_note is None else (export.gap_note,)
    return Track(
        loop_id, export.ts_s, t0, export.op, export.pv, export.sp, export.mv, export.mode, process, str(export.path),
        gaps,
    )  # fmt: skip


class Schedule:
    def __init__(self, tracks: Sequence[Track], speed: float, rate_hz: float | None = None, groups: int = 1):
        """``rate_hz``: each loop sends at most this often, what came due since its last message in
        one batch; ``groups``: the loops take turns over each interval (``bridge.publish.stagger_groups``,
        loop ``i`` offset by ``(i mod groups) / groups`` of it) instead of all sending at once."""
        self.tracks = list(tracks)
        self.speed = float(speed)
        self.rate_hz = rate_hz
        self.groups = max(1, min(int(groups), len(self.tracks) or 1))
        self.phase_s = (
            np.zeros(len(self.tracks))
            if rate_hz is None
            else (np.arange(len(self.tracks)) % self.groups) / self.groups / rate_hz
        )
        self.sent = [0] * len(self.tracks)
        self.samples_published = 0

    @property
    def step_s(self) -> float | None:
        """How often a publisher should ask what is due: each group's turn (None: whenever it likes)."""
        return None if self.rate_hz is None else 1.0 / self.rate_hz / self.groups

    @property
    def done(self) -> bool:
        return all(n == t.op.size for n, t in zip(self.sent, self.tracks, strict=True))

    @property
    def duration_s(self) -> float:
        """Wall-clock seconds until every track has been sent."""
        return max((t.duration_s for t in self.tracks), default=0.0) / self.speed

    def due(self, elapsed_s: float) -> list[dict]:
        """``SampleBatch`` dicts of every sample due by ``elapsed_s`` of wall clock and not yet sent."""
        out = []
        for i, t in enumerate(self.tracks):
            clock_s = elapsed_s
            if self.rate_hz is not None:  # this loop's last turn: its own tick, offset by its group
                turn = np.floor((elapsed_s - self.phase_s[i]) * self.rate_hz + 1e-9)
                clock_s = turn / self.rate_hz + self.phase_s[i]
                if turn < 0:
                    continue
            upto = min(t.op.size, int(np.floor(clock_s * self.speed / t.ts_s + 1e-9)) + 1)
            for lo in range(self.sent[i], upto, MAX_BATCH_SAMPLES):
                hi = min(lo + MAX_BATCH_SAMPLES, upto)
                batch = {
                    "schema_version": 1,
                    "loop_id": t.loop_id,
                    "seq": lo,
                    "t0_s": t.t0_s + lo * t.ts_s,
                    "ts_s": t.ts_s,
                    "op": t.op[lo:hi].tolist(),
                    "pv": t.pv[lo:hi].tolist(),
                    "process": t.process,
                }
                for name in ("sp", "mv", "mode"):
                    x = getattr(t, name)
                    if x is not None and np.all(np.isfinite(x[lo:hi])):
                        batch[name] = x[lo:hi].astype(float).tolist()
                out.append(batch)
                self.samples_published += hi - lo
            self.sent[i] = max(self.sent[i], upto)
        return out


def read_tracks(
    paths: Sequence[Path | str],
    ts_s: float | None,
    process: str | None,
    min_samples: int,
    pv_span: tuple[float, float] | None = None,
) -> tuple[list[Track], list[tuple[Path, StictionError]]]:
    """One track per readable export of ``paths`` (files or folders), in order; each unreadable one
    with its error (one loop's bad file never stops the others).  ``min_samples``: fewer samples
    than this is an error (the agent could never report such a loop)."""
    files = expand_paths(paths)
    tracks, failed = [], []
    for path, loop_id in zip(files, loop_ids(files), strict=True):
        try:
            export = read_export(path, ts_s, pv_span=pv_span)
            if export.op.size < min_samples:
                raise InputError(f"{path}: {export.op.size} samples, need at least {min_samples}")
            tracks.append(track(loop_id, export, process))
        except StictionError as e:
            failed.append((path, e))
    return tracks, failed
