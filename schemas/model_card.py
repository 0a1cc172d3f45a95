"""The model card beside every ONNX file: what the agent checks before it runs a model."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict

CARD_FORMAT = 1


class TensorSpec(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")

    name: str
    shape: list[int | str]
    description: str


class ModelCard(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")

    card_format: int = CARD_FORMAT
    name: str
    version: str
    onnx_file: str
    onnx_sha256: str
    feature_spec: dict
    """What the input is, exactly: e.g. window length and start rule, curve points; the agent compares it."""
    inputs: list[TensorSpec]
    outputs: list[TensorSpec]
    training_data: dict
    """What it was trained on: grid, realisations, disturbances, sha256 of the arrays."""
    settings: dict
    accuracy: dict
    """Mean absolute error (pp of 500 lbf) on the thesis test cases, computed at training time."""
    created: str
