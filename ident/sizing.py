"""S and J of a loop called sticky whose process nobody declared: read under the process diagnose identifies.

``stiction diagnose`` fits the physical valve and a process (integrating or first order, dead
time, sensor and actuator lags, the gain free) open loop from the measured OP to PV, and reads
the band S from the brackets its slips put on it and J from the least squares.  Its standard
errors are the fit's, conditional on the model being right; on simulated plant-like loops
(``sim.plant_loops``: processes, tunings and sampling the fit does not know) the model is only
close, and the errors are larger than the fit says.  So each standard error of a diagnosis
report is the fit's combined with a model error proportional to S, measured on those loops
(``ident.trust.with_model_error``, applied by ``ident.report.diagnosis_report``); and where the fit
cannot separate S from J (the whole band read as jump: fd at its bound of zero, where a few
wrong slips move S by a factor of several) or reads fewer than two slips, nothing is reported
and the reason is.  Nor where the band read is less than half the OP travel over which PV
stood still in the record (``ident.trust.stuck_travel_contradicts``, applied by
``ident.report.diagnosis_report``): a valve that stayed put while OP moved
that far has a band of about that at least, and a fit that says otherwise describes another loop.  Nor where the
fit keeps no slip the data show and its valve moves at half the samples or more (``ident.trust.dragged``, applied by
``ident.report.diagnosis_report``): a valve dragged behind OP has no stuck phase to read a band from.

Measured on simulated plant-like sticky loops called sticky by the detector (``stiction bench
sizing`` prints the same on any seed): seeds 2026 and 2027, 60 loops per class, 66 called
sticky, 36 read.  With the fit's own errors the truth was inside S +- 2 se in 28 % of them;
with ``ident.trust.MODEL_ERROR_S`` 0.20 in 94 % and 100 %; J +- 2 se (J trades off against the unknown
process gain) 94 % and 84 % with ``ident.trust.MODEL_ERROR_J`` 0.30.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from stiction.ident.models import is_lag_line
from stiction.ident.trust import band_doubts
from stiction.schemas.diagnosis import Process
from stiction.sim.valve import friction_pct, friction_se_pct


@dataclass(frozen=True)
class Sizing:
    """The valve's band and jump under the identified process; NaN where withheld (``why`` says why)."""

    s_pct: float
    j_pct: float
    s_se_pct: float
    j_se_pct: float
    process: Process | None
    slips: int
    why: str | None = None
    model_pv_pct: np.ndarray | None = field(default=None, repr=False, compare=False)
    doubts: tuple[str, ...] = ()
    """What makes the band read doubtful (``ident.trust.band_doubts``), for the report beside the numbers."""
    parameter_ranges: dict[str, tuple[float, float]] = field(default_factory=dict)
    """The diagnosis's ranges (about 95 %) of its named parameters (``ident.models.parameter_ranges``)."""

    @property
    def read(self) -> bool:
        return self.why is None

    def fs_fd_pct(self) -> tuple[float, float, float, float]:
        """(fs, fd, fs_se, fd_se) in % of 500 lbf (``sim.valve.friction_pct``)."""
        fs, fd = friction_pct(self.s_pct, self.j_pct)
        fs_se, fd_se = friction_se_pct(self.s_se_pct, self.j_se_pct)
        return float(fs), float(fd), float(fs_se), float(fd_se)


def size(op_pct: np.ndarray, pv_pct: np.ndarray, ts_s: float, name: str = "loop", sp_pct=None) -> Sizing:
    """Diagnose the record and read S and J with the model error added (seconds of CPU a loop);
    ``sp_pct``, the setpoint where recorded, lets a stuck setpoint step bound the band too."""
    from stiction.ident.friction import simulated_pv
    from stiction.ident.report import diagnose_loop

    report, record, d = diagnose_loop(name, np.asarray(op_pct, float), np.asarray(pv_pct, float), ts_s, sp=sp_pct)
    return replace(from_report(report), model_pv_pct=simulated_pv(d.extended.fit, record))


def from_report(report) -> Sizing:
    """The sizing a diagnosis report (``schemas.diagnosis.DiagnosisReport``) supports, with its parameters' ranges."""
    return replace(_sizing(report), parameter_ranges={k: tuple(v) for k, v in report.parameter_ranges.items()})


def _sizing(report) -> Sizing:
    nan = float("nan")
    s, j, s_se, j_se = (nan if v is None else float(v) for v in (report.s_pct, report.j_pct, report.s_se_pct,
                                                                  report.j_se_pct))  # fmt: skip
    process, slips = report.process, int(report.slips)
    if not (math.isfinite(s) and math.isfinite(j) and math.isfinite(s_se)):
        why = _why_not(report)
        return Sizing(nan, nan, nan, nan, process, slips, why)
    if not math.isfinite(j_se):
        why = (
            "the identified model reads the whole band as jump (fd at its bound of zero): S and J are not "
            "separable from the process gain in this record"
        )
        return Sizing(nan, nan, nan, nan, process, slips, why)
    doubts = tuple(band_doubts(s, s_se, process, j, j_se)) + lag_doubt(report, s, s_se)
    return Sizing(s, j, s_se, j_se, process, slips, doubts=doubts)


def lag_doubt(report, s_pct: float, s_se_pct: float) -> tuple[str, ...]:
    """Where the diagnosis names an actuator lag and gives its line (``ident.ties.lag_band_tie``: S at no lag and
    its slope), and the line moves S over the lag read by more than S's standard error: say so beside S, which a
    stroke test's lag would correct.  Where it moves S less (a 10 s flow loop of the StictionGPT plant: 0.2 % over a
    lag of 41 s, S 2.40 +- 0.49), the lag does not matter and nothing is said."""
    lines = [t for t in report.cannot_tell if is_lag_line(t)]
    if not lines:
        return ()
    s0, slope = lines[0].parameters.get("s_pct_at_no_lag"), lines[0].parameters.get("s_pct_per_lag_s")
    if s0 is None or not slope or not abs(s0 - s_pct) > s_se_pct:
        return ()
    return (
        f"S is read under an actuator lag of {(s0 - s_pct) / slope:.3g} s, which a limit cycle hardly tells from a "
        f"wider band: with no lag S would be {s0:.3g} %, {slope:.3g} % less for each second of lag (a stroke test's "
        "lag reads S off this line)",
    )


def _why_not(report) -> str:
    withheld = [i for i, w in enumerate(report.warnings) if "withheld" in w or "not supported" in w]
    if withheld:
        why = report.warnings[withheld[-1]]
        # "(above)" points at the data checks before it in the diagnosis; this reason travels alone
        return why.replace("(above)", f"({'; '.join(report.warnings[: withheld[-1]])})") if "(above)" in why else why
    return f"{report.slips} slip(s) read in the record: too few to bracket the band"
