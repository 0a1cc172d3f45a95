"""The record as the window network reads it: OP and PV themselves, not statistics of them.

The verdict's logistic models weigh eleven statistics of a window (``detect.features``).  Trained and judged on
the same kind of plant loop, those statistics rank the windows that show a valve fault and do not cycle above
their look-alikes with an AUC of 0.71-0.84 (seed 3031's plant-scale families, each judged by a model trained on
its own family at another seed); a small convolutional network reading OP and PV sample by sample ranked the same
windows at 0.93 (trained on 10,500 windows of every family): the evidence is in the record, and the statistics
lose it (docs/benchmarks.md, "The window network").  This module makes the network's input; the network is
trained by ``trainer.window_net`` and run by ``quantify.predictor`` (onnxruntime), and the verdict weighs its
probability beside the statistics in every window but the canonical loop's (``detect.verdict``).

Pure numpy, so that the trainer and the runtime make the input the same way.
"""

from __future__ import annotations

import numpy as np

CHANNELS = ("op", "pv", "error", "op_step", "pv_step")
"""The input's channels: OP and PV, each centred on its median and divided by its 5-95 % range (a record in any
units and offset reads the same); the control error PV - SP in PV's scale; OP's and PV's steps, ``STEP_GAIN``
times, in the same scales.  OP is mirrored for a direct-acting loop (``reverse_acting_op``)."""
CHUNK_SAMPLES = 600
"""The network reads chunks of this many samples: the simulated families' windows, which it is trained on."""
MAX_CHUNKS = 6
"""At most this many chunks of a record (3,600 samples: the stretch ``stiction quantify`` reads), spread evenly
over its end; the record's probability is the one of the chunks' mean log-odds."""
MIN_SAMPLES = 64
"""A record shorter than this gets no network reading (the verdict weighs its statistics alone)."""
STEP_GAIN = 5.0
"""Steps are small beside the range: scaled up so that the first layer sees them at the levels' size."""
CLIP = 5.0
"""Every channel is clipped to this many ranges: one wild sample does not dominate a chunk."""
FEATURE_SPEC = {
    "kind": "window_sequence",
    "channels": list(CHANNELS),
    "chunk_samples": CHUNK_SAMPLES,
    "max_chunks": MAX_CHUNKS,
    "step_gain": STEP_GAIN,
    "clip": CLIP,
}
"""What the network reads, written on its card and checked against it before it runs (``quantify.predictor``)."""


def reverse_acting_op(op: np.ndarray, pv: np.ndarray) -> np.ndarray:
    """OP as a reverse-acting controller would have written it: mirrored where OP's steps go with PV's (a
    direct-acting loop: its controller raises OP as PV rises; 11 of the 60 measured windows here), so that the
    network, trained on reverse-acting loops, reads both alike.  The sign is the covariance of OP's steps with
    PV's, negated: a PI controller's proportional kick dominates its step-to-step moves."""
    op, pv = np.asarray(op, float), np.asarray(pv, float)
    d_op, d_pv = np.diff(op), np.diff(pv)
    if d_op.size < 2:
        return op
    covariance = float(np.dot(d_op - d_op.mean(), d_pv - d_pv.mean()))
    return -op if covariance > 0 else op


def _range(x: np.ndarray) -> float:
    lo, hi = np.percentile(x, [5.0, 95.0])
    return float(hi - lo) + 1e-9 * max(1.0, float(np.max(np.abs(x))))


def net_input(op: np.ndarray, pv: np.ndarray, sp: np.ndarray | None = None) -> np.ndarray:
    """[len(CHANNELS), N] float32: one chunk as the network reads it (``CHANNELS``)."""
    op = reverse_acting_op(op, pv)
    pv = np.asarray(pv, float)
    sp = np.full_like(pv, float(np.median(pv))) if sp is None else np.asarray(sp, float)
    op_scale, pv_scale = _range(op), _range(pv)
    o = (op - np.median(op)) / op_scale
    p = (pv - np.median(pv)) / pv_scale
    e = (pv - sp) / pv_scale
    steps_o = np.diff(o, prepend=o[:1]) * STEP_GAIN
    steps_p = np.diff(p, prepend=p[:1]) * STEP_GAIN
    return np.clip(np.stack([o, p, e, steps_o, steps_p]), -CLIP, CLIP).astype(np.float32)


def chunk_starts(n: int, max_chunks: int = MAX_CHUNKS) -> np.ndarray:
    """Where each chunk of a record of ``n`` samples starts: one chunk of the whole record up to
    ``CHUNK_SAMPLES``; beyond, as many as cover its last ``max_chunks * CHUNK_SAMPLES`` samples, evenly spread
    (overlapping where the stretch is not a whole number of chunks), the last ending with the record."""
    if n <= CHUNK_SAMPLES:
        return np.zeros(1, int)
    span = min(n, max(1, max_chunks) * CHUNK_SAMPLES)
    k = int(np.ceil(span / CHUNK_SAMPLES))
    return (n - span + np.round(np.linspace(0, span - CHUNK_SAMPLES, k))).astype(int)


def _chunk_rows(op: np.ndarray, pv: np.ndarray, sp: np.ndarray, has_sp: np.ndarray) -> np.ndarray:
    """``net_input`` of every row of ``op``, ``pv``, ``sp`` [m, L] at once (``has_sp`` [m]: rows whose SP is
    recorded; elsewhere the error is PV about its median, as ``net_input`` reads a missing SP)."""
    d_op, d_pv = np.diff(op, axis=1), np.diff(pv, axis=1)
    covariance = np.sum((d_op - d_op.mean(axis=1, keepdims=True)) * (d_pv - d_pv.mean(axis=1, keepdims=True)), axis=1)
    op = np.where((covariance > 0)[:, None], -op, op)
    both = np.stack([op, pv])  # [2, m, L]
    lo, hi = np.percentile(both, [5.0, 95.0], axis=2)
    scale = hi - lo + 1e-9 * np.maximum(1.0, np.max(np.abs(both), axis=2))  # [2, m]
    centre = np.median(both, axis=2)
    o = (op - centre[0][:, None]) / scale[0][:, None]
    p = (pv - centre[1][:, None]) / scale[1][:, None]
    e = np.where(has_sp[:, None], (pv - sp) / scale[1][:, None], p)
    steps_o = np.diff(o, axis=1, prepend=o[:, :1]) * STEP_GAIN
    steps_p = np.diff(p, axis=1, prepend=p[:, :1]) * STEP_GAIN
    return np.clip(np.stack([o, p, e, steps_o, steps_p], axis=1), -CLIP, CLIP).astype(np.float32)


def chunk_rows(
    op: np.ndarray, pv: np.ndarray, sps: list | None = None, max_chunks: int = MAX_CHUNKS
) -> tuple[np.ndarray, np.ndarray]:
    """The chunks of every record of ``op``, ``pv`` [W, N] (``sps``: each record's setpoint or None), made at once:
    ``(x [k * readable, C, min(N, CHUNK_SAMPLES)], readable [W] bool)``, the chunks of each readable record in a
    row of ``k = len(chunk_starts(N, max_chunks))``; a record shorter than ``MIN_SAMPLES`` or with NaN in OP or PV
    is not read, a setpoint with NaN is read as none.  Row for row what ``chunks`` makes (the test compares them)."""
    op, pv = np.atleast_2d(np.asarray(op, float)), np.atleast_2d(np.asarray(pv, float))
    n_rows, n = op.shape
    sps = [None] * n_rows if sps is None else list(sps)
    length = min(n, CHUNK_SAMPLES)
    readable = np.all(np.isfinite(op), axis=1) & np.all(np.isfinite(pv), axis=1) & (n >= MIN_SAMPLES)
    if not readable.any():
        return np.zeros((0, len(CHANNELS), length), np.float32), readable
    sp = np.zeros_like(pv)
    has_sp = np.zeros(n_rows, bool)
    for i, row in enumerate(sps):
        if row is not None and np.all(np.isfinite(row)):
            sp[i], has_sp[i] = row, True
    starts = chunk_starts(n, max_chunks)
    idx = starts[:, None] + np.arange(length)  # [k, L]
    rows = np.flatnonzero(readable)

    def cut(x):
        return x[rows][:, idx].reshape(-1, length)  # [readable * k, L]

    return _chunk_rows(cut(op), cut(pv), cut(sp), np.repeat(has_sp[rows], len(starts))), readable


def chunks(op: np.ndarray, pv: np.ndarray, sp: np.ndarray | None = None) -> np.ndarray:
    """[k, len(CHANNELS), min(N, CHUNK_SAMPLES)]: one record's chunks, each scaled on its own (as the network was
    trained on whole windows); empty [0, ...] for a record shorter than ``MIN_SAMPLES`` or with NaN."""
    return chunk_rows(np.asarray(op, float)[None], np.asarray(pv, float)[None], [sp])[0]


def record_probabilities(chunk_logits: np.ndarray, readable: np.ndarray) -> np.ndarray:
    """Each record's probability from its chunks' log-odds (``chunk_rows``'s chunks, in its order): the one of
    their mean log-odds; nan for a record that was not read."""
    out = np.full(len(readable), np.nan)
    if readable.any():
        logits = np.asarray(chunk_logits, float).reshape(int(readable.sum()), -1)
        out[readable] = 1.0 / (1.0 + np.exp(-logits.mean(axis=1)))
    return out
