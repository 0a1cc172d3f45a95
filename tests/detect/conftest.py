from pathlib import Path

import pytest

from tests.measured import PLANT


@pytest.fixture
def plant_dir() -> Path:
    """The labelled measured windows (``stictiongpt_plant``); the test is skipped where they are not."""
    if not PLANT.is_dir():
        pytest.skip("measured plant data not here")
    return PLANT


@pytest.fixture
def measured_evidence(plant_dir):
    """``of(pattern)``: the evidence of each measured window whose file name matches ``pattern``."""
    from stiction.bridge.historian import read_export
    from stiction.detect.features import evidence

    def of(pattern: str) -> list:
        return [evidence(e.op, e.pv, e.ts_s, e.sp) for e in map(read_export, sorted(plant_dir.glob(pattern)))]

    return of


@pytest.fixture(scope="module")
def detector():
    """The shipped detector."""
    from stiction.detect.verdict import DETECTOR_FILE, Detector
    from stiction.quantify.predictor import DEFAULT_MODELS_DIR

    return Detector.load(DEFAULT_MODELS_DIR / DETECTOR_FILE)
