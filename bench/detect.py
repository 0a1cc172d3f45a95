"""``stiction bench detect``: is it the valve?  The verdict on loops it was not trained on, beside the
published tests, in one run.

- Simulated families (``sim.plant_families``: flow, level, slow, detuned; the judged valves' bands at plant
  scale by default, ``--bands thesis`` for the thesis's), leave-one-family-out:
  the detector trained on every family but one (seed ``SIM_SEED``) and judged on the one left out
  (another seed), as a plant's loops of a kind it never saw.  Per family: sensitivity (windows that
  show a valve fault, called stiction), specificity (the others, not called), balanced accuracy, and
  the share the verdict cannot settle (probability from ``LEANS_AT`` to ``STICTION_AT``, or a record it does
  not read: bad_data, a compressed archive's; counted neither way in the settled accuracy, reported on its own).
- Another simulator (``sim.two_parameter``: Choudhury's two-parameter valve under SIMC-tuned flow and level
  loops sampled 1-10 s, 2,000 samples), which no detector is trained on: judged by the detector trained on
  every family, as shipped, by kind; settled as the families are, too.
- Labelled measured windows (``loops.json`` beside the CSVs), leave-one-tag-out: each tag's windows
  judged by a detector trained without them (on the simulated families and the other tags), and
  by the detector trained on simulation alone; every window counted (one not settled or not read as not called),
  and settled as the families are.

The window network (``detect.sequence``) is part of the verdict: for the families left out, one is trained on the
other three families as the shipped one is (``trainer.window_net``, minutes: the bench's longest part); the other
simulator and the measured windows are read by the shipped network, which was trained on no window of either.

Methods: the project's verdict (data checks, then the stiction probability >= ``STICTION_AT``), the same verdict
without the window network (``statistics``: the logistic models alone, as before 2026-11-28), its
stuck-valve tests alone, Horch's cross-correlation test (stiction where it reads an odd CCF),
Choudhury's bicoherence test (nonlinear and oscillating), and He et al.'s shape test (SI of OP > 0.6).
"""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from stiction.detect.training import SIM_SEED

METHODS = ("ours", "statistics", "stuck", "horch", "bicoherence", "shape")
BAND_BINS_PCT = ((0.0, 1.0), (1.0, 2.0), (2.0, 5.0), (5.0, 10.0), (10.0, 100.0))
"""Bins of the band S (% of span, deadband included) by which the windows that show a fault are counted."""
SLIP_NOISE_BINS = ((0.0, 2.0), (2.0, 5.0), (5.0, 10.0), (10.0, np.inf))
"""Bins of the slip J over the measurement noise's standard deviation (both % of span): a slip under
twice the noise is one the record barely shows."""
EFFECT_NOISE_BINS = ((0.0, 1.0), (1.0, 2.0), (2.0, 5.0), (5.0, np.inf))
"""Bins of the fault's effect on PV over the noise (``sim.plant_families.VISIBLE_EFFECT``): the windows whose
stem slipped, by how much the record shows it; under 1 they are labelled healthy-looking."""


def _calls(ev, p_stiction: float, blocked: bool, p_statistics: float) -> dict[str, bool]:
    from stiction.detect.shape import STICTION as SHAPE_STICTION
    from stiction.detect.verdict import STEP_AT, STICTION_AT, STUCK_AT

    ramp, step = ev.stuck
    return {
        "ours": bool(not blocked and p_stiction >= STICTION_AT),
        "statistics": bool(not blocked and p_statistics >= STICTION_AT),
        "stuck": bool(not blocked and (ramp >= STUCK_AT or step >= STEP_AT)),
        "horch": ev.horch.verdict == "stiction",
        "bicoherence": bool(ev.bicoherence.nonlinear and ev.oscillation.oscillating),
        "shape": bool(np.isfinite(ev.shape_op) and ev.shape_op > SHAPE_STICTION),
    }


def _blocked(op, pv) -> bool:
    from stiction.ident.checks import blocking, data_checks

    return bool(blocking(data_checks(op, pv)))


def _settled(p: np.ndarray, truth: np.ndarray, blocked: np.ndarray, held: np.ndarray) -> tuple[dict, float]:
    """(rates, share not settled) of the ``held`` windows: a window whose probability ``p`` leans without settling
    (``LEANS_AT`` up to ``STICTION_AT``) or whose data are not read (``blocked``: bad data) is counted neither way,
    as issue 22 defines the verdict's accuracy; its share is said beside the rates."""
    from stiction.detect.verdict import STICTION_AT

    unsettled = _unsettled(p, blocked)
    settled = held & ~unsettled
    rates = _rates(p[settled] >= STICTION_AT, truth[settled]) | {"n": int(settled.sum())}
    return rates, float(np.mean(unsettled[held]))


def _unsettled(p: np.ndarray, blocked: np.ndarray) -> np.ndarray:
    """The windows counted neither way: leaning without settling (``LEANS_AT`` up to ``STICTION_AT``) or not read."""
    from stiction.detect.verdict import LEANS_AT, STICTION_AT

    return ((p >= LEANS_AT) & (p < STICTION_AT)) | blocked


def _false_alarms(p: np.ndarray, truth: np.ndarray, blocked: np.ndarray, fault_valve: np.ndarray) -> dict:
    """The settled windows labelled healthy (``_settled``) called stiction, split by the valve they were given:
    a healthy valve (a look-alike's: the false alarm that sends a crew to a good valve) or a faulty valve whose
    window does not show its fault as the label asks (fewer than ``FAULT_EVENTS`` slips, or an effect under
    ``VISIBLE_EFFECT`` noises): {split: {"called": n, "of": m}}."""
    from stiction.detect.verdict import STICTION_AT

    healthy = ~truth & ~_unsettled(p, blocked)
    called = p >= STICTION_AT
    return {name: {"called": int(np.sum(called & healthy & valve)), "of": int(np.sum(healthy & valve))}
            for name, valve in (("healthy_valve", ~fault_valve), ("faulty_valve_not_shown", fault_valve))}  # fmt: skip


def _fault_outcomes(p: np.ndarray, truth: np.ndarray, blocked: np.ndarray) -> dict:
    """Where the windows that show a fault go, as a plant counting the verdicts sees them: shares called stiction,
    leaning without settling (``LEANS_AT`` up to ``STICTION_AT``), not read (bad data) and read healthy."""
    from stiction.detect.verdict import STICTION_AT

    if not truth.any():
        return {"called": None, "leaning": None, "bad_data": None, "read_healthy": None}
    q, unread = p[truth], blocked[truth]
    called = ~unread & (q >= STICTION_AT)
    leaning = _unsettled(q, unread) & ~unread
    return {"called": float(np.mean(called)), "leaning": float(np.mean(leaning)), "bad_data": float(np.mean(unread)),
            "read_healthy": float(np.mean(~unread & ~called & ~leaning))}  # fmt: skip


def _rates(called: np.ndarray, truth: np.ndarray) -> dict:
    """Sensitivity, specificity, balanced accuracy and accuracy of boolean calls against the truth, and the
    balanced accuracy's standard error (``_balanced_se``)."""
    sens = float(np.mean(called[truth])) if truth.any() else float("nan")
    spec = float(np.mean(~called[~truth])) if (~truth).any() else float("nan")
    return {"sensitivity": sens, "specificity": spec, "balanced": float(np.nanmean([sens, spec])),
            "accuracy": float(np.mean(called == truth)),
            "balanced_se": _balanced_se(called[truth], ~called[~truth])}  # fmt: skip


def _balanced_se(hits: np.ndarray, rejections: np.ndarray) -> float:
    """The standard error of a balanced accuracy, the mean of two shares (the faults called ``hits``, the healthy
    windows left alone ``rejections``) read as independent binomial shares; each share's variance taken at
    (k + 1) / (n + 2), so that 20 of 20 does not read as certain (nan where either class has no window).  At 20 loops a
    cause a family holds 5-35 settled windows that show a fault, and its error is 0.03-0.10 (docs/benchmarks.md)."""
    if hits.size == 0 or rejections.size == 0:
        return float("nan")
    shares = [((x.sum() + 1) / (x.size + 2), x.size) for x in (hits, rejections)]
    return float(0.5 * np.sqrt(sum(q * (1 - q) / n for q, n in shares)))


def _share_called(faults: np.ndarray, called: np.ndarray, cycling: np.ndarray) -> dict:
    """How many windows ``faults`` picks, the share of them called stiction and the share that cycle."""
    if not faults.any():
        return {"show_fault": 0, "called": None, "cycling": None}
    return {"show_fault": int(faults.sum()), "called": float(np.mean(called[faults])),
            "cycling": float(np.mean(cycling[faults]))}  # fmt: skip


def _family_set(n_per_cause: int, seed: int, bands: str, samples: int | None = None, start: str = "operating_point"):
    from stiction.detect.features import evidence
    from stiction.sim.plant_families import WINDOW_SAMPLES, family_loops, simulate_families, stable

    loops = family_loops(n_per_cause, seed, bands=bands)
    rows = []
    records = simulate_families(loops, samples=samples or WINDOW_SAMPLES, start=start)
    for loop, rec in zip(loops, records, strict=True):
        if stable(rec):
            rows.append((loop, rec, evidence(rec.op, rec.pv, rec.ts_s, rec.sp), _blocked(rec.op, rec.pv)))
    return rows


def _two_parameter_set(n_per_cause: int, seed: int, samples: int | None = None):
    from stiction.detect.features import evidence
    from stiction.sim import two_parameter
    from stiction.sim.plant_families import stable

    loops = two_parameter.draw(n_per_cause, seed)
    rows = []
    for loop, rec in zip(loops, two_parameter.simulate(loops, samples or two_parameter.SAMPLES), strict=True):
        if stable(rec):
            blocked = _blocked(rec.op, rec.pv)
            ev = evidence(rec.op, rec.pv, rec.ts_s, rec.sp)
            if not blocked:  # its records are long enough for a long cycle to be read thinned, as the verdict does
                rec, ev = _as_the_verdict_reads(rec, ev)
            rows.append((loop, rec, ev, blocked))
    return rows


def _as_the_verdict_reads(rec, ev):
    """(record, evidence) as ``stiction quantify``'s verdict reads them: thinned where the record cycles more slowly
    than any training window (``detect.thinning``), the label kept."""
    from stiction.detect import thinning
    from stiction.detect.features import evidence

    step = int(thinning.verdict_steps(thinning.cycle_periods([ev], rec.ts_s), len(rec.op))[0])
    if step == 1:
        return rec, ev
    thin = replace(rec, op=thinning.thinned(rec.op, step), pv=thinning.thinned(rec.pv, step),
                   sp=thinning.thinned(rec.sp, step), ts_s=rec.ts_s * step,
                   mv=None if rec.mv is None else thinning.thinned(rec.mv, step))  # fmt: skip
    return thin, evidence(thin.op, thin.pv, thin.ts_s, thin.sp)


def _method_rows(calls: list[dict], truth: np.ndarray, oscillating: np.ndarray, held: np.ndarray) -> dict:
    """For the windows ``held`` picks: each method's rates, ours on the windows that oscillate regularly
    (the limit cycles: stiction against an external cycle or tuning), and the counts."""
    row = {m: _rates(np.array([c[m] for c, h in zip(calls, held, strict=True) if h]), truth[held]) for m in METHODS}
    ours = np.array([c["ours"] for c in calls])
    cycling = held & oscillating
    row["ours_oscillating"] = _rates(ours[cycling], truth[cycling]) | {
        "n": int(cycling.sum()), "show_fault": int(truth[cycling].sum())}  # fmt: skip
    row["n"], row["show_fault"] = int(held.sum()), int(truth[held].sum())
    return row


def _shipped_sequence(records) -> np.ndarray:
    """The shipped window network's probability of each record (op, pv, sp), nan where there is no network."""
    from stiction.quantify.predictor import load_window_net, sequence_probabilities

    net = load_window_net()
    out = np.full(len(records), np.nan)
    if net is not None:
        for i, (op, pv, sp) in enumerate(records):
            out[i] = sequence_probabilities(net, np.asarray(op, float)[None], np.asarray(pv, float)[None], [sp])[0]
    return out  # one record at a time: measured records differ in length


def _trained_sequence(model, records) -> np.ndarray:
    """A trained ``trainer.nets.WindowEnsemble``'s probability of each record (op, pv, sp) (torch), the records of
    one length (the judged families'), their chunks made and run at once as the runtime's are."""
    from stiction.detect import sequence
    from stiction.trainer.window_net import chunk_logits

    op, pv = np.stack([r[0] for r in records]), np.stack([r[1] for r in records])
    x, readable = sequence.chunk_rows(op, pv, [r[2] for r in records])
    return sequence.record_probabilities(chunk_logits(model, x), readable)


def _judged(rows, detector) -> tuple[dict, list[dict]]:
    """Each method's rates on ``rows`` (loop, record, evidence, blocked) by kind, ``detector`` and the shipped
    window network for ours; and each window's figures."""
    x = np.nan_to_num(np.array([r[2].vector for r in rows]))
    stuck = np.array([r[2].stuck for r in rows])
    osc = np.array([r[2].oscillation.oscillating for r in rows])
    seq = _shipped_sequence([(r[1].op, r[1].pv, r[1].sp) for r in rows])
    p = detector.stiction_probability(x, stuck, osc, sequence=seq)
    p_stat = detector.stiction_probability(x, stuck, osc)
    truth = np.array([r[1].shows_fault for r in rows])
    calls = [_calls(r[2], p[i], r[3], p_stat[i]) for i, r in enumerate(rows)]
    kinds = np.array([r[0].kind for r in rows])
    blocked = np.array([r[3] for r in rows], bool)
    by_kind = {}
    for kind in sorted(set(kinds)):
        held = kinds == kind
        by_kind[kind] = _method_rows(calls, truth, osc, held)
        by_kind[kind]["ours_settled"], by_kind[kind]["cannot_tell"] = _settled(p, truth, blocked, held)
        by_kind[kind]["fault_outcomes"] = _fault_outcomes(p[held], truth[held], blocked[held])
    windows = [
        {"kind": r[0].kind, "cause": r[0].cause, "shows_fault": bool(truth[i]), "blocked": bool(r[3]),
         "oscillating": bool(osc[i]), "p": float(p[i]), "p_statistics": float(p_stat[i]), "p_network": float(seq[i]),
         "s_pct": float(r[0].s_pct), "j_pct": float(r[0].j_pct)}
        for i, r in enumerate(rows)
    ]  # fmt: skip
    return by_kind, windows


def bench_detect(
    measured: list[Path],
    n_per_class: int = 20,
    seed: int = 2026,
    train_per_class: int = 20,
    bands: str = "plant",
    samples: int | None = None,
    window_net=None,
    windows: bool = False,
    start: str = "operating_point",
    train_start: str = "rest",
) -> dict:
    """``window_net``: the window networks' ``trainer.window_net.WindowNetSettings`` (default the shipped
    network's); ``windows``: add every held-out family window's figures, the independent simulator's and the
    measured windows' (their probabilities: ours, the statistics', the network's) (``--windows``);
    ``n_per_class``: judged loops of each cause in each family; ``train_per_class``: the same for training;
    ``bands``: the scale of the judged sticky valves' bands (``sim.plant_families.BANDS``); ``samples``: the
    judged records' length (default the training windows', ``sim.plant_families.WINDOW_SAMPLES``: the same
    loops recorded longer, as exports and the agent's windows hold them).  The detectors
    are trained as the shipped one is, on the thesis's bands: judged on plant-scale bands, the figures say
    how the verdict carries to valves smaller than it was trained on.  ``start``: where the judged families' loops
    start (in operation, as a plant's records are: from rest, the detuned family's windows were mostly start-up
    ramps), ``train_start`` the training families' (``sim.plant_families.START``; the shipped models' from rest)."""
    from stiction.bench.measured import labelled_exports
    from stiction.detect import training
    from stiction.detect.features import evidence
    from stiction.detect.verdict import LEANS_AT, STICTION_AT
    from stiction.sim.plant_families import FAMILIES

    t0 = time.perf_counter()
    exports = labelled_exports(measured)  # first: a folder without labelled exports is named before a minute's work
    sim = training.simulated_set(train_per_class, SIM_SEED, start=train_start)
    out: dict = {"bands": bands, "samples": samples, "start": start, "train_start": train_start, "families": {},
                 "measured": {}}  # fmt: skip

    t1 = time.perf_counter()
    rows = _family_set(n_per_class, seed, bands, samples, start)
    out["seconds_per_window"] = (time.perf_counter() - t1) / max(len(rows), 1)
    family = np.array([r[0].family for r in rows])
    truth = np.array([r[1].shows_fault for r in rows])
    x = np.nan_to_num(np.array([r[2].vector for r in rows]))
    stuck = np.array([r[2].stuck for r in rows])
    osc = np.array([r[2].oscillation.oscillating for r in rows])
    from stiction.trainer import window_net as wn

    settings = replace(window_net or wn.WindowNetSettings(), start=train_start)
    t2 = time.perf_counter()
    net_windows = wn.family_windows(settings)
    out["window_net"] = {"windows": int(len(net_windows.shows_fault)), "simulate_s": time.perf_counter() - t2}
    records = [(r[1].op, r[1].pv, r[1].sp) for r in rows]
    p, p_stat, seq_all = np.zeros(len(rows)), np.zeros(len(rows)), np.full(len(rows), np.nan)
    for f in FAMILIES:
        d = training.train(sim.subset(sim.family != f))
        held = family == f
        net = wn.train(net_windows.subset(net_windows.family != f), settings)
        seq = _trained_sequence(net, [records[i] for i in np.flatnonzero(held)])
        seq_all[held] = seq
        p[held] = d.stiction_probability(x[held], stuck[held], osc[held], sequence=seq)
        p_stat[held] = d.stiction_probability(x[held], stuck[held], osc[held])
    out["window_net"]["train_s"] = time.perf_counter() - t2 - out["window_net"]["simulate_s"]
    if windows:  # every held-out window's figures, for analysis outside the bench
        out["windows"] = [
            {"family": r[0].family, "cause": r[0].cause, "shows_fault": bool(r[1].shows_fault), "blocked": bool(r[3]),
             "oscillating": bool(osc[i]), "p": float(p[i]), "p_statistics": float(p_stat[i]),
             "p_network": float(seq_all[i]), "s_pct": float(r[0].s_pct), "j_pct": float(r[0].j_pct),
             "effect_noise": float(r[1].effect_noise)}
            for i, r in enumerate(rows)
        ]  # fmt: skip
    calls = [_calls(r[2], p[i], r[3], p_stat[i]) for i, r in enumerate(rows)]
    calls_ours = np.array([c["ours"] for c in calls])
    # the label before 2026-11-25 and the detector's training label: the stem slipped, shown or not
    slipped = np.array([r[1].stem_slipped for r in rows])
    # the windows the verdict does not settle: those it leans on, and those whose data it does not read (bad_data:
    # a compressed archive's, a dead sensor's); counted neither way in the settled figures, their share said
    blocked = np.array([r[3] for r in rows], bool)
    fault_valve = np.array([r[0].fault for r in rows])
    for f in FAMILIES:
        held = family == f
        row = _method_rows(calls, truth, osc, held)
        row["ours_settled"], row["cannot_tell"] = _settled(p, truth, blocked, held)
        row["false_alarms"] = _false_alarms(p[held], truth[held], blocked[held], fault_valve[held])
        row["fault_outcomes"] = _fault_outcomes(p[held], truth[held], blocked[held])
        # the same for the verdict without the window network
        row["statistics_settled"], row["statistics_cannot_tell"] = _settled(p_stat, truth, blocked, held)
        row["ours_stem_slipped"] = _rates(calls_ours[held], slipped[held])
        out["families"][f] = row
    out["by_cause"] = {
        cause: {"n": int(sum(m)), "show_fault": float(np.mean(truth[m])), "called": float(np.mean(p[m] >= STICTION_AT))}
        for cause in sorted({r[0].cause for r in rows})
        for m in [np.array([r[0].cause == cause for r in rows])]
    }

    band = np.array([r[0].s_pct for r in rows])
    slip_noise = np.array([r[0].j_pct / max(r[0].noise_pct, 1e-9) for r in rows])
    for key, value, bins in (("by_band", band, BAND_BINS_PCT), ("by_slip_noise", slip_noise, SLIP_NOISE_BINS)):
        out[key] = {f"{lo:g}-{hi:g}": _share_called(truth & (value >= lo) & (value < hi), calls_ours, osc)
                    for lo, hi in bins}  # fmt: skip
    effect = np.array([r[1].effect_noise for r in rows])
    out["by_effect_noise"] = {f"{lo:g}-{hi:g}": _share_called(slipped & (effect >= lo) & (effect < hi), calls_ours, osc)
                              for lo, hi in EFFECT_NOISE_BINS}  # fmt: skip

    # another simulator, another valve model, other tunings: judged by the detector trained on every family
    simulation_only = training.train(sim)
    out["two_parameter"], tp_windows = _judged(_two_parameter_set(n_per_class, seed, samples), simulation_only)
    if windows:
        out["two_parameter_windows"] = tp_windows

    measured_rows = [
        (tag, sticky, evidence(e.op, e.pv, e.ts_s, e.sp), _blocked(e.op, e.pv)) for tag, sticky, e in exports
    ]
    if measured_rows:
        tags = [r[0] for r in measured_rows]
        xm = np.nan_to_num(np.array([r[2].vector for r in measured_rows]))
        stuck_m = np.array([r[2].stuck for r in measured_rows])
        osc_m = np.array([r[2].oscillation.oscillating for r in measured_rows])
        sticky = np.array([r[1] for r in measured_rows])
        # the shipped window network never saw a measured window: it reads every tag as held out
        seq_m = _shipped_sequence([(e.op, e.pv, e.sp) for _, _, e in exports])
        p_cv, p_cv_stat = np.zeros(len(measured_rows)), np.zeros(len(measured_rows))
        for tag in sorted(set(tags)):
            keep = [i for i, t in enumerate(tags) if t != tag]
            held = [i for i, t in enumerate(tags) if t == tag]
            d = training.train(sim, xm[keep], list(sticky[keep]), [tags[i] for i in keep],
                               measured_oscillating=osc_m[keep])  # fmt: skip
            p_cv[held] = d.stiction_probability(xm[held], stuck_m[held], osc_m[held], sequence=seq_m[held])
            p_cv_stat[held] = d.stiction_probability(xm[held], stuck_m[held], osc_m[held])
        p_sim = simulation_only.stiction_probability(xm, stuck_m, osc_m, sequence=seq_m)
        calls = [_calls(r[2], p_cv[i], r[3], p_cv_stat[i]) for i, r in enumerate(measured_rows)]
        calls_sim = np.array([_calls(r[2], p_sim[i], r[3], p_sim[i])["ours"] for i, r in enumerate(measured_rows)])
        readable = ~np.array([r[3] for r in measured_rows])
        if windows:  # each measured window's figures, its tag held out
            out["measured_windows"] = [
                {"tag": tag, "sticky": bool(sticky[i]), "blocked": bool(measured_rows[i][3]),
                 "oscillating": bool(osc_m[i]), "p": float(p_cv[i]), "p_statistics": float(p_cv_stat[i]),
                 "p_network": float(seq_m[i])}
                for i, tag in enumerate(tags)
            ]  # fmt: skip
        out["measured"] = {
            "windows": len(measured_rows),
            "tags": len(set(tags)),
            "sticky": int(sticky.sum()),
            "bad_data": int((~readable).sum()),
            **{m: _rates(np.array([c[m] for c in calls]), sticky) for m in METHODS},
            "ours_simulation_only": _rates(calls_sim, sticky),
            "ours_readable": _rates(np.array([c["ours"] for c in calls])[readable], sticky[readable]),
            "ours_settled": _settled(p_cv, sticky, ~readable, np.ones(len(measured_rows), bool))[0],
            "near_threshold": int(np.sum(np.abs(p_cv - STICTION_AT) < 0.1)),
            "cannot_tell": float(np.mean((p_cv >= LEANS_AT) & (p_cv < STICTION_AT))),
        }
    out["seconds"] = time.perf_counter() - t0
    return out


def _outcomes_text(name: str, row: dict) -> str:
    o = row["fault_outcomes"]
    if o["called"] is None:
        return f"{name} none shows a fault"
    return f"{name} " + " / ".join(f"{o[k]:.2f}" for k in ("called", "leaning", "bad_data", "read_healthy"))


def print_table(fig: dict) -> None:
    from stiction.detect.verdict import LEANS_AT, STICTION_AT

    bands = {"plant": "plant-scale bands (S 0.5-10 % of span)", "thesis": "the thesis's bands (S 5-48 % of span)"}
    length = f", records of {fig['samples']} samples" if fig.get("samples") else ""
    print(f"simulated families, leave-one-family-out (trained on the others, the thesis's bands; judged on "
          f"{bands[fig.get('bands', 'thesis')]}{length}): sensitivity / specificity, balanced accuracy")  # fmt: skip
    print(f"{'family':10s}{'n':>5s}{'fault':>6s}" + "".join(f"{m:>19s}" for m in METHODS) + "   cannot tell")
    for f, row in fig["families"].items():
        cells = "".join(
            f"{row[m]['sensitivity']:>7.2f}/{row[m]['specificity']:.2f} {row[m]['balanced']:.2f}" for m in METHODS
        )
        print(f"{f:10s}{row['n']:5d}{row['show_fault']:6d}{cells}{100 * row['cannot_tell']:>11.0f} %")
    cycling = [f"{f} {r['ours_oscillating']['sensitivity']:.2f}/{r['ours_oscillating']['specificity']:.2f} "
               f"({r['ours_oscillating']['show_fault']} of {r['ours_oscillating']['n']} show a fault)"
               for f, r in fig["families"].items() if r["ours_oscillating"]["n"]]  # fmt: skip
    print("ours on the windows that oscillate regularly (sensitivity/specificity): " + ", ".join(cycling))
    print("ours on every window, where the windows that show a fault go (called / leaning, not settled / bad data / "
          "read healthy): " + "; ".join(_outcomes_text(f, r) for f, r in fig["families"].items()))  # fmt: skip
    settled = {f: r["ours_settled"] for f, r in fig["families"].items()}
    cells = [f"{f} {v['balanced']:.2f} +- {2 * v.get('balanced_se', np.nan):.2f}" for f, v in settled.items()]
    print(f"ours, the windows it settles (p below {LEANS_AT} or from {STICTION_AT}, data read): balanced "
          "(+- two standard errors) " + ", ".join(cells))  # fmt: skip
    if all("false_alarms" in r for r in fig["families"].values()):
        print("ours, the settled windows labelled healthy that it calls: of healthy valves, of faulty valves whose "
              "window does not show the fault (one slip, or under the noise) " + ", ".join(
                  f"{f} {a['healthy_valve']['called']} of {a['healthy_valve']['of']}, "
                  f"{a['faulty_valve_not_shown']['called']} of {a['faulty_valve_not_shown']['of']}"
                  for f, r in fig["families"].items() for a in [r["false_alarms"]]))  # fmt: skip
    if all("statistics_settled" in r for r in fig["families"].values()):
        print("statistics (without the window network), the windows it settles: balanced " + ", ".join(
            f"{f} {r['statistics_settled']['balanced']:.2f} ({100 * r['statistics_cannot_tell']:.0f} % not settled)"
            for f, r in fig["families"].items()))  # fmt: skip
    print("by cause (held out): " + "; ".join(
        f"{c} {100 * r['called']:.0f} % called ({100 * r['show_fault']:.0f} % show a fault)"
        for c, r in fig["by_cause"].items()))  # fmt: skip
    by_band = [f"{b} {100 * r['called']:.0f} % of {r['show_fault']}" for b, r in fig["by_band"].items()
               if r["show_fault"]]  # fmt: skip
    print("windows that show a fault, called stiction, by band S (% of span): " + "; ".join(by_band))
    slips = [f"{b} {100 * r['called']:.0f} % of {r['show_fault']} ({100 * r['cycling']:.0f} % cycle)"
             for b, r in fig["by_slip_noise"].items() if r["show_fault"]]  # fmt: skip
    print("the same by slip J over the noise's standard deviation: " + "; ".join(slips))
    effects = [f"{b} {100 * r['called']:.0f} % of {r['show_fault']}" for b, r in fig["by_effect_noise"].items()
               if r["show_fault"]]  # fmt: skip
    print("windows whose stem slipped, called stiction, by the fault's effect on PV over the noise (under 1: "
          "labelled healthy-looking): " + "; ".join(effects))  # fmt: skip
    stem = {f: r["ours_stem_slipped"]["balanced"] for f, r in fig["families"].items()}
    print("ours against the label before 2026-11-25 (the stem slipped twice, shown or not): balanced "
          + ", ".join(f"{f} {v:.2f}" for f, v in stem.items()))  # fmt: skip
    print(f"evidence per window: {1000 * fig['seconds_per_window']:.1f} ms (with the simulation)")
    wn = fig.get("window_net")
    if wn:
        print(f"window networks (one per family left out): {wn['windows']} simulated windows, "
              f"{wn['simulate_s']:.0f} s simulating, {wn['train_s']:.0f} s training; "
              "ours without them: statistics")  # fmt: skip
    m = fig.get("measured")
    if m:
        print(f"measured windows ({m['windows']} in {m['tags']} tags, {m['sticky']} labelled sticky, "
              f"{m['bad_data']} with blocking data problems), leave-one-tag-out:")  # fmt: skip
        for k in ("accuracy", "sensitivity", "specificity"):
            print(f"{k:22s}" + "".join(f"{m[x][k]:>12.2f}" for x in METHODS) + "   " + " ".join(METHODS))
        alone = m["ours_simulation_only"]
        print(f"ours trained on simulation alone: accuracy {alone['accuracy']:.2f}, sensitivity "
              f"{alone['sensitivity']:.2f}, specificity {alone['specificity']:.2f}; on the "
              f"{m['windows'] - m['bad_data']} readable windows {m['ours_readable']['accuracy']:.2f}")  # fmt: skip
        print(f"measured windows within 0.1 of the threshold: {m['near_threshold']}; cannot tell "
              f"{100 * m['cannot_tell']:.0f} %")  # fmt: skip
        st = m["ours_settled"]
        print(f"ours, the {st['n']} measured windows it settles (as the families'; cannot tell and bad data "
              f"counted neither way): accuracy {st['accuracy']:.2f}, sensitivity {st['sensitivity']:.2f}, "
              f"specificity {st['specificity']:.2f}")  # fmt: skip
    if fig.get("two_parameter"):
        print(
            "another simulator (sim.two_parameter: Choudhury's two-parameter valve, SIMC-tuned flow and level loops "
            "sampled 1-10 s), judged by the detector trained on every family: sensitivity / specificity, balanced"
        )
        for kind, row in fig["two_parameter"].items():
            cells = "".join(
                f"{row[m]['sensitivity']:>7.2f}/{row[m]['specificity']:.2f} {row[m]['balanced']:.2f}" for m in METHODS
            )
            o, st = row["ours_oscillating"], row["ours_settled"]
            print(f"{kind:10s}{row['n']:5d}{row['show_fault']:6d}{cells}   cycles {o['sensitivity']:.2f}/"
                  f"{o['specificity']:.2f} ({o['show_fault']} of {o['n']}); ours settled "
                  f"{st['sensitivity']:.2f}/{st['specificity']:.2f} {st['balanced']:.2f}, cannot tell "
                  f"{100 * row['cannot_tell']:.0f} %")  # fmt: skip
        print("  where its windows that show a fault go (called / leaning / bad data / read healthy): " + "; ".join(
            _outcomes_text(k, r) for k, r in fig["two_parameter"].items()))  # fmt: skip
    print(f"{fig['seconds']:.0f} s")
