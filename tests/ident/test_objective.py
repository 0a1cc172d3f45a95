"""The nuisance basis kept between fits (``ident.objective.nuisance_basis``): the same as computed afresh for
every record shape and process, and read-only, since every fit of a hypothesis shares it."""

from dataclasses import replace

import numpy as np
import pytest

from stiction.ident import objective
from stiction.ident.process import Dynamics, transfer_function
from stiction.ident.record import Record


def _record(seed: int, n: int = 400, horizon: int = 1, ts_s: float = 1.0) -> Record:
    rng = np.random.default_rng(seed)
    return Record(rng.normal(size=n).cumsum(), rng.normal(size=n).cumsum(), ts_s, horizon=horizon)


def test_every_record_shape_and_process_gets_the_basis_computed_afresh():
    tf, lagged = transfer_function(Dynamics(), 1.0), transfer_function(Dynamics(sensor_tau_s=3.0), 1.0)
    base = _record(1)
    shapes = [base, _record(2), _record(1, n=500), _record(1, horizon=5), replace(base, skip=20), _record(1, ts_s=2.0)]
    for record in shapes:
        for process in (tf, lagged):
            for omega in (None, 0.1):
                np.testing.assert_array_equal(
                    objective.nuisance_basis(record, process, omega), objective._basis(record, process, omega)
                )
    assert objective.nuisance_basis(base, tf) is objective.nuisance_basis(_record(9), tf)  # kept: the shape's
    with pytest.raises(ValueError):
        objective.nuisance_basis(base, tf)[0, 0] = 1.0
