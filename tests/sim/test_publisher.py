"""The simulator's publisher spreads its loops' messages over each interval, as a bridge does."""

import json
import threading
import time

import numpy as np

from stiction.sim.publisher import PublisherSettings, run


class _Session:
    """Records every put: (when, key, samples); nothing leaves the process."""

    def __init__(self):
        self.puts = []

    def put(self, key, payload, **kwargs):
        pass

    def declare_queryable(self, key, callback):
        return _Handle()

    def declare_publisher(self, key, **kwargs):
        session = self

        class _Publisher(_Handle):
            def put(self, payload):
                session.puts.append((time.monotonic(), key, len(json.loads(payload)["op"])))

        return _Publisher()


class _Handle:
    def undeclare(self):
        pass


def _publish(stagger: bool):
    session = _Session()
    settings = PublisherSettings(loops=8, speed=5.0, rate_hz=2.0, warmup_s=10.0, duration_s=10.0, stagger=stagger,
                                 history_samples=0)  # fmt: skip
    sent = run(settings, session, threading.Event())
    return sent, session.puts


def test_each_loop_sends_once_a_tick_its_share_of_the_samples_spread_over_the_tick():
    sent, puts = _publish(stagger=True)
    assert sent == 10 and len(puts) == 8 * 4  # 2.5 samples a message: 2 or 3 each of the 4 ticks
    per_loop = {}
    for _, key, n in puts:
        per_loop[key] = per_loop.get(key, 0) + n
    assert set(per_loop.values()) == {10}
    first_tick = np.array([at for at, _, _ in puts[:8]]) - puts[0][0]
    assert 0.3 < first_tick.max() < 0.5  # the 8 loops over most of the 0.5-s tick, not in one instant
    assert np.all(np.diff(first_tick) >= 0.0)


def test_unstaggered_every_loop_sends_in_the_same_instant():
    _, puts = _publish(stagger=False)
    first_tick = np.array([at for at, _, _ in puts[:8]]) - puts[0][0]
    assert first_tick.max() < 0.05


def test_a_loop_under_a_square_load_has_a_truth_message_that_says_its_shape():
    from stiction.schemas.messages import LoopTruth
    from stiction.sim.extensions import Extensions
    from stiction.sim.loop import LoopSpec
    from stiction.sim.publisher import truth_message

    ext = Extensions(osc_period_s=120.0, osc_amplitude_pct=2.0, osc_shape="square")
    message = truth_message("sq", LoopSpec(0.0, 0.0, extensions=ext))
    back = LoopTruth.model_validate_json(message.model_dump_json())
    assert back.extensions == {"osc_period_s": 120.0, "osc_amplitude_pct": 2.0, "osc_shape": "square"}
