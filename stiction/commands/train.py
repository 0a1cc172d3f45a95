"""``stiction train``: rebuild every model offline from the simulator (needs the ``train`` extra)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from stiction.errors import StictionError


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--models", type=Path, help="output directory (default: the agent's committed models)")
    p.add_argument("--realisations", type=int, default=3, help="draws of the limit cycle per grid point")
    p.add_argument("--noisy-variants", type=int, default=4, help="extra runs of the grid with random disturbances")
    p.add_argument("--ensemble", type=int, default=5, help="members of the cycle ensemble")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--json", action="store_true", help="print the summary as JSON")


def run(args: argparse.Namespace) -> int:
    try:
        from trainer.train import DEFAULT_MODELS_DIR, TrainSettings
        from trainer.train import run as train
    except ImportError as e:
        raise StictionError(f"training needs the train extra ({e.name} missing): pip install -e '.[train]'") from None
    for name in ("realisations", "ensemble"):
        if getattr(args, name) < 1:
            raise StictionError(f"--{name} must be at least 1")
    settings = TrainSettings(
        models_dir=args.models or DEFAULT_MODELS_DIR,
        realisations=args.realisations,
        noisy_variants=max(args.noisy_variants, 0),
        ensemble=args.ensemble,
        seed=args.seed,
    )
    summary = train(settings)
    if args.json:
        print(json.dumps(summary))
    else:
        print(f"trained in {summary['seconds']:.0f} s into {summary['models_dir']}")
        for test_set, acc in summary["accuracy"].items():
            print(
                f"  {test_set}: thesis MLP {acc['thesis_mlp_mae_pp']:.2f} pp, "
                f"cycle ensemble {acc['cycle_ensemble_mae_pp']:.2f} pp (n={acc['n']})"
            )
    return 0
