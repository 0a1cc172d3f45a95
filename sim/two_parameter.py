"""A second simulator of plant loops, independent of ``sim.loop``: Choudhury's data-driven two-parameter
valve (Choudhury, Thornhill & Shah 2005, "Modelling valve stiction", Control Eng. Practice 13) under
SIMC-tuned PI control of a first-order-plus-dead-time flow or an integrating level, stepped at the
historian's sample time.  The verdict's held-out check against another valve model, another simulator
and other tunings than the ones it was trained on (``stiction bench detect``, the row "choudhury").

Choudhury's valve, in % of span, band S and slip J: a valve that moves follows its input less
``(S - J) / 2`` in the direction of travel; it sticks where its input stops or reverses, and moves again
once the input has left the sticking point by more than S (the other way: the band) or J (the same way:
the slip alone).  Vectorised over loops, stepped over samples.

Loops are labelled by what their window shows, as ``sim.plant_families`` labels them (``simulate``): a valve
fault where the stem stood still at least twice while OP travelled half the band the valve presents and then moved,
and the record shows it above the noise.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from stiction.sim.plant_families import FAULT_EVENTS, VISIBLE_EFFECT, effect_noise, stuck_events

KINDS = ("flow", "level")
CAUSES = ("stiction", "backlash", "sine", "square", "tuning", "none")
"""Valve faults (a slip J > 0, or J = 0: backlash), and look-alikes: an external sine or a filtered square
load, a controller two to three times too aggressive, a healthy loop under a slow wander."""
BAND_PCT = (1.0, 10.0)
SAMPLE_TIMES_S = (1.0, 2.0, 5.0, 10.0)
WARMUP_SAMPLES = 500
SAMPLES = 2000
"""A record's length: the detector's training windows are 600 samples, an export's are read up to 3,600."""


@dataclass(frozen=True)
class Loop:
    kind: str
    cause: str
    ts_s: float
    gain: float
    """Flow: static gain, % per %; level: integrating rate, %/s per %."""
    tau_s: float | None
    dead_s: float
    kc: float
    ti_s: float
    s_pct: float
    j_pct: float
    noise_pct: float
    load_pct: float
    period_s: float
    seed: int


@dataclass(frozen=True)
class Record:
    op: np.ndarray
    pv: np.ndarray
    sp: np.ndarray
    ts_s: float
    shows_fault: bool
    mv: np.ndarray | None = None
    """The valve's stem position (% of span), as the plant does not record it."""
    effect_noise: float = 0.0
    """The fault's effect on PV over the noise (``sim.plant_families.VISIBLE_EFFECT``); 0 for a healthy valve."""


def presented_band_pct(s_pct: float, j_pct: float) -> float:
    """The OP travel after which a stuck stem of Choudhury's valve moves again, in a record with noise on OP: J where
    the valve slips (J > 0), S where it does not (backlash).  The valve reads the direction of travel from one
    sample's move, so under a noisy OP a stem stuck at a reversal moves as soon as OP is J away from the sticking
    point and one sample's noise points the old way: its limit cycles stick for J, not S (design seed 3131: the
    median stuck stretch of a tenth of its sticky loops is 0.31 of S, 1.02 of J).  Read against S, a textbook
    level limit cycle (S 6.6 %, J 2.7 %, stuck for 2.7 % of OP each half cycle) was labelled healthy-looking."""
    return min(s_pct, j_pct) if j_pct > 0 else s_pct


def draw(n_per_cause: int, seed: int) -> list[Loop]:
    """``n_per_cause`` loops of each cause for each kind, magnitudes at random."""
    rng = np.random.default_rng(seed)
    out = []
    for kind in KINDS:
        for cause in CAUSES:
            for _ in range(n_per_cause):
                ts = float(rng.choice(SAMPLE_TIMES_S))
                dead = float(rng.uniform(0.0, 10.0))
                if kind == "flow":
                    gain, tau = float(rng.uniform(0.5, 2.0)), float(rng.uniform(2.0, 30.0))
                    closed = max(dead, ts / 2) * float(rng.uniform(1.0, 3.0))
                    kc, ti = min(tau / (gain * (closed + dead)), 1.5 / gain), max(min(tau, 4 * (closed + dead)), ts)
                else:
                    gain, tau = float(np.exp(rng.uniform(np.log(0.002), np.log(0.02)))), None
                    closed = float(rng.uniform(60.0, 600.0))
                    kc, ti = 1.0 / (gain * (closed + dead)), 4.0 * (closed + dead)
                if cause == "tuning":
                    kc, ti = kc * float(rng.uniform(2.0, 3.5)), ti * float(rng.uniform(0.3, 0.6))
                s = float(np.exp(rng.uniform(*np.log(BAND_PCT)))) if cause in ("stiction", "backlash") else 0.0
                j = s * float(rng.uniform(0.1, 1.0)) if cause == "stiction" else 0.0
                load = float(rng.uniform(1.0, 4.0)) if cause in ("sine", "square") else 0.0
                period = ts * float(rng.uniform(10.0, 100.0)) if load else 0.0
                noise = float(rng.uniform(0.01, 0.1))
                out.append(Loop(kind, cause, ts, gain, tau, dead, kc, ti, s, j, noise, load, period,
                                int(rng.integers(2**31))))  # fmt: skip
    return out


def choudhury_step(x, x_prev, y_prev, stuck, x_stick, dir_stick, v_prev, s, j):
    """One sample of Choudhury's valve for every loop (arrays [L]): input ``x`` after ``x_prev``, the
    valve's last output ``y_prev``; state ``stuck``, the input where it stuck ``x_stick``, the direction
    it moved in before ``dir_stick``, the last non-zero input move's sign ``v_prev``.  Returns the output
    and the new state (``two_parameter_reference`` is the same, written one loop at a time)."""
    v = np.sign(x - x_prev)
    sticks = ~stuck & ((v == 0) | ((v_prev != 0) & (v != v_prev)))
    x_stick = np.where(sticks, x_prev, x_stick)
    dir_stick = np.where(sticks, v_prev, dir_stick)
    stuck = stuck | sticks
    threshold = np.where(v == dir_stick, j, s)
    breaks = stuck & (v != 0) & (np.abs(x - x_stick) > threshold)
    moving = ~stuck | breaks
    y = np.where(moving, x - v * (s - j) / 2, y_prev)
    stuck = stuck & ~breaks
    v_prev = np.where(v != 0, v, v_prev)
    return y, stuck, x_stick, dir_stick, v_prev


def simulate(loops: list[Loop], samples: int = SAMPLES) -> list[Record]:
    """Each loop's last ``samples`` samples after ``WARMUP_SAMPLES``, all loops stepped together, labelled as
    ``sim.plant_families`` labels its windows: a fault where the stem stood still at least ``FAULT_EVENTS`` times
    while OP travelled half the band the valve presents (``presented_band_pct``) and then moved, and where that
    changed PV by ``VISIBLE_EFFECT`` noises or more against the same loop with a healthy valve (the same noise,
    wander and load), simulated beside it."""
    faulty = [i for i, lp in enumerate(loops) if lp.s_pct > 0]
    twins = [replace(loops[i], s_pct=0.0, j_pct=0.0) for i in faulty]
    op, pv, mv = _run(loops + twins, samples)
    healthy_pv = dict(zip(faulty, pv[len(loops) :], strict=True))
    out = []
    for i, lp in enumerate(loops):
        events, effect = 0, 0.0
        if lp.s_pct > 0:
            events = stuck_events(op[i], mv[i], presented_band_pct(lp.s_pct, lp.j_pct))
            effect = effect_noise(pv[i], healthy_pv[i], lp.noise_pct)
        shown = events >= FAULT_EVENTS and effect >= VISIBLE_EFFECT
        out.append(Record(op[i], pv[i], np.full(samples, 50.0), lp.ts_s, shown, mv[i], effect))
    return out


def _run(loops: list[Loop], samples: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """OP, PV and the stem's position [loops, samples] of ``loops`` stepped together, after the warm-up."""
    n_loops, n = len(loops), samples + WARMUP_SAMPLES
    f = {k: np.array([getattr(lp, k) if getattr(lp, k) is not None else 0.0 for lp in loops], float)
         for k in ("ts_s", "gain", "tau_s", "dead_s", "kc", "ti_s", "s_pct", "j_pct", "noise_pct", "load_pct",
                   "period_s")}  # fmt: skip
    level = np.array([lp.kind == "level" for lp in loops])
    a = np.where(level, 1.0, np.exp(-f["ts_s"] / np.where(level, 1.0, f["tau_s"])))
    b = np.where(level, f["gain"] * f["ts_s"], f["gain"] * (1 - a))
    delay = np.round(f["dead_s"] / f["ts_s"]).astype(int)
    noise, wander, external = np.zeros((n_loops, n)), np.zeros((n_loops, n)), np.zeros((n_loops, n))
    for i, lp in enumerate(loops):
        rng = np.random.default_rng(lp.seed)
        noise[i] = lp.noise_pct * rng.standard_normal(n)
        walk = np.cumsum(rng.normal(0.0, 0.005, n))
        wander[i] = 5 * (walk - walk.mean())
        if lp.load_pct:
            t = np.arange(n) * lp.ts_s + rng.uniform(0, lp.period_s)
            wave = np.sin(2 * np.pi * t / lp.period_s)
            if lp.cause == "square":  # an upstream loop's cycle: a square wave through a lag of a tenth of it
                from scipy.signal import lfilter

                keep = np.exp(-lp.ts_s / (lp.period_s / 10))
                wave = lfilter([1 - keep], [1, -keep], np.sign(wave))
            external[i] = lp.load_pct * wave
    sticky = f["s_pct"] > 0
    op, pv, mv = np.zeros((n_loops, n)), np.zeros((n_loops, n)), np.zeros((n_loops, n))
    history = np.full((n_loops, int(delay.max()) + 1), 50.0)
    y_out, u, e_prev = np.zeros(n_loops), np.full(n_loops, 50.0), np.zeros(n_loops)
    stuck, x_stick = np.ones(n_loops, bool), np.full(n_loops, 50.0)
    dir_stick, v_prev, valve, u_prev = np.zeros(n_loops), np.zeros(n_loops), np.full(n_loops, 50.0), u.copy()
    rows = np.arange(n_loops)
    for k in range(n):
        pv[:, k] = 50.0 + y_out + external[:, k] + noise[:, k]
        e = 50.0 - pv[:, k]
        u = np.clip(u + f["kc"] * (e - e_prev + f["ts_s"] / f["ti_s"] * e), 0.0, 100.0)
        e_prev, op[:, k] = e, u
        out, stuck, x_stick, dir_stick, v_prev = choudhury_step(
            u, u_prev, valve, stuck, x_stick, dir_stick, v_prev, f["s_pct"], f["j_pct"]
        )
        valve, u_prev = np.where(sticky, out, u), u
        mv[:, k] = valve
        history = np.roll(history, 1, axis=1)
        history[:, 0] = valve
        y_out = a * y_out + b * (history[rows, delay] - 50.0 + wander[:, k])
    keep = slice(WARMUP_SAMPLES, n)
    return op[:, keep].copy(), pv[:, keep].copy(), mv[:, keep].copy()
