"""The fitted reading's inner loop, compiled: the physical valve driven by the recorded OP, integrated by the level
process, against the recorded PV, for many candidate frictions at once.

``ident.open_loop`` keeps the definition (``stem_path``, numpy, one candidate); tests/ident/test_open_loop.py
holds this kernel to it.  A candidate costs one pass over the window (1,000 samples: about 3 us); a fit
tries some 60,000.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True, error_model="numpy")
def segment_rss(op, pv, fs_lbf, stop_lbf, mv0, slip_share, gain_ts, lbf_per_pct, segment):
    """[C] residual sum of squares of PV against each candidate's simulated level, with a free offset in every
    stretch of ``segment`` samples (the whole window when ``segment >= op.size``).

    Candidate ``c``: a stem that starts stuck at ``mv0[c]``, breaks away when ``|lbf_per_pct (OP - MV)|`` exceeds
    ``fs_lbf[c]`` and stops with ``stop_lbf[c]`` left (``sim.valve.valve_step``); the interval's mean flow is the
    stem's end less the slip's withheld flow (``jump * slip_share``, ``slip_s / ts_s``: ``sim.actuator.actuate``);
    the level rises by ``gain_ts`` (gain times ``ts_s``) times it (``sim.loop.advance`` for ``gain / s``)."""
    n = op.size
    out = np.empty(fs_lbf.size)
    for c in range(fs_lbf.size):
        mv = mv0[c]
        level = 0.0
        total = 0.0
        s1 = 0.0
        s2 = 0.0
        count = 0
        for k in range(n):
            r = pv[k] - level
            s1 += r
            s2 += r * r
            count += 1
            if count == segment or k == n - 1:
                total += s2 - s1 * s1 / count
                s1 = 0.0
                s2 = 0.0
                count = 0
            force = lbf_per_pct * (op[k] - mv)
            flow = mv
            if abs(force) > fs_lbf[c]:
                jump = (force - np.sign(force) * stop_lbf[c]) / lbf_per_pct
                mv += jump
                flow = mv - jump * slip_share
            level += gain_ts * flow
        out[c] = total
    return out
