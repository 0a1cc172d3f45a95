"""Training sets, made from the simulator and featurised by the agent's own analysis."""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from stiction.quantify.analysis import analyse
from stiction.sim.extensions import Extensions
from stiction.sim.grid import random_disturbance, training_specs
from stiction.sim.loop import simulate

WINDOW_S = 1000


@dataclass(frozen=True)
class Dataset:
    inputs: np.ndarray  # [n, features]
    targets: np.ndarray  # [n, 2] fs_pct, fd_pct
    groups: np.ndarray  # [n] grid point index: validation splits by grid point, never within one

    def sha256(self) -> str:
        h = hashlib.sha256()
        for a in (self.inputs, self.targets, self.groups):
            h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
        return h.hexdigest()


def thesis_set(extensions: Extensions | None = None) -> Dataset:
    """Thesis 4.6: the 1275 noise-free patterns, one realisation, 100 OP samples from the first cycle."""
    specs = training_specs(extensions=extensions)
    r = simulate(specs).kept()
    from stiction.quantify.features import thesis_window

    inputs = thesis_window(r.op)
    targets = np.array([[s.fs_pct, s.fd_pct] for s in specs])
    return Dataset(inputs, targets, np.arange(len(specs)))


def cycle_set(
    realisations: int = 3,
    noisy_variants: int = 2,
    seed: int = 0,
    progress: Callable[[int, int], None] | None = None,
    extensions: Extensions | None = None,
) -> Dataset:
    """Cycle features of many draws per grid point.

    Each grid point is simulated ``realisations`` windows long after the warm-up, so
    every window is a different draw of the chaotic limit cycle; ``noisy_variants``
    more runs add a random disturbance each (different per grid point and run).
    """
    base = training_specs(extensions=extensions)
    rng = np.random.default_rng(seed)
    runs = [base] + [
        [replace(s, disturbance=random_disturbance(rng), seed=int(rng.integers(2**31))) for s in base]
        for _ in range(noisy_variants)
    ]
    duration = 1000 + WINDOW_S * realisations
    inputs, targets, groups = [], [], []
    total = len(runs) * realisations
    done = 0
    for specs in runs:
        r = simulate(specs, duration_s=duration)
        for k in range(realisations):
            sl = slice(1000 + k * WINDOW_S, 1000 + (k + 1) * WINDOW_S)
            a = analyse(r.op[:, sl], r.pv[:, sl], physical_reading=False)
            inputs.append(a.cycle_input)
            targets.append([[s.fs_pct, s.fd_pct] for s in specs])
            groups.append(np.arange(len(specs)))
            done += 1
            if progress:
                progress(done, total)
    return _finite(Dataset(np.concatenate(inputs), np.concatenate(targets, dtype=float), np.concatenate(groups)))


def _finite(ds: Dataset) -> Dataset:
    """Drop windows without a full feature vector (no ACF period): the agent reports no learned estimate there."""
    ok = np.all(np.isfinite(ds.inputs), axis=1)
    return Dataset(ds.inputs[ok], ds.targets[ok], ds.groups[ok])
