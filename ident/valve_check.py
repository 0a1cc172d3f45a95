"""OP against a measured stem position: the valve model checked on its own (where an export has ``mv``).

The stem is measured, so the process is the identity.  Two sticky valves compete with a linear one (the stem follows
the lagged OP), each calibrated to the measured travel (an offset and a gain: the positioner's calibration) and scored
by Schwarz's criterion on the stem's own residual: the physical valve of ``ident.fit`` (its slips read from the stem,
the process a lag far shorter than the sample time, the actuator's lag searched), which slips in jumps while OP
ramps, and Choudhury's two-parameter valve (``ident.stem_fit``), which sticks where OP turns and then follows it.
Until 2026-11-27 only the first was fitted, against a linear valve fitted the same way, and a two-parameter stem read
as linear: S 5 %, J 5 % over OP sines of 40 % by 10 of the criterion.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stiction.ident.fit import criterion, fit_valve
from stiction.ident.friction import friction, stem_path
from stiction.ident.process import NOMINAL, Dynamics
from stiction.ident.record import Record
from stiction.ident.stem import StemReader
from stiction.ident.stem_fit import LAGS_TS, WARMUP_SHARE, fit_stem
from stiction.ident.valve_model import Hypothesis, ValveFit

MODEL_ERROR = 0.20
"""S's and J's standard errors are the fit's combined with this share of S: the valve model, its lag and the stem's
alignment with OP are only close to a real stem's.  On 60 stems of Choudhury's valve driven by simulated plant OPs
(S 0.5-10 %, J 0-S, lags of 0-3 samples, noise 0.02-0.3 %, every other record stored in 0.1 % steps, calibration
gain 0.9-1.1; a ``/tmp`` script, seed 321), the 16 read sticky lay within two of the fit's own errors for 50 % of S,
and within two of these for 100 % (0.15: 100 % of S, 94 % of J); the same as ``ident.trust.MODEL_ERROR_S``."""
STRONG = 10.0
"""The criterion a sticky valve must gain over the linear one: very strong evidence on Schwarz's scale (Kass &
Raftery 1995, a difference of 10 in BIC), not a hair.  On the stems of ``stiction bench stem`` (seed 2718) a linear
stem behind a lag off the grid was read as a physical valve of S 7 % by 5."""
MIN_BAND_PCT = 0.25
"""A band under this (% of OP) is no sticky valve, whatever the criterion: the resolution a control valve's dynamic
specification asks of a good valve (EnTech's, 0.25-0.5 %).  A noise-free simulated stem prefers any model a hair
closer to it, a band of 0.04 % among them."""


@dataclass(frozen=True)
class ValveCheck:
    sticky: bool
    delta_criterion: float
    """Linear valve's criterion minus the sticky valve's: positive, the stem sticks."""
    s_pct: float
    j_pct: float
    actuator_tau_s: float
    calibration_gain: float
    calibration_offset_pct: float
    error_pct: float
    s_se_pct: float = float("nan")
    j_se_pct: float = float("nan")
    valve: str = "physical"
    """The sticky valve that fits the stem better: ``physical`` or ``two_parameter``."""


def _best(record: Record, reader: StemReader, dyn: Dynamics) -> ValveFit:
    """The physical valve's fit at the better actuator lag, its stem read in the units of the measured travel."""
    best = None
    path = reader.paths([(dyn, None)])[0]
    unit = 1.0 / (NOMINAL.gain * dyn.time_constant_s)  # gain ratio of a unit static gain
    for lag in LAGS_TS:
        hyp = Hypothesis(dyn, gain_free=False, actuator_tau_s=lag * record.ts_s, linear_valve=False, snapshot=True)
        vf = fit_valve(record, hyp, path, nominal_gain=unit, search="full")
        ic = criterion(vf.rss, vf.n_params, record.n_fit)
        if best is None or ic < best[1]:
            best = (vf, ic)
    return best[0]


def _calibrated(model: np.ndarray, stem: np.ndarray, first: int) -> tuple[float, float, float]:
    """(rss, offset, gain) of the measured ``stem`` about ``model`` (its position over each interval: the stem a
    sample later), least squares over intervals ``first`` to N - 2 (as ``ident.stem_fit.scores``)."""
    x = np.stack([np.ones(stem.size - 1 - first), model[first:-1]], axis=1)
    (offset, gain), *_ = np.linalg.lstsq(x, stem[first + 1 :], rcond=None)
    resid = stem[first + 1 :] - x @ [offset, gain]
    return float(resid @ resid), float(offset), float(gain)


def check_valve(op_pct: np.ndarray, mv_pct: np.ndarray, ts_s: float) -> ValveCheck:
    record = Record(np.asarray(op_pct, float), np.asarray(mv_pct, float), ts_s)
    stem = record.pv_pct
    dyn = Dynamics(time_constant_s=0.01 * ts_s)  # the stem is read directly: no process between
    reader = StemReader(stem, ts_s)
    physical = _best(record, reader, dyn)
    two = fit_stem(record.op_pct, stem, ts_s)
    # the physical valve scored as the two-parameter one is: on the stem's residual, calibrated the same way
    first = max(1, int(WARMUP_SHARE * record.n))
    rss, offset, gain = _calibrated(stem_path(physical, record), stem, first)
    scored = record.n - 1 - first
    # its own parameters (each slip read from the stem among them: a staircase of read slips follows any stem) and the
    # calibration's two; the two-parameter valve's slips follow from its S and J
    physical_ic = float(criterion(rss, physical.n_params + 2, scored))
    f = friction(physical, record)
    if physical_ic <= two.sticky_criterion or not np.isfinite(two.sticky_criterion):
        sticky_ic, valve = physical_ic, "physical"
        s, j, s_se, j_se, lag = f.s_pct, f.j_pct, f.s_se_pct, f.j_se_pct, physical.hypothesis.actuator_tau_s
        error = float(np.sqrt(rss / scored))
    else:
        sticky_ic, valve = two.sticky_criterion, "two_parameter"
        s, j, s_se, j_se, lag = two.s_pct, two.j_pct, two.s_se_pct, two.j_se_pct, two.actuator_tau_s
        offset, gain, error = two.sticky_offset_pct, two.sticky_gain, two.sticky_error_pct
    # sticky where the criterion prefers it and the band read is surely above zero (a noise-free record's criterion
    # prefers any model a hair closer, a band of 0.00 % among them)
    s_se, j_se = float(np.hypot(s_se, MODEL_ERROR * s)), float(np.hypot(j_se, MODEL_ERROR * s))
    sticky = bool(two.linear_criterion - sticky_ic > STRONG and s - 2 * s_se > 0 and s >= MIN_BAND_PCT)
    if not sticky:
        lag, offset, gain, error = two.linear_tau_s, two.linear_offset_pct, two.linear_gain, two.linear_error_pct
    return ValveCheck(
        sticky,
        float(two.linear_criterion - sticky_ic),
        float(s),
        float(j),
        float(lag),
        float(gain),
        float(offset),
        float(error),
        float(s_se),
        float(j_se),
        valve,
    )
