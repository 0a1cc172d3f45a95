"""A dashboard's view of the key space: one subscription to every report, one to every truth."""

from __future__ import annotations

import threading

from stiction.schemas import keys
from stiction.schemas.messages import LoopTruth
from stiction.schemas.report import StictionReport


class Dashboard:
    def __init__(self, session, prefix: str):
        self.prefix = prefix
        self.reports: dict[str, StictionReport] = {}
        self.truths: dict[str, LoopTruth] = {}
        self.received = 0
        self.bad = 0
        self._lock = threading.Lock()
        self._subs = [
            session.declare_subscriber(keys.all_reports(prefix), self._on_report),
            session.declare_subscriber(keys.all_truths(prefix), self._on_truth),
        ]
        self._session = session

    def _read(self, model, sample):
        """The message as ``model``, or None (counted in ``bad``) if it does not validate."""
        try:
            return model.model_validate_json(sample.payload.to_bytes())
        except ValueError:
            self.bad += 1
            return None

    def _on_report(self, sample) -> None:
        report = self._read(StictionReport, sample)
        if report is not None:
            with self._lock:
                self.reports[report.loop_id] = report
                self.received += 1

    def _on_truth(self, sample) -> None:
        truth = self._read(LoopTruth, sample)
        if truth is not None:
            with self._lock:
                self.truths[truth.loop_id] = truth

    def fetch_truths(self) -> None:
        """Late joiner: ask the simulator for every loop's truth."""
        for reply in self._session.get(keys.all_truths(self.prefix), timeout=2.0):
            if reply.ok is not None:
                self._on_truth(reply.ok)

    def fetch_latest(self, timeout_s: float = 1.0) -> None:
        """Ask the agents for every loop's latest report: a report can be completed after it was
        published (a background sizing), and ``get`` answers with it."""
        latest, bad = latest_reports(self._session, self.prefix, timeout_s)
        with self._lock:
            self.bad += bad
            for report in latest.values():
                held = self.reports.get(report.loop_id)
                if held is None or (report.t_end_s or 0.0) >= (held.t_end_s or 0.0):
                    self.reports[report.loop_id] = report

    def snapshot(self) -> tuple[dict[str, StictionReport], dict[str, LoopTruth]]:
        with self._lock:
            return dict(self.reports), dict(self.truths)

    def close(self) -> None:
        for s in self._subs:
            s.undeclare()


def latest_reports(session, prefix: str, timeout_s: float) -> tuple[dict[str, StictionReport], int]:
    """Every loop's latest report in the key space (a ``get`` the agents answer), and how many replies
    did not validate.  Where two agents answer for one loop (a hand-over), the later window wins."""
    latest: dict[str, StictionReport] = {}
    bad = 0
    for reply in session.get(keys.all_reports(prefix), timeout=timeout_s):
        if reply.ok is None:
            continue
        try:
            report = StictionReport.model_validate_json(reply.ok.payload.to_bytes())
        except ValueError:
            bad += 1
            continue
        held = latest.get(report.loop_id)
        if held is None or (report.t_end_s or 0.0) >= (held.t_end_s or 0.0):
            latest[report.loop_id] = report
    return latest, bad
