"""The pure pipeline ``windows (op, pv, ts) -> stiction reports``, used by ``quantify`` and the agent.

Every window runs the thesis chain (ACF period, INLPCA denoiser for rough windows,
the 100-sample OP network) and its estimate is in every report.  Beside it the
report carries the physical reading of the slips and the learned cycle ensemble,
and ``method`` says which one ``fs_pct``/``fd_pct`` come from:

1. ``physical`` where the slips read fs and fd to within ``PHYSICAL_MAX_SE_PCT``;
2. else ``learned``, the cycle ensemble on the INLPCA curve;
3. else ``thesis``; ``none`` if not even that could run.

All three read the thesis's level loop: where its process is neither declared nor identified
(``ident.controller``), ``method`` is ``none`` and the headline numbers are null, the learned
and thesis readings staying in their blocks, and a warning says why.  Such a loop called
sticky has its own process identified and S and J read under it outside this pipeline
(seconds of CPU a window, ``quantify.identified``): by ``stiction quantify`` at once, by the
agent in the background.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np

from detect import features
from detect.training import DETECTOR_FILE
from detect.verdict import Detector, Verdict, decide
from ident import controller
from ident.checks import blocking, data_checks, impossible_friction
from quantify import inlpca, physical
from quantify.acf import acf_period
from quantify.analysis import WindowAnalysis, analyse
from quantify.features import CYCLE_FEATURES, THESIS_WINDOW
from quantify.identified import NOT_IDENTIFIED, NOT_READ_WARNING
from quantify.predictor import DEFAULT_MODELS_DIR, load_models, model_version
from quantify.window import Reading, Window
from schemas.report import Estimate, ProcessInfo, StictionReport
from sim.loop import TS_S
from sim.process import LOOPS
from sim.valve import band_and_jump_pct, band_and_jump_se_pct, fault_kind

PHYSICAL_MAX_SE_PCT = 0.25
SEGMENTED_MAX_SE_PCT = 0.5
"""Trust for the segmented (noisy-window) reading; chosen on 200 random loops of seed 12345, not the holdout."""
STAGES = ("verdict", "readings", "report")
"""The pipeline's stages: data checks, evidence and verdict; INLPCA, slips and networks; the report's assembly."""
MAX_SLIPS_PER_PERIOD = 12  # more is noise read as slips (slow cycles may slip ~6 times a period)


class Result(NamedTuple):
    report: StictionReport
    details: Details | None
    reading: Reading | None
    """The friction reading made from this very window (None where the verdict is not stiction, or
    where the window carried an earlier reading)."""


READING_FIELDS = (
    "fs_pct", "fd_pct", "s_pct", "j_pct", "s_se_pct", "j_se_pct", "stiction_kind", "fs_se_pct", "fd_se_pct",
    "denoised", "method", "thesis", "physical", "learned", "ood_score", "explained", "estimate_t_end_s",
)  # fmt: skip


@dataclass(frozen=True)
class Details:
    """What the pipeline saw in a window, for viewers and plots."""

    curve: np.ndarray  # [M, 2] the INLPCA curve, (op, pv), closed
    denoised: np.ndarray  # [N, 2] each sample's projection onto the curve
    model_pv: np.ndarray | None = None
    """[K] PV as the identified process and valve simulate it from OP, the window's last K samples (or None)."""


def _opt(x) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None


def _estimate(values) -> Estimate:
    if values is None:
        return Estimate(fs_pct=None, fd_pct=None)
    fs, fd, fs_se, fd_se = values
    return Estimate(fs_pct=_opt(fs), fd_pct=_opt(fd), fs_se_pct=_opt(fs_se), fd_se_pct=_opt(fd_se))


def _impossible(fs_pct, fd_pct, fs_se_pct, fd_se_pct, op_range_pct: float) -> str | None:
    """Why no valve the models know has this friction, or None: fs beyond 500 lbf, fd above fs
    or below zero, a band wider than OP moved (each beyond two standard errors)."""
    if not (np.isfinite(fs_pct) and np.isfinite(fd_pct)):
        return None
    fs_se = fs_se_pct if np.isfinite(fs_se_pct) else 0.0
    fd_se = fd_se_pct if np.isfinite(fd_se_pct) else 0.0
    if fs_pct - 2 * fs_se > 100.0:
        return f"fs {fs_pct:.0f} % of 500 lbf is beyond the largest friction the models know (100 %)"
    if fd_pct + 2 * fd_se < 0:
        return f"fd {fd_pct:.1f} % is below zero"
    s_pct, j_pct = band_and_jump_pct(fs_pct, fd_pct)
    s_se, j_se = band_and_jump_se_pct(fs_se, fd_se)
    return impossible_friction(float(s_pct), float(j_pct), float(s_se), float(j_se), op_range_pct)


class Quantifier:
    """Loads the models once; ``quantify`` is then a pure function of the windows."""

    def __init__(self, models_dir: Path | None = None):
        self.thesis, self.cycle = load_models(models_dir)
        self.model_version = model_version(self.thesis, self.cycle)
        own = Path(models_dir) / DETECTOR_FILE if models_dir is not None else None
        self.detector = Detector.load(own if own is not None and own.is_file() else DEFAULT_MODELS_DIR / DETECTOR_FILE)
        self.cpu_s = dict.fromkeys(STAGES, 0.0)
        """CPU seconds of the calling thread in each stage, summed over every window quantified (the
        agent's profile: ``stiction bench throughput`` prints it)."""

    def quantify(self, windows: Sequence[Window], denoise: bool | None = None) -> list[StictionReport]:
        """Reports in the order of ``windows``; windows of equal length and sample time are batched.

        The INLPCA and the models run only where the report can use them: windows called sticky,
        and declared level loops (their slips may override the verdict); elsewhere every friction
        number is null anyway, and so are ``explained`` and ``ood_score``."""
        return [r.report for r in self.results(windows, denoise=denoise)]

    def quantify_with_details(
        self, windows: Sequence[Window], denoise: bool | None = None
    ) -> list[tuple[StictionReport, Details]]:
        """As ``quantify``, with what the pipeline saw in each window (the INLPCA runs on every one)."""
        return [(r.report, r.details) for r in self.results(windows, denoise=denoise, details=True)]

    def results(self, windows: Sequence[Window], denoise: bool | None = None, details: bool = False) -> list[Result]:
        """Report, details (None unless asked for) and the fresh friction reading of every window."""
        for w in windows:
            w.validate()
        out: list[Result | None] = [None] * len(windows)
        groups: dict[tuple[int, float], list[int]] = {}
        for i, w in enumerate(windows):
            groups.setdefault((len(w.op), float(w.ts_s)), []).append(i)
        for (_, ts_s), idx in groups.items():
            op = np.stack([np.asarray(windows[i].op, float) for i in idx])
            pv = np.stack([np.asarray(windows[i].pv, float) for i in idx])
            batch = self._batch(op, pv, ts_s, [windows[i] for i in idx], denoise, details)
            for j, result in zip(idx, batch, strict=True):
                out[j] = result
        return out

    def _batch(self, op, pv, ts_s, windows, denoise, details=True) -> list[Result]:
        clock = time.thread_time()
        n = op.shape[0]
        sps = [None if w.sp is None else np.asarray(w.sp, float) for w in windows]
        declared = np.array([w.process == "level" for w in windows])
        identified = _canonical_level(op, pv, ts_s, sps, ~declared)
        level = declared | identified
        problems_all = [data_checks(op[i], pv[i]) for i in range(n)]
        evs = features.evidence_rows(op, pv, ts_s, sps)
        verdicts = [
            decide(self.detector, ev, [c.message for c in blocking(problems)])
            for ev, problems in zip(evs, problems_all, strict=True)
        ]
        clock = self._lap("verdict", clock)
        sticky = np.array([v.verdict == "stiction" for v in verdicts])
        carried = sticky & np.array([w.carry is not None for w in windows])
        deferred = sticky & ~carried & np.array([w.defer_reading for w in windows])
        use = (level | sticky) & ~carried & ~deferred
        # the viewer's path fits every window for its curves; the report reads the fit only where
        # it can use it, so that a report is the same with and without a viewer
        a = _analyse_where(op, pv, ts_s, denoise, use | details, level & (use | details))
        curves = None
        if details:
            angles = np.linspace(-np.pi, np.pi, 129)  # closed: the last point repeats the first
            curves = a.fit.curve(np.broadcast_to(angles, (n, angles.size)))
        thesis_in = a.thesis_input
        thesis_ok = use & np.all(np.isfinite(thesis_in), axis=1)
        thesis = np.full((n, 2), np.nan)
        if thesis_ok.any():
            thesis[thesis_ok] = self.thesis.run(thesis_in[thesis_ok])["fs_fd_pct"]
        cycle_ok = use & np.all(np.isfinite(a.cycle_input), axis=1)
        learned, spread, ood = np.full((n, 2), np.nan), np.full((n, 2), np.nan), np.full(n, np.nan)
        if cycle_ok.any():
            out = self.cycle.run(a.cycle_input[cycle_ok])
            learned[cycle_ok], spread[cycle_ok], ood[cycle_ok] = out["fs_fd_pct"], out["fs_fd_std_pct"], out["ood"]
        phys = a.physical
        n_samples = op.shape[1]
        slip_limit = MAX_SLIPS_PER_PERIOD * n_samples * ts_s / np.where(np.isfinite(a.period_s), a.period_s, np.inf)
        physical_ok = (
            level
            & np.isfinite(phys.fs_pct)
            & (phys.fs_se_pct <= np.where(phys.segmented, SEGMENTED_MAX_SE_PCT, PHYSICAL_MAX_SE_PCT))
            & (phys.fd_se_pct <= np.where(phys.segmented, SEGMENTED_MAX_SE_PCT, PHYSICAL_MAX_SE_PCT))
            & (phys.slips <= slip_limit)
        )
        clock = self._lap("readings", clock)
        results: list[Result] = []
        for i, w in enumerate(windows):
            problems, ev, verdict = problems_all[i], evs[i], verdicts[i]
            if physical_ok[i] and verdict.verdict in ("other_cause", "no_oscillation"):
                # the declared level loop's slips read fs and fd: the valve's own evidence outweighs the cycle's shape
                verdict = Verdict("stiction", verdict.stiction_probability, "stiction", "the slips read fs and fd")
            warnings = [c.message for c in problems] + ([verdict.stuck_valve] if verdict.stuck_valve else [])
            if w.full_samples is not None and len(w.op) < w.full_samples:
                warnings.append(
                    f"partial window: {len(w.op)} of {w.full_samples} samples (a new loop); "
                    "the verdict and numbers firm up as the window fills"
                )
            if w.interpolated:
                warnings.append(f"{w.interpolated} samples interpolated across gaps in the stream")
            if not level[i]:
                warnings.append(NOT_IDENTIFIED)
            if carried[i] or deferred[i]:
                extra = list(w.carry.warnings) if carried[i] else [DEFERRED_WARNING]
                report = self._report(w, i, a, use, "none", (np.nan,) * 4, _NOTHING_SHOWN, verdict, ev, problems,
                                      warnings + extra, ood, level, ts_s, identified)  # fmt: skip
                if carried[i]:
                    report = report.model_copy(update=w.carry.fields)
                results.append(Result(report, None, None))
                continue
            fresh = len(warnings)
            if np.isfinite(ood[i]) and ood[i] > 1:
                warnings.append(f"window unlike the training data (ood {ood[i]:.1f} > 1): learned estimate unreliable")
            candidates = [
                ("physical", physical_ok[i], phys.fs_pct[i], phys.fd_pct[i], phys.fs_se_pct[i], phys.fd_se_pct[i]),
                ("learned", cycle_ok[i], learned[i, 0], learned[i, 1], spread[i, 0], spread[i, 1]),
                ("thesis", thesis_ok[i], thesis[i, 0], thesis[i, 1], np.nan, np.nan),
            ]
            method, estimate, shown, why_not = _choose(candidates, float(np.ptp(op[i])), verdict.verdict, level[i])
            warnings += why_not
            if verdict.verdict != "stiction" and verdict.verdict != "bad_data":
                warnings.append(f"no friction numbers: {verdict.verdict.replace('_', ' ')} ({verdict.reason})")
            elif verdict.verdict == "bad_data":
                warnings.append("no estimate: the data cannot show a valve's friction (above)")
            elif method == "none" and level[i]:
                warnings.append("no estimate: no oscillation period found, or every reading withheld")
            report = self._report(
                w, i, a, use, method, estimate, shown, verdict, ev, problems, warnings, ood, level, ts_s, identified
            )
            reading = None
            if verdict.verdict == "stiction":
                fields = {k: getattr(report, k) for k in READING_FIELDS}
                reading = Reading(fields, tuple(warnings[fresh:]), w.t_end_s)
            results.append(Result(report, None, reading))
        self._lap("report", clock)
        if not details:
            return results
        return [r._replace(details=Details(curves[i], a.fit.denoised[i])) for i, r in enumerate(results)]

    def _lap(self, stage: str, since: float) -> float:
        now = time.thread_time()
        self.cpu_s[stage] += now - since
        return now

    def _report(
        self, w, i, a, use, method, estimate, shown, verdict, ev, problems, warnings, ood, level, ts_s, identified
    ):
        """Assembly only: the numbers chosen above, as the report's fields."""
        fs, fd, fs_se, fd_se = (_opt(v) for v in estimate)
        s_pct = j_pct = s_se = j_se = None
        if fs is not None and fd is not None:
            s_pct, j_pct = (_opt(v) for v in band_and_jump_pct(fs, fd))
            if fs_se is not None:
                s_se, j_se = (_opt(v) for v in band_and_jump_se_pct(fs_se, fd_se or 0.0))
        period = a.period_s[i] if np.isfinite(a.period_s[i]) else (ev.oscillation.period_s or np.nan)
        return StictionReport(
            loop_id=w.loop_id,
            verdict=verdict.verdict,
            stiction_probability=verdict.stiction_probability,
            likely_cause=verdict.likely_cause,
            regularity=_opt(ev.oscillation.regularity),
            amplitude_pct=_opt(ev.oscillation.amplitude_pct),
            checks=[c.name for c in problems],
            process=_process(w, ts_s, bool(identified[i])),
            fs_pct=fs,
            fd_pct=fd,
            s_pct=s_pct,
            j_pct=j_pct,
            s_se_pct=s_se,
            j_se_pct=j_se,
            stiction_kind=fault_kind(s_pct, j_pct, j_se),
            fs_se_pct=fs_se,
            fd_se_pct=fd_se,
            period_s=_opt(period),
            denoised=bool(a.noisy[i] and use[i]),
            method=method,
            thesis=_estimate(shown["thesis"]),
            physical=_estimate(shown["physical"]) if level[i] and shown["physical"] is not None else None,
            learned=_estimate(shown["learned"]),
            ood_score=_opt(ood[i]),
            explained=_opt(a.fit.explained[i]) if use[i] else None,
            oscillating=ev.oscillation.oscillating,
            warnings=warnings,
            model_version=self.model_version,
            t_end_s=w.t_end_s,
            n_samples=int(len(w.op)),
            partial=w.full_samples is not None and len(w.op) < w.full_samples,
            interpolated_samples=int(w.interpolated),
            estimate_t_end_s=w.t_end_s if method != "none" else None,
        )


_NOTHING_SHOWN = {"thesis": None, "physical": None, "learned": None}
DEFERRED_WARNING = (
    "friction not read in this report: the agent is catching up and reads a share of its sticky loops "
    "each pass; a coming report reads it"
)


def _analyse_where(op, pv, ts_s, denoise, need: np.ndarray, level: np.ndarray) -> WindowAnalysis:
    """``analyse`` of the windows in ``need`` (the physical reading only of the declared level
    loops), the others left empty: nan, no fit, not denoised; the ACF period for every window."""
    n = op.shape[0]
    if need.all() and level.all():
        return analyse(op, pv, ts_s, denoise=denoise)
    period_s, regularity = acf_period(op, ts_s)
    reading = physical.no_reading(n)
    if level.any():
        reading = _scatter(reading, physical.read_best(op[level], pv[level], ts_s), level)
    empty = WindowAnalysis(
        period_s, regularity, np.full(n, np.nan), np.zeros(n, bool), _no_fit(op.shape),
        np.full((n, THESIS_WINDOW), np.nan), np.full((n, CYCLE_FEATURES), np.nan), reading,
    )  # fmt: skip
    if not need.any():
        return empty
    some = analyse(op[need], pv[need], ts_s, denoise=denoise, physical_reading=False)
    return dataclasses.replace(
        empty,
        roughness=_put(empty.roughness, some.roughness, need),
        noisy=_put(empty.noisy, some.noisy, need),
        fit=_scatter(empty.fit, some.fit, need),
        thesis_input=_put(empty.thesis_input, some.thesis_input, need),
        cycle_input=_put(empty.cycle_input, some.cycle_input, need),
    )


def _put(full: np.ndarray, part: np.ndarray, where: np.ndarray) -> np.ndarray:
    out = full.copy()
    out[where] = part
    return out


def _scatter(full, part, where: np.ndarray):
    """A dataclass of per-window arrays, ``part``'s rows put where ``where`` is true."""
    values = {}
    for f in dataclasses.fields(full):
        a, b = getattr(full, f.name), getattr(part, f.name)
        values[f.name] = (
            tuple(_put(x, y, where) for x, y in zip(a, b, strict=True)) if isinstance(a, tuple) else _put(a, b, where)
        )
    return type(full)(**values)


def _no_fit(shape: tuple[int, int]) -> inlpca.InlpcaFit:
    n, m = shape
    h = inlpca.DEFAULT_SETTINGS.hidden_units
    nan = np.nan
    params = (
        np.full((n, h, 2), nan), np.full((n, h), nan), np.full((n, 2, h), nan), np.full((n, 2), nan),
        np.full((n, 2), nan), np.full((n, 2), nan),
    )  # fmt: skip
    return inlpca.InlpcaFit(
        np.full((n, m), nan), np.ones(n), np.full((n, m, 2), nan), np.full((n, 2), nan), np.full(n, nan), params
    )


def _choose(candidates, op_range_pct: float, verdict: str, known_process: bool):
    """The first method whose estimate a valve can have: ``(method, (fs, fd, fs_se, fd_se), shown, warnings)``.

    ``shown`` holds each method's block, None where it did not run or is impossible; every block
    is None unless the verdict is stiction (no friction numbers for a loop without it).  Without a
    known process no block becomes the headline: the learned models and the thesis chain read the
    thesis's level loop only (on simulated plant-like loops their S was 26-47 % off in median,
    inside S +- 2 spread in 60-67 %: ``stiction bench sizing``): ``NOT_READ_WARNING``, until a sizing
    under the identified process replaces it (``quantify.identified.with_sizing``)."""
    method, chosen = "none", (np.nan, np.nan, np.nan, np.nan)
    shown, warnings = {}, []
    for name, ok, *estimate in candidates:
        why = _impossible(*estimate, op_range_pct) if ok else None
        if why and verdict == "stiction":
            warnings.append(f"{name} estimate withheld: {why}")
        shown[name] = estimate if ok and not why and verdict == "stiction" else None
        if shown[name] is not None and method == "none" and known_process:
            method, chosen = name, tuple(estimate)
    if not known_process and verdict == "stiction":
        warnings.append(NOT_READ_WARNING)
    return method, chosen, shown, warnings


def warm_up() -> None:
    """Compile (or load from their caches) the compiled parts, INLPCA, evidence and the PI fit, now
    rather than in the first report's time: a first compile on a machine takes seconds."""
    inlpca.warm_up()
    features.warm_up()
    t = np.arange(64, dtype=float)
    controller.fit_pi(np.sin(t / 5)[None], np.cos(t / 5)[None])


def _process(w: Window, ts_s: float, identified: bool) -> ProcessInfo:
    if w.process == "level" or identified:
        source = "declared" if w.process == "level" else "identified"
        return ProcessInfo(kind="integrating", source=source, gain=LOOPS["level"].gain, sample_time_s=ts_s)
    return ProcessInfo(kind="unknown", source="none", sample_time_s=ts_s)


def _canonical_level(op, pv, ts_s: float, sps, undeclared: np.ndarray) -> np.ndarray:
    """Which undeclared windows are the thesis's level loop: its PI (Kc 3, Ti 30 s at 1 s sampling)
    read off the record (``ident.controller``); the physical reading then checks the process."""
    out = np.zeros(op.shape[0], bool)
    canonical = LOOPS["level"]
    if ts_s != TS_S or not undeclared.any():
        return out
    idx = np.flatnonzero(undeclared)
    fit = controller.fit_pi(op[idx], pv[idx], ts_s, [sps[i] for i in idx])
    out[idx] = controller.matches(fit, canonical.controller_gain, canonical.integral_time_s)
    return out
