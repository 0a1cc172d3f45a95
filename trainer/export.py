"""ONNX export: fixed names, dynamic batch axis, checked with onnx.checker, traced with a batch of 2."""

from __future__ import annotations

import hashlib
from pathlib import Path

import onnx
import torch
from torch import nn


def export(model: nn.Module, n_features: int, path: Path, input_name: str, output_names: list[str]) -> str:
    """Write ``path``; returns its sha256."""
    model.eval()
    example = torch.zeros(2, n_features)
    dynamic = {input_name: {0: "batch"}} | {name: {0: "batch"} for name in output_names}
    torch.onnx.export(
        model,
        (example,),
        str(path),
        input_names=[input_name],
        output_names=output_names,
        dynamic_axes=dynamic,
        opset_version=17,
        dynamo=False,
    )
    onnx.checker.check_model(onnx.load(str(path)))
    return hashlib.sha256(path.read_bytes()).hexdigest()
