"""The agent builds the windows of the loops due a batch at a time, as it quantifies them.

Built all at once, the copies of thousands of due windows were freed only after every report between
them had been made, and the heap kept their holes (docs/scaling.md).  A stub quantifier records how many
windows the core had built when each batch reached it."""

import argparse
import json
import time

import numpy as np
import pytest

from stiction.agent.core import CoreSettings
from stiction.agent.service import AgentService, AgentSettings
from stiction.schemas import keys

PREFIX = "test/batches"


class _Session:
    def put(self, *args, **kwargs):
        pass


class _Quantifier:
    """Answers no window (as a quantifier that failed on each), recording what it was given."""

    def __init__(self, built: list[int]):
        self.cpu_s: dict[str, float] = {}
        self.built, self.calls = built, []

    def results(self, windows, details=False):
        self.calls.append(([len(w.op) for w in windows], self.built[0]))
        return [None] * len(windows)


def _message(loop_id: str, n: int, rng: np.random.Generator) -> bytes:
    op, pv = rng.normal(50, 1, n).tolist(), rng.normal(50, 1, n).tolist()
    return json.dumps({"loop_id": loop_id, "seq": 0, "t0_s": 0.0, "ts_s": 1.0, "op": op, "pv": pv}).encode()


def test_the_windows_of_loops_due_together_are_built_one_batch_at_a_time():
    core = CoreSettings(prefix=PREFIX, first_report_samples=200)
    settings = AgentSettings("agent-a", core, size_every_s=0, max_batch=10)
    built = [0]
    quantifier = _Quantifier(built)
    agent = AgentService(settings, _Session(), quantifier=quantifier)
    agent._alive = {"agent-a"}
    agent.core.set_agents({"agent-a"})
    build = agent.core._window

    def counted(*args, **kwargs):
        built[0] += 1
        return build(*args, **kwargs)

    agent.core._window = counted
    rng = np.random.default_rng(3)
    for i in range(25):
        loop_id = f"L{i}"
        message = (keys.samples(PREFIX, loop_id), _message(loop_id, 300, rng), "application/json", time.monotonic())
        agent._inbox.append((*message, False))
    while agent.step():
        pass

    sizes = [len(lengths) for lengths, _ in quantifier.calls]
    assert sizes == [10, 10, 5]  # every loop due, in batches of at most max_batch
    assert all(lengths == [300] * len(lengths) for lengths, _ in quantifier.calls)  # each its whole window
    assert [seen for _, seen in quantifier.calls] == [10, 20, 25]  # no batch's windows built before its turn


class _Pool:
    """A sizing pool that records what it was given and never finishes (``concurrent.futures`` futures)."""

    def __init__(self):
        self.submitted: list[str] = []

    def submit(self, fn, op, pv, ts_s, loop_id, sp=None):
        from concurrent.futures import Future

        self.submitted.append(loop_id)
        return Future()


def _window(loop_id: str):
    from types import SimpleNamespace

    return SimpleNamespace(loop_id=loop_id, op=np.zeros(600), pv=np.zeros(600), ts_s=1.0, t_end_s=600.0,
                           partial=False, sp=None)  # fmt: skip


def test_as_many_loops_are_sized_at_once_as_there_are_sizing_workers_and_the_rest_wait():
    from stiction.commands.agent import run
    from stiction.schemas.errors import InputError

    for workers in (1, 3):
        settings = AgentSettings("agent-a", CoreSettings(prefix=PREFIX), size_every_s=600.0, size_workers=workers)
        agent = AgentService(settings, _Session(), quantifier=_Quantifier([0]))
        pool = _Pool()
        agent._pool = lambda pool=pool: pool
        for i in range(5):
            agent._size_or_queue(_window(f"L{i}"))
        assert pool.submitted == [f"L{i}" for i in range(workers)]
        assert list(agent._size_queue) == [f"L{i}" for i in range(workers, 5)]
    args = argparse.Namespace(size_every=60.0, size_workers=0)
    with pytest.raises(InputError, match="--size-workers 0"):
        run(args)
