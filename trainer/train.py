"""Rebuild every model offline: ``stiction train`` (settings -> logging -> run)."""

from __future__ import annotations

import json
import logging
import time
from dataclasses import asdict, dataclass, field
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from stiction.quantify.analysis import analyse
from stiction.quantify.features import CURVE_POINTS, CYCLE_FEATURES, THESIS_WINDOW
from stiction.quantify.inlpca import InlpcaSettings
from stiction.schemas.model_card import ModelCard, TensorSpec
from stiction.sim.extensions import Extensions
from stiction.sim.grid import case_specs
from stiction.sim.loop import simulate
from stiction.trainer import data, nets, window_net
from stiction.trainer.export import export
from stiction.trainer.fit import FitSettings, fit

log = logging.getLogger(__name__)

MODEL_VERSION = "1"
DEFAULT_MODELS_DIR = Path(__file__).resolve().parent.parent / "quantify" / "models"


@dataclass(frozen=True)
class TrainSettings:
    models_dir: Path = DEFAULT_MODELS_DIR
    realisations: int = 3
    noisy_variants: int = 4
    ensemble: int = 5
    seed: int = 0
    accuracy_seeds: int = 5
    extensions: dict[str, float | str] = field(default_factory=dict)
    """Every training loop (and test case) on this extended loop: ``stiction train --extension NAME=VALUE``."""
    # full-batch L-BFGS: the thesis trained in MATLAB, whose default trainer is second-order (Levenberg-Marquardt)
    thesis_fit: FitSettings = field(
        default_factory=lambda: FitSettings(epochs=400, patience=40, learning_rate=1.0, optimiser="lbfgs")
    )
    cycle_fit: FitSettings = field(
        default_factory=lambda: FitSettings(epochs=400, patience=30, batch_size=256, learning_rate=2e-3)
    )
    window_net: window_net.WindowNetSettings = field(default_factory=window_net.WindowNetSettings)
    """The verdict's window network (``trainer.window_net``), written beside the others."""


def _split(groups: np.ndarray, seed: int, val_share: float = 0.2):
    """80/20 by grid point: all draws of a grid point land on the same side."""
    rng = np.random.default_rng(seed)
    unique = np.unique(groups)
    val_groups = rng.choice(unique, int(round(val_share * unique.size)), replace=False)
    val = np.isin(groups, val_groups)
    return ~val, val


def _scaled_mse(y_std):
    def loss(pred, y):
        return (((pred - y) / y_std) ** 2).mean()

    return loss


def _tensors(ds: data.Dataset):
    return torch.tensor(ds.inputs, dtype=torch.float32), torch.tensor(ds.targets, dtype=torch.float32)


def train_thesis(ds: data.Dataset, settings: TrainSettings) -> tuple[nets.ThesisMLP, dict]:
    x, y = _tensors(ds)
    tr, va = _split(ds.groups, settings.seed)
    model = nets.ThesisMLP(x[tr].mean(0), x[tr].std(0), y[tr].mean(0), y[tr].std(0))
    bar = tqdm(total=settings.thesis_fit.epochs, desc="thesis MLP", unit="epoch", leave=False)
    result = fit(
        model,
        x[tr],
        y[tr],
        x[va],
        y[va],
        _scaled_mse(y[tr].std(0)),
        settings.thesis_fit,
        on_epoch=lambda e, t, v: bar.update(1),
    )
    bar.close()
    return model, asdict(result)


def train_cycle(ds: data.Dataset, settings: TrainSettings) -> tuple[nets.CycleEnsemble, list[dict]]:
    x, y = _tensors(ds)
    members, results = [], []
    for k in tqdm(range(settings.ensemble), desc="cycle ensemble", unit="member", leave=False):
        tr, va = _split(ds.groups, settings.seed + 1 + k)
        torch.manual_seed(settings.seed + k)
        model = nets.CycleMLP(x[tr].mean(0), x[tr].std(0), y[tr].mean(0), y[tr].std(0))
        fs = FitSettings(**(asdict(settings.cycle_fit) | {"seed": settings.seed + k}))
        results.append(asdict(fit(model, x[tr], y[tr], x[va], y[va], _scaled_mse(y[tr].std(0)), fs)))
        members.append(model)
    return nets.CycleEnsemble(members, nets.fit_ood(x)), results


def _mae(pred: np.ndarray, specs) -> float:
    truth = np.array([[s.fs_pct, s.fd_pct] for s in specs])
    return float(np.mean(np.abs(pred - truth)))


def test_case_accuracy(
    thesis: nets.ThesisMLP, cycle: nets.CycleEnsemble, n_seeds: int, extensions: Extensions | None = None
) -> dict:
    """MAE (pp of 500 lbf) of both models on C1-C10 and on N1-N10 over ``n_seeds`` seeds."""
    clean = [s for n, s in case_specs(extensions=extensions).items() if n.startswith("C")]
    noisy = [
        s
        for seed in range(n_seeds)
        for n, s in case_specs(seed=seed, extensions=extensions).items()
        if n.startswith("N")
    ]
    out = {}
    for name, specs, denoise in (("C1-C10", clean, False), ("N1-N10", noisy, True)):
        r = simulate(specs).kept()
        a = analyse(r.op, r.pv, denoise=denoise)
        with torch.no_grad():
            t = thesis(torch.tensor(a.thesis_input, dtype=torch.float32)).numpy()
            c = cycle(torch.tensor(a.cycle_input, dtype=torch.float32))[0].numpy()
        out[name] = {"thesis_mlp_mae_pp": _mae(t, specs), "cycle_ensemble_mae_pp": _mae(c, specs), "n": len(specs)}
    return out


def run(settings: TrainSettings) -> dict:
    started = time.perf_counter()
    torch.manual_seed(settings.seed)
    torch.set_num_threads(2)
    settings.models_dir.mkdir(parents=True, exist_ok=True)
    log.info("training with %s", settings)

    extensions = Extensions(**settings.extensions)
    thesis_ds = data.thesis_set(extensions)
    bar = tqdm(total=(1 + settings.noisy_variants) * settings.realisations, desc="cycle features", unit="batch")
    cycle_ds = data.cycle_set(
        settings.realisations,
        settings.noisy_variants,
        settings.seed,
        progress=lambda done, total: bar.update(1),
        extensions=extensions,
    )
    bar.close()
    thesis_model, thesis_fit = train_thesis(thesis_ds, settings)
    cycle_model, cycle_fits = train_cycle(cycle_ds, settings)
    accuracy = test_case_accuracy(thesis_model, cycle_model, settings.accuracy_seeds, extensions)
    created = datetime.now(UTC).isoformat(timespec="seconds")
    settings_json = json.loads(json.dumps(asdict(settings), default=str))

    def write(name, model, n_features, input_spec, outputs, feature_spec, training_data, model_settings):
        path = settings.models_dir / f"{name}.onnx"
        sha = export(model, n_features, path, input_spec.name, [o.name for o in outputs])
        return ModelCard(
            name=name,
            version=MODEL_VERSION,
            onnx_file=path.name,
            onnx_sha256=sha,
            feature_spec=feature_spec,
            inputs=[input_spec],
            outputs=outputs,
            training_data=training_data,
            settings=model_settings | {"train": settings_json},
            accuracy={k: {"mae_pp": v[f"{name}_mae_pp"], "n": v["n"]} for k, v in accuracy.items()},
            created=created,
        )

    thesis_card = write(
        "thesis_mlp",
        thesis_model,
        THESIS_WINDOW,
        TensorSpec(name="op_window", shape=["batch", THESIS_WINDOW], description="OP, percent"),
        [TensorSpec(name="fs_fd_pct", shape=["batch", 2], description="fs, fd: percent of 500 lbf")],
        {
            "kind": "thesis_window",
            "length": THESIS_WINDOW,
            "start": "first upward mean crossing of OP",
            "noisy": "rebuilt OP: INLPCA curve walked at uniform speed, one turn per ACF period",
        },
        {
            "set": "1275-pattern grid, one realisation, noise-free (thesis 4.2)",
            "extensions": settings.extensions,
            "n": int(thesis_ds.inputs.shape[0]),
            "sha256": thesis_ds.sha256(),
        },
        {"hidden": 25, "activation": "sigmoid", "split": "80/20 by grid point", "fit": thesis_fit},
    )
    cycle_card = write(
        "cycle_ensemble",
        cycle_model,
        CYCLE_FEATURES,
        TensorSpec(
            name="features",
            shape=["batch", CYCLE_FEATURES],
            description="INLPCA curve OP and PV at 32 angles, time shares, ACF period",
        ),
        [
            TensorSpec(name="fs_fd_pct", shape=["batch", 2], description="ensemble mean, percent of 500 lbf"),
            TensorSpec(name="fs_fd_std_pct", shape=["batch", 2], description="ensemble spread"),
            TensorSpec(name="ood", shape=["batch"], description="distance from training data, 1 = 99th pct"),
        ],
        {
            "kind": "cycle_features",
            "curve_points": CURVE_POINTS,
            "n_features": CYCLE_FEATURES,
            "inlpca": asdict(InlpcaSettings()),
        },
        {
            "set": "1275-pattern grid",
            "extensions": settings.extensions,
            "realisations": settings.realisations,
            "noisy_variants": settings.noisy_variants,
            "n": int(cycle_ds.inputs.shape[0]),
            "sha256": cycle_ds.sha256(),
        },
        {
            "members": settings.ensemble,
            "hidden": [64, 64],
            "activation": "tanh",
            "split": "80/20 by grid point",
            "fits": cycle_fits,
        },
    )
    for card in (thesis_card, cycle_card):
        (settings.models_dir / f"{card.name}.card.json").write_text(card.model_dump_json(indent=2) + "\n")
    windows = window_net.run(settings.models_dir, settings.window_net)
    summary = {"seconds": time.perf_counter() - started, "accuracy": accuracy, "models_dir": str(settings.models_dir),
               "window_net": windows}  # fmt: skip
    log.info("trained in %.0f s: %s", summary["seconds"], accuracy)
    return summary
