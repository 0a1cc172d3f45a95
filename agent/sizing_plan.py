"""Which sticky loops of unknown process the agent sizes in the background, and what their reports then carry.

Identifying a loop's process and reading S and J under it (``ident.sizing``) takes seconds of
CPU, a thousand times a report's budget.  A valve's friction changes over weeks, so the agent
sizes each such loop once every ``refresh_s`` on a worker of its own, at most ``in_flight``
at a time, and every report of the loop while it is called sticky carries the last sizing
(``estimate_t_end_s`` names the window it came from).  Pure: no clock, no processes.
"""

from __future__ import annotations

from dataclasses import dataclass

from agent.identified import with_sizing
from ident.sizing import Sizing
from schemas.report import StictionReport


@dataclass(frozen=True)
class Sized:
    sizing: Sizing
    t_end_s: float | None
    at_s: float
    """When it was made (the agent's monotonic clock)."""


class SizingPlan:
    def __init__(self, refresh_s: float, in_flight: int = 1):
        self.refresh_s = refresh_s
        self.max_in_flight = in_flight
        self.latest: dict[str, Sized] = {}
        self.in_flight: set[str] = set()
        self.done = 0

    def wanted(self, report: StictionReport, now_s: float) -> bool:
        """Whether to size this report's loop now (then ``started`` it)."""
        if report.verdict != "stiction" or report.process.source != "none" or report.loop_id in self.in_flight:
            return False
        if len(self.in_flight) >= self.max_in_flight:
            return False
        last = self.latest.get(report.loop_id)
        return last is None or now_s - last.at_s >= self.refresh_s

    def started(self, loop_id: str) -> None:
        self.in_flight.add(loop_id)

    def finished(self, loop_id: str, sizing: Sizing | None, t_end_s: float | None, now_s: float) -> None:
        """A sizing came back (None: the worker failed; the loop is tried again after ``refresh_s``)."""
        self.in_flight.discard(loop_id)
        self.done += 1
        nan = float("nan")
        failed = Sizing(nan, nan, nan, nan, None, 0, "the background identification failed")
        self.latest[loop_id] = Sized(sizing if sizing is not None else failed, t_end_s, now_s)

    def apply(self, report: StictionReport) -> StictionReport:
        """The report with the loop's last sizing, where it is of a sticky loop of unknown process."""
        last = self.latest.get(report.loop_id)
        if last is None:
            return report
        return with_sizing(report, last.sizing, last.t_end_s, NOTE)


NOTE = (
    "S and J from the identified process are re-read in the background (estimate_t_end_s names the window "
    "they came from)"
)
