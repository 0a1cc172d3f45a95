"""``stiction simulate``: simulated loops as historian-export CSVs, or the training grid as one file."""

from __future__ import annotations

import argparse
import logging
import sys
import time
from dataclasses import fields
from pathlib import Path

from stiction.schemas.errors import InputError
from stiction.sim.extensions import OSC_SHAPES

log = logging.getLogger(__name__)

_EXTENSION_HELP = {
    "dead_time_s": "transport delay between valve and PV [s]",
    "deadband_pct": "valve backlash/deadband, full width [%% of OP]",
    "actuator_tau_s": "first-order lag between OP and the valve's drive [s]",
    "sensor_tau_s": "first-order filter on the PV measurement [s]",
    "quantum_pct": "historian storage step of PV and OP [%%]",
    "gain_ratio": "process gain over nominal",
    "osc_period_s": "period of an external oscillating load [s]",
    "osc_amplitude_pct": "amplitude of that load [%% of span]",
    "time_constant_s": "self-regulating process with this time constant instead of the integrator [s]",
}


def add_arguments(p: argparse.ArgumentParser) -> None:
    what = p.add_mutually_exclusive_group(required=True)
    what.add_argument("--fs-pct", type=float, help="static friction, percent of 500 lbf")
    what.add_argument("--case", help="a thesis test case: C1..C10, N1..N10")
    what.add_argument("--grid", action="store_true", help="the 1275-pattern training grid into one .npz file")
    p.add_argument("--fd-pct", type=float, help="dynamic friction, percent of 500 lbf (with --fs-pct)")
    p.add_argument("--loop", default="level", choices=["level", "concentration"])
    p.add_argument("--valve", default="physical", choices=["physical", "he", "kano"], help="valve model")
    p.add_argument("--disturbance", choices=["sine", "gaussian", "brownian"], help="disturbance shape")
    p.add_argument("--on", dest="disturbance_on", default="output", choices=["input", "output"])
    p.add_argument("--coefficient", type=float, default=0.1, help="relative disturbance amplitude (spec)")
    p.add_argument("--omega-rad-s", type=float, help="sine disturbance frequency [rad/s]")
    p.add_argument("--seed", type=int, default=0)
    ext = p.add_argument_group("extensions (the diagnose catalogue)")
    for name, text in _EXTENSION_HELP.items():
        ext.add_argument("--" + name.replace("_", "-"), type=float, help=text)
    ext.add_argument(
        "--osc-shape",
        choices=OSC_SHAPES,
        help="shape of that load: sine (default), or a square or triangle through a lag of a tenth of its period",
    )
    plant = p.add_argument_group("a loop of its own instead of --loop (a plant's flow or level loop)")
    plant.add_argument("--process-gain", type=float, help="process gain [%%/%% static, or %%/s per %% integrating]")
    plant.add_argument(
        "--process-tau-s", type=float, help="process time constant [s]; without it the process integrates"
    )
    plant.add_argument("--kc", type=float, help="PI controller gain")
    plant.add_argument("--ti-s", type=float, help="PI integral time [s]")
    p.add_argument("--ts-s", type=float, default=1.0, help="the controller's sample time [s] (default 1)")
    p.add_argument("--record-every", type=int, default=1, help="keep one sample every N controller samples")
    p.add_argument("--record", choices=["snapshot", "mean"], default="snapshot", help="what a kept sample is")
    p.add_argument("--duration-s", type=float, default=2000.0, help="simulated time from rest [s]")
    p.add_argument("--warmup-s", type=float, default=1000.0, help="samples before this are not written [s]")
    p.add_argument("--out", type=Path, help="output file (CSV; .npz with --grid); CSV goes to stdout without it")
    p.add_argument("--no-truth", action="store_true", help="do not write the PATH.truth.json sidecar")


def _process(args):
    """A loop of its own from --process-gain, --process-tau-s, --kc and --ti-s (all four or none but tau)."""
    from stiction.sim.process import ProcessModel

    own = {"--process-gain": args.process_gain, "--kc": args.kc, "--ti-s": args.ti_s}
    if all(v is None for v in own.values()) and args.process_tau_s is None:
        return None
    missing = [k for k, v in own.items() if v is None]
    if missing:
        raise InputError(f"a loop of its own needs {', '.join(missing)} too (and --process-tau-s if it settles)")
    return ProcessModel(args.process_gain, args.process_tau_s, args.kc, args.ti_s)


def _spec(args):
    from stiction.sim.disturbance import Disturbance
    from stiction.sim.extensions import Extensions
    from stiction.sim.grid import case_specs
    from stiction.sim.loop import LoopSpec

    try:
        if args.case:
            cases = case_specs(seed=args.seed)
            if args.case.upper() not in cases:
                raise InputError(f"--case {args.case}: expected one of {', '.join(cases)}")
            spec = cases[args.case.upper()]
        else:
            if args.fd_pct is None:
                raise InputError("--fs-pct needs --fd-pct (dynamic friction, percent of 500 lbf)")
            disturbance = None
            if args.disturbance:
                disturbance = Disturbance(args.disturbance, args.disturbance_on, args.coefficient, args.omega_rad_s)
            spec = LoopSpec(args.fs_pct, args.fd_pct, disturbance=disturbance, seed=args.seed)
        given = {f.name: getattr(args, f.name) for f in fields(Extensions) if getattr(args, f.name) is not None}
        return LoopSpec(
            spec.fs_pct,
            spec.fd_pct,
            loop=args.loop,
            valve=args.valve,
            disturbance=spec.disturbance,
            extensions=Extensions(**given),
            seed=spec.seed,
            process=_process(args),
        )
    except ValueError as e:
        raise InputError(str(e)) from None


def run(args: argparse.Namespace) -> int:
    from stiction.sim import export
    from stiction.sim.grid import training_specs
    from stiction.sim.loop import simulate

    if args.warmup_s >= args.duration_s:
        raise InputError(f"--warmup-s {args.warmup_s} must be below --duration-s {args.duration_s}")
    if not args.ts_s > 0 or args.record_every < 1:
        raise InputError(f"--ts-s {args.ts_s} must be > 0 and --record-every {args.record_every} at least 1")
    if args.out is not None and args.out.is_dir():
        raise InputError(f"--out {args.out}: is a directory, expected a file name")
    if args.out is not None and not args.out.parent.is_dir():
        raise InputError(f"--out {args.out}: no folder {args.out.parent}")
    if args.grid:
        if args.out is None or args.out.suffix != ".npz":
            raise InputError("--grid writes one .npz file: give --out PATH.npz")
        specs = training_specs(loop=args.loop, valve=args.valve)
        started = time.perf_counter()
        result = simulate(specs, duration_s=args.duration_s).kept(args.warmup_s)
        export.write_grid(args.out, result, args.duration_s, args.warmup_s)
        print(
            f"wrote {len(specs)} patterns x {result.t_s.size} samples to {args.out} "
            f"in {time.perf_counter() - started:.1f} s",
            file=sys.stderr,
        )
        return 0
    spec = _spec(args)
    log.info("simulating %s", spec)
    result = simulate([spec], duration_s=args.duration_s, ts_s=args.ts_s).kept(args.warmup_s)
    result = result.recorded(args.record_every, args.record)
    if args.out is None:
        export.write_csv(sys.stdout, result)
        return 0
    export.write_csv(args.out, result)
    if not args.no_truth:
        export.write_truth(args.out.with_suffix(".truth.json"), result)
    print(
        f"wrote {result.t_s.size} samples of fs={spec.fs_pct:g} %, fd={spec.fd_pct:g} % to {args.out}", file=sys.stderr
    )
    return 0
