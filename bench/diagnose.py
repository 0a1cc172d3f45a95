"""``stiction bench diagnose``: per cause, what diagnose names, how well it reads the parameter, and at what cost.

Loops: the canonical loop with one hidden effect each (``sim.grid.effect_loops``), white
noise of 1-4 % of PV's RMS on PV, OP/PV/SP only (no MV).  For every cause: how often it is
named (the confusion row: the first cause named) or, not named, listed among the answers the
report says the data cannot tell from the one given (``cannot_tell``), the median relative error of its
parameters, how often the extended model gains on the canonical one, fs/fd error of the
canonical and of the extended model, and CPU seconds per loop; ``--json`` adds each loop's row
(``loops``: its effect, what was named and read).  With ``retrain``, the same
loops are also quantified by ``stiction quantify``'s pipeline with the canonical models and
with models retrained on the cause (at the middle of its range): same loops, same run.
"""

from __future__ import annotations

import multiprocessing
import os
import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from functools import partial
from pathlib import Path

import numpy as np

from stiction.ident.diagnose import diagnose
from stiction.ident.models import cause_parameters, is_lag_line
from stiction.ident.record import Record
from stiction.ident.report import diagnosis_report
from stiction.ident.ties import DEADBAND_WIDENS_PCT
from stiction.sim.extensions import CATALOGUE
from stiction.sim.grid import EFFECT_RANGES, effect_loops
from stiction.sim.independent import simulate_independent
from stiction.sim.loop import DURATION_S, WARMUP_S, simulate
from stiction.sim.valve import band_and_jump_pct

SEED = 20261122
SIMULATORS = {
    "project": "the project's simulator (sim.loop)",
    "independent": "the independent simulator (sim.independent: continuous time, written apart from sim.loop)",
}


def _truth(spec) -> list[float]:
    """fs, fd as the data can tell them: a deadband reads as friction (``tests/ident/test_diagnose.py``)."""
    widen = spec.extensions.deadband_pct * DEADBAND_WIDENS_PCT
    return [spec.fs_pct + widen, spec.fd_pct + widen]


def _record(spec, samples: int | None, simulator: str) -> Record:
    """OP and PV of ``spec``'s loop from the named simulator (``SIMULATORS``)."""
    if simulator == "independent":
        r = simulate_independent(spec)
        return Record(r.op, r.pv, r.ts_s)
    r = simulate([spec]).kept() if samples is None else simulate([spec], duration_s=WARMUP_S + samples).kept()
    return Record(r.op[0], r.pv[0], float(r.t_s[1] - r.t_s[0]))


def _one(spec, samples: int | None = None, simulator: str = "project") -> dict:
    """One loop's diagnosis and what it got right; ``samples``: the record's length (default the canonical
    loop's 1,000 kept samples), the same loop simulated longer."""
    rec = _record(spec, samples, simulator)
    started = time.process_time()
    d = diagnose(rec)
    seconds = time.process_time() - started
    rep = diagnosis_report("bench", rec, d)  # what a user reads: withheld numbers are no estimate
    truth = _truth(spec)
    ext = [_nan(rep.fs_pct), _nan(rep.fd_pct)]
    se = [_nan(rep.fs_se_pct), _nan(rep.fd_se_pct)]
    s_true = float(band_and_jump_pct(*truth)[0])
    lines = [t.parameters for t in rep.cannot_tell if is_lag_line(t)]
    lag = spec.extensions.actuator_tau_s
    return {
        "s_true": s_true,
        "s_read": _nan(rep.s_pct),
        "s_se": _nan(rep.s_se_pct),
        # S on the report's lag line at the true lag (ident.ties.lag_band_tie), where it gives one
        "s_on_line_at_true_lag": lines[0]["s_pct_at_no_lag"] - lines[0]["s_pct_per_lag_s"] * lag if lines and lag > 0
        else float("nan"),
        "named": list(d.causes),
        "ties": [(t.named, t.alternative, t.delta_criterion, dict(t.parameters)) for t in d.ties],
        "truth": spec.extensions.active(),
        "params": {k: float(v) for k, v in cause_parameters(d.extended).items()},
        "ranges": {k: list(v) for k, v in rep.parameter_ranges.items()},
        "gain_pct": d.gain_pct(rec),
        "fs_fd_base": [_nan(rep.base_friction.fs_pct), _nan(rep.base_friction.fd_pct)],
        "fs_fd_ext": ext,
        "fs_fd_true": truth,
        "covered": bool(all(abs(e - t) <= 2 * u for e, t, u in zip(ext, truth, se, strict=True)))
        if np.all(np.isfinite(ext + se))
        else None,
        "seconds": seconds,
        "samples": int(rec.n),
    }


def _nan(x) -> float:
    return float("nan") if x is None else float(x)


def _mae(rows: list[dict], key: str) -> tuple[float, int]:
    """Mean absolute fs/fd error over the loops where there is an estimate, and how many those are."""
    errs = [np.mean(np.abs(np.subtract(r[key], r["fs_fd_true"]))) for r in rows]
    errs = [e for e in errs if np.isfinite(e)]
    return (float(np.mean(errs)) if errs else float("nan")), len(errs)


def _within(truth: dict[str, float], params: dict[str, float]) -> bool:
    """The true parameters within the bounds a tie gives (``name_low``, ``name_high``); no bound, no limit."""
    for key, bound in params.items():
        name, _, side = key.rpartition("_")
        if side == "low" and not truth.get(name, -np.inf) >= bound:
            return False
        if side == "high" and not truth.get(name, np.inf) <= bound:
            return False
    return True


def _said_cannot_tell(cause: str, row: dict) -> bool:
    """The report lists the true cause (or ``none``) among the answers the data cannot tell from the one
    given: a tie of the criteria, the record's own limit or a parameter's interval, the truth within
    the bounds those give."""
    return any(
        cause in alternative.split("+") and _within(row["truth"], params)
        for _named, alternative, _delta, params in row["ties"]
    )


def _summary(cause: str, rows: list[dict]) -> dict:
    first = Counter(r["named"][0] if r["named"] else "none" for r in rows)
    hit = [(cause in r["named"]) if cause != "none" else not r["named"] for r in rows]
    tied = [not h and _said_cannot_tell(cause, r) for h, r in zip(hit, rows, strict=True)]
    rel = [
        abs(r["params"][p] - v) / abs(v)
        for r in rows
        for p, v in r["truth"].items()
        if p in r["params"] and np.isfinite(r["params"][p])
    ]
    # the true parameter within the range the report gives it (about 95 %), where the cause is named with one
    in_range = [
        r["ranges"][p][0] <= v <= r["ranges"][p][1] for r in rows for p, v in r["truth"].items() if p in r["ranges"]
    ]
    base, n_base = _mae(rows, "fs_fd_base")
    ext, n_ext = _mae(rows, "fs_fd_ext")
    on_line = [r for r in rows if np.isfinite(r.get("s_on_line_at_true_lag", np.nan)) and np.isfinite(r["s_read"])]
    read_off = [abs(r["s_read"] - r["s_true"]) for r in on_line]
    line_off = [abs(r["s_on_line_at_true_lag"] - r["s_true"]) for r in on_line]
    return {
        # the actuator lag's line, where the report gives one: S off as read, and on the line at the true lag
        "lag_line": {
            "n": len(on_line),
            "s_read_err_median_pct": float(np.median(read_off)),
            "s_on_line_err_median_pct": float(np.median(line_off)),
            "s_within_2se_share": float(np.mean([abs(r["s_read"] - r["s_true"]) <= 2 * r["s_se"] for r in on_line])),
        }
        if on_line
        else None,
        "n": len(rows),
        "named_share": float(np.mean(hit)),
        "cannot_tell_share": float(np.mean(tied)),
        "first_named": dict(first),
        "param_rel_err_median": float(np.median(rel)) if rel else None,
        "param_in_range_share": float(np.mean(in_range)) if in_range else None,
        "param_in_range": [int(sum(in_range)), len(in_range)],
        "gain_positive_share": float(np.mean([r["gain_pct"] > 0 for r in rows])),
        # the same over the loops the report does not call a tie: a cause the data cannot tell apart gains nothing
        "gain_positive_not_tied": [int(sum(r["gain_pct"] > 0 for r, t in zip(rows, tied, strict=True) if not t)),
                                   int(sum(not t for t in tied))],  # fmt: skip
        "fs_fd_mae_canonical_pp": base,
        "fs_fd_mae_extended_pp": ext,
        "fs_fd_read_canonical": n_base,
        "fs_fd_read_extended": n_ext,
        "fs_fd_within_2se_share": float(np.mean(covered))
        if (covered := [r["covered"] for r in rows if r["covered"] is not None])
        else None,
        "s_per_loop_median": float(np.median([r["seconds"] for r in rows])),
        "s_per_loop_max": float(max(r["seconds"] for r in rows)),
        "false_causes": dict(Counter(c for r in rows for c in r["named"] if c != cause)),
    }


def _loop_row(row: dict) -> dict:
    """What one loop was and what diagnose read (the JSON's ``loops``): its hidden effect, the causes named, their
    parameters, fs/fd true and read under the extended model with their coverage, and CPU seconds."""
    keys = ("truth", "named", "params", "ranges", "fs_fd_true", "fs_fd_ext", "covered", "gain_pct", "seconds",
            "s_true", "s_read", "s_se", "s_on_line_at_true_lag")
    return {k: row[k] for k in keys}


def _pool(workers: int) -> ProcessPoolExecutor:
    # one BLAS thread per worker: the figures are CPU seconds of one core per loop
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[var] = "1"
    return ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn"))


def bench_diagnose(
    per_cause: int = 20,
    causes: list[str] | None = None,
    workers: int = 2,
    progress=None,
    draws: str = "catalogue",
    seed: int = SEED,
    samples: int | None = None,
    simulator: str = "project",
) -> dict:
    """``simulator``: which of ``SIMULATORS`` makes the loops (the same draws); ``draws``: the magnitudes'
    ranges (``sim.grid.DRAWS``: the catalogue's, or ``wide``, as plants have them);
    ``seed``: where the loops are drawn from (each cause its own offset from it); ``samples``: each record's length
    (default 1,000: the canonical loop's kept samples; ``stiction diagnose`` reads up to 3,600 of an export)."""
    causes = causes or list(EFFECT_RANGES)
    out = {}
    with _pool(workers) as pool:
        for c in causes:
            specs = effect_loops(c, per_cause, seed + list(EFFECT_RANGES).index(c), draws=draws)
            rows = list(pool.map(partial(_one, samples=samples, simulator=simulator), specs))
            out[c] = _summary(c, rows) | {"params": list(CATALOGUE.get(c, ())), "loops": [_loop_row(r) for r in rows]}
            if progress:
                progress(c, out[c])
    # a deadband is an effect too: the report says every sticky valve's reading may hold one (a tie), and the
    # deadband loops count there, neither named nor missed (left out of this share before 2026-11-26)
    effects = [c for c in out if c != "none"]
    return {
        "per_cause": out,
        "loops_per_cause": per_cause,
        "samples": samples or int(DURATION_S - WARMUP_S),
        "draws": draws,
        "seed": seed,
        "simulator": simulator,
        "overall": {
            "named_share_effects": float(np.mean([out[c]["named_share"] for c in effects])) if effects else None,
            "cannot_tell_share_effects": float(np.mean([out[c]["cannot_tell_share"] for c in effects]))
            if effects
            else None,
            "none_given_a_cause": 1 - out["none"]["named_share"] - out["none"]["cannot_tell_share"]
            if "none" in out
            else None,
            "none_cannot_tell": out["none"]["cannot_tell_share"] if "none" in out else None,
            "gain_positive_share_effects": float(np.mean([out[c]["gain_positive_share"] for c in effects]))
            if effects
            else None,
            "gain_positive_share_effects_not_tied": _pooled([out[c]["gain_positive_not_tied"] for c in effects]),
            "param_in_range_share": _pooled([out[c]["param_in_range"] for c in out]),
            "fs_fd_mae_canonical_pp": float(np.nanmean([out[c]["fs_fd_mae_canonical_pp"] for c in out])),
            "fs_fd_mae_extended_pp": float(np.nanmean([out[c]["fs_fd_mae_extended_pp"] for c in out])),
            "s_per_loop_median": float(np.median([out[c]["s_per_loop_median"] for c in out])),
            "s_per_loop_max": float(max(out[c]["s_per_loop_max"] for c in out)),
        },
    }


def _pooled(counts: list[list[int]]) -> float | None:
    """The share of (hits, of) pairs pooled; None where there is nothing to count."""
    hits, of = sum(c[0] for c in counts), sum(c[1] for c in counts)
    return hits / of if of else None


def middle_extension(cause: str) -> dict[str, float]:
    """The cause at the middle of its range in the generated loops (a process gain: its geometric middle)."""
    out = {}
    for name, (lo, hi) in EFFECT_RANGES[cause].items():
        out[name] = float(np.sqrt(lo * hi)) if name == "gain_ratio" else 0.5 * (lo + hi)
    if cause == "process_gain":
        out["gain_ratio"] = 1.6  # the range straddles 1; the middle would be no effect
    return out


def _quantify_rows(models_dir: Path | None, specs) -> list[list[float]]:
    from stiction.quantify.pipeline import Quantifier, Window

    q = Quantifier(models_dir)
    r = simulate(specs).kept()
    windows = [Window(f"l{i}", r.op[i], r.pv[i], 1.0) for i in range(len(specs))]
    return [[rep.fs_pct, rep.fd_pct] for rep in q.quantify(windows)]


def _fs_fd_mae(est: np.ndarray, truth: np.ndarray) -> float:
    return float(np.nanmean(np.mean(np.abs(est - truth), axis=1)))


def bench_retrained(per_cause: int, causes: list[str], models_root: Path, progress=None) -> dict:
    """Quantify's error with the canonical models and with models retrained on each cause, same loops."""
    from stiction.trainer.train import TrainSettings
    from stiction.trainer.train import run as train

    out = {}
    for c in causes:
        if c in ("none", "deadband", "quantization"):
            continue  # nothing to retrain on: no effect, one the data cannot tell, one of the record only
        ext = middle_extension(c)
        models = models_root / (c + "-" + "-".join(f"{k}={v:g}" for k, v in ext.items()))
        started = time.perf_counter()
        if not (models / "cycle_ensemble.card.json").exists():
            train(TrainSettings(models_dir=models, realisations=1, noisy_variants=1, ensemble=2, extensions=ext))
        trained_s = time.perf_counter() - started
        from dataclasses import replace

        from stiction.sim.extensions import Extensions

        specs = [replace(s, extensions=Extensions(**ext)) for s in effect_loops(c, per_cause, SEED + 1000)]
        truth = np.array([_truth(s) for s in specs])
        canonical = np.array(_quantify_rows(None, specs), dtype=float)
        retrained = np.array(_quantify_rows(models, specs), dtype=float)

        out[c] = {
            "extension": ext,
            "models": str(models),
            "train_s": trained_s,
            "quantify_canonical_mae_pp": _fs_fd_mae(canonical, truth),
            "quantify_retrained_mae_pp": _fs_fd_mae(retrained, truth),
            "n": len(specs),
        }
        if progress:
            progress(c, out[c])
    return out


def print_header(
    per_cause: int, draws: str = "catalogue", seed: int = SEED, samples: int | None = None, simulator: str = "project"
) -> None:
    ranges = "the catalogue's magnitudes" if draws == "catalogue" else "magnitudes drawn wide (WIDE_EFFECT_RANGES)"
    drawn = "" if seed == SEED else f", drawn from seed {seed}"
    length = f", {samples} samples a record" if samples else ""
    print(f"diagnose on {per_cause} generated loops per cause, {ranges} (noise 1-4 % of PV RMS, OP/PV only){drawn}"
          f"{length}, from {SIMULATORS[simulator]}")  # fmt: skip
    print(
        f"{'cause':22s} {'named':>7s} {'or tie':>7s} {'param':>6s} {'range':>6s} {'gain>0':>7s} {'fs/fd pp':>8s} "
        f"{'':>8s} {'read':>7s} {'in 2se':>6s} {'s/loop':>6s}"
    )
    print(
        f"{'':22s} {'':>7s} {'':>7s} {'(med)':>6s} {'holds':>6s} {'':>7s} {'canon.':>8s} {'extend.':>8s} {'':>7s} "
        f"{'':>6s} {'(CPU)':>6s}"
    )


def print_row(c: str, s: dict) -> None:
    """One cause's figures, as ``bench_diagnose`` finishes it (its ``progress``)."""
    first = ", ".join(f"{k} {v}" for k, v in sorted(s["first_named"].items(), key=lambda kv: -kv[1]))
    shares = ("param_rel_err_median", "param_in_range_share", "fs_fd_within_2se_share")
    param, held, cover = (_pct(s[k]) for k in shares)
    print(
        f"{c:22s} {100 * s['named_share']:5.0f} % {100 * s['cannot_tell_share']:5.0f} % {param:>6s} {held:>6s} "
        f"{100 * s['gain_positive_share']:5.0f} % "
        f"{s['fs_fd_mae_canonical_pp']:8.2f} {s['fs_fd_mae_extended_pp']:8.2f} "
        f"{s['fs_fd_read_extended']:3d}/{s['n']:<3d} {cover:>6s} {s['s_per_loop_median']:6.1f}   "
        f"first named: {first}",
        flush=True,
    )
    if (line := s.get("lag_line")) is not None:
        print(
            f"{'':22s} the lag's line on {line['n']} loops: S off by {line['s_read_err_median_pct']:.2f} % of span "
            f"as read, {line['s_on_line_err_median_pct']:.2f} % on the line at the true lag (medians); S read within "
            f"two of its errors {100 * line['s_within_2se_share']:.0f} %",
            flush=True,
        )


def print_retrained_header() -> None:
    print("quantify (learned pipeline, no process declared) on loops with each effect at its middle value:")


def print_retrained(c: str, s: dict) -> None:
    """One cause's retrained figures, as ``bench_retrained`` finishes it (its ``progress``)."""
    print(
        f"  {c:22s} quantify with canonical models {s['quantify_canonical_mae_pp']:6.2f} pp, "
        f"retrained on {s['extension']} {s['quantify_retrained_mae_pp']:6.2f} pp (n={s['n']})",
        flush=True,
    )


def _pct(x: float | None) -> str:
    return "-" if x is None else f"{100 * x:.0f} %"


def print_overall(figures: dict) -> None:
    o = figures["overall"]
    tied, none_tied = 100 * (o["cannot_tell_share_effects"] or 0), 100 * (o["none_cannot_tell"] or 0)
    print(
        f"overall: effects named {100 * (o['named_share_effects'] or 0):.0f} % (and {tied:.0f} % in a set the report "
        f"says the data cannot tell apart), canonical loops given a cause {100 * (o['none_given_a_cause'] or 0):.0f} % "
        f"(and {none_tied:.0f} % tied), a gain in fit on {_pct(o.get('gain_positive_share_effects'))} of the effects' "
        f"loops ({_pct(o.get('gain_positive_share_effects_not_tied'))} of those not said to be a tie), "
        f"the true parameter within its named range on {_pct(o.get('param_in_range_share'))}, "
        f"fs/fd {o['fs_fd_mae_canonical_pp']:.2f} pp canonical -> "
        f"{o['fs_fd_mae_extended_pp']:.2f} pp extended, {o['s_per_loop_median']:.1f} s per loop (median; "
        f"{o['s_per_loop_max']:.1f} s at most)"
    )
