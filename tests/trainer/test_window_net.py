"""The shipped window network is the one this code's settings train, reading the input this code makes."""

import json
from dataclasses import asdict

from stiction.detect import sequence
from stiction.quantify.predictor import DEFAULT_MODELS_DIR
from stiction.trainer.window_net import NAME, WINDOW_SEED, WindowNetSettings


def test_the_shipped_window_network_was_trained_with_this_codes_settings_on_this_codes_input():
    card = json.loads((DEFAULT_MODELS_DIR / f"{NAME}.card.json").read_text())
    settings = WindowNetSettings()
    assert card["settings"] == json.loads(json.dumps(asdict(settings)))
    assert card["feature_spec"] == sequence.FEATURE_SPEC
    assert card["training_data"]["seeds"] == [WINDOW_SEED, WINDOW_SEED + settings.seeds - 1]
    assert card["training_data"]["label"] == "sim.plant_families.FamilyRecord.shows_fault"
    assert sorted(card["training_data"]["families"]) == ["detuned", "flow", "level", "slow"]
