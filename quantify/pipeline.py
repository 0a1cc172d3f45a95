"""The pure pipeline ``windows (op, pv, ts) -> stiction reports``, used by ``quantify`` and the agent.

Every window runs the thesis chain (ACF period, INLPCA denoiser for rough windows, the
100-sample OP network) and its estimate is in every report; beside it the physical reading of
the slips and the learned cycle ensemble.  Which one speaks is ``quantify.policy``'s choice; the
report is put together by ``quantify.assembly``: this module batches the windows, runs the
verdict and the readings where the report can use them, and hands each window's draft on.  A
loop called sticky whose process is neither declared nor recognised has it identified and S and
J read under it outside this pipeline (seconds of CPU a window, ``ident.sizing``): by
``stiction quantify`` at once, by the agent in the background.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from stiction.detect import features, sequence, thinning
from stiction.detect.verdict import DETECTOR_FILE, Detector, decide_rows
from stiction.ident import controller, open_loop
from stiction.ident.checks import blocking, data_checks_rows
from stiction.quantify import inlpca, physical, policy
from stiction.quantify.analysis import analyse_where
from stiction.quantify.assembly import NOTHING_SHOWN, assemble, estimate_block, friction_fields, opt, process_info
from stiction.quantify.predictor import (
    DEFAULT_MODELS_DIR,
    ModelError,
    load_models,
    load_window_net,
    model_version,
    sequence_probabilities,
)
from stiction.quantify.window import Reading, Window
from stiction.schemas.report import StictionReport

STAGES = ("verdict", "readings", "report")
"""The pipeline's stages: data checks, evidence and verdict; INLPCA, slips and networks; the report's assembly."""
FITTED_WARNING = (
    "physical reading fitted: the slips read from PV's steps were too noisy to trust or did not explain the record, "
    "and the valve fitted to the whole record (driven by its OP) leaves only PV's measurement noise, a load's cycle, "
    "or a wandering inflow's drift"
)
UNFITTED_WARNING = (
    "the slips read from PV's steps were too noisy to trust, and this reader does not fit the valve to the whole "
    "record at once (seconds a window): the agent fits it in the background and the loop's next reports carry "
    "the fitted reading where it is accepted; `stiction quantify` on an export of this window fits it"
)
DEFERRED_WARNING = (
    "friction not read in this report: the agent is catching up and reads a share of its sticky loops "
    "each pass; a coming report reads it"
)
THINNED_WARNING = (
    "the verdict read one sample in {step} (one every {ts_s:.4g} s): the loop cycles every {period:.0f} samples, "
    "longer than any cycle the detector was trained on (at most {longest:.0f}), so it is read at the sampling that "
    "makes it a typical one; the friction numbers read every sample"
)
NO_SETPOINT_WARNING = (
    "no setpoint (SP) in the record: the verdict reads PV's deviation from its own level, and cannot see a valve "
    "that stays put after a setpoint step while OP winds up (that test needs SP); export SP with OP and PV where the "
    "historian has it"
)
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


@dataclass(frozen=True)
class Result:
    draft: StictionReport
    """The window's facts, to be put together with what is known of the loop's process
    (``quantify.assembly.assemble``); ``report`` is that with nothing known beside the window."""
    details: Details | None = None
    reading: Reading | None = None
    """The friction reading made from this very window (None where the verdict is not stiction, or
    where the window carried an earlier reading)."""
    unchecked: bool = False
    """The reading rests on a trusted slip reading that this quantifier did not check against the record
    (``fit_valve`` off): a worker's fit checks it as ``stiction quantify`` does (``quantify.refit``)."""

    @property
    def report(self) -> StictionReport:
        return assemble(self.draft)


class Quantifier:
    """Loads the models once; ``quantify`` is then a pure function of the windows."""

    def __init__(self, models_dir: Path | None = None, sequence_chunks: int = sequence.MAX_CHUNKS,
                 fit_valve: bool = True):  # fmt: skip
        """``sequence_chunks``: the most chunks of a window the window network reads (``detect.sequence``);
        ``fit_valve``: fit the valve to the record of a sticky level loop no slip reading is trusted for
        (``ident.open_loop``, about 1 s a window)."""
        self.sequence_chunks = sequence_chunks
        self.fit_valve = fit_valve
        self.thesis, self.cycle = load_models(models_dir)
        self.model_version = model_version(self.thesis, self.cycle)
        own = Path(models_dir) / DETECTOR_FILE if models_dir is not None else None
        path = own if own is not None and own.is_file() else DEFAULT_MODELS_DIR / DETECTOR_FILE
        try:
            self.detector = Detector.load(path)
        except (ValueError, KeyError) as e:  # a file of another version, or not a detector's
            said = str(e) if str(path) in str(e) else f"{path}: not a detector file ({e.__class__.__name__}: {e})"
            raise ModelError(said) from None
        self.window_net = load_window_net(models_dir)
        if self.window_net is not None:
            self.model_version = model_version(self.thesis, self.cycle, self.window_net)
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
        """Draft, details (None unless asked for) and the fresh friction reading of every window."""
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
        identified = policy.canonical_level(op, pv, ts_s, sps, ~declared)
        level = declared | identified
        problems_all = data_checks_rows(op, pv)
        blocked = [[c.message for c in blocking(problems)] for problems in problems_all]
        evs = features.evidence_rows(op, pv, ts_s, sps)
        # a window that is not the canonical loop's (its own models read it, at its own sampling) and whose data are
        # read: the window network speaks there, and a cycle longer than any trained on is read thinned
        read = ~level & np.array([not said for said in blocked])
        periods = thinning.cycle_periods(evs, ts_s)
        steps = np.where(read, thinning.verdict_steps(periods, op.shape[1]), 1)
        seq = np.full(n, np.nan)
        for step in np.unique(steps):
            at_step = steps == step
            if step > 1:
                idx = np.flatnonzero(at_step)
                o, p, sp = _thinned_rows(op, pv, sps, idx, step)
                for i, ev in zip(idx, features.evidence_rows(o, p, ts_s * step, sp), strict=True):
                    evs[i] = ev
            net = np.flatnonzero(at_step & read) if self.window_net is not None else []
            if len(net):
                seq[net] = sequence_probabilities(
                    self.window_net, *_thinned_rows(op, pv, sps, net, step), self.sequence_chunks
                )
        verdicts = decide_rows(self.detector, evs, blocked, level, seq)
        clock = self._lap("verdict", clock)
        sticky = np.array([v.verdict == "stiction" for v in verdicts])
        carried = sticky & np.array([w.carry is not None for w in windows])
        deferred = sticky & ~carried & np.array([w.defer_reading for w in windows])
        use = (level | sticky) & ~carried & ~deferred
        # the viewer's path fits every window for its curves; the report reads the fit only where
        # it can use it, so that a report is the same with and without a viewer
        a = analyse_where(op, pv, ts_s, denoise, use | details, level & (use | details))
        thesis_ok = use & np.all(np.isfinite(a.thesis_input), axis=1)
        thesis = np.full((n, 2), np.nan)
        if thesis_ok.any():
            thesis[thesis_ok] = self.thesis.run(a.thesis_input[thesis_ok])["fs_fd_pct"]
        cycle_ok = use & np.all(np.isfinite(a.cycle_input), axis=1)
        learned, spread, ood = np.full((n, 2), np.nan), np.full((n, 2), np.nan), np.full(n, np.nan)
        if cycle_ok.any():
            out = self.cycle.run(a.cycle_input[cycle_ok])
            learned[cycle_ok], spread[cycle_ok], ood[cycle_ok] = out["fs_fd_pct"], out["fs_fd_std_pct"], out["ood"]
        phys = a.physical
        physical_ok = policy.physical_trusted(phys, level, a.period_s, op.shape[1], ts_s)
        op_range_pct = np.ptp(op, axis=1)
        physical_ok &= policy.possible(phys, op_range_pct, where=physical_ok)
        band = policy.band_read(phys, level)
        fitted_ok = np.zeros(n, bool)
        fittable = use & level & ~physical_ok & (sticky | band)
        want = fittable & self.fit_valve  # a new array: ``fittable`` itself says below what was left unfitted
        slips_trusted = use & level & physical_ok & sticky
        if self.fit_valve:  # a trusted slip reading is checked against the record, and fitted where it falls short
            checked = np.flatnonzero(slips_trusted)
            short = [i for i in checked if not open_loop.explains(op[i], pv[i], phys.fs_pct[i], phys.fd_pct[i], ts_s)]
            want[short] = True
        if want.any():  # the valve fitted to the record where no slip reading is trusted or explains it
            rows = np.flatnonzero(want)
            seeds = np.stack([np.column_stack([phys.fs_pct[rows], phys.fd_pct[rows]]), learned[rows]], axis=1)
            fit = open_loop.read(op[rows], pv[rows], ts_s, extra=seeds)
            phys, fitted_ok = policy.with_fitted(phys, fit, rows)
            physical_ok = physical_ok | fitted_ok
        clock = self._lap("readings", clock)
        results: list[Result] = []
        for i, w in enumerate(windows):
            problems, ev = problems_all[i], evs[i]
            verdict = verdicts[i]
            if band[i]:
                verdict = policy.called_by_band(verdict, float(phys.fs_pct[i]), float(phys.fs_se_pct[i]))
            warnings = [c.message for c in problems] + ([verdict.stuck_valve] if verdict.stuck_valve else [])
            if steps[i] > 1:
                said = {"step": int(steps[i]), "ts_s": ts_s * steps[i], "period": periods[i]}
                warnings.append(THINNED_WARNING.format(**said, longest=thinning.LONGEST_PERIOD_SAMPLES))
            if w.sp is None and read[i]:
                warnings.append(NO_SETPOINT_WARNING)
            if verdict.verdict == "stiction" and verdict.sequence:
                warnings.append(verdict.sequence)
            if verdict is not verdicts[i]:
                warnings.append(f"stiction: {verdict.reason}")
            partial = w.partial
            if partial:
                warnings.append(
                    f"partial window: {len(w.op)} of {w.full_samples} samples (a new loop); "
                    "the verdict and numbers firm up as the window fills"
                )
            if w.interpolated:
                warnings.append(f"{w.interpolated} samples interpolated across gaps in the stream")
            common = {
                "loop_id": w.loop_id,
                "verdict": verdict.verdict,
                "stiction_probability": verdict.stiction_probability,
                "likely_cause": verdict.likely_cause,
                "regularity": opt(ev.oscillation.regularity),
                "amplitude_pct": opt(ev.oscillation.amplitude_pct),
                "checks": [c.name for c in problems],
                "process": process_info(w, ts_s, bool(identified[i])),
                "period_s": opt(a.period_s[i] if np.isfinite(a.period_s[i]) else (ev.oscillation.period_s or np.nan)),
                "oscillating": ev.oscillation.oscillating,
                "model_version": self.model_version,
                "t_end_s": w.t_end_s,
                "n_samples": int(len(w.op)),
                "partial": partial,
                "interpolated_samples": int(w.interpolated),
            }
            if carried[i] or deferred[i]:
                fields = {**friction_fields("none", (np.nan,) * 4, w.t_end_s), **_blocks(NOTHING_SHOWN, level[i])}
                fields |= {"denoised": False, "ood_score": None, "explained": None}
                if carried[i]:
                    fields |= w.carry.fields
                extra = list(w.carry.warnings) if carried[i] else [DEFERRED_WARNING]
                draft = StictionReport(**common, **fields, warnings=warnings + extra)
                results.append(Result(draft))
                continue
            fresh = len(warnings)
            if np.isfinite(ood[i]) and ood[i] > 1:
                warnings.append(f"window unlike the training data (ood {ood[i]:.1f} > 1): learned estimate unreliable")
            if fitted_ok[i]:
                warnings.append(FITTED_WARNING)
            elif fittable[i] and not self.fit_valve:
                warnings.append(UNFITTED_WARNING)
            physical_i = (phys.fs_pct[i], phys.fd_pct[i], phys.fs_se_pct[i], phys.fd_se_pct[i])
            learned_i = (learned[i, 0], learned[i, 1], spread[i, 0], spread[i, 1])
            can_combine = bool(level[i] and cycle_ok[i])  # both readings ran: elsewhere nothing to weigh
            agree, combined = policy.combine(physical_i, learned_i) if can_combine else (False, (np.nan,) * 4)
            candidates = [
                ("physical", physical_ok[i], *physical_i),
                ("combined", can_combine and agree, *combined),
                ("learned", cycle_ok[i], *learned_i),
                ("thesis", thesis_ok[i], thesis[i, 0], thesis[i, 1], np.nan, np.nan),
            ]
            method, estimate, shown, why_not = policy.choose(
                candidates, float(op_range_pct[i]), verdict.verdict, level[i]
            )
            warnings += why_not
            if verdict.verdict != "stiction" and verdict.verdict != "bad_data":
                warnings.append(f"no friction numbers: {verdict.verdict.replace('_', ' ')} ({verdict.reason})")
            elif verdict.verdict == "bad_data":
                warnings.append("no estimate: the data cannot show a valve's friction (above)")
            elif method == "none" and level[i] and not np.isfinite(a.period_s[i]):
                warnings.append(
                    "no estimate: OP has no period (its autocorrelation has no peak: a drift, or a single slip "
                    "in the window), which the learned readings need, and no slips were read that can be trusted"
                )
            elif method == "none" and level[i]:
                warnings.append("no estimate: every reading withheld")
            fields = {
                **friction_fields(method, estimate, w.t_end_s),
                **_blocks(shown, level[i]),
                "denoised": bool(a.noisy[i] and use[i]),
                "ood_score": opt(ood[i]),
                "explained": opt(a.fit.explained[i]) if use[i] else None,
            }
            draft = StictionReport(**common, **fields, warnings=warnings)
            reading = None
            if verdict.verdict == "stiction":
                reading = Reading({k: getattr(draft, k) for k in READING_FIELDS}, tuple(warnings[fresh:]), w.t_end_s)
            unchecked = reading is not None and bool(slips_trusted[i]) and not self.fit_valve
            results.append(Result(draft, None, reading, unchecked))
        self._lap("report", clock)
        if not details:
            return results
        angles = np.linspace(-np.pi, np.pi, 129)  # closed: the last point repeats the first
        curves = a.fit.curve(np.broadcast_to(angles, (n, angles.size)))
        return [replace(r, details=Details(curves[i], a.fit.denoised[i])) for i, r in enumerate(results)]

    def _lap(self, stage: str, since: float) -> float:
        now = time.thread_time()
        self.cpu_s[stage] += now - since
        return now


def _thinned_rows(op: np.ndarray, pv: np.ndarray, sps: list, rows: np.ndarray, step: int) -> tuple:
    """(op, pv, sps) of ``rows`` of a batch at every ``step``-th sample (``detect.thinning``; 1: as they are)."""
    sp = [None if sps[i] is None else thinning.thinned(sps[i], step) for i in rows]
    return thinning.thinned(op[rows], step), thinning.thinned(pv[rows], step), sp


def _blocks(shown: dict, level: bool) -> dict:
    """Each method's block of the report (the physical one only where the process is a level loop)."""
    physical = estimate_block(shown["physical"]) if level and shown["physical"] is not None else None
    return {
        "thesis": estimate_block(shown["thesis"]),
        "physical": physical,
        "learned": estimate_block(shown["learned"]),
    }


def warm_up(fit_valve: bool = True) -> None:
    """Compile (or load from their caches) the compiled parts, INLPCA, evidence, the physical and (``fit_valve``, as
    the ``Quantifier`` is told) fitted readings and the PI fit, now rather than in the first report's time: a first
    compile on a machine takes seconds."""
    inlpca.warm_up()
    features.warm_up()
    physical.warm_up()
    if fit_valve:
        open_loop.warm_up()
    t = np.arange(64, dtype=float)
    controller.fit_pi(np.sin(t / 5)[None], np.cos(t / 5)[None])
