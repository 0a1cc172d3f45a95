"""OP against a measured stem position: the valve model checked on its own (where an export has ``mv``).

The stem is measured, so the process is the identity: the same fits as for PV, with the
process a lag far shorter than the sample time, a free gain (the positioner's calibration:
stem travel per % of OP) and the actuator's lag searched.  A linear valve (the stem follows
the lagged OP) competes with the sticky one on the same criterion.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stiction.ident.fit import criterion, fit_valve
from stiction.ident.friction import friction, stem_path
from stiction.ident.process import NOMINAL, Dynamics
from stiction.ident.record import Record
from stiction.ident.stem import StemReader
from stiction.ident.valve_model import Hypothesis, ValveFit

LAG_GRID_TS = (0.0, 0.3, 0.6, 1.0, 1.5, 2.0, 3.0, 5.0)


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


def _best(record: Record, reader: StemReader, dyn: Dynamics, linear: bool) -> tuple[ValveFit, float]:
    """The better actuator lag; a sticky stem is read in the units of the measured travel (gain 1)."""
    best = None
    path = reader.paths([(dyn, None)])[0]
    unit = 1.0 / (NOMINAL.gain * dyn.time_constant_s)  # gain ratio of a unit static gain
    for lag in LAG_GRID_TS:
        hyp = Hypothesis(dyn, gain_free=linear, actuator_tau_s=lag * record.ts_s, linear_valve=linear, snapshot=True)
        vf = fit_valve(record, hyp, path, nominal_gain=unit, search="full")
        ic = criterion(vf.rss, vf.n_params, record.n_fit)
        if best is None or ic < best[1]:
            best = (vf, ic)
    return best


def check_valve(op_pct: np.ndarray, mv_pct: np.ndarray, ts_s: float) -> ValveCheck:
    record = Record(np.asarray(op_pct, float), np.asarray(mv_pct, float), ts_s)
    dyn = Dynamics(time_constant_s=0.01 * ts_s)  # the stem is read directly: no process between
    reader = StemReader(record.pv_pct, ts_s)
    sticky, ic_sticky = _best(record, reader, dyn, linear=False)
    linear, ic_linear = _best(record, reader, dyn, linear=True)
    chosen = sticky if ic_sticky < ic_linear else linear
    # calibration: the measured stem against the model's, in levels
    model = stem_path(chosen, record)
    x = np.stack([np.ones(record.n - 1), model[:-1]], axis=1)
    (offset, gain), *_ = np.linalg.lstsq(x, record.pv_pct[1:], rcond=None)
    error = float(np.sqrt(np.mean((record.pv_pct[1:] - x @ [offset, gain]) ** 2)))
    f = friction(sticky, record)
    return ValveCheck(
        bool(ic_sticky < ic_linear),
        float(ic_linear - ic_sticky),
        float(f.s_pct),
        float(f.j_pct),
        chosen.hypothesis.actuator_tau_s,
        float(gain),
        float(offset),
        error,
    )
