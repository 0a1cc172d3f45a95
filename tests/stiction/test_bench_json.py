"""``stiction bench ... --json`` prints strict JSON: a share of no windows (NaN) is null, numpy's numbers
are JSON's, and a strict parser (a dashboard's) reads the object."""

import json

import numpy as np

from stiction.commands.bench import _print_json


def _strict(text: str):
    def refuse(constant):
        raise ValueError(f"not JSON: {constant}")

    return json.loads(text, parse_constant=refuse)


def test_not_a_number_prints_as_null_and_numpy_as_plain_numbers(capsys):
    figures = {"sensitivity": float("nan"), "rows": [np.float64(np.inf), 0.5, np.int64(3)],
               "curve": np.array([1.0, np.nan]), "nested": {"pair": (np.float32(2.0), np.bool_(True))}}  # fmt: skip
    _print_json(figures)
    out = _strict(capsys.readouterr().out)
    assert out == {"sensitivity": None, "rows": [None, 0.5, 3], "curve": [1.0, None], "nested": {"pair": [2.0, True]}}
