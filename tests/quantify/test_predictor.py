"""The agent refuses models whose card does not match the file or the code."""

import json
import shutil

import pytest

from stiction.quantify.predictor import DEFAULT_MODELS_DIR, ModelError, Predictor


@pytest.fixture
def models(tmp_path):
    for f in DEFAULT_MODELS_DIR.iterdir():
        shutil.copy(f, tmp_path / f.name)
    return tmp_path


def test_committed_models_load():
    for name in ("thesis_mlp", "cycle_ensemble"):
        assert Predictor(DEFAULT_MODELS_DIR, name).card.name == name


def test_missing_card_says_how_to_get_one(tmp_path):
    with pytest.raises(ModelError, match="stiction train"):
        Predictor(tmp_path, "thesis_mlp")


def test_changed_onnx_file_is_refused(models):
    path = models / "thesis_mlp.onnx"
    path.write_bytes(path.read_bytes() + b"\0")
    with pytest.raises(ModelError, match="sha256"):
        Predictor(models, "thesis_mlp")


def test_card_for_other_features_is_refused(models):
    card_path = models / "cycle_ensemble.card.json"
    card = json.loads(card_path.read_text())
    card["feature_spec"]["curve_points"] = 16
    card_path.write_text(json.dumps(card))
    with pytest.raises(ModelError, match="other features"):
        Predictor(models, "cycle_ensemble")


def test_malformed_card_is_refused(models):
    (models / "thesis_mlp.card.json").write_text("{not json")
    with pytest.raises(ModelError, match="not a valid model card"):
        Predictor(models, "thesis_mlp")
