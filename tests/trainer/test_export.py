"""Torch and onnxruntime agree on both exported networks, at any batch size."""

import numpy as np
import onnxruntime as ort
import torch

from stiction.trainer import nets
from stiction.trainer.export import export


def _run(path, name, x):
    session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    return session.run(None, {name: x.astype(np.float32)})


def test_thesis_mlp_torch_matches_onnxruntime(tmp_path):
    torch.manual_seed(0)
    x = torch.randn(50, 100) * 10
    model = nets.ThesisMLP(x.mean(0), x.std(0), torch.tensor([40.0, 15.0]), torch.tensor([25.0, 12.0]))
    path = tmp_path / "m.onnx"
    export(model, 100, path, "op_window", ["fs_fd_pct"])
    for batch in (1, 7):
        xb = torch.randn(batch, 100) * 10
        with torch.no_grad():
            expected = model(xb).numpy()
        np.testing.assert_allclose(_run(path, "op_window", xb.numpy())[0], expected, rtol=1e-5, atol=1e-4)


def test_cycle_ensemble_torch_matches_onnxruntime(tmp_path):
    torch.manual_seed(1)
    x = torch.randn(300, 97)
    members = [
        nets.CycleMLP(x.mean(0), x.std(0), torch.tensor([40.0, 15.0]), torch.tensor([25.0, 12.0])) for _ in range(3)
    ]
    model = nets.CycleEnsemble(members, nets.fit_ood(x))
    path = tmp_path / "c.onnx"
    export(model, 97, path, "features", ["fs_fd_pct", "fs_fd_std_pct", "ood"])
    xb = torch.randn(9, 97)
    with torch.no_grad():
        expected = [t.numpy() for t in model(xb)]
    for got, want in zip(_run(path, "features", xb.numpy()), expected, strict=True):
        np.testing.assert_allclose(got, want, rtol=1e-4, atol=1e-4)


def test_ood_score_is_one_at_the_training_99th_percentile_and_grows_off_it():
    torch.manual_seed(2)
    x = torch.randn(2000, 20) @ torch.randn(20, 20)
    ood = nets.fit_ood(x, k=5)
    with torch.no_grad():
        scores = ood(x)
        far = ood(x[:10] + 20 * x.std(0))
    assert abs(float((scores <= 1).float().mean()) - 0.99) < 0.005
    assert bool((far > 3).all())


def test_window_ensemble_torch_matches_onnxruntime_at_any_batch_and_length(tmp_path):
    torch.manual_seed(3)
    model = nets.WindowEnsemble([nets.WindowNet(5, 8) for _ in range(2)])
    path = tmp_path / "w.onnx"
    export(model, 0, path, "chunks", ["logit"], example=torch.zeros(2, 5, 600), dynamic_axes={0: "batch", 2: "samples"})
    for batch, samples in ((1, 600), (4, 600), (3, 257)):
        xb = torch.randn(batch, 5, samples)
        with torch.no_grad():
            expected = model(xb).numpy()
        np.testing.assert_allclose(_run(path, "chunks", xb.numpy())[0], expected, rtol=1e-4, atol=1e-4)
