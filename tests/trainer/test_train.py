"""``stiction train`` end to end in miniature: models the agent accepts."""

from pathlib import Path

import numpy as np

from stiction.quantify.pipeline import Quantifier, Window
from stiction.schemas.model_card import ModelCard
from stiction.sim.loop import LoopSpec, simulate
from stiction.trainer.fit import FitSettings
from stiction.trainer.train import TrainSettings, run


def test_small_training_run_writes_models_the_agent_loads(tmp_path: Path):
    settings = TrainSettings(
        models_dir=tmp_path,
        realisations=1,
        noisy_variants=0,
        ensemble=2,
        accuracy_seeds=1,
        thesis_fit=FitSettings(epochs=300, patience=50, learning_rate=1e-2),
        cycle_fit=FitSettings(epochs=20, patience=5, batch_size=256, learning_rate=2e-3),
    )
    summary = run(settings)
    for name in ("thesis_mlp", "cycle_ensemble"):
        card = ModelCard.model_validate_json((tmp_path / f"{name}.card.json").read_text())
        assert card.accuracy["C1-C10"]["n"] == 10
        assert len(card.training_data["sha256"]) == 64
    assert summary["accuracy"]["C1-C10"]["cycle_ensemble_mae_pp"] < 15  # a crude model, but a model
    r = simulate([LoopSpec(40, 10)]).kept()
    report = Quantifier(tmp_path).quantify([Window("x", r.op[0], r.pv[0])])[0]
    assert report.learned.fs_pct is not None and np.isfinite(report.learned.fs_pct)
