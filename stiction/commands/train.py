"""``stiction train``: rebuild every model offline from the simulator (needs the ``train`` extra).

The models go to a new folder unless ``--replace-shipped`` says to overwrite the ones the
agent ships with; ``--extension NAME=VALUE`` trains on the loop extended by a diagnose cause.
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import fields
from pathlib import Path

from stiction.schemas.errors import InputError, StictionError


def add_arguments(p: argparse.ArgumentParser) -> None:
    where = p.add_mutually_exclusive_group()
    where.add_argument("--models", type=Path, help="output directory (default: a new stiction-models-<time> folder)")
    where.add_argument(
        "--replace-shipped", action="store_true", help="overwrite the models the agent ships with (quantify/models)"
    )
    p.add_argument(
        "--extension",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="train on the extended loop, e.g. dead_time_s=3 (repeatable; the names of stiction simulate's flags)",
    )
    p.add_argument(
        "--detector",
        action="store_true",
        help="train only the stiction detector (seconds, no torch): simulated plant-like loops, plus --measured",
    )
    p.add_argument(
        "--window-net",
        action="store_true",
        help="train only the window network the verdict reads beside its statistics (torch, about 6 minutes)",
    )
    p.add_argument(
        "--measured", type=Path, metavar="DIR", help="labelled measured exports (loops.json beside) for --detector"
    )
    p.add_argument("--realisations", type=int, default=3, help="draws of the limit cycle per grid point")
    p.add_argument("--noisy-variants", type=int, default=4, help="extra runs of the grid with random disturbances")
    p.add_argument("--ensemble", type=int, default=5, help="members of the cycle ensemble")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--json", action="store_true", help="print the summary as JSON")


def parse_extensions(items: list[str]) -> dict[str, float | str]:
    """``NAME=VALUE`` pairs as the simulator's extensions, checked against its catalogue."""
    from stiction.sim.extensions import Extensions

    known = {f.name for f in fields(Extensions)}
    out: dict[str, float | str] = {}
    for item in items:
        name, sep, value = item.partition("=")
        name = name.strip().replace("-", "_")
        if not sep or name not in known:
            raise InputError(f"--extension {item!r}: expected NAME=VALUE with NAME one of {', '.join(sorted(known))}")
        if name == "osc_shape":  # the one extension that is a name, not a number
            out[name] = value.strip()
            continue
        try:
            out[name] = float(value)
        except ValueError:
            raise InputError(f"--extension {item!r}: {value!r} is not a number") from None
    try:
        Extensions(**out)
    except ValueError as e:
        raise InputError(f"--extension: {e}") from None
    return out


def _models_dir(args, shipped: Path) -> Path:
    if args.replace_shipped:
        return shipped
    models_dir = args.models or Path(f"stiction-models-{time.strftime('%Y%m%d-%H%M%S')}")
    if models_dir.exists() and not models_dir.is_dir():
        raise InputError(f"--models {models_dir}: exists and is not a directory")
    return models_dir


def train_detector(args: argparse.Namespace) -> int:
    """The detector alone: numpy and scipy, a few seconds."""
    import numpy as np

    from stiction.bench.measured import labelled_exports
    from stiction.detect import training
    from stiction.detect.features import evidence
    from stiction.detect.verdict import DETECTOR_FILE
    from stiction.quantify.predictor import DEFAULT_MODELS_DIR

    models_dir = _models_dir(args, DEFAULT_MODELS_DIR)
    n_per_cause = training.N_PER_CAUSE
    sim = training.simulated_set(n_per_cause, args.seed + training.SIM_SEED)
    canonical_seed = args.seed + training.SIM_SEED + training.CANONICAL_SEED_OFFSET
    mx, sticky, tags, oscillating = [], [], [], []
    if args.measured is not None:
        if not args.measured.exists():
            raise InputError(f"--measured {args.measured}: no such folder")
        for tag, is_sticky, e in labelled_exports([args.measured]):
            ev = evidence(e.op, e.pv, e.ts_s, e.sp)
            mx.append(ev.vector)
            oscillating.append(ev.oscillation.oscillating)
            sticky.append(is_sticky)
            tags.append(tag)
        if not mx:
            raise InputError(f"--measured {args.measured}: no labelled exports (a loops.json beside them)")
    trained_on = (
        f"{n_per_cause} simulated loops per cause and family of sim.plant_families at the thesis's bands (seed "
        f"{args.seed + training.SIM_SEED}) and {round(training.PLANT_SHARE * n_per_cause)} at plant-scale bands (seed "
        f"{args.seed + training.SIM_SEED + training.PLANT_SEED_OFFSET}, the cycle model only), sticky where "
        "the valve's stem slipped in the window, and "
        f"{2 * training.THESIS_SHARE * n_per_cause} canonical sticky loops (half noise-free); the canonical model "
        f"on {training.CANONICAL_PER_CLASS} sticky canonical loops and as many healthy ones under an external "
        f"load, a sine, filtered square or filtered triangle in turn (seeds {canonical_seed}-{canonical_seed + 3}, "
        "a quarter noise-free); every model's probability read at equal priors"
        + (f"; {len(mx)} labelled measured windows of {len(set(tags))} tags from {args.measured.name}" if mx else "")
    )
    canonical = training.canonical_set(training.CANONICAL_PER_CLASS, canonical_seed)
    detector = training.train(
        sim, np.array(mx) if mx else None, sticky, tags, trained_on, np.array(oscillating, bool), canonical
    )
    models_dir.mkdir(parents=True, exist_ok=True)
    detector.save(models_dir / DETECTOR_FILE)
    print(f"detector written to {models_dir / DETECTOR_FILE}: {trained_on}")
    return 0


def train_window_net(args: argparse.Namespace) -> int:
    """The window network alone (``trainer.window_net``): simulated families, torch, a few minutes."""
    try:
        from stiction.trainer import window_net
        from stiction.trainer.train import DEFAULT_MODELS_DIR
    except ImportError as e:
        raise StictionError(f"training needs the train extra ({e.name} missing): pip install -e '.[train]'") from None
    models_dir = _models_dir(args, DEFAULT_MODELS_DIR)
    summary = window_net.run(models_dir, window_net.WindowNetSettings(seed=args.seed))
    if args.json:
        print(json.dumps(summary))
    else:
        print(f"window network written to {models_dir}: {summary['windows']} simulated windows, "
              f"{summary['simulate_s']:.0f} s simulating, {summary['train_s']:.0f} s training")  # fmt: skip
    return 0


def run(args: argparse.Namespace) -> int:
    if args.detector and args.window_net:
        raise InputError("--detector and --window-net: one at a time (each writes only its own model)")
    if args.detector:
        return train_detector(args)
    if args.window_net:
        return train_window_net(args)
    extensions = parse_extensions(args.extension)
    for name in ("realisations", "ensemble"):
        if getattr(args, name) < 1:
            raise StictionError(f"--{name} must be at least 1")
    try:
        from stiction.trainer.train import DEFAULT_MODELS_DIR, TrainSettings
        from stiction.trainer.train import run as train
    except ImportError as e:
        raise StictionError(f"training needs the train extra ({e.name} missing): pip install -e '.[train]'") from None
    models_dir = _models_dir(args, DEFAULT_MODELS_DIR)
    settings = TrainSettings(
        models_dir=models_dir,
        realisations=args.realisations,
        noisy_variants=max(args.noisy_variants, 0),
        ensemble=args.ensemble,
        seed=args.seed,
        extensions=extensions,
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
        print(f"  use them with --models {summary['models_dir']}")
    return 0
