"""Open-loop fits of the valve and the process to one measured loop, for one hypothesis.

A hypothesis fixes the process dynamics (``ident.process.Dynamics``), whether the process
gain is free, the actuator lag and an external oscillation's period.  Under it:

1. the stem's slips are read from PV (``ident.stem``);
2. the valve model says where the stem lands after each slip: ``drive - s * stop`` with
   ``drive`` the (lagged) OP when it slipped and ``s`` the slip's direction; the interval
   of a slip sees the old position until the break and withholds ``Fv/k`` seconds of
   flow per percent of the jump (``sim.valve``);
3. through the process, PV's change over the compared horizon is then linear in the
   gain ``g``, in ``g * stop`` and in the nuisances (initial state, a constant, the
   level before the first slip, an external sine): one least-squares solve gives all
   of them with their covariance (variable projection, ``ident.objective``).

The slips' times come from the data, not from an open-loop run of the valve: OP's
excursions in a closed loop are exactly what the real valve needed to slip, so a model
valve whose band is a hair too wide misses a slip and never catches up again (the
objective of a plain open-loop fit is a needle).  The band ``S`` is read afterwards
from the brackets every slip puts on it, and the valve model then adds the slips the
segmentation missed: wherever the drive leaves the band around the stem.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

import numpy as np

from stiction.ident import delta_fits, kernels
from stiction.ident.objective import nuisance_basis, project_out
from stiction.ident.process import TransferFunction, transfer_function
from stiction.ident.record import Record, process_sign
from stiction.ident.stem import StemPath
from stiction.ident.valve_model import (
    SLIP_S,
    Drive,
    Hypothesis,
    Slips,
    ValveFit,
    drive_of,
    linear_fit,
    own_params,
    path_regressors,
    path_regressors_many,
    solve,
    solved_rows,
    time_share,
    valve_from_fit,
)
from stiction.sim.valve import VALVE, slide_speed_pct_s


def walk(
    read: Slips,
    drive: Drive,
    band: np.ndarray,
    stop: np.ndarray,
    level0: np.ndarray,
    window: int,
    read_levels: np.ndarray | None = None,
) -> list[Slips]:
    """The valve model's own slips from the drive, anchored to the slips read from the data; per candidate.

    For each candidate valve (arrays over candidates) the stem sits where it landed and slips
    wherever the drive leaves the band around it.  A slip read from the data that the model
    does not make, and will not make within ``window`` samples after it, is made there anyway
    (forced): the model re-synchronises with the data instead of drifting away from it for
    the rest of the record.  With ``read_levels`` (% of OP) the stem continues after a slip the
    data confirm from the data's estimate of where it landed, as an observer would, where that is
    short of the model's own landing; never past it.  Behind a long actuator lag the drive creeps
    on after a slip and breaks the stem away again a few samples later (the simulator's stair,
    ``sim.valve.lagged_valve_step``); PV reads the stair as one step, and the stem set at its end
    at the first slip made no second one (``stiction bench diagnose --draws wide``: 6 of 8 lags
    named on the bench's seed, 8 of 8 after).  A stem that breaks away behind a lagged drive still faster
    than its slide speed (``sim.valve.slide_speed_pct_s`` of the candidate's Fs - Fc) slides along it,
    ``stop`` behind, until the drive slows to that speed, as the spec's valve does (``sim.independent``).
    Compiled (``ident.kernels``); ``tests/ident/walk_reference.py`` is the plain transcription.
    """
    if np.any(np.diff(read.at) < 0):
        raise ValueError("read slips out of time order")
    band, stop = np.asarray(band, float), np.asarray(stop, float)
    # a stem slides only along a drive that moves within an interval (a lag); the speeds' bisection is 40 % of a
    # walk's time, so a held drive's walk does without them
    speed = slide_speed_pct_s(VALVE.lbf_per_pct * (band - stop)) * drive.ts_s if drive.moves else np.inf
    slide = np.broadcast_to(speed, band.shape)
    counts, at, dirs, brk, land, forced, offs = kernels.walk(
        drive.start,
        drive.end,
        drive.mean,
        drive.moves,
        drive.decay,
        read.at.astype(np.int64),
        read.directions.astype(np.int64),
        np.zeros(read.at.size) if read_levels is None else np.asarray(read_levels, float),
        read_levels is not None,
        band,
        stop,
        np.asarray(level0, float),
        int(window),
        np.ascontiguousarray(slide, dtype=float),
    )
    return [Slips(at[c, :m], dirs[c, :m], brk[c, :m], land[c, :m], forced[c, :m], offs[c, :m])
            for c, m in enumerate(counts)]  # fmt: skip


def _as_slips(ev: list[tuple]) -> Slips:
    if not ev:
        return Slips(*(np.zeros(0, t) for t in (int, int, float, float, bool)))
    at, dirs, brk, land, rd, off = (np.array(x) for x in zip(*ev, strict=True))
    return Slips(at.astype(int), dirs.astype(int), brk.astype(float), land.astype(float), rd.astype(bool),
                 off.astype(float))  # fmt: skip


def _breaks(drive: Drive, k: int, level: np.ndarray, d: np.ndarray, band: np.ndarray):
    """(share of interval k's time before the break, drive at the break) for stems at ``level`` slipping in ``d``."""
    if not drive.moves:
        return np.zeros(level.size), np.full(level.size, drive.mean[k])
    start, end = drive.start[k], drive.end[k]
    threshold = level + d * band
    frac = np.clip((threshold - start) / (end - start), 0.0, 1.0) if end != start else np.zeros(level.size)
    frac = np.where(d * (start - level) > band, 0.0, frac)  # past the band at the start: it breaks away at once
    return time_share(frac, drive.decay), start + frac * (end - start)


def _batch_fit(
    record: Record, hyp: Hypothesis, regs: np.ndarray, tf: TransferFunction, q: np.ndarray, nominal_gain: float
):
    """Least squares of every candidate's regressors [C, 4, N] at once: (rss [C], coef [C, 4]) of ``ROWS``.
    Only the rows the fit reads go through the process: those it solves for, and the drive's, which a fixed
    gain moves to the target's side (the jump's row is read only at a moving drive)."""
    rows = solved_rows(hyp)
    used = sorted(set(rows) | {0})
    # take, not regs[:, used]: numpy's fancy index along the second axis comes back transposed, and the filter's
    # reshape then copied it a second time (3 % of a diagnosis)
    x = record.compared_response(tf, np.take(regs, used, axis=1)).reshape(regs.shape[0], len(used), -1)
    y = project_out(record.target[None, :], q)[0]
    q = np.ascontiguousarray(q)
    xq = (x.reshape(-1, x.shape[-1]) @ q).reshape(x.shape[0], len(used), -1)
    at = np.array([used.index(i) for i in rows], np.int64)
    rss, solved = kernels.projected_fits(np.ascontiguousarray(x), xq, np.ascontiguousarray(q.T), y, at, hyp.gain_free,
                                         float(nominal_gain))  # fmt: skip
    coef = np.zeros((regs.shape[0], 4))
    coef[:, rows] = solved
    if not hyp.gain_free:
        coef[:, 0] = nominal_gain
    return rss, coef


CHUNK_BYTES = 4_000_000
"""Candidates are fitted in chunks whose regressors take about this much memory: a long record's batch of a
thousand candidates was 115 MB of regressors and as much again filtered, fresh pages from the system every
call (a 3,600-sample diagnosis spent a quarter of its time in the kernel, 1.1 GB peak); chunks of a few
MB are reused from the heap."""


def _fit_sets(record: Record, hyp: Hypothesis, sets: list[Slips], tf: TransferFunction, q: np.ndarray,
              nominal_gain: float) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """``_batch_fit`` of every slip set's regressors (``path_regressors_many``), built and fitted in chunks of
    ``CHUNK_BYTES``: (rss [C], coef [C, 4])."""
    chunk = max(1, CHUNK_BYTES // (4 * 8 * max(record.n, 1)))
    out = [
        _batch_fit(record, hyp, path_regressors_many(sets[i : i + chunk], record.n, record.ts_s, hyp.snapshot), tf,
                   q, nominal_gain)
        for i in range(0, len(sets), chunk)
    ]  # fmt: skip
    return np.concatenate([o[0] for o in out]), np.concatenate([o[1] for o in out])


def _fit_near(record: Record, hyp: Hypothesis, base: Slips, change: Changes, tf: TransferFunction, q: np.ndarray,
              nominal_gain: float) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """``_fit_sets`` of ``base`` and of it with each of ``change`` made: from the base's fit and each candidate's
    few steps (``ident.delta_fits``), without filtering them through the process; a candidate that differs in
    many places (a long chain of jumps at a moving drive) filtered as ``_fit_sets`` does."""
    rows = solved_rows(hyp)
    row_index = np.array(rows, np.int64)
    near = delta_fits.NearBase(record, tf, q, path_regressors(base, record.n, record.ts_s, hyp.snapshot))
    c = change.index.size
    rss, coef = np.empty(1 + c), np.zeros((1 + c, 4))
    rss[1:], coef[1:, rows] = near.fits(base, SLIP_S / record.ts_s, hyp.snapshot, change.index, change.shift,
                                        change.landing, change.dropped, row_index, hyp.gain_free, nominal_gain)
    # the normal equations lose digits where the fit explains nearly all (1e-6 of the residual on measured
    # loops): the base's residual summed sample by sample, and each candidate's as its difference from it
    rss[0], coef[0, rows], gram_rss = near.base_fit(row_index, hyp.gain_free, nominal_gain)
    rss[1:] += rss[0] - gram_rss
    far = np.flatnonzero(np.isnan(rss[1:]))
    if far.size:
        sets = change.only(far).sets(base)
        rss[1 + far], coef[1 + far] = _fit_sets(record, hyp, sets, tf, q, nominal_gain)
    if not hyp.gain_free:
        coef[:, 0] = nominal_gain
    return rss, coef


@dataclass(frozen=True)
class Changes:
    """One change each to a slip set: slip ``index`` dropped, or moved by ``shift`` samples to land at
    ``landing`` (% of OP)."""

    index: np.ndarray
    shift: np.ndarray
    landing: np.ndarray
    dropped: np.ndarray

    @classmethod
    def moves(cls, moves: np.ndarray, at: np.ndarray, drive: Drive) -> Changes:
        """Each of ``moves`` [C, 2] (a read slip's index, its shift): it lands where the drive is then."""
        index, shift = moves[:, 0].astype(np.int64), moves[:, 1].astype(np.int64)
        return cls(index, shift, drive.mean[at[index] + shift], np.zeros(index.size, bool))

    @classmethod
    def drops(cls, index: np.ndarray) -> Changes:
        z = np.zeros(index.size)
        return cls(np.asarray(index, np.int64), z.astype(np.int64), z, np.ones(index.size, bool))

    def only(self, which: np.ndarray) -> Changes:
        """These changes at indices ``which``."""
        return Changes(*(getattr(self, f.name)[which] for f in fields(Changes)))

    def sets(self, base: Slips) -> list[Slips]:
        """The slip sets themselves, each the base with its change made (what ``_fit_sets`` reads)."""
        out = []
        for i, s, land, drop in zip(self.index, self.shift, self.landing, self.dropped, strict=True):
            if drop:
                out.append(Slips(*(np.delete(getattr(base, f.name), i) for f in fields(Slips))))
            else:
                at, landing = base.at.copy(), base.landing_drive.copy()
                at[i], landing[i] = at[i] + s, land
                out.append(replace(base, at=at, landing_drive=landing))
        return out


def _walk_parameters(coef: np.ndarray, bands: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(stop, level0) of each candidate from its coefficients [C, 4]; stop = S - J where no held slip reads it.
    A level0 the data cannot read (its regressor within the nuisances' span: an integrating process's constant
    stem offset is a ramp of PV, which the record's trend takes) comes back exactly 0 from the least squares and
    is nan here, not a stem at 0 % of OP: walked from 0, every candidate's stem slipped at every sample to reach
    its drive, and of a loop and its mirror (OP recorded as 100 - OP) only one read so."""
    g = np.where(coef[:, 0] == 0, np.nan, coef[:, 0])
    stop = np.where(coef[:, 1] != 0, coef[:, 1] / g, bands - coef[:, 2] / g)
    return stop, np.where(coef[:, 3] != 0, coef[:, 3] / g, np.nan)


S_WIDE = np.geomspace(1 / 3, 3, 17) - 1
"""Relative to the brackets' band: a first reading spoiled by spurious slips can be far off."""
S_GRID = np.linspace(-0.2, 0.2, 21)
S_FINE = np.linspace(-0.025, 0.025, 11)
WALK_ITERATIONS = 2
SEARCH_GRIDS = {
    "read": (),
    "quick": (np.array([-0.04, 0.0, 0.04]),),
    "full": (np.union1d(S_WIDE, S_GRID), S_GRID, S_FINE),
}


def local_minima(c: np.ndarray, count: int, ties: str = "quicksort") -> list[int]:
    """Indices of the ``count`` lowest local minima of ``c``, lowest first.  ``ties``, numpy's sort kind, orders equal
    minima: "stable" by position (the band's search, where neighbouring bands often walk the same slips and tie);
    the default does not promise an order (a cause's screen, as its figures were measured)."""
    if c.size == 1:
        return [0]
    left = np.concatenate([[np.inf], c[:-1]])
    right = np.concatenate([c[1:], [np.inf]])
    idx = np.flatnonzero((c <= left) & (c <= right))
    return [int(i) for i in idx[np.argsort(c[idx], kind=ties)][:count]]


def criterion(rss: np.ndarray | float, n_params: np.ndarray | int, n: int) -> np.ndarray | float:
    """Schwarz's criterion (BIC) of Gaussian residuals: every parameter must buy log(n) of n log(RSS)."""
    return n * np.log(np.maximum(rss, 1e-300) / n) + n_params * np.log(n)


def _held_gain(record: Record, nominal_gain: float | None) -> float:
    """The gain ratio a hypothesis without a free gain is held at: ``nominal_gain`` where given, else the canonical
    loop's of the sign the record's controller shows (``ident.record.process_sign``: a direct-acting loop's PV falls
    as the valve opens)."""
    return float(process_sign(record.op_pct, record.pv_pct)) if nominal_gain is None else float(nominal_gain)


def fit_valve(
    record: Record,
    hyp: Hypothesis,
    path: StemPath,
    nominal_gain: float | None = None,
    search: str = "full",
    start: tuple[float, float, float] | None = None,
) -> ValveFit:
    """The valve-model fit under ``hyp`` (``_anchored_fit``; ``nominal_gain``: ``_held_gain``); behind a sensor lag or
    a dead time, in a full search, also with the read slips' times refined (``_slip_times_refined``), whichever the
    criterion prefers (with a dead time as well, a dead time would lose to a sensor lag by the search alone).

    A sensor's lag smears each slip over several samples of PV, and the slips read through its inverse
    land a sample or two off (on 8 sensor-lag loops of the wide draws at seed 555, 0-60 % of them more
    than one sample from the simulator's): the band read from their brackets is then off, and the band's
    search is a needle (a band 1 % off moves every slip).  Given the simulator's own slip times the fit
    read fs and fd within 1 pp on 6 of those 8."""
    nominal_gain = _held_gain(record, nominal_gain)
    fitted = _anchored_fit(record, hyp, path, nominal_gain, search, start)
    smeared = hyp.dynamics.sensor_tau_s > 0 or hyp.dynamics.dead_time_s > 0
    if search != "full" or hyp.linear_valve or not smeared or path.slips.size < 2:
        return fitted
    moved = _slip_times_refined(record, hyp, path, nominal_gain)
    if moved is None:
        return fitted
    other = _anchored_fit(record, hyp, moved, nominal_gain, search, start)
    n = record.n_fit
    return other if criterion(other.rss, other.n_params, n) < criterion(fitted.rss, fitted.n_params, n) else fitted


SLIP_SHIFTS = (-2, -1, 1, 2)
"""Samples by which a read slip's time is tried earlier or later."""
SLIP_SWEEPS = 2


def _slip_times_refined(record: Record, hyp: Hypothesis, path: StemPath, nominal_gain: float) -> StemPath | None:
    """``path`` with each read slip moved by the shift of ``SLIP_SHIFTS`` that most lowers the linear fit's
    residual, the others held (every slip's shifts fitted at once), for ``SLIP_SWEEPS`` sweeps; None where
    no slip moved.  A move that would reach or pass a neighbour's time is not made."""
    tf = transfer_function(hyp.dynamics, record.ts_s)
    q = nuisance_basis(record, tf, 2 * np.pi / hyp.osc_period_s if hyp.osc_period_s else None)
    drive = drive_of(record.op_pct, hyp.actuator_tau_s, record.ts_s)
    given, path = path, _as_the_process_reads(record, hyp, path, nominal_gain)
    at = np.asarray(path.slips, int).copy()
    for _ in range(SLIP_SWEEPS):
        bounds = np.concatenate([[0], at, [record.n]])  # a slip stays between its neighbours, inside the record
        moves = [(i, d) for i in range(at.size) for d in SLIP_SHIFTS if bounds[i] < at[i] + d < bounds[i + 2]]
        change = Changes.moves(np.array(moves, np.int64).reshape(-1, 2), at, drive)
        rss = _fit_near(record, hyp, Slips.from_path(replace(path, slips=at), drive), change, tf, q, nominal_gain)[0]
        best: dict[int, tuple[int, float]] = {}
        for (i, d), r in zip(moves, rss[1:], strict=True):
            if r < rss[0] and (i not in best or r < best[i][1]):
                best[i] = (d, r)
        changed = False
        for i in sorted(best):  # in order, each against its neighbours as already moved
            k = at[i] + best[i][0]
            if (at[i - 1] if i > 0 else 0) < k < (at[i + 1] if i + 1 < at.size else record.n):
                at[i], changed = k, True
        if not changed:
            break
    return None if np.array_equal(at, given.slips) else given.with_slips(at)


def _as_the_process_reads(record: Record, hyp: Hypothesis, path: StemPath, nominal_gain: float) -> StemPath:
    """``path`` with its slips' directions and levels flipped where the process is reverse-acting (PV falls as
    the stem opens: the slips read from PV are the stem's, mirrored): by the controller's sign where the gain is
    free, by the sign of the fixed gain where it is not (``Fitter`` fixes it at the controller's sign)."""
    sign = process_sign(record.op_pct, record.pv_pct) if hyp.gain_free else (-1 if nominal_gain < 0 else 1)
    if sign < 0:
        return StemPath(path.slips, -path.directions, -path.levels, path.noise_sd)
    return path


def _anchored_fit(
    record: Record,
    hyp: Hypothesis,
    path: StemPath,
    nominal_gain: float = 1.0,
    search: str = "full",
    start: tuple[float, float, float] | None = None,
) -> ValveFit:
    """The valve-model fit under ``hyp``, anchored to the slips read from the data.

    The slips read from the data (``path``) start it; then the band S is searched (``search``:
    "full" on two grids, "quick" just around the brackets' reading, "read" not at all):
    for each candidate the valve model decides its own slips from the drive (``walk``), and a
    read slip the model does not make is forced, at the price of a parameter.  The least
    squares re-solve stop and the gain for every candidate; the criterion picks the band.
    ``start`` (band, stop, level0, % of OP), say another model's valve, is searched around too.
    """
    tf = transfer_function(hyp.dynamics, record.ts_s)
    omega = 2 * np.pi / hyp.osc_period_s if hyp.osc_period_s else None
    q = nuisance_basis(record, tf, omega)
    drive = drive_of(record.op_pct, hyp.actuator_tau_s, record.ts_s)
    if hyp.linear_valve:
        x = record.compared_response(tf, drive.mean[None, :])
        y = record.target if hyp.gain_free else record.target - nominal_gain * x[0]
        fit = solve(y, x if hyp.gain_free else x[:0], q)
        if not hyp.gain_free:
            fit = replace(fit, prediction=fit.prediction + nominal_gain * x[0])
        g = float(fit.coef[0]) if hyp.gain_free else nominal_gain
        g_se = float(np.sqrt(fit.cov[0, 0])) if hyp.gain_free else 0.0
        empty = Slips(*(np.zeros(0, t) for t in (int, int, float, float, bool)))
        return ValveFit(hyp, empty, fit, g, g_se, 0.0, 0.0, np.nan, tf, 0.0, 0.0)
    path = _as_the_process_reads(record, hyp, path, nominal_gain)
    read = Slips.from_path(path, drive)
    best = _finish(record, hyp, read, tf, q, nominal_gain)
    if search != "read" and read.at.size and hyp.osc_period_s:
        # an external load the segmentation cut into steps leaves slips where the stem never moved:
        # anchored there, the valve model would land far from the stem
        pruned = _prune_forced(
            record, hyp, read, tf, q, nominal_gain, best.fit.n_params + own_params(hyp), harmful_only=True
        )
        if pruned.at.size < read.at.size:
            read = pruned
            best = _finish(record, hyp, read, tf, q, nominal_gain)
    band0, band0_se, _ = _band(best, drive)
    # no valve lands beyond its drive, nor further from it than OP ever moved
    op_range = float(np.ptp(record.op_pct))
    band0 = min(band0, 0.75 * op_range) if np.isfinite(band0) else band0
    limit = band0 if np.isfinite(band0) and band0 > 0 else op_range
    if not (0.0 <= best.stop_pct <= limit) or best.jump_pct > limit:
        best = _finish(record, hyp, read, tf, q, nominal_gain, limit)
    best = replace(best, band_pct=band0, band_se=band0_se)
    usable = np.isfinite(band0) and band0 > 0 and np.isfinite(best.stop_pct)
    if search == "read" or not usable:
        return best
    window = 2 + int(round(hyp.dynamics.sensor_tau_s / record.ts_s))
    # at a moving drive (an actuator lag) every landing is the last one plus a jump: an error in one
    # carries into all the next, and only the data can stop it, as an observer would.  At a held
    # drive a landing is the drive less stop, which re-synchronises by itself.
    read_levels = _read_levels(path, best) if drive.moves else None
    n, fixed = record.n_fit, best.fit.n_params + own_params(hyp)

    def evaluate(centres: list[tuple[float, float, float]], grid: np.ndarray):
        """Every centre's band times ``1 + grid``, walked and fitted: (bands, criteria, slip sets, stops, levels)."""
        bands = np.concatenate([c[0] * (1 + grid) for c in centres])
        stops = np.concatenate([np.full(grid.size, c[1]) for c in centres])
        levels = np.concatenate([np.full(grid.size, c[2]) for c in centres])
        for _ in range(WALK_ITERATIONS):
            cands = walk(read, drive, bands, stops, levels, window, read_levels)
            rss, coef = _fit_sets(record, hyp, cands, tf, q, nominal_gain)
            new_stops, new_levels = _walk_parameters(coef, bands)
            stops = np.where(np.isfinite(new_stops), new_stops, stops)
            levels = np.where(np.isfinite(new_levels), new_levels, levels)
        ic = criterion(rss, fixed + np.array([c.read.sum() for c in cands]), n)
        # no valve lands beyond its drive or jumps backwards: 0 <= stop <= S (a little noise aside),
        # and none that slipped had a band wider than OP ever moved
        tol = 0.05 * bands
        possible = (stops >= -tol) & (stops <= bands + tol) & (bands <= op_range)
        if drive.moves:  # nor jumps past its drive: J <= S (fd >= 0), J read from the slips at a moving drive
            with np.errstate(divide="ignore", invalid="ignore"):
                jumps = coef[:, 2] / coef[:, 0]
            possible &= ~(jumps > bands + tol)
        return bands, np.where(possible, ic, np.inf), cands, stops, levels

    tried_band, tried_ic = [np.inf], [criterion(best.rss, best.n_params, n)]
    winner = (np.inf, read, best.stop_pct, best.level0_pct)

    def tried(bands, ic, cands, stops, levels) -> None:
        """Records the grid's fits; the best becomes the winner where it beats every fit tried before."""
        nonlocal winner
        tried_band.extend(bands), tried_ic.extend(ic)
        i = int(np.argmin(ic))
        if np.isfinite(ic[i]) and ic[i] < min(tried_ic[: -bands.size]):
            winner = (float(bands[i]), cands[i], float(stops[i]), float(levels[i]))

    centres = [(band0, best.stop_pct, best.level0_pct)]
    if start is not None and all(np.isfinite(start)) and start[0] > 0:
        centres.append(tuple(float(x) for x in start))
    grids = SEARCH_GRIDS[search]
    first = evaluate(centres, grids[0])
    tried(*first)
    # the finer grids refine the first grid's best basin and the next best ones (``BASINS``): under noise the
    # band's criterion has several, and the best on the coarse grid need not hold the best fit
    # each basin: its centre (band, stop, level) and its criterion there
    basins = [((winner[0], winner[2], winner[3]) if np.isfinite(winner[0]) else centres[0], min(tried_ic))]
    if len(grids) > 1:
        bands, ic, _, stops, levels = first
        order = np.argsort(bands, kind="stable")
        for i in order[local_minima(ic[order], ic.size, ties="stable")]:
            if len(basins) >= BASINS or not np.isfinite(ic[i]):
                break
            if not any(abs(bands[i] / centre[0] - 1) < BASIN_APART for centre, _ in basins):
                basins.append(((float(bands[i]), float(stops[i]), float(levels[i])), float(ic[i])))
    for centre, centre_ic in basins:
        for grid in grids[1:]:
            fits = evaluate([centre], grid)
            tried(*fits)
            i = int(np.argmin(fits[1]))
            if np.isfinite(fits[1][i]) and fits[1][i] < centre_ic:
                centre, centre_ic = (float(fits[0][i]), float(fits[3][i]), float(fits[4][i])), float(fits[1][i])
    if not np.isfinite(winner[0]):
        return best
    band, slips = winner[0], winner[1]
    rounds = QUICK_PRUNE_ROUNDS if search == "quick" else PRUNE_ROUNDS
    slips = _prune_forced(record, hyp, slips, tf, q, nominal_gain, fixed, rounds=rounds)
    fitted = _finish(record, hyp, slips, tf, q, nominal_gain, band)
    tried_band, tried_ic = np.array(tried_band[1:]), np.array(tried_ic[1:])
    inside = tried_band[tried_ic - tried_ic.min() <= 1.0]
    step = float(abs(S_FINE[1] - S_FINE[0]) * band)
    band_se = float(max(inside.max() - inside.min(), step) / 2) if inside.size > 1 else step
    return replace(fitted, band_pct=band, band_se=band_se)


BASINS = 3
"""Basins of the first grid (its lowest local minima over the band) the finer grids refine, each on its own.  Under
noise the criterion over the band has several, and the one lowest on the coarse grid need not hold the best fit:
behind a sensor lag of 8.4 s (seed 555 of the wide draws, ``tests/ident/test_fit.py``) the coarse grid's best
point read the band 25.7 % (fs 61.6, the truth 77.0) at -1280.6, and a fit started at the true band reached
-1289.8 with fs 77.0; refined from the first grid's three lowest basins the search finds it.  Chosen before any
benchmark ran (three, as ``ident.cause_fit.FULL_FITS_PER_CAUSE``); up to 64 more fits a full search: 3-22 % more
CPU a loop in median on ``stiction bench diagnose --draws wide`` (docs/benchmarks.md)."""
BASIN_APART = 0.1
"""Basins closer than this (relative band) are one: a second start beside the first refines the same minimum."""

PRUNE_ROUNDS = 2
QUICK_PRUNE_ROUNDS = 1
"""Pruning rounds of a first-pass fit (a screen of a cause's grid): the full fits that follow prune
twice.  One round instead of two left every figure of ``stiction bench diagnose`` (the catalogue's
draws and the wide ones) unchanged; none at all moved the wide draws' dead time 3.7 -> 4.0 pp."""


def _prune_forced(
    record: Record,
    hyp: Hypothesis,
    slips: Slips,
    tf,
    q,
    nominal_gain: float,
    fixed: int,
    harmful_only: bool = False,
    rounds: int = PRUNE_ROUNDS,
) -> Slips:
    """Drop the forced slips that do not earn their parameter: a level shift the data read that the
    valve model did not make is not always the valve's (a flow wandering between two stored values).

    ``harmful_only``: drop only those whose removal lowers the residual itself - a slip read where
    the stem never moved lands the model far from the stem, a real one never does."""
    for _ in range(rounds):
        forced = np.flatnonzero(slips.read)
        if forced.size == 0:
            break
        rss, _ = _fit_near(record, hyp, slips, Changes.drops(forced), tf, q, nominal_gain)
        read = int(slips.read.sum())
        ic = criterion(rss, fixed + np.concatenate([[read], np.full(forced.size, read - 1)]), record.n_fit)
        better = forced[rss[1:] < rss[0]] if harmful_only else forced[ic[1:] < ic[0]]
        if better.size == 0:
            break
        keep = np.setdiff1d(np.arange(slips.at.size), better)
        candidate = Slips(*(getattr(slips, f.name)[keep] for f in fields(Slips)))
        regs = path_regressors(candidate, record.n, record.ts_s, hyp.snapshot)[None]
        rss_c, _ = _batch_fit(record, hyp, regs, tf, q, nominal_gain)
        if criterion(rss_c[0], fixed + int(candidate.read.sum()), record.n_fit) >= ic[0]:
            break  # together they were needed after all
        slips = candidate
    return slips


def _read_levels(path: StemPath, first: ValveFit) -> np.ndarray | None:
    """Where the data say the stem landed after each read slip, in % of OP.

    The input estimate's levels are ``g (M - b)``: the first fit gives ``g``, and ``b`` is
    the offset that best aligns them with the landings it predicts.  ``path`` is the stem as the process reads it
    (``_as_the_process_reads``: mirrored where the gain is negative), so its levels are divided by the gain's size:
    divided by a negative gain they were mirrored twice, and a direct-acting loop's stem ran against its drive.
    """
    if not (np.isfinite(first.gain_ratio) and first.gain_ratio != 0 and first.slips.at.size):
        return None
    # the read slips that survived the pruning, with the level the data read after each
    data = path.levels[1:][np.isin(path.slips, first.slips.at)] / abs(first.gain_ratio)
    model = first.slips.landing_drive - first.slips.directions * first.stop_pct
    return data + float(np.median(model - data))


def refit(record: Record, hyp: Hypothesis, slips: Slips, nominal_gain: float | None = None) -> ValveFit | None:
    """``hyp``'s linear fit with the given slips (their landings taken from its own drive); ``nominal_gain``: the
    gain ratio a hypothesis without a free gain is held at (``_held_gain``)."""
    if hyp.linear_valve or slips.at.size == 0:
        return None
    nominal_gain = _held_gain(record, nominal_gain)
    tf = transfer_function(hyp.dynamics, record.ts_s)
    omega = 2 * np.pi / hyp.osc_period_s if hyp.osc_period_s else None
    q = nuisance_basis(record, tf, omega)
    drive = drive_of(record.op_pct, hyp.actuator_tau_s, record.ts_s)
    # the slips' times and directions only: where the stem lands follows from this hypothesis's own drive
    slips = replace(slips, breaks=np.zeros(slips.at.size), landing_drive=drive.mean[slips.at])
    vf = _finish(record, hyp, slips, tf, q, nominal_gain)
    band, band_se, _ = _band(vf, drive)
    return replace(vf, band_pct=band, band_se=band_se)


def _finish(
    record: Record, hyp: Hypothesis, slips: Slips, tf, q, nominal_gain: float, band: float | None = None
) -> ValveFit:
    """The full linear fit (with covariance) for one set of slips.

    With the band known, a stop the least squares put outside 0..S (a direction of the design it
    cannot read: all slips one way, say, where a stem's level shift is the nuisance's constant) is
    held at the nearest possible value and the rest refitted: no valve lands beyond its drive.
    """
    x = record.compared_response(tf, path_regressors(slips, record.n, record.ts_s, hyp.snapshot))
    fit = linear_fit(record, hyp, x, q, nominal_gain)
    c = valve_from_fit(fit)
    if band is not None and np.isfinite(band) and not (0.0 <= c.stop <= band):
        stop = float(np.clip(c.stop, 0.0, band)) if np.isfinite(c.stop) else 0.5 * band
        fit = _held(record, hyp, x, q, nominal_gain, 1, stop)
        c = replace(valve_from_fit(fit), stop=stop)
    if band is not None and np.isfinite(band) and np.isfinite(c.jump) and c.jump > band:
        # nor jumps past its drive (J <= S: fd >= 0), which a longer lag than the true one buys
        fit = _held(record, hyp, x, q, nominal_gain, 2, band, also=(1, c.stop) if 0 <= c.stop <= band else None)
        c = replace(valve_from_fit(fit), jump=float(band))
    lo, hi = float(record.op_pct.min()), float(record.op_pct.max())
    if not lo - (hi - lo) - 1.0 <= c.level0 <= hi + (hi - lo) + 1.0:
        # the stem before the first slip, read from a piece too short to tell: where OP started
        c = replace(c, level0=float(record.op_pct[0]))
    return ValveFit(
        hyp, slips, fit, c.gain, c.gain_se, c.stop, c.stop_se, c.level0, tf, jump_pct=c.jump, jump_se=c.jump_se
    )


def _held(record: Record, hyp: Hypothesis, x: np.ndarray, q, nominal_gain: float, row: int, value: float,
          also: tuple[int, float] | None = None):  # fmt: skip
    """The linear fit with ``ROWS[row]`` held at ``value`` (and ``also``, a second (row, value)), the
    rest refitted; the held coefficients are the gain's times the value, with the gain's covariance."""
    holds = [(row, value)] + ([also] if also is not None else [])
    held = x.copy()
    for r, v in holds:
        held[0] = held[0] + v * x[r]
        held[r] = 0.0
    fit = linear_fit(record, hyp, held, q, nominal_gain)
    coef, cov = fit.coef.copy(), fit.cov.copy()
    for r, v in holds:
        coef[r] = coef[0] * v
        cov[r, :], cov[:, r] = v * cov[0, :], v * cov[:, 0]
        cov[r, r] = v * v * fit.cov[0, 0]
    return replace(fit, coef=coef, cov=cov)


def _robust_se(x: np.ndarray) -> float:
    """Standard error of a median from the MAD (normal efficiency factor 1.25)."""
    mad = 1.4826 * np.median(np.abs(x - np.median(x)))
    return 1.25 * mad / np.sqrt(x.size)


def _band(vf: ValveFit, drive: Drive, stop: float | None = None) -> tuple[float, float, int]:
    """The band S from the read slips' brackets, given where the stem landed: (median, its SE, slips read).

    With fewer than three brackets the spread of their midpoints says nothing: the SE is then half
    the brackets' own width plus a quarter of the band, wide enough to cover what one or two slips
    leave open.
    """
    stop = vf.stop_pct if stop is None else stop
    s = vf.slips
    if s.at.size < 2 or not np.isfinite(stop):
        return np.nan, np.nan, 0
    landed = s.landing_drive - s.directions * stop
    k = s.at[1:]
    use = s.read[1:] & (k >= 1)
    prev_level = landed[:-1][use]
    before = np.abs(drive.end[k[use] - 1] - prev_level)
    after = np.abs(drive.end[k[use]] - prev_level)
    mid = 0.5 * (before + after)
    if mid.size == 0:
        return np.nan, np.nan, 0
    if mid.size < 3:
        band = float(np.median(mid))
        return band, float(np.max(after - before) / 2 + 0.25 * band), int(mid.size)
    return float(np.median(mid)), _robust_se(mid), int(mid.size)
