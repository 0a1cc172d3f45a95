"""The valve model's walk sample by sample: the plain transcription ``ident.fit.walk`` is checked against."""

from __future__ import annotations

import numpy as np

from stiction.ident.fit import _as_slips, _breaks
from stiction.ident.valve_model import Drive, Slips


def walk_by_sample(
    read: Slips, drive: Drive, band: np.ndarray, stop: np.ndarray, level0: np.ndarray, window: int,
    read_levels: np.ndarray | None = None,
) -> list[Slips]:
    out = []
    for c in range(band.size):
        level = float(level0[c])
        used = np.zeros(read.at.size, bool)
        events = []
        anchor_of = {int(k): j for j, k in enumerate(read.at)}
        for k in range(1, drive.end.size):
            gap = drive.end[k] - level
            j = anchor_of.get(k)
            if abs(gap) > band[c]:
                d = int(np.sign(gap))
                brk, land = _breaks(drive, k, np.array([level]), np.array([d]), band[c : c + 1])
                events.append((k, d, float(brk[0]), float(land[0]), False))
                level = float(land[0]) - d * stop[c]
                near = [i for i in range(read.at.size) if abs(read.at[i] - k) <= window and read.directions[i] == d]
                near = [i for i in near if not used[i]]
                if near:
                    i = min(near, key=lambda i: abs(read.at[i] - k))
                    used[i] = True
                    # the observer: the data's landing where it is short of the model's, never past it
                    if read_levels is not None and d * (read_levels[i] - level) < 0:
                        level = float(read_levels[i])
                continue
            if j is not None and not used[j]:
                d = int(read.directions[j])
                ahead = drive.end[k + 1 : k + 1 + window]
                # the model slips this way by itself within the window: leave it to the model
                first = next((i for i, x in enumerate(ahead) if abs(x - level) > band[c]), None)
                if first is not None and np.sign(ahead[first] - level) == d:
                    continue
                events.append((k, d, 0.0, float(drive.mean[k]), True))
                used[j] = True
                level = float(drive.mean[k]) - d * stop[c] if read_levels is None else float(read_levels[j])
        out.append(_as_slips(events))
    return out
