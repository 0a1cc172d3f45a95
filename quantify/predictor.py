"""ONNX predictors, checked against their model cards before they run (onnxruntime, no torch)."""

from __future__ import annotations

import hashlib
import logging
from dataclasses import asdict
from pathlib import Path

import numpy as np
import onnxruntime as ort

from stiction.detect import sequence
from stiction.quantify.features import CURVE_POINTS, CYCLE_FEATURES, THESIS_WINDOW
from stiction.quantify.inlpca import InlpcaSettings
from stiction.schemas.errors import StictionError
from stiction.schemas.model_card import CARD_FORMAT, ModelCard

log = logging.getLogger(__name__)

DEFAULT_MODELS_DIR = Path(__file__).resolve().parent / "models"


class ModelError(StictionError):
    """A model file or its card is missing or does not match this code."""


EXPECTED_FEATURES = {
    "thesis_mlp": {"kind": "thesis_window", "length": THESIS_WINDOW},
    "cycle_ensemble": {
        "kind": "cycle_features",
        "curve_points": CURVE_POINTS,
        "n_features": CYCLE_FEATURES,
        "inlpca": asdict(InlpcaSettings()),
    },
    "window_net": sequence.FEATURE_SPEC,
}


class Predictor:
    """One ONNX model with its card; ``run(x)`` returns the outputs by name."""

    def __init__(self, models_dir: Path, name: str):
        card_path = Path(models_dir) / f"{name}.card.json"
        if not card_path.is_file():
            raise ModelError(f"no model card {card_path}: run `stiction train` or pass --models DIR")
        try:
            card = ModelCard.model_validate_json(card_path.read_text())
        except ValueError as e:
            raise ModelError(f"{card_path}: not a valid model card ({e.__class__.__name__})") from None
        if card.card_format != CARD_FORMAT:
            raise ModelError(f"{card_path}: card format {card.card_format}, this code reads {CARD_FORMAT}")
        expected = EXPECTED_FEATURES[name]
        mismatch = {k: (card.feature_spec.get(k), v) for k, v in expected.items() if card.feature_spec.get(k) != v}
        if mismatch:
            raise ModelError(
                f"{card_path}: trained on other features than this code computes {mismatch}; "
                "retrain with `stiction train`"
            )
        onnx_path = card_path.parent / card.onnx_file
        if not onnx_path.is_file():
            raise ModelError(f"{onnx_path} missing (named by {card_path.name})")
        digest = hashlib.sha256(onnx_path.read_bytes()).hexdigest()
        if digest != card.onnx_sha256:
            raise ModelError(f"{onnx_path}: sha256 differs from its card; the file was changed or replaced")
        options = ort.SessionOptions()
        # on 2 cores the default thread pool gives millisecond spikes (STACK.md)
        options.intra_op_num_threads = 1
        options.inter_op_num_threads = 1
        self.session = ort.InferenceSession(str(onnx_path), options, providers=["CPUExecutionProvider"])
        names = [i.name for i in self.session.get_inputs()]
        if names != [t.name for t in card.inputs]:
            raise ModelError(f"{onnx_path}: inputs {names} differ from the card's")
        self.card = card
        self.input_name = names[0]
        self.output_names = [o.name for o in self.session.get_outputs()]
        log.info("loaded %s version %s from %s", name, card.version, onnx_path)

    def run(self, x: np.ndarray) -> dict[str, np.ndarray]:
        outputs = self.session.run(None, {self.input_name: np.ascontiguousarray(x, dtype=np.float32)})
        return dict(zip(self.output_names, outputs, strict=True))


def load_models(models_dir: Path | None = None) -> tuple[Predictor, Predictor]:
    models_dir = Path(models_dir) if models_dir is not None else DEFAULT_MODELS_DIR
    return Predictor(models_dir, "thesis_mlp"), Predictor(models_dir, "cycle_ensemble")


def model_version(*predictors: Predictor) -> str:
    """E.g. ``thesis_mlp-1.3fa2c1d0+cycle_ensemble-1.9b0e77aa``: name, version, file hash."""
    return "+".join(f"{p.card.name}-{p.card.version}.{p.card.onnx_sha256[:8]}" for p in predictors)


WINDOW_NET = "window_net"


def load_window_net(models_dir: Path | None = None) -> Predictor | None:
    """The window network (``detect.sequence``) of ``models_dir`` where it holds one, else the shipped one; None
    where neither has one (models trained before it: the verdict then weighs its statistics alone, as it did)."""
    for folder in ([Path(models_dir)] if models_dir is not None else []) + [DEFAULT_MODELS_DIR]:
        if (folder / f"{WINDOW_NET}.card.json").is_file():
            return Predictor(folder, WINDOW_NET)
    log.warning("no window network in %s or the shipped models: the verdict weighs the statistics alone", models_dir)
    return None


NET_BATCH_CHUNKS = 32
"""Chunks run through the window network at a time.  onnxruntime keeps the memory of its largest run for the next
(its arena): in a process alone, the agent's batch of 200 windows in one run kept 44 MB more than runs of 32 chunks
(9 MB), at the same cost a chunk (0.33-0.43 ms here then; 0.24 ms since the network is exported with 2-D
convolutions, ``trainer.nets.WindowEnsemble2d``).  In an agent of 20,000 plant-like loops the peak's spread
between runs is as large as that (docs/scaling.md, "Every goal again")."""


def sequence_probabilities(
    net: Predictor, op: np.ndarray, pv: np.ndarray, sps: list, max_chunks: int = sequence.MAX_CHUNKS
) -> np.ndarray:
    """The window network's probability that each window [n, N] shows a valve fault (nan where it reads none:
    too short, or NaN in the record): every window's chunks (at most ``max_chunks``) made at once and run
    ``NET_BATCH_CHUNKS`` at a time, each window's chunks' mean log-odds."""
    x, readable = sequence.chunk_rows(op, pv, sps, max_chunks)
    logits = [net.run(x[i : i + NET_BATCH_CHUNKS])["logit"] for i in range(0, len(x), NET_BATCH_CHUNKS)]
    return sequence.record_probabilities(np.concatenate(logits) if logits else np.zeros(0), readable)
