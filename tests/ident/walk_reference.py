"""The valve model's walk sample by sample: the plain transcription ``ident.fit.walk`` is checked against."""

from __future__ import annotations

import numpy as np

from stiction.ident.fit import _as_slips, _breaks
from stiction.ident.valve_model import Drive, Slips
from stiction.sim.valve import slide_speed_pct_s


def walk_by_sample(
    read: Slips, drive: Drive, band: np.ndarray, stop: np.ndarray, level0: np.ndarray, window: int,
    read_levels: np.ndarray | None = None,
) -> list[Slips]:
    out = []
    lagged = drive.moves and 0 < drive.decay < 1
    tau = -1 / np.log(drive.decay) if lagged else 0.0  # intervals
    for c in range(band.size):
        level = float(level0[c])
        used = np.zeros(read.at.size, bool)
        events = []
        anchor_of = {int(k): j for j, k in enumerate(read.at)}
        speed = float(slide_speed_pct_s(12.0 * (band[c] - stop[c]))) * drive.ts_s
        sliding = None  # the direction a sliding stem moves in
        for k in range(1, drive.end.size):
            j = anchor_of.get(k)
            s0, e0 = drive.start[k], drive.end[k]
            op = (e0 - drive.decay * s0) / (1 - drive.decay) if lagged else e0
            if sliding is not None:
                rate = abs(op - s0) / tau
                t_c = (tau * np.log(rate / speed) if speed > 0 else np.inf) if rate > speed else 0.0
                # a shorter slide, or one along a drive that hardly moves, is none: it sticks where it is
                if (e0 - s0) * sliding > 1e-9 and t_c > 1e-6:
                    if j is not None and not used[j] and read.directions[j] == sliding:
                        used[j] = True
                    if t_c >= 1:
                        land, share = e0, (e0 - drive.mean[k]) / (e0 - s0)
                    else:
                        land = op + (s0 - op) * np.exp(-t_c / tau)
                        # the drive's mean until it slows, then the stuck stem's level: the flow the slip's share mixes
                        area = op * t_c + (s0 - op) * tau * (1 - np.exp(-t_c / tau)) + (1 - t_c) * land
                        share = (land - area) / (land - s0)
                    events.append((k, sliding, -share, float(land), False, 0.0))
                    level = float(land) - sliding * stop[c]
                    sliding = sliding if t_c >= 1 else None
                    continue
                sliding = None
            gap = drive.end[k] - level
            if abs(gap) > band[c]:
                d = int(np.sign(gap))
                brk, land = _breaks(drive, k, np.array([level]), np.array([d]), band[c : c + 1])
                brk, land = float(brk[0]), float(land[0])
                slid = lagged and np.sign(op - s0) == d and abs(op - land) / tau > speed
                offset = 0.0
                if slid:
                    t_e = min(brk + tau * np.log(abs(op - land) / tau / speed), 1.0) if speed > 0 else 1.0
                    land = e0 if t_e >= 1 else op + (s0 - op) * np.exp(-t_e / tau)
                    sliding = d if t_e >= 1 else None
                    # from the break to t_e the stem follows the drive: its mean there, less the landing's
                    ts = np.linspace(brk, t_e, 2001)
                    offset = float(np.trapezoid(op + (s0 - op) * np.exp(-ts / tau), ts)) - (t_e - brk) * land
                events.append((k, d, -brk if slid else brk, land, False, offset))
                level = land - d * stop[c]
                near = [i for i in range(read.at.size) if abs(read.at[i] - k) <= window and read.directions[i] == d]
                near = [i for i in near if not used[i]]
                if near:
                    i = min(near, key=lambda i: abs(read.at[i] - k))
                    used[i] = True
                    # the observer: the data's landing where it is short of the model's, never past it
                    if read_levels is not None and not slid and d * (read_levels[i] - level) < 0:
                        level = float(read_levels[i])
                continue
            if j is not None and not used[j]:
                d = int(read.directions[j])
                ahead = drive.end[k + 1 : k + 1 + window]
                # the model slips this way by itself within the window: leave it to the model
                first = next((i for i, x in enumerate(ahead) if abs(x - level) > band[c]), None)
                if first is not None and np.sign(ahead[first] - level) == d:
                    continue
                events.append((k, d, 0.0, float(drive.mean[k]), True, 0.0))
                used[j] = True
                level = float(drive.mean[k]) - d * stop[c] if read_levels is None else float(read_levels[j])
        out.append(_as_slips(events))
    return out
