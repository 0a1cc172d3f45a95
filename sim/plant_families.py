"""Simulated plant loops in families, labelled by what each window shows: the detector's training
and held-out sets (``detect.training``, ``stiction bench detect``).

A family is a kind of plant loop: its process, its tuning and how its historian samples it.

- ``flow``: self-regulating, time constant 1-10 s, dead time 0-2 s, recorded every 1-2 s;
- ``level``: integrating, recorded every 1-10 s;
- ``slow``: self-regulating, 20-200 s, dead time 2-30 s (temperatures, compositions), recorded
  every 5-60 s;
- ``detuned``: any of those processes under a controller 3-20 times slower than SIMC's
  (gain 0.05-0.3 of it, integral time 3-20 times), as plants often run them.

By default every loop starts from rest (PV 0, SP 50) and runs a window's warm-up before its recorded window, as
the shipped detector and window network were trained.  ``simulate_families(..., start="operating_point")`` starts
each loop settled at SP instead (``sim.loop.LoopState.at_operating_point``): from rest, a detuned controller is
still climbing to its setpoint after the warm-up (on seed 3031, 376 of the detuned family's 720 windows began
more than 3 % of span below SP, start-up ramps on which the detector found 38 % of the faults shown, against 83 %
elsewhere); ``start="both"`` settles every other loop.  ``stiction bench detect`` judges its held-out families in
operation.  Models retrained on loops started in operation, or on both starts, were judged and not shipped
(docs/benchmarks.md, "The families started at their operating point", "The families judged in operation").

Every family gets every cause in equal numbers.  Valve faults, in the two-parameter sense
(Choudhury, Thornhill & Shah 2005; Kano 2004: a band S = deadband + stickband, a slip J >= 0):
``stick_slip`` (the physical valve), ``he`` (He et al. 2007's two-parameter valve),
``backlash`` (a valve with backlash and no slip: S > 0, J = 0), ``stick_backlash`` (both) and ``kano``
(Kano et al. 2004's valve: its stem, once it slipped, follows OP while OP keeps its direction, where the
physical and He's valves stick again at once: a jump, then a ramp with OP).
Look-alikes: an external load that is a ``sine``, a first-order filtered ``triangle`` or
``square`` (the cycle of an upstream loop's sticky valve) from 2 to 60 cycles a window;
``tuning`` (a controller 1.5-2.5 times too aggressive for its dead time); ``quantization``
(a stepped record); ``compression`` (a historian's swinging-door-like archive: a value stored
when it moved by more than its deadband, linear between stored values); ``noise`` (a healthy loop
wandering under coloured measurement noise and a slow load).  Operators move setpoints in half
of the loops; a tenth of every cause's records are stepped and a fifth compressed, as historians
store them, so that neither artefact tells a cause.

A window is labelled by what it shows, not by the valve it was given: ``shows_fault`` where the
stem stood still at least twice in the recorded window while OP travelled half the band or more,
and then moved (a slip, or the end of the backlash's play), and where the fault changed the record
by more than its noise: the same loop with a healthy valve (the same loads, noise and setpoint
moves) is simulated beside it, and PV's difference between the two, RMS over the window, must
reach the measurement noise's standard deviation (``VISIBLE_EFFECT``).  A sticky valve the loop
never exercises in the window, or whose effect the noise hides, is a healthy-looking window, and
is labelled so.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from stiction.sim.disturbance import first_order, periodic_wave, unit_shape
from stiction.sim.extensions import Extensions
from stiction.sim.loop import LoopSpec, LoopState, build_batch, run_batch
from stiction.sim.plant_loops import by_sample_interval
from stiction.sim.process import ProcessModel
from stiction.sim.valve import band_and_jump_pct, friction_pct

FAMILIES = ("flow", "level", "slow", "detuned")
FAULTS = ("stick_slip", "he", "backlash", "stick_backlash", "kano")
LOOK_ALIKES = ("sine", "triangle", "square", "tuning", "quantization", "compression", "noise")
CAUSES = FAULTS + LOOK_ALIKES
WINDOW_SAMPLES = 600
FAULT_EVENTS = 2
"""Stuck-then-moved events a window must show to be labelled a valve fault: a cycle's worth.  With
one, detuned loops whose valve slipped once in the window were labelled sticky and the detector
trained on them called a third of the detuned family's look-alikes sticky (held out: specificity
0.63 against 0.85 with two)."""
BANDS = ("thesis", "plant")
"""Scales of the sticky valves' band S: ``thesis``, the thesis's friction (fs 6-60 % of 500 lbf, fd
10-90 % below it: S 5-48 % of span), on which the shipped detector is trained; ``plant``, S drawn
log-uniform over ``PLANT_BAND_PCT``, the bands plants report.  A detector judged only on the first
is judged on cycles over a third of the span, which few plant valves make."""
PLANT_BAND_PCT = (0.5, 10.0)
"""The band S (% of span) of plant-scale sticky valves: the industrial cases of Choudhury, Shah &
Thornhill's book and Jelali & Huang's benchmark read 0.5-5 %, the measured 2411FIC20102 about 2 %;
up to 10 % for a badly worn valve."""
FAULT_TRAVEL_SHARE = 0.5
"""OP travel over a stuck stretch, as a share of S, that counts as exercising the band."""
VISIBLE_EFFECT = 1.0
"""The fault's effect on the record that counts as shown: PV's difference from the same loop with a
healthy valve, RMS over the window, in standard deviations of the measurement noise.  An effect under
the noise is one no test reading OP and PV sees (the valve's stem slipped, the record did not say so).
Set at one noise before any detector was judged against it, not tuned."""


@dataclass(frozen=True)
class FamilyLoop:
    spec: LoopSpec
    family: str
    cause: str
    every: int
    """Controller periods (1 s) per recorded sample."""
    s_pct: float
    j_pct: float
    noise_pct: float
    noise_ar: float
    """AR(1) coefficient of the measurement noise (0 white, towards 1 coloured)."""
    load_pct: float
    load_shape: str | None = None
    load_period_s: float = 0.0
    load_filter_s: float = 0.0
    quantum_pct: float = 0.0
    compression_pct: float = 0.0
    sp_steps: tuple[tuple[float, float], ...] = ()

    @property
    def fault(self) -> bool:
        return self.cause in FAULTS


@dataclass(frozen=True)
class FamilyRecord:
    """One loop's window as its historian holds it, and what the window shows."""

    op: np.ndarray
    pv: np.ndarray
    sp: np.ndarray
    ts_s: float
    stuck_events: int
    effect_noise: float = 0.0
    """The fault's effect on PV over the measurement noise (``VISIBLE_EFFECT``); 0 for a healthy valve."""

    @property
    def stem_slipped(self) -> bool:
        """The valve's nonlinearity exercised (``FAULT_EVENTS`` stuck-then-moved events), shown or not."""
        return self.stuck_events >= FAULT_EVENTS

    @property
    def shows_fault(self) -> bool:
        """The window's label: the stem slipped and that changed PV by ``VISIBLE_EFFECT`` noises or more."""
        return self.stem_slipped and self.effect_noise >= VISIBLE_EFFECT


def _process(rng: np.random.Generator, family: str, aggressive: float | None) -> tuple[ProcessModel, float, int]:
    """(process and PI, dead time [s], controller periods per recorded sample) of one family's loop."""
    kind = family if family != "detuned" else str(rng.choice(["flow", "level", "slow"]))
    if kind == "flow":
        tau, dead, every = float(rng.uniform(1.0, 10.0)), float(rng.uniform(0.0, 2.0)), int(rng.choice([1, 2]))
    elif kind == "slow":
        tau, dead, every = (
            float(np.exp(rng.uniform(np.log(20), np.log(200)))),
            float(rng.uniform(2.0, 30.0)),
            int(rng.choice([5, 10, 30, 60])),
        )
    else:
        tau, dead, every = None, float(rng.uniform(0.0, 8.0)), int(rng.choice([1, 2, 5, 10]))
    closed_s = max(dead, float(rng.uniform(0.5, 2.0)) * (tau if tau else 10.0))
    if family == "detuned":
        gain_share, ti_times = float(rng.uniform(0.05, 0.3)), float(rng.uniform(3.0, 20.0))
    else:
        gain_share, ti_times = float(rng.uniform(0.5, 1.0)), float(rng.uniform(1.0, 3.0))
    if aggressive is not None:
        gain_share, ti_times = aggressive, 1.0
        dead = max(dead, 3.0 if kind != "slow" else 10.0)
        closed_s = dead
    if tau is None:
        gain = float(np.exp(rng.uniform(np.log(0.005), np.log(0.1))))
        kc = 1.0 / (gain * (closed_s + dead))
        ti = 4.0 * (closed_s + dead)
        model = ProcessModel(gain=gain, time_constant_s=None, controller_gain=kc * gain_share,
                             integral_time_s=ti * ti_times)  # fmt: skip
    else:
        gain = float(np.exp(rng.uniform(np.log(0.5), np.log(2.0))))
        kc = tau / (gain * (closed_s + dead))
        ti = min(tau, 4.0 * (closed_s + dead))
        model = ProcessModel(gain=gain, time_constant_s=tau, controller_gain=kc * gain_share,
                             integral_time_s=ti * ti_times)  # fmt: skip
    return model, dead, every


def _friction(rng: np.random.Generator, sticky: bool, bands: str) -> tuple[float, float]:
    """(fs, fd) in % of 500 lbf of one loop's valve; (0, 0) for a valve without stick-slip.  The
    slip's share ``u`` (``fd = fs (1 - u)``, ``J / S = u / (2 - u)``) is drawn for every loop, so that
    both band scales give the same loops but for their bands."""
    if bands not in BANDS:
        raise ValueError(f"bands {bands!r}: one of {', '.join(BANDS)}")
    if bands == "thesis":
        fs = float(rng.uniform(6.0, 60.0)) if sticky else 0.0
        return fs, fs * (1 - float(rng.uniform(0.1, 0.9)))
    s_pct = float(np.exp(rng.uniform(*np.log(PLANT_BAND_PCT)))) if sticky else 0.0
    u = float(rng.uniform(0.1, 0.9))
    fs, fd = friction_pct(s_pct, s_pct * u / (2 - u))
    return float(fs), float(fd)


def family_loops(
    n_per_cause: int, seed: int, families: tuple[str, ...] = FAMILIES, bands: str = "thesis"
) -> list[FamilyLoop]:
    """``n_per_cause`` loops of every cause in every family, magnitudes drawn at random; the sticky
    valves' bands at the scale ``bands`` names (``BANDS``)."""
    rng = np.random.default_rng(seed)
    out = []
    for family in families:
        for cause in CAUSES:
            for _ in range(n_per_cause):
                aggressive = float(rng.uniform(1.5, 2.5)) if cause == "tuning" else None
                model, dead, every = _process(rng, family, aggressive)
                fs, fd = _friction(rng, cause in ("stick_slip", "he", "stick_backlash", "kano"), bands)
                backlash = float(rng.uniform(0.5, 5.0)) if cause in ("backlash", "stick_backlash") else 0.0
                params: dict = {"dead_time_s": dead, "deadband_pct": backlash}
                valve = cause if cause in ("he", "kano") else "physical"
                spec = LoopSpec(fs, fd, valve=valve, process=model, extensions=Extensions(**params),
                                seed=int(rng.integers(2**31)), sp_pct=50.0)  # fmt: skip
                s_pct, j_pct = (float(v) for v in band_and_jump_pct(fs, fd))
                window_s = WINDOW_SAMPLES * every
                shape = cause if cause in ("sine", "triangle", "square") else None
                period = window_s / float(np.exp(rng.uniform(np.log(2.0), np.log(60.0)))) if shape else 0.0
                period = max(period, 4.0 * every)  # a cycle the record can show
                load_pct = float(rng.uniform(1.0, 5.0)) if shape else float(rng.uniform(0.0, 0.5))
                if cause == "noise":
                    load_pct = float(rng.uniform(0.5, 3.0))
                steps = int(rng.integers(1, 4)) if rng.random() < 0.5 else 0
                artefact = float(rng.random())  # the historian's: a stepped or compressed record, on any loop
                sp_steps = tuple((float(rng.uniform(0.05, 0.95)), float(rng.choice([-1, 1]) * rng.uniform(1.0, 5.0)))
                                 for _ in range(steps))  # fmt: skip
                out.append(
                    FamilyLoop(
                        spec, family, cause, every, s_pct + backlash, j_pct,
                        noise_pct=float(rng.uniform(0.02, 0.3)),
                        noise_ar=float(rng.choice([0.0, rng.uniform(0.5, 0.95)])),
                        load_pct=load_pct, load_shape=shape, load_period_s=period,
                        load_filter_s=float(rng.uniform(0.05, 0.25)) * period if shape in ("triangle", "square") else 0,
                        quantum_pct=float(rng.uniform(0.2, 1.0)) if cause == "quantization" or artefact < 0.1 else 0.0,
                        compression_pct=float(rng.uniform(0.1, 1.0))
                        if cause == "compression" or 0.1 <= artefact < 0.3 else 0.0,
                        sp_steps=sp_steps,
                    )
                )  # fmt: skip
    return out


def _load(loop: FamilyLoop, t_s: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """The load on the process input: the family's external cycle, or a slow brown wander."""
    if loop.load_shape is None:
        return loop.load_pct * unit_shape("brownian", t_s.size, 1.0, rng)
    wave = periodic_wave(loop.load_shape, (t_s / loop.load_period_s + rng.random()) % 1.0)
    if loop.load_filter_s > 0:  # first order, the upstream process's lag
        wave = first_order(wave, np.exp(-1.0 / loop.load_filter_s))
    return loop.load_pct * wave / max(np.max(np.abs(wave)), 1e-9)


def _noise(loop: FamilyLoop, n: int, rng: np.random.Generator) -> np.ndarray:
    from scipy.signal import lfilter

    white = rng.standard_normal(n)
    coloured = lfilter([np.sqrt(1 - loop.noise_ar**2)], [1, -loop.noise_ar], white)
    return loop.noise_pct * coloured


def compress(x: np.ndarray, deadband: float) -> np.ndarray:
    """A historian's archive of ``x``: a value stored when it moved more than ``deadband`` from the
    last stored one, linear between stored values (the last sample always stored)."""
    kept = [0]
    for k in range(1, x.size):
        if abs(x[k] - x[kept[-1]]) > deadband:
            kept.append(k)
    if kept[-1] != x.size - 1:
        kept.append(x.size - 1)
    return np.interp(np.arange(x.size), kept, x[kept])


def stuck_events(op: np.ndarray, mv: np.ndarray, s_pct: float) -> int:
    """Stretches in which the stem stood still while OP travelled ``FAULT_TRAVEL_SHARE`` of the band
    or more, and that ended with the stem moving: the valve's nonlinearity exercised."""
    if s_pct <= 0:
        return 0
    moving = np.abs(np.diff(mv)) > 1e-9
    events, start = 0, 0
    for k in np.flatnonzero(moving):
        if np.ptp(op[start : k + 1]) >= FAULT_TRAVEL_SHARE * s_pct:
            events += 1
        start = k + 1
    return events


def healthy(spec: LoopSpec) -> LoopSpec:
    """The same loop with a valve that neither sticks nor has backlash."""
    return replace(
        spec, fs_pct=0.0, fd_pct=0.0, valve="physical", extensions=replace(spec.extensions, deadband_pct=0.0)
    )


def effect_noise(pv: np.ndarray, healthy_pv: np.ndarray, noise_pct: float) -> float:
    """RMS of PV's difference from the healthy valve's, in standard deviations of the noise."""
    return float(np.sqrt(np.mean((pv - healthy_pv) ** 2)) / max(noise_pct, 1e-12))


START = ("rest", "operating_point", "both")
"""Where the families' loops start (``simulate_families``): from rest, settled at their setpoint, or every other loop
(odd places in the list) settled and the others from rest."""


def in_operation(n_loops: int, start: str) -> np.ndarray:
    """Which of ``n_loops`` loops start settled at their setpoint under ``start`` (``START``)."""
    if start not in START:
        raise ValueError(f"start {start!r}: one of {', '.join(START)}")
    if start == "operating_point":
        return np.ones(n_loops, bool)
    if start == "both":
        return np.arange(n_loops) % 2 == 1
    return np.zeros(n_loops, bool)


def simulate_families(
    loops: list[FamilyLoop], warmup_windows: float = 1.0, samples: int = WINDOW_SAMPLES, start: str = "rest"
) -> list[FamilyRecord]:
    """Each loop's recorded window (``samples`` samples after a warm-up of ``warmup_windows`` times
    ``WINDOW_SAMPLES``) and its label.  The loops are the same at any ``samples`` (their loads' periods
    were drawn for ``WINDOW_SAMPLES``): a longer record of the same loop, as an export holds.  ``start``: from
    ``"rest"``, at each loop's ``"operating_point"``, or ``"both"`` (``START``, ``in_operation``)."""
    settled = in_operation(len(loops), start)
    out: list = [None] * len(loops)
    for every, idx in by_sample_interval(loops).items():
        n = int((samples + WINDOW_SAMPLES * warmup_windows) * every)
        t_s = np.arange(n, dtype=float)
        first = n - samples * every  # the recorded window's first controller period
        w, z, moves = (np.zeros((len(idx), n)) for _ in range(3))
        for row, i in enumerate(idx):
            rng = np.random.default_rng(loops[i].spec.seed)
            w[row] = _load(loops[i], t_s, rng)
            z[row] = _noise(loops[i], n, rng)
            for share, step_pct in loops[i].sp_steps:
                moves[row, first + int(share * samples * every) :] += step_pct
        # each faulty valve's loop again with a healthy valve, in the same batch: what the fault did to PV
        faults = [row for row, i in enumerate(idx) if loops[i].fault]
        twins = [idx[row] for row in faults]  # the loops the batch's last rows run again, healthy
        specs = [loops[i].spec for i in idx] + [healthy(loops[i].spec) for i in twins]
        noise, loads = z - moves, np.vstack([w, w[faults]])
        batch = build_batch(specs)
        # in operation from the first sample, settled at SP under the load's first value; a twin as its loop
        rows_settled = settled[[*idx, *twins]]
        state = LoopState.at_operating_point(batch, loads[:, 0]).where(rows_settled) if rows_settled.any() else None
        op, pv_plant, mv = run_batch(batch, loads, np.vstack([noise, noise[faults]]), state=state)
        twin_pv = dict(zip(faults, pv_plant[len(idx) :], strict=True))
        op, pv_plant, mv = op[: len(idx)], pv_plant[: len(idx)], mv[: len(idx)]
        pv = pv_plant + moves
        keep = slice(first + every - 1, n, every)
        for row, i in enumerate(idx):
            loop = loops[i]
            o, p = op[row, keep], pv[row, keep]
            q = loop.quantum_pct
            if q > 0:
                o, p = np.round(o / q) * q, np.round(p / q) * q
            if loop.compression_pct > 0:
                o, p = compress(o, loop.compression_pct), compress(p, loop.compression_pct)
            events = stuck_events(op[row, first:], mv[row, first:], loop.s_pct) if loop.fault else 0
            effect = effect_noise(pv_plant[row, keep], twin_pv[row][keep], loop.noise_pct) if loop.fault else 0.0
            sp = loop.spec.sp_pct + moves[row, keep]
            out[i] = FamilyRecord(o, p, sp, float(every), events, effect)
    return out


def stable(record: FamilyRecord) -> bool:
    """Whether a generated loop stayed within the span's reach (an unstable tuning diverges)."""
    op, pv = record.op, record.pv
    return bool(np.all(np.isfinite(op)) and np.all(np.isfinite(pv)) and np.ptp(pv) < 100 and np.ptp(op) < 1000)
