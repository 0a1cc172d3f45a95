"""The coded ring against the float64 samples it was given, on streams of every scale, with an outlier hidden
in one."""

import numpy as np
import pytest

from stiction.agent.coded_ring import CODES_FITTED, CodedRing, fitted_step


def _stream(rng, offset: float, span: float, n: int) -> np.ndarray:
    """A loop's signal: a level that wanders, a cycle, noise; ``span`` its size, ``offset`` where it sits."""
    t = np.arange(n)
    wander = 0.1 * np.cumsum(rng.normal(size=n)) / np.sqrt(n)
    return offset + span * (0.3 * np.sin(t / 37.0) + wander + 1e-3 * rng.normal(size=n))


def _feed(ring: CodedRing, stream: np.ndarray, size: int, rng):
    """Write ``stream`` in messages of random length at the ring's positions; yield (samples so far, positions of
    the window oldest first)."""
    seq = 0
    while seq < stream.size:
        n = int(rng.integers(1, 40)) if rng.random() < 0.9 else int(rng.integers(40, 2 * size))
        part = stream[seq : seq + n][-size:]
        first = seq + min(n, stream.size - seq) - part.size
        for k, v in enumerate(part):
            ring.put((first + k) % size, [float(v)]) if rng.random() < 0.5 else ring.write(
                slice((first + k) % size, (first + k) % size + 1), np.array([v])
            )
        seq += min(n, stream.size - seq)
        if seq >= size and (seq // size) > ((seq - n) // size):
            ring.narrow()
        count = min(seq, size)
        yield seq, (seq - count + np.arange(count)) % size


@pytest.mark.parametrize(("offset", "span"), [(50.0, 20.0), (0.0, 1e-3), (1013.25, 0.05), (-4e5, 3e4), (7.0, 1e6)])
def test_every_sample_reads_back_within_a_step_of_the_grid_of_its_windows(offset, span):
    rng = np.random.default_rng(int(abs(offset)) + 7)
    size = 200
    stream = _stream(rng, offset, span, 3000)
    ring = CodedRing(size)
    for seq, at in _feed(ring, stream, size, rng):
        expected = stream[seq - at.size : seq]
        around = stream[max(0, seq - 3 * size) : seq]
        bound = fitted_step(around.min(), around.max())
        finest = 2**-30 * np.abs(around).max()  # a signal that barely moves: far below float32's resolution (2^-24)
        assert bound <= 2 * max((around.max() - around.min()) / (2 * CODES_FITTED), finest)
        assert np.all(np.abs(ring.read(at) - expected) <= bound)


def test_an_outlier_coarsens_the_grid_and_its_resolution_comes_back_once_it_slid_out():
    """Hidden effect: one spike of a million in a signal of a few %."""
    rng = np.random.default_rng(3)
    size = 200
    stream = _stream(rng, 40.0, 5.0, 2000)
    stream[700] = 1e6
    ring = CodedRing(size)
    steps = {seq: ring.step for seq, _ in _feed(ring, stream, size, rng)}
    coarse = max(s for seq, s in steps.items() if 700 < seq <= 900)
    late = [s for seq, s in steps.items() if seq > 1100]
    assert coarse >= 1e6 / (2 * CODES_FITTED) and max(late) <= fitted_step(stream[900:].min(), stream[900:].max())
    at = (2000 - size + np.arange(size)) % size
    assert np.all(np.abs(ring.read(at) - stream[-size:]) <= max(late))


def test_zero_reads_back_zero_and_a_repeated_value_one_value():
    ring = CodedRing(100)
    ring.write(slice(0, 50), np.r_[np.zeros(25), np.linspace(3.0, 78.0, 25)])
    ring.write(slice(50, 100), np.full(50, 37.123456))
    got = ring.read(np.arange(100))
    assert np.all(got[:25] == 0.0) and np.unique(got[50:]).size == 1
    assert abs(got[50] - 37.123456) <= ring.step


def test_a_sample_written_on_a_grid_that_stays_reads_back_within_its_step():
    rng = np.random.default_rng(5)
    ring = CodedRing(500)
    ring.write(slice(0, 2), np.array([10.0, 30.0]))  # the grid, fitted to the range the rest stays inside
    values = rng.uniform(10.0, 30.0, 498)
    for k in range(0, 250, 5):
        ring.put(2 + k, values[k : k + 5].tolist())
    ring.write(slice(252, 500), values[250:])
    held = ring.read(np.arange(2, 500))
    assert ring.step == fitted_step(10.0, 30.0) and held.dtype == np.float64
    assert np.all(np.abs(held - values) < ring.step)
    assert np.all(((held - values) == 0) | ((held / ring.step) % 2 == 1))  # rounded to an odd multiple of the step


def test_a_value_repeated_across_the_grids_widenings_keeps_one_code():
    """Hidden effect: a stepped PV of three levels, its first message one level alone (the finest grid), the others
    arriving later, each widening the grid; the agent's window must still hold three values, not five."""
    rng = np.random.default_rng(11)
    for levels, size in [(np.array([49.04312291, 50.00475277, 50.96638263]), 1000)] + [
        (np.sort(rng.uniform(-50, 150, 3)), int(rng.choice([1000, 300])))
        for _ in range(20)  # and rings that turn over
    ]:
        stream = np.r_[np.full(5, levels[1]), levels[rng.integers(0, 3, 995)]]
        ring, seq = CodedRing(size), 0
        while seq < stream.size:
            n = int(rng.integers(1, 8))
            part = stream[seq : seq + n]
            at = seq % size
            first = min(part.size, size - at)
            ring.put(at, part[:first].tolist()) if rng.random() < 0.5 else ring.write(
                slice(at, at + first), part[:first]
            )
            if first < part.size:
                ring.put(0, part[first:].tolist())
            seq += part.size
        assert np.unique(ring.read(np.arange(size))).size == 3


@pytest.mark.parametrize("values", [[1e308, -1e308, 5.0], [-1.7e308, 1.7e308], [1e300, 2.0, 3.0], [3.5e-44, 0.0]])
def test_values_at_float64s_ends_are_held_within_a_step_and_raise_nothing(values):
    """A message in wrong units must not stop the agent: the grid reaches any finite value."""
    for how in ("put", "write"):
        ring = CodedRing(10)
        ring.write(slice(0, 1), np.array([values[-1]])) if how == "put" else None
        for k, v in enumerate(values):
            ring.put(1 + k, [v]) if how == "put" else ring.write(slice(1 + k, 2 + k), np.array([v]))
        got = ring.read(np.arange(1, 1 + len(values)))
        assert np.all(np.isfinite(got)) and np.all(np.abs(got - np.array(values)) <= ring.step)


def test_one_sample_at_a_time_codes_what_the_arrays_code():
    """The one-sample path of ``put`` (the spec's stream) writes the bytes that ``write`` writes for the same
    samples, through the grid's widenings (an outlier, then a wider signal) and on a ring that turns over."""
    rng = np.random.default_rng(21)
    stream = _stream(rng, 50.0, 20.0, 900)
    stream[300] = 400.0  # an outlier: the grid widens
    stream[600:] *= 3.0  # and widens again
    one, arrays = CodedRing(250), CodedRing(250)
    for seq, v in enumerate(stream):
        one.put(seq % 250, [float(v)])
        arrays.write(slice(seq % 250, seq % 250 + 1), np.array([v]))
        assert one.step == arrays.step and one.base == arrays.base
    assert one.buf == arrays.buf
