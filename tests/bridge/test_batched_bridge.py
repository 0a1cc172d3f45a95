"""The OPC UA bridge at a rate the user chooses: several seconds of a loop's samples a message, its loops
spread over the interval, and the same samples as one a message."""

import numpy as np
import pytest

from stiction.bridge.opcua import BridgeSettings, OpcuaBridge
from stiction.bridge.sampler import Reading
from stiction.schemas.loop_file import LoopFile, LoopNodes
from stiction.schemas.messages import SampleBatch


def _run(n_loops: int, batch_s: float | None, seconds: int = 40, seed: int = 3):
    """Every loop's OP and PV changing at random instants for ``seconds``, the bridge ticking just after each
    grid point: (the batches published at each tick, the bridge)."""
    loops = {f"L{i}": LoopNodes(op=f"ns=2;s=L{i}.OP", pv=f"ns=2;s=L{i}.PV") for i in range(n_loops)}
    now = [0.0]
    ticks: list[list[dict]] = []
    bridge = OpcuaBridge(
        LoopFile(loops=loops, sample_time_s=1.0),
        BridgeSettings("b", "opc.tcp://127.0.0.1:1", batch_s=batch_s),
        lambda batch: ticks[-1].append(batch),
        clock=lambda: now[0],
    )
    rng = np.random.default_rng(seed)
    for t in range(seconds):
        for loop_id in loops:
            for role in ("op", "pv"):
                at = t + float(rng.uniform(0.0, 0.99))
                bridge.sampler.add(Reading(loop_id, role, float(rng.normal(50, 5)), True, at, at))
        now[0] = t + 1.05
        ticks.append([])
        bridge._publish_due()
    return ticks, bridge


def _samples(ticks) -> dict[str, dict[float, tuple[float, float]]]:
    """Each loop's samples by their grid time, checked to be numbered without gaps from the loop's first."""
    out: dict[str, dict[float, tuple[float, float]]] = {}
    first: dict[str, float] = {}
    for tick in ticks:
        for b in tick:
            SampleBatch.model_validate(b)
            got = out.setdefault(b["loop_id"], {})
            start = first.setdefault(b["loop_id"], b["t0_s"])
            assert b["seq"] == round((b["t0_s"] - start) / b["ts_s"])
            for i, (op, pv) in enumerate(zip(b["op"], b["pv"], strict=True)):
                t = b["t0_s"] + i * b["ts_s"]
                assert t not in got, "a sample published twice"
                got[t] = (op, pv)
    return out


@pytest.mark.parametrize("batch_s", [5.0, 3.0])
def test_batches_of_several_seconds_carry_the_samples_of_one_a_message_spread_over_the_loops(batch_s):
    n = 20
    single, _ = _run(n, None)
    batched, bridge = _run(n, batch_s)
    every = _samples(single)
    grouped = _samples(batched)
    groups = round(batch_s)
    for loop_id, got in grouped.items():  # the same values at the same sequence numbers
        assert got == {k: every[loop_id][k] for k in got}
        assert max(every[loop_id]) - max(got) < groups  # at most one interval behind
    per_tick = [len(t) for t in batched[groups:]]
    assert min(per_tick) >= n // groups and max(per_tick) <= -(-n // groups)  # the loops spread over the ticks
    after_first = [len(b["op"]) for t in batched[2 * groups :] for b in t]  # past every loop's first message
    assert set(after_first) == {groups}  # a loop's samples of ``batch_s`` seconds a message
    assert [len(t) for t in single[1:]] == [n] * (len(single) - 1)
    assert bridge.health().loops_publishing == n  # each loop counted by its own last turn, not by the last tick
