"""Many loops as an endless stream: the batch simulator advanced chunk by chunk.

Disturbances keep the relative amplitudes of the spec (scaled on the clean loop's RMS
over samples 1000..1999) and the very same random draws as ``simulate``: the first
``DURATION_S`` samples of a stream equal ``simulate(specs)`` sample for sample; after
that, white noise keeps drawing from the loop's generator and a brownian walk keeps
walking with the normalisation of its first 2000 samples.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from stiction.sim.disturbance import rms, unit_shape
from stiction.sim.loop import (
    DURATION_S,
    TS_S,
    WARMUP_S,
    LoopSpec,
    LoopState,
    advance,
    build_batch,
    external_oscillation,
    simulate,
)


@dataclass(frozen=True)
class Chunk:
    """``n`` consecutive samples of every loop: arrays ``(n_loops, n)``; ``seq`` of the first sample."""

    seq: int
    t0_s: float
    op: np.ndarray
    pv: np.ndarray
    sp: np.ndarray
    mv: np.ndarray


class LoopStream:
    def __init__(self, specs: Sequence[LoopSpec], ts_s: float = TS_S):
        self.specs = tuple(specs)
        self.ts_s = ts_s
        self.batch = build_batch(self.specs, ts_s)
        self.state = LoopState.at_rest(self.batch)
        n = len(self.specs)
        n_ref = int(DURATION_S / ts_s)
        clean = simulate([replace(s, disturbance=None) for s in self.specs], DURATION_S, ts_s).kept(WARMUP_S)
        self._rms_mv, self._rms_pv = rms(clean.mv), rms(clean.pv)
        self._rngs = [np.random.default_rng(s.seed) for s in self.specs]
        # the first n_ref samples of every shape exactly as simulate() draws them
        self._head = np.zeros((n, n_ref))
        self._walk_end = np.zeros(n)
        self._walk_norm = np.ones((n, 2))  # (mean, std) of the raw walk over its first n_ref samples
        for i, s in enumerate(self.specs):
            d = s.disturbance
            if d is None or d.coefficient == 0 or d.shape == "sine":
                continue
            if d.shape == "gaussian":
                self._head[i] = unit_shape("gaussian", n_ref, ts_s, self._rngs[i])
            else:
                walk = np.cumsum(self._rngs[i].standard_normal(n_ref))
                mean, std = walk.mean(), np.sqrt(np.mean((walk - walk.mean()) ** 2))
                self._head[i] = (walk - mean) / std
                self._walk_end[i], self._walk_norm[i] = walk[-1], (mean, std)
        self.seq = 0

    def _shapes(self, k0: int, n: int) -> tuple[np.ndarray, np.ndarray]:
        """Input and output disturbances for samples ``k0 .. k0+n-1``."""
        w, z = np.zeros((len(self.specs), n)), np.zeros((len(self.specs), n))
        k = k0 + np.arange(n)
        n_ref = self._head.shape[1]
        for i, s in enumerate(self.specs):
            d = s.disturbance
            if d is None or d.coefficient == 0:
                continue
            if d.shape == "sine":
                shape = np.sin(d.omega_rad_s * self.ts_s * k)
            else:
                shape = np.empty(n)
                head = k < n_ref
                shape[head] = self._head[i, k[head]]
                m = int((~head).sum())
                if m:
                    white = self._rngs[i].standard_normal(m)
                    if d.shape == "gaussian":
                        shape[~head] = white
                    else:
                        walk = self._walk_end[i] + np.cumsum(white)
                        self._walk_end[i] = walk[-1]
                        shape[~head] = (walk - self._walk_norm[i, 0]) / self._walk_norm[i, 1]
            scale = self._rms_mv[i] if d.where == "input" else self._rms_pv[i]
            (w if d.where == "input" else z)[i] = d.coefficient * scale * shape
        w += external_oscillation(self.specs, k * self.ts_s)
        return w, z

    def next(self, n: int) -> Chunk:
        """Advance every loop by ``n`` samples."""
        w, z = self._shapes(self.seq, n)
        n_loops = len(self.specs)
        op, pv, mv = (np.empty((n_loops, n)) for _ in range(3))
        for j in range(n):
            mv[:, j] = self.state.mv
            self.state, op[:, j], pv[:, j] = advance(self.batch, self.state, w[:, j], z[:, j], self.ts_s)
        sp = np.broadcast_to(self.batch.sp[:, None], op.shape)
        chunk = Chunk(self.seq, self.seq * self.ts_s, op, pv, sp, mv)
        self.seq += n
        return chunk
