"""The sampled stiction loop (spec/thesis-loop.md), vectorised across many loops.

Per sample k (Ts = 1 s, thesis Table 2.2):

1. ``PV[k] = y(k Ts) + z[k]``; positional PI: ``OP[k] = Kc (e[k] + Ts/Ti sum e[j])``
2. ``MV[k]`` is the stem position at ``k Ts``;
3. over ``[k Ts, (k+1) Ts)`` the valve is driven by OP[k] (through any deadband and
   actuator lag) and the process by ``MV(t) + w[k]``.

Every loop in a batch has its own fs/fd, valve model, process, disturbance and
extensions.  The stem jumps in closed form (``sim.valve``), the plant advances with
its exact discretisation (``sim.process``), so one sample costs a few dozen numpy
operations on arrays of all loops at once (``advance``: the definition, which the stream
steps).  A whole record runs compiled (``run_batch`` -> ``sim.kernel``), the same
operations loop by loop, tested against ``advance`` repeated.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from stiction.sim.actuator import actuate
from stiction.sim.disturbance import Disturbance, first_order, periodic_wave, rms, unit_shape
from stiction.sim.extensions import OSC_FILTER_SHARE, Extensions
from stiction.sim.kernel import run_loops
from stiction.sim.process import LOOPS, ProcessModel, continuous_plant, discretise
from stiction.sim.valve import Friction, pct_to_lbf

TS_S = 1.0
DURATION_S = 2000.0
WARMUP_S = 1000.0
"""Samples before this are dropped: the limit cycle is established by then (spec)."""

ValveKind = Literal["physical", "he", "kano"]
VALVES = ("physical", "he", "kano")
"""The physical valve (thesis 2.3), He et al. (2007)'s and Kano et al. (2004)'s two-parameter valves
(``sim.valve.Friction``); fs and fd of every one in the thesis's units."""


@dataclass(frozen=True)
class LoopSpec:
    """Everything that defines one simulated loop."""

    fs_pct: float
    fd_pct: float
    loop: str = "level"
    valve: ValveKind = "physical"
    disturbance: Disturbance | None = None
    extensions: Extensions = field(default_factory=Extensions)
    seed: int = 0
    sp_pct: float = 1.0
    process: ProcessModel | None = None
    """A loop of its own (process and PI tuning) in place of the named one: plant loops are not the thesis's."""

    def __post_init__(self):
        if self.process is None and self.loop not in LOOPS:
            raise ValueError(f"unknown loop {self.loop!r}: expected one of {sorted(LOOPS)}")
        if self.process is not None:
            p = self.process
            if not (p.gain != 0 and np.isfinite(p.gain) and p.controller_gain != 0 and p.integral_time_s > 0):
                raise ValueError(f"process {p}: need a finite nonzero gain, a nonzero Kc and Ti > 0")
            if p.time_constant_s is not None and not p.time_constant_s > 0:
                raise ValueError(f"process time constant must be > 0, got {p.time_constant_s}")
        if self.valve not in VALVES:
            raise ValueError(f"unknown valve model {self.valve!r}: expected one of {', '.join(VALVES)}")
        if self.valve == "kano" and self.extensions.actuator_tau_s > 0:
            raise ValueError("the kano valve tracks an actuator without lag: set actuator_tau_s to 0")
        if not (np.isfinite(self.fs_pct) and np.isfinite(self.fd_pct)):
            raise ValueError("fs_pct and fd_pct must be finite")
        if not 0 <= self.fd_pct <= self.fs_pct:
            raise ValueError(f"need 0 <= fd_pct <= fs_pct, got fs_pct={self.fs_pct}, fd_pct={self.fd_pct}")

    @property
    def model(self) -> ProcessModel:
        """The loop's process and controller."""
        return self.process if self.process is not None else LOOPS[self.loop]


@dataclass(frozen=True)
class SimResult:
    """Named signals of a batch: each ``(n_loops, n_samples)``, percent of span; ``t_s`` in s."""

    specs: tuple[LoopSpec, ...]
    t_s: np.ndarray
    op: np.ndarray
    pv: np.ndarray
    sp: np.ndarray
    mv: np.ndarray

    def kept(self, warmup_s: float = WARMUP_S) -> SimResult:
        """The samples after the warm-up (the thesis's pattern: samples 1000..1999)."""
        i = int(np.searchsorted(self.t_s, warmup_s))
        return SimResult(self.specs, self.t_s[i:], self.op[:, i:], self.pv[:, i:], self.sp[:, i:], self.mv[:, i:])

    def recorded(self, every: int, how: Literal["snapshot", "mean"] = "snapshot") -> SimResult:
        """As a historian keeps it: one sample every ``every`` controller periods, the last value or the mean."""
        if every < 1:
            raise ValueError(f"record every {every} samples: expected 1 or more")
        if every == 1:
            return self
        n = (self.t_s.size // every) * every

        def keep(x):
            blocks = x[:, :n].reshape(x.shape[0], -1, every)
            return blocks.mean(axis=2) if how == "mean" else blocks[:, :, -1]

        t = self.t_s[:n].reshape(-1, every)[:, -1]
        return SimResult(self.specs, t, keep(self.op), keep(self.pv), keep(self.sp), keep(self.mv))


@dataclass(frozen=True)
class Batch:
    """Per-loop parameters of a batch, as arrays over loops."""

    kc: np.ndarray
    ti_s: np.ndarray
    sp: np.ndarray
    friction: Friction
    phi: np.ndarray  # (n, 2, 2)
    gamma_now: np.ndarray  # (n, 2)
    gamma_prev: np.ndarray
    gamma_w: np.ndarray
    c: np.ndarray  # (n, 2)
    delay: np.ndarray  # (n,) int samples
    deadband_pct: np.ndarray
    actuator_tau_s: np.ndarray


def _friction(specs: Sequence[LoopSpec]) -> Friction:
    fs_lbf = pct_to_lbf([s.fs_pct for s in specs])
    fd_lbf = pct_to_lbf([s.fd_pct for s in specs])
    physical = Friction.physical(fs_lbf, fd_lbf)
    he = Friction.he(fs_lbf / physical.lbf_per_pct, fd_lbf / physical.lbf_per_pct)
    is_he = np.array([s.valve in ("he", "kano") for s in specs])  # Kano's valve is He's whose stem tracks

    def pick(a, b):
        return np.where(is_he, np.broadcast_to(b, is_he.shape), np.broadcast_to(a, is_he.shape))

    return Friction(
        pick(physical.fs_lbf, he.fs_lbf),
        pick(physical.stop_lbf, he.stop_lbf),
        pick(physical.slip_s, he.slip_s),
        pick(physical.lbf_per_pct, he.lbf_per_pct),
        pick(physical.slide_pct_s, he.slide_pct_s),
        np.array([s.valve == "kano" for s in specs]),
    )


def build_batch(specs: Sequence[LoopSpec], ts_s: float = TS_S) -> Batch:
    plants = {}

    def key(s: LoopSpec):
        e = s.extensions
        return (s.model, e.gain_ratio, e.time_constant_s, e.sensor_tau_s, e.dead_time_s)

    for s in specs:
        e = s.extensions
        if key(s) not in plants:
            A, B, C = continuous_plant(s.model, e.gain_ratio, e.time_constant_s, e.sensor_tau_s)
            plants[key(s)] = discretise(A, B, C, ts_s, e.dead_time_s)
    per_loop = [plants[key(s)] for s in specs]

    def stack(name):
        return np.stack([getattr(p, name) for p in per_loop])

    return Batch(
        kc=np.array([s.model.controller_gain for s in specs]),
        ti_s=np.array([s.model.integral_time_s for s in specs]),
        sp=np.array([s.sp_pct for s in specs]),
        friction=_friction(specs),
        phi=stack("phi"),
        gamma_now=stack("gamma_now"),
        gamma_prev=stack("gamma_prev"),
        gamma_w=stack("gamma_w"),
        c=stack("c"),
        delay=stack("delay_samples").astype(int),
        deadband_pct=np.array([s.extensions.deadband_pct for s in specs]),
        actuator_tau_s=np.array([s.extensions.actuator_tau_s for s in specs]),
    )


def external_oscillation(specs: Sequence[LoopSpec], t_s: np.ndarray) -> np.ndarray:
    """[loops, samples] each loop's external load (``Extensions.osc_*``), zero where it has none."""
    w = np.zeros((len(specs), t_s.size))
    for i, s in enumerate(specs):
        e = s.extensions
        if e.osc_period_s > 0:
            w[i] = e.osc_amplitude_pct * load_wave(e.osc_shape, t_s, e.osc_period_s)
    return w


def load_wave(shape: str, t_s: np.ndarray, period_s: float) -> np.ndarray:
    """A unit wave of ``shape`` (``extensions.OSC_SHAPES``) at the evenly spaced times ``t_s``; a square or a
    triangle through a first-order lag of ``OSC_FILTER_SHARE`` of the period, started settled on its first value."""
    if shape == "sine":
        return np.sin(2 * np.pi * t_s / period_s)
    keep = np.exp(-(t_s[1] - t_s[0]) / (OSC_FILTER_SHARE * period_s)) if t_s.size > 1 else 0.0
    return first_order(periodic_wave(shape, (t_s / period_s) % 1.0), keep, settled=True)


@dataclass(frozen=True)
class LoopState:
    """Explicit state of every loop of a batch at a sample instant (arrays over loops)."""

    x: np.ndarray
    """Plant state ``(n, 2)``: process output y and sensor reading, percent."""
    error_sum: np.ndarray
    """Sum of control errors so far (the PI's integral)."""
    mv: np.ndarray
    """Stem position, percent of span (always stuck at a sample instant)."""
    drive: np.ndarray
    """The actuator's drive after deadband and lag, percent of OP."""
    played: np.ndarray
    """Output of the deadband's play."""
    flow_hist: np.ndarray
    """Mean valve flow of past intervals, a ring ``(n, max_delay + 2)`` indexed by ``k``."""
    k: int = 0

    @classmethod
    def at_rest(cls, batch: Batch) -> LoopState:
        n = batch.kc.size
        zeros = np.zeros(n)
        return cls(np.zeros((n, 2)), zeros, zeros, zeros, zeros, np.zeros((n, int(batch.delay.max()) + 2)))

    @classmethod
    def at_operating_point(cls, batch: Batch, load_pct: np.ndarray, ts_s: float = TS_S) -> LoopState:
        """Every loop settled at its setpoint under a constant load ``load_pct`` (one per loop, in the units of
        ``w``): the plant's states where its output reads SP, the stem (and the deadband's play and the actuator's
        drive) where it holds the plant there, and the controller's integral where OP asks for that stem.  A plant
        loop recorded in operation, not started empty: from rest, a controller 3-20 times slower than its process
        asks (``sim.plant_families``'s detuned family) is still climbing from 0 to SP after a window's warm-up
        (``simulate_families(start=...)``)."""
        n = batch.kc.size
        x, mv = np.zeros((n, 2)), np.zeros(n)
        for i in range(n):
            # the discretised plant at rest, x = Phi x + (Gamma_now + Gamma_prev) u, and c x = SP; least squares
            # picks 0 for a state the output does not read (an integrating plant's unused sensor state)
            m = np.zeros((3, 3))
            m[:2, :2], m[:2, 2], m[2, :2] = (
                batch.phi[i] - np.eye(2),
                batch.gamma_now[i] + batch.gamma_prev[i],
                batch.c[i],
            )
            z = np.linalg.lstsq(m, np.array([0.0, 0.0, batch.sp[i]]), rcond=None)[0]
            x[i], mv[i] = z[:2], z[2] - load_pct[i]
        error_sum = mv * batch.ti_s / (batch.kc * ts_s)  # OP = Kc (0 + Ts/Ti sum e) = the stem's position
        flow_hist = np.repeat(mv[:, None], int(batch.delay.max()) + 2, axis=1)
        return cls(x, error_sum, mv.copy(), mv.copy(), mv.copy(), flow_hist)

    def where(self, rows: np.ndarray) -> LoopState:
        """This state in the loops of ``rows`` (bool, one per loop), the others at rest (``at_rest``)."""
        rows = np.asarray(rows, bool)
        fields = (self.x, self.error_sum, self.mv, self.drive, self.played, self.flow_hist)
        return LoopState(*(_rows_or_rest(a, rows) for a in fields), k=self.k)


def _rows_or_rest(a: np.ndarray, rows: np.ndarray) -> np.ndarray:
    return np.where(rows.reshape((-1,) + (1,) * (a.ndim - 1)), a, 0.0)


def advance(batch: Batch, state: LoopState, w: np.ndarray, z: np.ndarray, ts_s: float = TS_S):
    """One sample of every loop: returns ``(next_state, op, pv)`` for sample ``state.k``.

    ``w`` and ``z`` are this sample's input and output disturbances, one per loop.
    """
    x = state.x
    pv = np.einsum("ij,ij->i", batch.c, x) + z
    error = batch.sp - pv
    error_sum = state.error_sum + error
    op = batch.kc * (error + ts_s / batch.ti_s * error_sum)

    act = actuate(
        op, state.mv, state.drive, state.played, batch.friction, batch.deadband_pct, batch.actuator_tau_s, ts_s
    )
    mv_next, flow = act.mv_pct, act.flow_pct

    hist = state.flow_hist
    ring = hist.shape[1]
    if ring > 2 or np.any(batch.gamma_prev):
        hist = hist.copy()
        hist[:, state.k % ring] = flow
        rows = np.arange(flow.size)
        flow_now = hist[rows, (state.k - batch.delay) % ring]
        flow_prev = hist[rows, (state.k - batch.delay - 1) % ring]
    else:
        flow_now, flow_prev = flow, np.zeros_like(flow)
    x_next = (
        np.einsum("nij,nj->ni", batch.phi, x)
        + batch.gamma_now * flow_now[:, None]
        + batch.gamma_prev * flow_prev[:, None]
        + batch.gamma_w * w[:, None]
    )
    return LoopState(x_next, error_sum, mv_next, act.drive_pct, act.played_pct, hist, state.k + 1), op, pv


def run_batch(
    batch: Batch, w: np.ndarray, z: np.ndarray, ts_s: float = TS_S, state: LoopState | None = None
) -> tuple[np.ndarray, ...]:
    """Run ``advance`` over all samples; ``w``, ``z``: ``(n_loops, n_samples)``.

    Returns ``(op, pv, mv)``, each ``(n_loops, n_samples)``, MV being the stem at each sample.
    Compiled (``sim.kernel``: the same operations loop by loop); ``advance`` is its reference.
    """
    state = LoopState.at_rest(batch) if state is None else state
    n = batch.kc.size
    f = batch.friction

    def per_loop(v):
        return np.ascontiguousarray(np.broadcast_to(np.asarray(v, dtype=float), (n,)))

    def read(v, dtype=float):  # read only by the kernel: no copy where the array is already as it needs
        return np.ascontiguousarray(v, dtype=dtype)

    def own(v):  # the state, which the kernel advances in place: a copy, the caller's stays as it was
        return np.array(v, dtype=float, order="C")

    return run_loops(
        read(batch.kc), read(batch.ti_s), read(batch.sp),
        per_loop(f.fs_lbf), per_loop(f.stop_lbf), per_loop(f.slip_s), per_loop(f.lbf_per_pct), per_loop(f.slide_pct_s),
        read(np.broadcast_to(f.tracks, (n,)), np.bool_),
        read(batch.phi), read(batch.gamma_now), read(batch.gamma_prev), read(batch.gamma_w), read(batch.c),
        read(batch.delay, np.int64), read(batch.deadband_pct), read(batch.actuator_tau_s),
        read(w), read(z), float(ts_s),
        own(state.x), own(state.error_sum), own(state.mv), own(state.drive), own(state.played),
        own(state.flow_hist), int(state.k),
    )  # fmt: skip


def _quantise(x: np.ndarray, quantum: np.ndarray) -> np.ndarray:
    q = quantum[:, None]
    return np.where(q > 0, np.round(x / np.where(q > 0, q, 1.0)) * q, x)


def disturbance_signals(
    specs: Sequence[LoopSpec], t_s: np.ndarray, clean: SimResult, warmup_s: float = WARMUP_S
) -> tuple[np.ndarray, np.ndarray]:
    """Input and output disturbances ``(w, z)``, scaled on the clean loops' RMS after ``warmup_s``."""
    n_samples = t_s.size
    ts_s = float(t_s[1] - t_s[0])
    w, z = np.zeros((len(specs), n_samples)), np.zeros((len(specs), n_samples))
    keep = t_s >= warmup_s if np.any(t_s >= warmup_s) else np.ones(n_samples, bool)
    for i, s in enumerate(specs):
        d = s.disturbance
        if d is None or d.coefficient == 0:
            continue
        shape = unit_shape(d.shape, n_samples, ts_s, np.random.default_rng(s.seed), d.omega_rad_s)
        if d.where == "input":
            w[i] = d.coefficient * rms(clean.mv[i, keep]) * shape
        else:
            z[i] = d.coefficient * rms(clean.pv[i, keep]) * shape
    return w, z


def simulate(
    specs: Sequence[LoopSpec], duration_s: float = DURATION_S, ts_s: float = TS_S, warmup_s: float = WARMUP_S
) -> SimResult:
    """Simulate every loop of ``specs`` for ``duration_s`` from rest; the full record is returned.

    Disturbances are scaled relative to the same loop without disturbance over the
    samples after ``warmup_s`` (spec), so a batch with disturbances runs twice.
    """
    specs = tuple(specs)
    if not specs:
        raise ValueError("simulate needs at least one LoopSpec")
    n_samples = int(round(duration_s / ts_s))
    if n_samples < 2:
        raise ValueError(f"duration_s={duration_s} gives fewer than 2 samples")
    t_s = np.arange(n_samples) * ts_s
    batch = build_batch(specs, ts_s)
    w0 = external_oscillation(specs, t_s)
    z0 = np.zeros_like(w0)
    op, pv, mv = run_batch(batch, w0, z0, ts_s)
    if any(s.disturbance is not None for s in specs):
        w, z = disturbance_signals(specs, t_s, SimResult(specs, t_s, op, pv, pv, mv), warmup_s)
        op, pv, mv = run_batch(batch, w0 + w, z, ts_s)
    quantum = np.array([s.extensions.quantum_pct for s in specs])
    sp = np.broadcast_to(batch.sp[:, None], op.shape).copy()
    return SimResult(specs, t_s, _quantise(op, quantum), _quantise(pv, quantum), sp, mv)
