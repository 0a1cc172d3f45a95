"""The one-line status every long-running command prints every 10 s without being asked."""

from __future__ import annotations

import time


class Every:
    """True once every ``seconds`` (never for 0)."""

    def __init__(self, seconds: float):
        self.seconds = seconds
        self.last = time.monotonic()

    def __call__(self) -> bool:
        now = time.monotonic()
        if self.seconds <= 0 or now - self.last < self.seconds:
            return False
        self.last = now
        return True


def _counts(d: dict[str, int]) -> str:
    return ", ".join(f"{k} {v}" for k, v in sorted(d.items())) or "none"


def agent_line(h) -> str:
    p99 = f"{h.latency_p99_s * 1e3:.0f} ms" if h.latency_p99_s is not None else "-"
    rates = (
        f"{h.samples_per_s:.0f} samples/s, {h.reports_per_s:.1f} reports/s"
        if h.samples_per_s is not None and h.reports_per_s is not None
        else "-"
    )
    return (
        f"agent {h.agent_id}: {h.loops_seen} loops ({h.loops_owned} owned, {len(h.agents_alive)} agent(s) alive), "
        f"{rates}, {h.reports} reports, p99 latency {p99}, rejected: {_counts(h.rejected)}"
        + (f", friction readings put off: {h.readings_deferred}" if h.readings_deferred else "")
        + (f", sticky loops sized under their identified process: {h.loops_sized}" if h.loops_sized else "")
        + (f", noisy level loops' valves fitted: {h.loops_fitted}" if h.loops_fitted else "")
    )


def bridge_line(h, samples_per_s: float) -> str:
    return (
        f"bridge {h.bridge_id}: {'connected' if h.connected else 'NOT CONNECTED'} to {h.source}, "
        f"{h.loops_publishing}/{h.loops} loops publishing, {samples_per_s:.0f} samples/s, "
        f"dropped: {_counts(h.dropped)}, missing loops: {len(h.loops_missing)}, reconnects {h.reconnects}"
    )
