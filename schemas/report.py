"""The stiction report: output of ``stiction quantify`` and of the agent (spec/interfaces.md)."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

SCHEMA_VERSION = 1
"""The version of the stream's messages (``schemas.messages``)."""
REPORT_SCHEMA_VERSION = 3
"""The report's version: 2 adds the verdict, the stiction probability, the likely cause, the process and
the data checks, and nulls every friction number unless the verdict is ``stiction``; 3 makes ``s_pct``
Choudhury's band (deadband + stickband, the OP travel after a reversal before the stem moves: (fs + fd)/12
where it was fs/12), adds ``stiction_kind``, and counts a valve's deadband as stiction, not as an other
cause (docs/reports.md, migration)."""

Verdict = Literal["stiction", "other_cause", "no_oscillation", "bad_data"]


class ProcessInfo(BaseModel):
    """What is known of the loop's process when the friction is read."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    kind: Literal["integrating", "self_regulating", "unknown"]
    source: Literal["declared", "identified", "none"] = Field(
        description="declared with --process, identified from the data (stiction diagnose), or not known"
    )
    gain: float | None = Field(None, description="%/s per % (integrating) or % per % (self-regulating)")
    gain_se: float | None = Field(None, description="one standard error of an identified gain")
    time_constant_s: float | None = None
    dead_time_s: float | None = None
    sensor_tau_s: float | None = Field(None, description="an identified sensor's first-order lag, s (0: none named)")
    actuator_tau_s: float | None = Field(
        None,
        description="an identified actuator's first-order lag, s (0: none named); S trades with it (a longer lag, a "
        "narrower band), and S's error holds that doubt",
    )
    parameter_ranges: dict[str, tuple[float, float]] = Field(
        default_factory=dict,
        description="about 95 % range (low, high) of an identified time_constant_s, dead_time_s, sensor_tau_s and "
        "actuator_tau_s, as stiction diagnose gives them (from how far it read them on simulated loops)",
    )
    sample_time_s: float
    description: str | None = Field(None, description="the identified model in words, where one was identified")
    pv_explained_share: float | None = Field(
        None,
        description="an identified model's share of PV's course explained by its simulation from OP (the diagnosis's "
        "process.pv_explained_share; 0 or below: none of it)",
    )


class Estimate(BaseModel):
    """One method's estimate of the friction, percent of 500 lbf (the thesis convention)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    fs_pct: float | None
    fd_pct: float | None
    fs_se_pct: float | None = Field(None, description="standard error of fs_pct, where the method gives one")
    fd_se_pct: float | None = None


class StictionReport(BaseModel):
    """How sticky one loop's valve is, from one window of its OP and PV."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    schema_version: Literal[3] = REPORT_SCHEMA_VERSION
    loop_id: str
    verdict: Verdict = Field(
        description="what the loop is doing: stiction (the friction numbers are its valve's), other_cause "
        "(oscillates, not from stiction: likely_cause), no_oscillation, or bad_data (warnings say which)"
    )
    stiction_probability: float | None = Field(
        description="the detector's probability that the valve sticks (0..1), read as if a sticky and a healthy "
        "valve were equally likely before the data; null for bad data"
    )
    likely_cause: str | None = Field(
        description="stiction, or for other_cause the look-alike it resembles most (external_oscillation, "
        "tuning, quantization, noise); a valve's deadband is stiction (stiction_kind), not another cause"
    )
    regularity: float | None = Field(
        description="regularity of the oscillation's zero crossings (Thornhill 2003; for a cycle of steady swing "
        "also read by the periods' median): > 1.5 a regular oscillation"
    )
    amplitude_pct: float | None = Field(
        description="half the typical peak-to-peak swing of the control error (PV where no setpoint), % of span"
    )
    checks: list[str] = Field(
        default_factory=list, description="names of the data checks that failed (flat_pv, manual, saturated_op, ...)"
    )
    process: ProcessInfo = Field(description="the process the friction is read under")
    fs_pct: float | None = Field(description="static friction, percent of 500 lbf; None if not quantifiable")
    fd_pct: float | None = Field(description="dynamic friction, percent of 500 lbf")
    s_pct: float | None = Field(
        description="band S in percent of span (Choudhury, Thornhill & Shah 2005): deadband + stickband, the OP "
        "travel after a reversal before the stem moves; (fs + fd)/12 lbf per % for the thesis's valve "
        "(from report schema 3; before, fs/12)"
    )
    j_pct: float | None = Field(
        description="slip jump J in percent of span: how far the stem jumps when it breaks away; (fs - fd)/12"
    )
    stiction_kind: Literal["stick_slip", "deadband"] | None = Field(
        None,
        description="the kind of valve fault where the data tell: stick_slip (J surely above zero) or deadband "
        "(backlash without a slip: J surely below a quarter of S); null where they cannot tell or S is not read",
    )
    s_se_pct: float | None = Field(description="uncertainty (one standard error) of s_pct")
    j_se_pct: float | None = Field(description="uncertainty (one standard error) of j_pct")
    fs_se_pct: float | None = Field(description="uncertainty (one standard error) of fs_pct")
    fd_se_pct: float | None = Field(description="uncertainty (one standard error) of fd_pct")
    period_s: float | None = Field(description="oscillation period from the autocorrelation function")
    denoised: bool = Field(description="the INLPCA denoiser ran on this window")
    method: Literal["physical", "combined", "learned", "thesis", "identified", "stem", "none"] = Field(
        description="which estimate fs_pct/fd_pct come from: the physical reading of the slips, the physical and "
        "the learned readings weighed by their errors where they agree (both blocks shown), the learned "
        "cycle predictor, the thesis chain, the fit under the process identified from the record "
        "(stiction quantify), the valve's measured stem position where the export records it and it sticks "
        "(stiction quantify; the verdict is then the stem's), or none"
    )
    thesis: Estimate = Field(description="the thesis chain's estimate (ACF, INLPCA, 100-sample OP MLP)")
    physical: Estimate | None = Field(
        description="the physical reading of the slips; null unless the loop is declared the level loop "
        "and its data can be read"
    )
    learned: Estimate = Field(description="the learned cycle predictor (ensemble mean and spread)")
    ood_score: float | None = Field(
        description="distance of the window from the training data: <= 1 inside the range of 99 % of training windows; "
        "null where the models did not run (the verdict is not stiction and the loop not a declared level loop)"
    )
    explained: float | None = Field(
        description="share of the standardised OP-PV variance the INLPCA curve explains; null where it did not run"
    )
    oscillating: bool = Field(description="a regular oscillation was found (regularity above 1.5, two cycles or more)")
    warnings: list[str] = Field(default_factory=list)
    model_version: str
    agent_id: str | None = Field(None, description="the agent that produced the report (None: offline)")
    t_end_s: float | None = Field(None, description="time of the window's last sample")
    n_samples: int
    partial: bool = Field(
        False, description="the window is shorter than the agent's full window (a new loop's first reports)"
    )
    interpolated_samples: int = Field(
        0, description="samples of the window filled in by linear interpolation across short gaps in the stream"
    )
    estimate_t_end_s: float | None = Field(
        None,
        description="end of the window the friction numbers were read from: t_end_s where they were read from "
        "this window; earlier where the agent carried a recent reading of a loop still called sticky (it reads "
        "afresh every --estimate-every reports); null without friction numbers or without window times",
    )
