"""ONNX export: fixed names, dynamic batch axis, checked with onnx.checker, traced with a batch of 2."""

from __future__ import annotations

import hashlib
from pathlib import Path

import onnx
import torch
from torch import nn


def export(
    model: nn.Module,
    n_features: int,
    path: Path,
    input_name: str,
    output_names: list[str],
    example: torch.Tensor | None = None,
    dynamic_axes: dict[int, str] | None = None,
) -> str:
    """Write ``path``; returns its sha256.  ``example``: the traced input (default a batch of 2 of
    ``n_features``); ``dynamic_axes``: the input's axes that vary (default the batch, axis 0), the outputs'
    batch axis always."""
    model.eval()
    example = torch.zeros(2, n_features) if example is None else example
    axes = dynamic_axes or {0: "batch"}
    dynamic = {input_name: axes} | {name: {0: "batch"} for name in output_names}
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
