"""A second, independent reading of the canonical loop and the diagnose catalogue, for judging diagnose.

``sim.loop`` is the fast simulator the fit was built beside; a fit can come to depend on its choices.
This one is written from spec/thesis-loop.md and the catalogue of spec/interfaces.md alone and shares no
dynamics with ``sim.loop``, ``sim.valve``, ``sim.actuator`` or ``sim.process``: everything runs in continuous
time through ``scipy.integrate.solve_ivp``, with the stem's stick/slip switches as events, and where the
spec leaves a choice it takes the other one, as an outside implementation may:

- the external load is a sine continuous in time (``sim.loop`` holds its value over each sample);
- a dead time delays the stem's position itself, slips and all (``sim.loop`` delays each interval's mean flow);
- an actuator lag drives the valve continuously, so a stuck stem breaks away wherever in an interval the
  lagged drive's force reaches the static friction (found by root finding);
- the deadband is a backlash on OP, before the lag.

Slow (a few seconds a loop): for benchmarks and tests only.  Takes the same ``LoopSpec`` (the physical valve,
the level or concentration loop, white noise on PV the controller sees, the extensions) and returns OP, PV and
the stem at 1 s, samples 1000..1999, as stored (a quantum rounds both, outside the loop).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

M_LBF_S2_IN = 3.0 / 386.09
FORCE_LBF_PER_PCT_OP = 12.0  # Sa * 12 psi / 100 %
SPRING_LBF_IN = 300.0
FV_LBF_S_IN = 3.5
VS_IN_S = 0.01
DELTA_IN_S = 1e-6
IN_PER_PCT = 0.04
TS_S = 1.0
TOTAL_S, KEPT_FROM_S = 2000, 1000
LOOPS = {"level": (1.0 / 15.0, None, 3.0, 30.0), "concentration": (3.0, 10.0, 0.2, 2.0)}
"""gain, time constant (None: integrating), Kc, Ti: thesis Table 2.2."""


@dataclass(frozen=True)
class IndependentRecord:
    op: np.ndarray
    pv: np.ndarray
    mv: np.ndarray
    ts_s: float = TS_S


class _Stem:
    """The stem's position over time so far, as knots (s, in), for the delayed flow."""

    def __init__(self):
        self.t = [0.0]
        self.x = [0.0]

    def add(self, t: np.ndarray, x: np.ndarray) -> None:
        for ti, xi in zip(t, x, strict=True):
            if ti > self.t[-1]:
                self.t.append(float(ti))
                self.x.append(float(xi))
            else:
                self.x[-1] = float(xi)

    def at(self, t: float) -> float:
        return float(np.interp(t, self.t, self.x, left=0.0)) if t > 0 else 0.0


def _valve_interval(x, v, drive0, target, tau_s, fs, fd, t0, stem: _Stem):
    """Advance the stem over one interval; the drive (% OP) relaxes from ``drive0`` to ``target`` with
    ``tau_s`` (0: at ``target`` at once).  Returns the stem's state and the slips' spans (start, end)."""

    def drive(t):
        return target if tau_s <= 0 else target + (drive0 - target) * np.exp(-(t - t0) / tau_s)

    def force(t, x):
        return FORCE_LBF_PER_PCT_OP * drive(t) - SPRING_LBF_IN * x

    def rhs(t, s):
        x, v = s
        f = force(t, x)
        if abs(v) <= DELTA_IN_S:
            return [v, (f - fs * np.sign(f)) / M_LBF_S2_IN]
        sgn = np.sign(v)
        friction = fd * sgn + FV_LBF_S_IN * v + (fs - fd) * np.exp(-((v / VS_IN_S) ** 2)) * sgn
        return [v, (f - friction) / M_LBF_S2_IN]

    t, end, slips, breaking = t0, t0 + TS_S, [], False
    for _ in range(200):
        if t >= end - 1e-12:
            break
        if not breaking and abs(v) <= DELTA_IN_S and abs(force(t, x)) <= fs:
            # stuck: until the lagged drive's force reaches fs, or the interval's end
            if tau_s > 0 and abs(force(end, x)) > fs:
                side = np.sign(force(end, x))
                t_break = brentq(lambda tt, side=side, x=x: side * force(tt, x) - fs, t, end, xtol=1e-12)
                stem.add(np.array([t_break]), np.array([x]))
                t, v, breaking = t_break, 0.0, True
                continue
            stem.add(np.array([end]), np.array([x]))
            return x, 0.0, slips
        breaking = False
        direction = np.sign(v) if abs(v) > DELTA_IN_S else np.sign(force(t, x))

        def stops(tt, s, direction=direction):
            return direction * s[1] - DELTA_IN_S

        stops.terminal, stops.direction = True, -1
        sol = solve_ivp(rhs, (t, end), [x, v], method="Radau", rtol=1e-8, atol=1e-11, events=stops)
        stem.add(sol.t, sol.y[0])
        slips.append((t, float(sol.t[-1])))
        x, v, t = float(sol.y[0, -1]), float(sol.y[1, -1]), float(sol.t[-1])
        if sol.status == 1:
            v = 0.0
    else:
        raise RuntimeError("independent simulator: too many stick/slip switches in one interval")
    return x, v, slips


def simulate_independent(spec, total_s: int = TOTAL_S, kept_from_s: int = KEPT_FROM_S) -> IndependentRecord:
    """One loop of ``spec`` (a ``sim.loop.LoopSpec`` with the physical valve) through this simulator: ``total_s``
    seconds from rest, the samples from ``kept_from_s`` on kept (the spec's 2,000 and 1,000)."""
    clean = _run(spec, None, total_s, kept_from_s)
    noise = None
    d = spec.disturbance
    if d is not None and d.coefficient > 0:
        if (d.shape, d.where) != ("gaussian", "output"):
            raise ValueError("the independent simulator takes white noise on PV only")
        kept_pv = clean.pv - clean.pv.mean()
        rms = float(np.sqrt(np.mean(kept_pv**2)))
        noise = d.coefficient * rms * np.random.default_rng(spec.seed).standard_normal(total_s)
    return clean if noise is None else _run(spec, noise, total_s, kept_from_s)


def _run(spec, noise: np.ndarray | None, total_s: int, kept_from_s: int) -> IndependentRecord:
    if spec.valve != "physical" or spec.process is not None:
        raise ValueError("the independent simulator runs the spec's loops with the physical valve only")
    e = spec.extensions
    gain, tc, kc, ti = LOOPS[spec.loop]
    gain *= e.gain_ratio
    if e.time_constant_s is not None:
        gain, tc = (gain * e.time_constant_s, e.time_constant_s) if tc is None else (gain * tc / e.time_constant_s,
                                                                                      e.time_constant_s)
    if e.osc_period_s > 0 and e.osc_shape != "sine":
        raise ValueError("the independent simulator's external load is a sine")
    fs, fd = 5.0 * spec.fs_pct, 5.0 * spec.fd_pct
    theta, tau_a, tau_s, half_band = e.dead_time_s, e.actuator_tau_s, e.sensor_tau_s, e.deadband_pct / 2

    def load(t):
        return e.osc_amplitude_pct * np.sin(2 * np.pi * t / e.osc_period_s) if e.osc_period_s > 0 else 0.0

    stem = _Stem()
    x = v = y = ym = 0.0
    played = drive = 0.0
    error_sum = 0.0
    recent_slips: list[tuple[float, float]] = []
    op, pv, mv = (np.empty(total_s) for _ in range(3))
    for k in range(total_s):
        t0 = k * TS_S
        pv[k] = (ym if tau_s > 0 else y) + (0.0 if noise is None else noise[k])
        error = spec.sp_pct - pv[k]
        error_sum += error
        op[k] = kc * (error + TS_S / ti * error_sum)
        mv[k] = x / IN_PER_PCT
        if op[k] - played > half_band:
            played = op[k] - half_band
        elif op[k] - played < -half_band:
            played = op[k] + half_band
        x, v, slips = _valve_interval(x, v, drive if tau_a > 0 else played, played, tau_a, fs, fd, t0, stem)
        recent_slips = [sl for sl in recent_slips if sl[1] + theta >= t0] + slips
        drive = played + (drive - played) * np.exp(-TS_S / tau_a) if tau_a > 0 else played

        def process(t, s):
            flow = stem.at(t - theta) / IN_PER_PCT + load(t)
            dy = gain * flow if tc is None else (gain * flow - s[0]) / tc
            return [dy, (s[0] - s[1]) / tau_s if tau_s > 0 else 0.0]

        # split where the delayed stem moves, so that no step strides over a slip
        moves = (c for a, b in recent_slips for c in (a + theta, b + theta))
        cuts = sorted({t0, t0 + TS_S, *(c for c in moves if t0 < c < t0 + TS_S)})
        s = [y, ym]
        for a, b in zip(cuts[:-1], cuts[1:], strict=True):
            sol = solve_ivp(process, (a, b), s, method="RK45", rtol=1e-9, atol=1e-12)
            s = list(sol.y[:, -1])
        y, ym = s
        _forget(stem, t0 - theta - 2 * TS_S)
    kept = slice(kept_from_s, total_s)
    q = e.quantum_pct
    stored = (lambda a: np.round(a / q) * q) if q > 0 else (lambda a: a)
    return IndependentRecord(stored(op[kept]), stored(pv[kept]), mv[kept])


def _forget(stem: _Stem, before_s: float) -> None:
    """Drop knots no delayed read will reach (keeping one before ``before_s``)."""
    i = int(np.searchsorted(stem.t, before_s)) - 1
    if i > 0:
        del stem.t[:i], stem.x[:i]
