"""The shipped window network is the one this code's settings train, reading the input this code makes."""

import hashlib
import json
from dataclasses import asdict

import numpy as np

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


def _logits(path, x):
    import onnxruntime as ort

    return ort.InferenceSession(str(path), providers=["CPUExecutionProvider"]).run(None, {"chunks": x})[0]


def _chunks(seed: int = 9393, n: int = 6, samples: int = 1300):
    from stiction.sim import two_parameter

    recs = two_parameter.simulate(two_parameter.draw(1, seed)[:n], samples)
    op, pv = np.stack([r.op for r in recs]), np.stack([r.pv for r in recs])
    return sequence.chunk_rows(op, pv, [r.sp for r in recs], 3)[0]


def test_the_exported_network_is_the_trained_one_with_two_dimensional_convolutions(tmp_path):
    """The runtime's form (``WindowEnsemble2d``): every convolution 2-D, the logits the trained ensemble's."""
    import onnx
    import torch

    from stiction.trainer import nets
    from stiction.trainer.window_net import _export

    torch.manual_seed(3)
    model = nets.WindowEnsemble([nets.WindowNet() for _ in range(2)]).eval()
    path = tmp_path / "w.onnx"
    _export(model, path)
    convs = [n for n in onnx.load(str(path)).graph.node if n.op_type == "Conv"]
    kernels = [next(a.ints for a in n.attribute if a.name == "kernel_shape") for n in convs]
    assert len(kernels) == 10 and all(len(k) == 2 for k in kernels)
    x = _chunks()
    with torch.no_grad():
        want = model(torch.from_numpy(x)).numpy()
    np.testing.assert_allclose(_logits(path, x), want, rtol=1e-5, atol=1e-5)


def test_the_shipped_network_computes_the_ensemble_its_weights_make():
    """Read back from the shipped file (``read_onnx``) and run by torch in its 1-D training form, the weights give the
    logits the shipped 2-D file gives: re-exporting changed the form, not the network."""
    import torch

    from stiction.trainer.window_net import read_onnx

    path = DEFAULT_MODELS_DIR / f"{NAME}.onnx"
    model = read_onnx(path)
    assert len(model.members) == WindowNetSettings().members
    x = _chunks()
    with torch.no_grad():
        want = model(torch.from_numpy(x)).numpy()
    np.testing.assert_allclose(_logits(path, x), want, rtol=1e-5, atol=1e-5)


def test_exporting_a_network_again_keeps_its_logits_and_card_and_renews_the_hash(tmp_path):
    import shutil

    from stiction.schemas.model_card import ModelCard
    from stiction.trainer.window_net import export_again

    for suffix in (".onnx", ".card.json"):
        shutil.copy(DEFAULT_MODELS_DIR / f"{NAME}{suffix}", tmp_path / f"{NAME}{suffix}")
    (tmp_path / f"{NAME}.card.json").write_text(
        (tmp_path / f"{NAME}.card.json").read_text().replace('"onnx_sha256": "', '"onnx_sha256": "0')
    )  # a stale hash, as a file exported in another form leaves
    before = ModelCard.model_validate_json((tmp_path / f"{NAME}.card.json").read_text())
    x = _chunks()
    want = _logits(tmp_path / f"{NAME}.onnx", x)
    card = export_again(tmp_path)
    assert card.onnx_sha256 == hashlib.sha256((tmp_path / f"{NAME}.onnx").read_bytes()).hexdigest()
    assert card.model_dump(exclude={"onnx_sha256"}) == before.model_dump(exclude={"onnx_sha256"})
    assert ModelCard.model_validate_json((tmp_path / f"{NAME}.card.json").read_text()) == card
    np.testing.assert_allclose(_logits(tmp_path / f"{NAME}.onnx", x), want, rtol=1e-5, atol=1e-5)


def test_another_models_onnx_file_is_refused_by_name_not_read_as_a_window_network():
    import pytest

    from stiction.trainer.window_net import read_onnx

    path = DEFAULT_MODELS_DIR / "thesis_mlp.onnx"
    with pytest.raises(ValueError, match=r"thesis_mlp\.onnx.*not a window network") as e:
        read_onnx(path)
    assert "\n" not in str(e.value)
