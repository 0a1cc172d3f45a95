"""``stiction train`` end to end in miniature: models the agent accepts."""

from pathlib import Path

import numpy as np
import pytest

from stiction.quantify.pipeline import Quantifier, Window
from stiction.schemas.model_card import ModelCard
from stiction.sim.loop import LoopSpec, simulate
from stiction.trainer.fit import FitSettings
from stiction.trainer.train import TrainSettings, run
from stiction.trainer.window_net import WindowNetSettings


@pytest.mark.slow
def test_small_training_run_writes_models_the_agent_loads(tmp_path: Path):
    settings = TrainSettings(
        models_dir=tmp_path,
        realisations=1,
        noisy_variants=0,
        ensemble=2,
        accuracy_seeds=1,
        thesis_fit=FitSettings(epochs=300, patience=50, learning_rate=1e-2),
        cycle_fit=FitSettings(epochs=20, patience=5, batch_size=256, learning_rate=2e-3),
        window_net=WindowNetSettings(seeds=1, n_per_cause=1, members=1, epochs=1),
    )
    summary = run(settings)
    for name in ("thesis_mlp", "cycle_ensemble", "window_net"):
        card = ModelCard.model_validate_json((tmp_path / f"{name}.card.json").read_text())
        assert len(card.training_data["sha256"]) == 64
        if name != "window_net":
            assert card.accuracy["C1-C10"]["n"] == 10
    assert summary["accuracy"]["C1-C10"]["cycle_ensemble_mae_pp"] < 15  # a crude model, but a model
    r = simulate([LoopSpec(40, 10)]).kept()
    quantifier = Quantifier(tmp_path)
    own = ModelCard.model_validate_json((tmp_path / "window_net.card.json").read_text())
    assert quantifier.window_net.card.onnx_sha256 == own.onnx_sha256  # its own network, not the shipped one
    assert f"window_net-1.{own.onnx_sha256[:8]}" in quantifier.model_version
    report = quantifier.quantify([Window("x", r.op[0], r.pv[0])])[0]
    assert report.learned.fs_pct is not None and np.isfinite(report.learned.fs_pct)
