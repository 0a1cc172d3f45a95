"""A window that fails to quantify costs only its own report: the batch is retried window by window."""

import numpy as np

from stiction.agent.service import quantify_isolated
from stiction.quantify.pipeline import Window
from stiction.schemas.errors import StictionError


def _windows(*ids):
    t = np.arange(200.0)
    return [Window(i, np.sin(t / 9), np.cos(t / 9), 1.0, 200.0) for i in ids]


def _quantify_failing_on(bad: dict):
    calls = []

    def quantify(windows):
        calls.append([w.loop_id for w in windows])
        for w in windows:
            if w.loop_id in bad:
                raise bad[w.loop_id]
        return [f"report of {w.loop_id}" for w in windows]

    return quantify, calls


def test_a_batch_without_a_failure_is_quantified_once():
    quantify, calls = _quantify_failing_on({})
    rejected = []
    out = quantify_isolated(quantify, _windows("a", "b"), lambda *r: rejected.append(r))
    assert out == ["report of a", "report of b"] and calls == [["a", "b"]] and not rejected


def test_a_refused_window_and_a_fault_in_another_cost_only_their_own_reports():
    quantify, _ = _quantify_failing_on({"b": StictionError("b: OP is NaN"), "d": ValueError("empty max")})
    rejected = []
    out = quantify_isolated(quantify, _windows("a", "b", "c", "d"), lambda *r: rejected.append(r))
    assert out == ["report of a", None, "report of c", None]
    assert [reason for reason, _ in rejected] == ["window_refused", "window_refused"]
    assert "b: OP is NaN" in rejected[0][1]
    assert "d: internal error (ValueError: empty max)" in rejected[1][1]
