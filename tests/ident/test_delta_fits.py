"""The fits of slip sets near a base set (``ident.delta_fits``) against the fits that filter every set through
the process (``ident.fit._fit_sets``): the same residuals and coefficients, for slips moved and dropped, a
fixed and a free gain, a moving drive (an actuator lag: slips that break within an interval and chain their
jumps), slips on neighbouring samples, the stem's position sampled itself (``snapshot``), a compared horizon
over one sample and an external oscillation's nuisances."""

from dataclasses import replace

import numpy as np
import pytest

from stiction.ident import delta_fits, fit
from stiction.ident.objective import nuisance_basis
from stiction.ident.process import Dynamics, transfer_function
from stiction.ident.record import Record
from stiction.ident.stem import StemReader
from stiction.ident.valve_model import Hypothesis, Slips, drive_of
from stiction.sim.disturbance import Disturbance
from stiction.sim.extensions import Extensions
from stiction.sim.loop import LoopSpec, simulate

HYPOTHESES = {
    "sensor lag, fixed gain": Hypothesis(dynamics=Dynamics(sensor_tau_s=3.0)),
    "actuator lag, free gain": Hypothesis(gain_free=True, actuator_tau_s=2.5),
    "the stem sampled itself": Hypothesis(snapshot=True, dynamics=Dynamics(sensor_tau_s=2.0)),
    "self-regulating, dead time, load": Hypothesis(
        dynamics=Dynamics(time_constant_s=150.0, dead_time_s=2.4), osc_period_s=90.0
    ),
}


def _record(horizon: int) -> Record:
    spec = LoopSpec(40.0, 15.0, disturbance=Disturbance("gaussian", "output", 0.02),
                    extensions=Extensions(actuator_tau_s=2.5), seed=4)  # fmt: skip
    r = simulate([spec]).kept()
    return Record(r.op[0], r.pv[0], 1.0, horizon=horizon)


def _near(base: Slips, n: int) -> fit.Changes:
    """Each slip moved a sample either way (where it stays between its neighbours, inside the record), and
    each dropped; a moved slip lands 0.1 % of OP higher than it did."""
    moves = [
        (i, step)
        for i in range(base.at.size)
        for step in (-1, 1)
        if (base.at[i - 1] if i else 0) < base.at[i] + step < (base.at[i + 1] if i + 1 < base.at.size else n)
    ]
    index = np.array([i for i, _ in moves] + list(range(base.at.size)))
    shift = np.array([s for _, s in moves] + [0] * base.at.size)
    landing = np.concatenate([base.landing_drive[[i for i, _ in moves]] + 0.1, np.zeros(base.at.size)])
    dropped = np.arange(index.size) >= len(moves)
    return fit.Changes(index, shift, landing, dropped)


@pytest.mark.parametrize("horizon", [1, 6])
@pytest.mark.parametrize("name", list(HYPOTHESES))
def test_fits_near_a_base_are_the_fits_of_every_set_filtered(name, horizon):
    record, hyp = _record(horizon), HYPOTHESES[name]
    tf = transfer_function(hyp.dynamics, record.ts_s)
    q = nuisance_basis(record, tf, 2 * np.pi / hyp.osc_period_s if hyp.osc_period_s else None)
    path = StemReader(record.pv_pct, record.ts_s).paths([(hyp.dynamics, hyp.osc_period_s)])[0]
    walked = fit.fit_valve(record, hyp, path, search="quick").slips
    read = Slips.from_path(path, drive_of(record.op_pct, hyp.actuator_tau_s, record.ts_s))
    # slips that break within their interval chain their jumps (a moving drive): every other one here
    breaking = replace(read, breaks=np.where(np.arange(read.at.size) % 2 == 1, 0.4, 0.0))
    # slips on neighbouring samples (a measured record's stem often moves twice running)
    pairs = np.flatnonzero(np.diff(read.at) > 2)[::3]
    fields = Slips.__dataclass_fields__
    twice = Slips(*(np.insert(getattr(read, f), pairs + 1, getattr(read, f)[pairs]) for f in fields))
    twice = replace(twice, at=np.insert(read.at, pairs + 1, read.at[pairs] + 1))
    assert np.all(np.diff(twice.at) > 0) and np.sum(np.diff(twice.at) == 1) >= 5
    twice_breaking = replace(twice, breaks=np.where(np.arange(twice.at.size) % 3 == 1, 0.4, 0.0))
    for base in (walked, read, breaking, twice, twice_breaking):
        assert base.at.size > 10
        change = _near(base, record.n)
        want_rss, want_coef = fit._fit_sets(record, hyp, [base, *change.sets(base)], tf, q, 1.0)
        rss, coef = fit._fit_near(record, hyp, base, change, tf, q, 1.0)
        np.testing.assert_allclose(rss, want_rss, rtol=1e-8)
        # a row the compared samples hardly see (the level before an early first slip) is held by the ridge
        # alone: its coefficient is nothing but rounding, in either
        np.testing.assert_allclose(coef, want_coef, rtol=1e-6, atol=1e-6 * np.abs(want_coef).max())


def test_a_candidate_that_differs_in_many_places_is_still_fitted():
    """A dropped slip in a long chain of jumps (more steps than ``MAX_STEPS``) is filtered in full, not lost."""
    record, hyp = _record(1), HYPOTHESES["actuator lag, free gain"]
    tf = transfer_function(hyp.dynamics, record.ts_s)
    q = nuisance_basis(record, tf)
    path = StemReader(record.pv_pct, record.ts_s).paths([(hyp.dynamics, None)])[0]
    base = Slips.from_path(path, drive_of(record.op_pct, 2.5, record.ts_s))
    base = replace(base, breaks=np.where(np.arange(base.at.size) > 0, 0.3, 0.0))  # every jump chained
    assert base.at.size * 2 > delta_fits.MAX_STEPS
    change = fit.Changes.drops(np.array([1, 3, base.at.size - 2]))
    want_rss, _ = fit._fit_sets(record, hyp, [base, *change.sets(base)], tf, q, 1.0)
    rss, _ = fit._fit_near(record, hyp, base, change, tf, q, 1.0)
    np.testing.assert_allclose(rss, want_rss, rtol=1e-8)
