"""The window network's input (``detect.sequence``): the same record in any units, offset or controller action
reads the same, every chunk lies in the record and its end is read, and a record it cannot read gives none."""

import numpy as np
import pytest

from stiction.detect import sequence
from stiction.sim.plant_families import family_loops, simulate_families


@pytest.fixture(scope="module")
def record():
    loop = next(lp for lp in family_loops(1, 4141) if lp.cause == "stick_slip" and lp.family == "flow")
    return simulate_families([loop], samples=1500)[0]


def test_a_record_in_other_units_and_offsets_reads_the_same(record):
    base = sequence.chunks(record.op, record.pv, record.sp)
    # OP in 0-1 instead of %, PV and SP in engineering units of a 0-400 range
    other = sequence.chunks(record.op / 100, 4.0 * record.pv + 120.0, 4.0 * record.sp + 120.0)
    np.testing.assert_allclose(other, base, atol=2e-5)


def test_a_direct_acting_loop_reads_as_its_reverse_acting_mirror(record):
    """A direct-acting controller raises OP as PV rises: the same loop with its valve's action reversed writes
    100 - OP (or, with the process gain's sign flipped, PV mirrored about SP)."""
    base = sequence.chunks(record.op, record.pv, record.sp)
    np.testing.assert_allclose(sequence.chunks(100.0 - record.op, record.pv, record.sp), base, atol=1e-5)
    assert sequence.reverse_acting_op(record.op, record.pv) is not None
    flipped = sequence.reverse_acting_op(100.0 - record.op, record.pv)
    np.testing.assert_allclose(flipped, record.op - 100.0)


def test_chunks_cover_the_records_end_and_at_most_the_stretch_quantify_reads():
    n_chunk, most = sequence.CHUNK_SAMPLES, sequence.MAX_CHUNKS
    assert list(sequence.chunk_starts(200)) == [0] and list(sequence.chunk_starts(n_chunk)) == [0]
    for n in (n_chunk + 1, 1000, 1800, 3600, 10_000):
        starts = sequence.chunk_starts(n)
        assert starts[-1] + n_chunk == n and starts.min() >= max(0, n - most * n_chunk)
        assert len(starts) <= most and np.all(np.diff(starts) > 0) and np.all(np.diff(starts) <= n_chunk)
    assert sequence.chunk_starts(1000).tolist() == [0, 400] and sequence.chunk_starts(1000, 1).tolist() == [400]


def test_a_record_the_network_cannot_read_gives_no_chunk_and_no_probability(record):
    short = sequence.chunks(record.op[: sequence.MIN_SAMPLES - 1], record.pv[: sequence.MIN_SAMPLES - 1])
    pv = record.pv.copy()
    pv[100] = np.nan
    gap = sequence.chunks(record.op, pv)
    assert short.shape[0] == 0 and gap.shape[0] == 0
    assert np.isnan(sequence.record_probabilities(np.zeros(0), np.array([False]))).all()
    # a setpoint with a gap is read as none, the record still is
    sp = record.sp.copy()
    sp[5] = np.nan
    assert sequence.chunks(record.op, record.pv, sp).shape[0] == len(sequence.chunk_starts(record.op.size))


def test_the_probability_is_the_one_of_the_chunks_mean_log_odds():
    p = sequence.record_probabilities(np.array([0.0, 0.0, -2.0, 4.0]), np.array([True, False, True]))
    assert p[0] == pytest.approx(0.5) and np.isnan(p[1]) and p[2] == pytest.approx(1 / (1 + np.exp(-1.0)))


def test_the_batch_input_is_the_one_chunk_by_chunk_of_the_simple_reference(record):
    """``chunk_rows`` (every chunk of every record at once) against ``net_input`` applied to each chunk."""
    n = 1300
    op = np.stack([record.op[:n], 100.0 - record.op[100 : 100 + n], record.op[:n]])  # the second direct-acting
    pv = np.stack([record.pv[:n], record.pv[100 : 100 + n], record.pv[:n]])
    sps = [record.sp[:n], None, None]
    pv[2, 7] = np.nan  # not readable
    x, readable = sequence.chunk_rows(op, pv, sps)
    assert readable.tolist() == [True, True, False]
    starts = sequence.chunk_starts(n)
    want = [sequence.net_input(op[i, s : s + 600], pv[i, s : s + 600], None if sps[i] is None else sps[i][s : s + 600])
            for i in (0, 1) for s in starts]  # fmt: skip
    np.testing.assert_allclose(x, np.stack(want), atol=1e-6)
    np.testing.assert_allclose(sequence.chunks(op[1], pv[1]), x[len(starts) :], atol=1e-6)
