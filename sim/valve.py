"""Control valves with stiction: the physical model (thesis 2.3) and He's model.

The physical model is Kayihan & Doyle's pneumatic valve with Karnopp/Stribeck
friction, as fixed in ``spec/thesis-loop.md``.  Its integration here rests on
three facts about that valve (checked against a tight-tolerance ODE solution in
``tests/sim/test_valve_reference.py``):

1. Between samples the drive (OP) is constant, so a stuck stem feels a constant
   force and stays stuck: only a sample can start a slip.
2. The stem's linear part (m, Fv, k) is overdamped (time constants 3 ms and
   9 ms).  Once the stem moves faster than a few Stribeck velocities the
   friction is plain Coulomb, the motion is the closed-form step response of a
   second-order system towards the point where ``F = Fc``, and velocity never
   reverses: a slip ends when the Stribeck term catches the decaying stem,
   a small residual ``r(Fs - Fc)`` short of that point, 45-80 ms after it began.
3. That residual depends only on ``Fs - Fc`` (the stem reaches the Stribeck
   region on the slow mode's manifold), so it is tabulated once by integrating
   the tail with velocity as the independent variable.

So a slip is one closed-form jump per sample, with no time-stepping at all,
vectorised over loops.  He's two-parameter model (He et al. 2007) is the same
jump without the residual and without the slip's duration.

Units: OP, MV in percent of span; forces in lbf; stem position in inches.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

FRICTION_FULL_SCALE_LBF = 500.0
"""The thesis expresses fs and fd as percent of 500 lbf."""


@dataclass(frozen=True)
class ValveConstants:
    """Physical valve of thesis section 2.3 (Kayihan & Doyle), spec Table 'Physical valve model'."""

    mass_lbf_s2_per_in: float = 3.0 / 386.09
    diaphragm_area_in2: float = 100.0
    spring_lbf_per_in: float = 300.0
    viscous_lbf_s_per_in: float = 3.5
    stribeck_in_per_s: float = 0.01
    zero_band_in_per_s: float = 1e-6
    psi_per_pct_op: float = 12.0 / 100.0
    in_per_pct_mv: float = 4.0 / 100.0

    @property
    def lbf_per_pct(self) -> float:
        """Net force per percent of OP - MV: ``Sa * 0.12 psi = k * 0.04 in = 12 lbf``."""
        return self.diaphragm_area_in2 * self.psi_per_pct_op

    @property
    def slow_root_per_s(self) -> float:
        """Slower (less negative) root of ``m s^2 + Fv s + k``."""
        m, c, k = self.mass_lbf_s2_per_in, self.viscous_lbf_s_per_in, self.spring_lbf_per_in
        return (-c + np.sqrt(c * c - 4 * m * k)) / (2 * m)


VALVE = ValveConstants()

PCT_OF_500LBF_PER_PCT_OF_SPAN = VALVE.lbf_per_pct * 100.0 / FRICTION_FULL_SCALE_LBF
"""A band in % of span (OP - MV) as friction in % of 500 lbf: 12 lbf per % of OP."""


def pct_to_lbf(friction_pct):
    """Friction in percent of 500 lbf (the thesis convention) to lbf."""
    return np.asarray(friction_pct, dtype=float) * FRICTION_FULL_SCALE_LBF / 100.0


def lbf_to_pct(friction_lbf):
    return np.asarray(friction_lbf, dtype=float) * 100.0 / FRICTION_FULL_SCALE_LBF


def band_and_jump_pct(fs_pct, fd_pct, valve: ValveConstants = VALVE):
    """Choudhury's S and J (percent of span) of a valve with static friction fs and Coulomb friction fd
    (percent of 500 lbf): the only place this relation is written.

    S is the band of the two-parameter description (Choudhury, Thornhill & Shah 2005; Kano 2004):
    deadband + stickband, the travel of the valve's input after a reversal before the stem moves.
    A stem that stopped with the Coulomb force on one side (``F = fd``) moves the other way once
    ``F = -fs``: OP travels ``(fs + fd) / 12 lbf per %``.  J is the slip: a stuck stem breaks away at
    ``fs`` and stops where the force left is ``fd``, ``(fs - fd) / 12``.  In He's terms (He et al. 2007)
    ``S = fs + fd`` and ``J = fs - fd``.  (The slip stops a residual of under 0.1 lbf short of fd,
    ``stop_residual_in``: 0.01 % of span, left out.)
    """
    fs_lbf, fd_lbf = pct_to_lbf(fs_pct), pct_to_lbf(fd_pct)
    return (fs_lbf + fd_lbf) / valve.lbf_per_pct, (fs_lbf - fd_lbf) / valve.lbf_per_pct


def friction_pct(s_pct, j_pct, valve: ValveConstants = VALVE):
    """(fs, fd) in percent of 500 lbf of a valve with band S and jump J (percent of span): the
    inverse of ``band_and_jump_pct``, ``fs = 12 (S + J) / 2``, ``fd = 12 (S - J) / 2`` lbf."""
    s, j = np.asarray(s_pct, dtype=float), np.asarray(j_pct, dtype=float)
    return lbf_to_pct(valve.lbf_per_pct * (s + j) / 2), lbf_to_pct(valve.lbf_per_pct * (s - j) / 2)


def band_and_jump_se_pct(fs_se_pct, fd_se_pct, valve: ValveConstants = VALVE):
    """Standard errors of (S, J) from those of (fs, fd), taken as independent errors."""
    se = np.hypot(pct_to_lbf(fs_se_pct), pct_to_lbf(fd_se_pct)) / valve.lbf_per_pct
    return se, se


def friction_se_pct(s_se_pct, j_se_pct, valve: ValveConstants = VALVE):
    """Standard errors of (fs, fd) from those of (S, J), taken as independent errors."""
    se = lbf_to_pct(valve.lbf_per_pct * np.hypot(s_se_pct, j_se_pct) / 2)
    return se, se


SLIP_SHARE = 0.25
"""A valve whose slip J is surely below this share of its band S reads as deadband/backlash."""


def fault_kind(s_pct, j_pct, j_se_pct) -> str | None:
    """What kind of valve fault a band S and slip J (% of span, J's standard error) describe, where the
    data tell: ``stick_slip`` (a slip surely above zero: J - 2 se > 0), ``deadband`` (backlash without
    a slip worth the name: J + 2 se below ``SLIP_SHARE`` of S), or None."""
    if s_pct is None or j_pct is None or j_se_pct is None or not s_pct > 0:
        return None
    if j_pct - 2 * j_se_pct > 0:
        return "stick_slip"
    if j_pct + 2 * j_se_pct < SLIP_SHARE * s_pct:
        return "deadband"
    return None


_TABLE_GAP_LBF = np.concatenate([[0.0], np.geomspace(1e-3, 2e3, 160)])


@lru_cache(maxsize=4)
def _stop_residual_table(valve: ValveConstants) -> tuple[np.ndarray, np.ndarray]:
    """Distance [in] short of the Coulomb equilibrium at which a slip sticks, per ``Fs - Fc``.

    The tail of a slip: with ``r`` the distance left to the point where F = Fc,
    ``r' = -v`` and ``m v' = k r - Fv v - (Fs - Fc) exp(-(v/vs)^2)``.  Starting on
    the slow mode's manifold at 20 Stribeck velocities (where the Stribeck term is
    e^-400) and integrating ``dr/dv`` with RK4 down to v = 0 is smooth and cheap.
    """
    m, k = valve.mass_lbf_s2_per_in, valve.spring_lbf_per_in
    c, vs = valve.viscous_lbf_s_per_in, valve.stribeck_in_per_s
    gap = _TABLE_GAP_LBF
    v0 = 20.0 * vs
    r = np.full_like(gap, v0 / -valve.slow_root_per_s)
    n_steps = 800
    h = -v0 / n_steps

    def dr_dv(v, r):
        return -v * m / (k * r - c * v - gap * np.exp(-((v / vs) ** 2)))

    v = v0
    for _ in range(n_steps):
        k1 = dr_dv(v, r)
        k2 = dr_dv(v + h / 2, r + h / 2 * k1)
        k3 = dr_dv(v + h / 2, r + h / 2 * k2)
        k4 = dr_dv(v + h, r + h * k3)
        r = r + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        v += h
    r[0] = 0.0  # no Stribeck drop: the stem creeps all the way to F = Fc
    return gap, r


def slide_speed_pct_s(gap_lbf, valve: ValveConstants = VALVE) -> np.ndarray:
    """The drive's speed (% of OP a second) above which a moving stem slides along with it, for ``Fs - Fc =
    gap_lbf``: where the friction's fall with speed (Stribeck's term) no longer outruns its viscous rise,
    ``2 gap V / vs^2 exp(-(V/vs)^2) = Fv`` on the falling side (V > vs / sqrt 2); below it steady sliding is
    unstable and the stem sticks.  Checked against the spec's ODE (``sim.independent``, ``tests/sim``): a stem
    behind a decelerating drive sticks within 0.2 s of it.  0 where the gap is too small for any instability."""
    gap = np.maximum(np.asarray(gap_lbf, dtype=float), 1e-300)
    vs = valve.stribeck_in_per_s
    target = valve.viscous_lbf_s_per_in * vs / (2 * gap)  # u exp(-u^2) at the root, u = V / vs
    lo, hi = np.full(gap.shape, np.sqrt(0.5)), np.full(gap.shape, 8.0)
    for _ in range(60):  # bisection on the falling side, where u exp(-u^2) decreases
        mid = 0.5 * (lo + hi)
        above = mid * np.exp(-(mid**2)) > target
        lo, hi = np.where(above, mid, lo), np.where(above, hi, mid)
    u = np.where(target < np.sqrt(0.5) * np.exp(-0.5), 0.5 * (lo + hi), 0.0)
    return u * vs / valve.in_per_pct_mv


SLIDING_TOL_PCT = 1e-9
"""A stem this close to ``stop`` behind its drive ended the last interval sliding (it lands exactly there)."""


def stop_residual_in(gap_lbf, valve: ValveConstants = VALVE) -> np.ndarray:
    """Stop residual [in] for ``Fs - Fc = gap_lbf``; never more than the gap allows (k r < Fs - Fc)."""
    gap_tab, r_tab = _stop_residual_table(valve)
    gap = np.clip(np.asarray(gap_lbf, dtype=float), 0.0, gap_tab[-1])
    r = np.interp(gap, gap_tab, r_tab)
    return np.minimum(r, gap / valve.spring_lbf_per_in)


@dataclass(frozen=True)
class Slip:
    """Outcome of one sample interval of a stem that starts the interval stuck."""

    mv_pct: np.ndarray
    """Stem position at the end of the interval."""
    deficit_pct_s: np.ndarray
    """``MV_end * Ts - integral of MV`` over the interval: flow the slips' timing withholds."""
    slipped: np.ndarray


@dataclass(frozen=True)
class Friction:
    """A valve's friction as the sampled loop sees it, vectorised over loops.

    ``stop_lbf`` is the force left on the stem when a slip sticks; ``slip_s``
    is how much flow-time a slip of 1 % withholds (``Fv/k``, the sum of the
    overdamped stem's two time constants).
    """

    fs_lbf: np.ndarray
    stop_lbf: np.ndarray
    slip_s: float
    lbf_per_pct: float
    slide_pct_s: np.ndarray | float = np.inf
    """A stem that breaks away behind a drive moving faster than this (% of OP a second: an actuator's lag
    moves it continuously) slides along with it instead of sticking again (``slide_speed_pct_s``); He's
    model has no such speed."""
    tracks: np.ndarray | bool = False
    """A stem that slipped follows its drive while the drive keeps moving the same way (Kano et al. 2004's and
    Choudhury et al. 2005's data-driven valves: ``kano``); it sticks where the drive stops or turns.  The physical
    and He's valves stick again at every sample.  For an actuator without lag only (the lagged valve slides by
    ``slide_pct_s``)."""

    @classmethod
    def physical(cls, fs_lbf, fd_lbf, valve: ValveConstants = VALVE) -> Friction:
        fs, fd = np.asarray(fs_lbf, float), np.asarray(fd_lbf, float)
        residual_lbf = valve.spring_lbf_per_in * stop_residual_in(fs - fd, valve)
        # the slide speed from Fs - stop, which a fit reads (band less stop), not Fs - Fc: under 0.1 lbf apart
        return cls(fs, fd + residual_lbf, valve.viscous_lbf_s_per_in / valve.spring_lbf_per_in, valve.lbf_per_pct,
                   slide_speed_pct_s(fs - fd - residual_lbf, valve))  # fmt: skip

    @classmethod
    def he(cls, fs_op_pct, fd_op_pct) -> Friction:
        """He et al. (2007) two-parameter model with ``fs``, ``fd`` in percent of OP.

        For this valve the physical model's ``fs``, ``fd`` map to ``fs/12``, ``fd/12``
        (spec; thesis Figure 2.5).  A slip is an instant jump that ends exactly at fd.
        """
        return cls(np.asarray(fs_op_pct, float), np.asarray(fd_op_pct, float), 0.0, 1.0)


def valve_step(drive_pct, mv_pct, friction: Friction, last_drive_pct=None) -> Slip:
    """One interval of constant drive (vectorised over loops).

    A stem breaks away when ``|F| > Fs`` with ``F = 12 lbf/% * (drive - MV)``, slips
    to where the force left is ``stop_lbf`` and sticks there.  A valve that ``tracks`` and sits
    ``stop_lbf`` behind ``last_drive_pct`` (the last interval's drive: it was moving) while the drive
    moves on the same way is carried to ``stop_lbf`` behind the new drive.
    """
    force_lbf = friction.lbf_per_pct * (drive_pct - mv_pct)
    slipped = np.abs(force_lbf) > friction.fs_lbf
    end_force_lbf = np.sign(force_lbf) * friction.stop_lbf
    jump_pct = np.where(slipped, (force_lbf - end_force_lbf) / friction.lbf_per_pct, 0.0)
    if last_drive_pct is not None and np.any(friction.tracks):
        d = np.sign(drive_pct - last_drive_pct)
        stop_pct = friction.stop_lbf / friction.lbf_per_pct
        carried = friction.tracks & (d != 0) & (np.abs(d * (last_drive_pct - mv_pct) - stop_pct) <= SLIDING_TOL_PCT)
        jump_pct = np.where(carried, drive_pct - d * stop_pct - mv_pct, jump_pct)
        slipped = slipped | carried
    return Slip(mv_pct=mv_pct + jump_pct, deficit_pct_s=jump_pct * friction.slip_s, slipped=slipped)


def lagged_valve_step(drive_pct, op_pct, tau_s, ts_s, mv_pct, friction: Friction):
    """One interval in which the drive relaxes towards OP: ``P(t) = OP + (P0 - OP) e^(-t/tau)``.

    The drive moves monotonically, so the first breakaway time is closed-form.  A stem that breaks away while
    the drive moves faster than ``friction.slide_pct_s`` does not stick again: it slides along ``stop`` behind
    the drive until the drive slows to that speed (``t_c = tau ln(rate / slide)``), as the spec's ODE does
    (``sim.independent``); a stem that ended the last interval so, and whose drive still moves that fast the
    same way, slides on from the start.  After that each further travel of ``(Fs - stop)/12`` breaks the stem
    away again; the stair that follows is integrated as its mean line (exact at the stair's ends).
    Returns ``(Slip, drive_end_pct)``.
    """
    tau_s = np.asarray(tau_s, float)
    p0, op = np.asarray(drive_pct, float), np.asarray(op_pct, float)
    decay = np.exp(-ts_s / tau_s)
    p_end = op + (p0 - op) * decay
    d = np.sign(op - p0)
    band_pct = friction.fs_lbf / friction.lbf_per_pct
    stop_pct = friction.stop_lbf / friction.lbf_per_pct
    step_pct = np.maximum(band_pct - stop_pct, 1e-9)
    rate0 = np.abs(op - p0) / tau_s
    carried = (d != 0) & (np.abs(d * (p0 - mv_pct) - stop_pct) <= SLIDING_TOL_PCT) & (rate0 > friction.slide_pct_s)
    p_break = mv_pct + d * band_pct
    already = (np.abs(p0 - mv_pct) > band_pct) | carried
    slipped = already | (d * (p_end - p_break) > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_break = np.where(already, 0.0, tau_s * np.log((op - p0) / (op - p_break)))
    t_break = np.where(slipped, np.clip(np.nan_to_num(t_break), 0.0, ts_s), ts_s)
    d_drive = d
    d = np.where(already & ~carried, np.sign(p0 - mv_pct), d)
    # after the break the stem slides while the drive, moving its way, is faster than the slide speed
    with np.errstate(divide="ignore", invalid="ignore"):
        t_slow = np.where((d == d_drive) & (rate0 > friction.slide_pct_s),
                          tau_s * np.log(rate0 / friction.slide_pct_s), 0.0)  # fmt: skip
    t_slide = np.where(slipped, np.clip(np.nan_to_num(t_slow), t_break, ts_s), t_break)
    p_at_break = np.where(already, p0, p_break)
    p_slid = np.where(t_slide > t_break, op + (p0 - op) * np.exp(-t_slide / tau_s), p_at_break)
    mv_first = p_slid - d * stop_pct
    n_more = np.where(slipped, np.floor(np.maximum(d * (p_end - p_slid), 0.0) / step_pct), 0.0)
    mv_end = np.where(slipped, mv_first + d * n_more * step_pct, mv_pct)

    # integral of MV over the interval
    with np.errstate(divide="ignore", invalid="ignore"):
        t_last = np.where(
            n_more > 0,
            tau_s * np.log((op - p0) / (op - (p_slid + d * n_more * step_pct))),
            t_slide,
        )
    t_last = np.clip(np.nan_to_num(t_last, nan=ts_s), t_slide, ts_s)

    def drive_integral(t1, t2):
        return op * (t2 - t1) + (p0 - op) * tau_s * (np.exp(-t1 / tau_s) - np.exp(-t2 / tau_s))

    slide = drive_integral(t_break, t_slide) - d * stop_pct * (t_slide - t_break)
    stair = drive_integral(t_slide, t_last) - (d * stop_pct + d * step_pct / 2) * (t_last - t_slide)
    stair = np.where(n_more > 0, stair, mv_first * (t_last - t_slide))
    integral = mv_pct * t_break + slide + stair + mv_end * (ts_s - t_last)
    # a slip withholds Fv/k seconds of flow per % of its travel, in its own direction (as ``valve_step``)
    deficit = np.where(slipped, mv_end * ts_s - integral, 0.0) + (mv_end - mv_pct) * friction.slip_s
    return Slip(mv_pct=mv_end, deficit_pct_s=deficit, slipped=slipped), p_end
