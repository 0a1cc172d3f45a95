"""A regular cycle longer than any the detector was trained on, read at a sampling that makes it a typical one.

The detector and the window network are trained on the simulated families' windows of ``WINDOW_SAMPLES`` samples
(``sim.plant_families``): a window that cycles holds two cycles at least (``oscillation.MIN_CYCLES``), so no
training cycle was longer than ``LONGEST_PERIOD_SAMPLES``.  A historian that records a loop much faster than it
cycles gives a cycle of many more samples (a level loop cycling every 15 minutes, recorded every second: 900): the
window network's chunks of 600 samples then hold part of one cycle, and the statistics read a shape they never saw.
Such a record is read by the verdict at every ``step``-th sample, the step that brings its period nearest the
training cycles' median (``TYPICAL_PERIOD_SAMPLES``), where the record keeps a training window's length thinned
(an export of 1,200 samples or more; an agent's window of 1,000 is read as it is).  The readings of S and J read
every sample.

A record's pace measured without a cycle (PV's half-life) was tried and reverted: over a long record a slow load
wander stretches it as a faster recording does (docs/benchmarks.md, "Tried and reverted").
"""

from __future__ import annotations

import numpy as np

from stiction.detect.oscillation import MIN_CYCLES

WINDOW_SAMPLES = 600
"""The families' window, which the detector and the window network are trained on."""
LONGEST_PERIOD_SAMPLES = WINDOW_SAMPLES / MIN_CYCLES
"""300 samples: the longest cycle a training window that cycles can hold."""
TYPICAL_PERIOD_SAMPLES = 63.0
"""The median period, in samples, of the training seed's windows that cycle (seed 7: 60 at the thesis's bands, 66
at plant scale; 344 windows).  Read off the training windows, not chosen on any verdict."""


def cycle_periods(evs, ts_s: float) -> np.ndarray:
    """[W] the period, in samples, of each window's regular cycle from its evidence (``detect.features.Evidence``);
    0 where it has none."""
    return np.array([ev.oscillation.period_s / ts_s if ev.oscillation.oscillating else 0.0 for ev in evs])


def verdict_steps(periods_samples: np.ndarray, n: int) -> np.ndarray:
    """[W] int: the step the verdict reads each of W records of ``n`` samples at, from the period (samples) of its
    regular cycle (nan or 0 where it has none): 1 unless the cycle is longer than ``LONGEST_PERIOD_SAMPLES``."""
    period = np.nan_to_num(np.asarray(periods_samples, float), nan=0.0)
    steps = np.ones(period.shape, int)
    long = period > LONGEST_PERIOD_SAMPLES
    steps[long] = np.clip(np.rint(period[long] / TYPICAL_PERIOD_SAMPLES), 1, max(1, n // WINDOW_SAMPLES))
    return steps


def thinned(x: np.ndarray, step: int) -> np.ndarray:
    """Every ``step``-th sample of the last axis, the last sample kept (a record's end is its newest data)."""
    x = np.asarray(x)
    return x[..., (x.shape[-1] - 1) % step :: step]
