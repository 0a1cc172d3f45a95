"""Which sticky loops of unknown process the agent sizes in the background, and what their reports then carry.

Identifying a loop's process and reading S and J under it (``ident.sizing``) takes seconds of
CPU, a thousand times a report's budget.  A valve's friction changes over weeks, so the agent
sizes each such loop once every ``refresh_s`` on a worker of its own, at most ``in_flight``
at a time, and every report of the loop while it is called sticky carries the last sizing
(``estimate_t_end_s`` names the window it came from).  A new loop's partial window is sized
from ``MIN_PARTIAL_SAMPLES`` on (a 200-sample start often holds too few slips), and again once
the window is full or twice as long; where the partial window read nothing, already at half as
long again (a stream that ends before its window fills, as a replayed 751-sample export does,
is then still sized on most of its record).  A loop whose stream records the valve's position has its
stem checked against OP the same way (``quantify.stem``, a fraction of a second a window), once every
``refresh_s`` whatever its verdict, every report carrying the last check.  A noisy level loop whose report went out
without the fitted reading (``quantify.pipeline.UNFITTED_WARNING``: a fit takes seconds) has its window fitted the
same way (``quantify.refit``), again every ``refresh_s`` while it stays sticky; the agent's core carries an accepted
fit's reading in its reports (``agent.core.AgentCore.adopt``).  A level loop whose trusted slip reading went out
unchecked against the record is checked the same way, once every ``refresh_s``, after every other job waiting: where
the record does not bear the reading out, the worker fits the valve.  Pure: no clock, no processes.
"""

from __future__ import annotations

from dataclasses import dataclass

from stiction.ident.sizing import Sizing
from stiction.quantify.assembly import assemble, needs_sizing
from stiction.quantify.pipeline import FITTED_WARNING, UNFITTED_WARNING
from stiction.schemas.report import StictionReport


@dataclass(frozen=True)
class Sized:
    sizing: Sizing
    t_end_s: float | None
    at_s: float
    """When it was made (the agent's monotonic clock)."""
    n_samples: int = 0
    partial: bool = False
    """Whether the window it was made from was a new loop's partial one."""


MIN_PARTIAL_SAMPLES = 500
"""A new loop's partial window is sized once it holds this many samples."""
GROWN = 2.0
"""A partial window's sizing is made again once the window is full or holds this many times its samples."""
GROWN_UNREAD = 1.5
"""... or this many times, where the partial window's sizing read no S and J."""


class SizingPlan:
    def __init__(self, refresh_s: float, in_flight: int = 1):
        self.refresh_s = refresh_s
        self.max_in_flight = in_flight
        self.latest: dict[str, Sized] = {}
        self.in_flight: dict[str, tuple[int, bool]] = {}  # loop -> (samples, partial) of the window being sized
        self.done = 0
        self.stems: dict[str, tuple] = {}  # loop -> (its measured stem's last check or None, why not read, when)
        self.stems_in_flight: set[str] = set()
        self.fits: dict[str, float] = {}  # loop -> when its window was last fitted (accepted or not)
        self.fits_in_flight: set[str] = set()
        self.fits_done = 0

    def has_room(self) -> bool:
        """Whether another sizing or fit may start now (else the caller queues the loop)."""
        return len(self.in_flight) + len(self.fits_in_flight) < self.max_in_flight

    def fit_wanted(self, report: StictionReport, now_s: float) -> bool:
        """Whether this sticky report's window should be fitted: its reading was left unfitted, or it carries a fit
        older than ``refresh_s`` (refitted while the loop stays sticky)."""
        if UNFITTED_WARNING not in report.warnings and FITTED_WARNING not in report.warnings:
            return False
        return self._fit_due(report, now_s)

    def check_wanted(self, report: StictionReport, unchecked: bool, now_s: float) -> bool:
        """Whether this sticky report's slip reading, trusted but ``unchecked`` against the record
        (``quantify.pipeline.Result``), should be checked by a fit on a worker, as ``stiction quantify`` checks
        it: once every ``refresh_s``, after the fits and sizings waiting (the agent's ``_check_queue``).  A
        check is a fit (1-4 s of a worker) where the record does not bear the reading out: 29 of the 30 trusted slip
        readings of design seed 3131's first 60 random loops, whose records carry a load or noise (9 of those fits
        accepted)."""
        return unchecked and self._fit_due(report, now_s)

    def _fit_due(self, report: StictionReport, now_s: float) -> bool:
        return report.verdict == "stiction" and self.fit_due(report.loop_id, now_s)

    def fit_due(self, loop_id: str, now_s: float) -> bool:
        """Whether the loop's window is neither being fitted nor was fitted (or checked) within ``refresh_s``."""
        if loop_id in self.fits_in_flight:
            return False
        last = self.fits.get(loop_id)
        return last is None or now_s - last >= self.refresh_s

    def fit_started(self, loop_id: str) -> None:
        self.fits_in_flight.add(loop_id)

    def fit_finished(self, loop_id: str, now_s: float) -> None:
        """A fit came back (accepted, refused, or failed: the loop is tried again after ``refresh_s``)."""
        self.fits_in_flight.discard(loop_id)
        self.fits[loop_id] = now_s
        self.fits_done += 1

    def wanted(self, report: StictionReport, now_s: float) -> bool:
        """Whether this report's window should be sized (now if ``has_room``, else when a sizing ends)."""
        if not needs_sizing(report) or report.loop_id in self.in_flight:
            return False
        if report.partial and report.n_samples < MIN_PARTIAL_SAMPLES:
            return False
        last = self.latest.get(report.loop_id)
        if last is None or now_s - last.at_s >= self.refresh_s:
            return True
        grown = GROWN if last.sizing.read else GROWN_UNREAD
        return last.partial and (not report.partial or report.n_samples >= grown * last.n_samples)

    def started(self, loop_id: str, n_samples: int = 0, partial: bool = False) -> None:
        self.in_flight[loop_id] = (n_samples, partial)

    def finished(self, loop_id: str, sizing: Sizing | None, t_end_s: float | None, now_s: float) -> None:
        """A sizing came back (None: the worker failed; the loop is tried again after ``refresh_s``)."""
        n_samples, partial = self.in_flight.pop(loop_id, (0, False))
        self.done += 1
        nan = float("nan")
        failed = Sizing(nan, nan, nan, nan, None, 0, "the background identification failed")
        self.latest[loop_id] = Sized(sizing if sizing is not None else failed, t_end_s, now_s, n_samples, partial)

    def stem_wanted(self, loop_id: str, has_mv: bool, n_samples: int, now_s: float) -> bool:
        """Whether this loop's measured stem should be checked against OP now (``quantify.stem``): a loop whose
        window records the valve's position, once every ``refresh_s``, from ``MIN_PARTIAL_SAMPLES`` samples on,
        whatever its verdict (the stem can show a valve OP and PV do not)."""
        if not has_mv or n_samples < MIN_PARTIAL_SAMPLES or loop_id in self.stems_in_flight:
            return False
        last = self.stems.get(loop_id)
        return last is None or now_s - last[2] >= self.refresh_s

    def stem_started(self, loop_id: str) -> None:
        self.stems_in_flight.add(loop_id)

    def stem_finished(self, loop_id: str, result: tuple | None, now_s: float) -> None:
        """A stem check came back: (check, why not read), or None where the worker failed (tried again later)."""
        self.stems_in_flight.discard(loop_id)
        check, note = result if result is not None else (None, "the background check of the measured stem failed")
        self.stems[loop_id] = (check, note, now_s)

    def apply(self, draft: StictionReport, agent_id: str | None = None) -> StictionReport:
        """The report of a pipeline's draft (``quantify.assembly``), with the loop's last sizing where
        it is of a sticky loop of unknown process, and its measured stem's last check where it has one."""
        last = self.latest.get(draft.loop_id)
        check, note, _ = self.stems.get(draft.loop_id, (None, None, 0.0))
        if last is None:
            return assemble(draft, agent_id=agent_id, stem=check, stem_note=note)
        return assemble(draft, last.sizing, last.t_end_s, NOTE, agent_id=agent_id, stem=check, stem_note=note)


NOTE = (
    "S and J from the identified process are re-read in the background (estimate_t_end_s names the window "
    "they came from)"
)
