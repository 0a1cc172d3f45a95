"""What ``stiction bench throughput``'s figures mean: the plant-scale goals, the sweep for the largest
loop count that holds them, and the figures as text."""

from __future__ import annotations

from collections.abc import Callable

GOALS = {"latency_p99_s": 1.0, "agent_cpu_share": 0.6, "agent_peak_rss_mb": 500.0}
"""The plant-scale goals per agent: p99 from a window's last sample to its report, cores, MB; and no
sample lost, every expected report made."""


def missed_goals(f: dict) -> list[str]:
    """The goals a run missed, each in a few words (none: it holds them)."""
    out = []
    p99 = f["latency_p99_s"]  # every report of the live phase, the first interval's too
    if p99 is None or p99 >= GOALS["latency_p99_s"]:
        out.append(f"p99 {p99 if p99 is None else round(p99, 2)} s")
    if f["samples_lost"]:
        out.append(f"{f['samples_lost']} samples lost")
    if f["reports"] < f["reports_expected"]:
        out.append(f"{f['reports']} of {f['reports_expected']} reports")
    if max(f["agent_cpu_share"]) >= GOALS["agent_cpu_share"]:
        out.append(f"{max(f['agent_cpu_share']):.2f} of a core")
    if f["agent_peak_rss_mb"] >= GOALS["agent_peak_rss_mb"]:
        out.append(f"{f['agent_peak_rss_mb']:.0f} MB")
    return out


def find_limit(run: Callable[[int], dict], start: int, progress: Callable[[int, dict, list[str]], None] | None = None):
    """Loop counts up by a quarter from ``start`` (rounded to 500) until a run misses a goal:
    ``(largest count that held or None, [{loops, missed, figures}, ...])``."""
    held, runs, loops = None, [], start
    while True:
        f = run(loops)
        missed = missed_goals(f)
        runs.append({"loops": loops, "missed": missed, "figures": f})
        if progress is not None:
            progress(loops, f, missed)
        if missed:
            return held, runs
        held, loops = loops, int(round(loops * 1.25 / 500) * 500) or loops + 500


def print_step(loops: int, f: dict, missed: list[str]) -> None:
    """One line of the sweep."""
    p99 = f["latency_p99_s"]
    print(
        f"{loops} loops: p99 {'-' if p99 is None else f'{p99:.2f}'} s, "
        f"{max(f['agent_cpu_share']):.2f} of a core, {f['agent_peak_rss_mb']:.0f} MB, "
        f"{f['samples_lost']} samples lost: " + ("holds" if not missed else "misses " + ", ".join(missed)),
        flush=True,
    )


def print_limit(held: int | None, start: int, f: dict) -> None:
    """The sweep's answer, with the run's settings and the machine (``f``: the last run's figures)."""
    h = f["host"]
    print(
        f"largest loop count that holds the goals here: {held if held is not None else f'none from {start}'} "
        f"({f['agents']} agent(s), {f['mix']}, {f['batch_s']:g} s a message, {f['seconds']:g} s live; "
        f"{h['cpu']}, {h['cpus']} cores)"
    )


def print_table(f: dict) -> None:
    """One run's figures as text."""
    lat = (
        f"p50 {f['latency_p50_s'] * 1e3:.0f} ms, p99 {f['latency_p99_s'] * 1e3:.0f} ms"
        if f["latency_p50_s"] is not None
        else "no reports"
    )
    print(
        f"{f['loops']} {f['mix']} loops at {f['speed']:g} Hz, {f['agents']} agent(s), {f['seconds']:g} s, "
        f"{f['batch_s']:g} s of samples a message on {'shard keys' if f['sharded'] else 'the spec key'}"
    )
    print(f"  verdicts reported: {', '.join(f'{k} {v}' for k, v in sorted(f['verdicts'].items()))}")
    print(
        f"  samples/s ingested {f['samples_per_s']:.0f}   reports/s {f['reports_per_s']:.1f} "
        f"({f['reports']} of {f['reports_expected']} expected)"
    )
    print(
        f"  stiction reports with S and J {f['stiction_reports_with_friction']} of {f['verdicts'].get('stiction', 0)} "
        f"({f['stiction_reports_read_from_own_window']} read from their own window, the others carried a recent "
        f"reading); readings put off {f['readings_deferred']}"
    )
    settled = f["latency_p99_after_first_interval_s"]
    settled = f"; p99 {settled * 1e3:.0f} ms once every loop has reported" if settled is not None else ""
    print(f"  latency last sample -> report: {lat}{settled}")
    by = " ".join("-" if x is None else f"{x:.2f}" for x in f["latency_p99_by_10s"])
    print(f"  p99 by 10 s of stream (s): {by}")
    print(f"  samples lost {f['samples_lost']}   rejected {f['rejected'] or 'none'}")
    shares = ", ".join(f"{x:.0%}" for x in f["messages_received_share"])
    print(
        f"  messages received by each agent: {shares} of those published; "
        f"windows from history {f['windows_from_history']}"
    )
    killed = f" (agent 0 SIGKILLed at {f['killed_agent_at_s']:.0f} s)" if f["killed_agent_at_s"] is not None else ""
    print(
        f"  exactly once{killed}: {f['reports_duplicated']} reports duplicated, "
        f"{f['report_intervals_missed']} intervals without a report"
    )
    print(
        f"  agent CPU {', '.join(f'{c:.0%}' for c in f['agent_cpu_share'])} of a core, "
        f"peak RSS {f['agent_peak_rss_mb']:.0f} MB; sizing worker "
        f"{', '.join(f'{c:.0%}' for c in f['sizing_worker_cpu_share'])} of a core, {f['loops_sized']} loops sized, "
        f"{f.get('loops_fitted', 0)} fitted"
    )
    print(f"  host: {f['host']['cpu']}, {f['host']['cpus']} cores")
    stages = f["agent_cpu_by_stage"]
    print("  agent CPU by stage (cores): " + ", ".join(f"{k} {v:.2f}" for k, v in stages.items()))
    if f.get("agent_cpu_share_second_half") is not None:
        late = f["agent_cpu_by_stage_second_half"]
        print(
            f"  over the second half of the live phase: agent CPU "
            f"{', '.join(f'{c:.0%}' for c in f['agent_cpu_share_second_half'])} of a core; by stage "
            + ", ".join(f"{k} {v:.2f}" for k, v in late.items())
        )
