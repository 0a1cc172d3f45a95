"""The diagnosis of one measured loop: output of ``stiction diagnose --json`` (spec/interfaces.md)."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

DIAGNOSIS_VERSION = 2


class _Frozen(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


class CauseCandidate(_Frozen):
    """One catalogue cause fitted on top of the model it was tried on."""

    cause: str
    parameters: dict[str, float] = Field(description="its fitted parameters, named as in the catalogue")
    error_pct: float | None = Field(description="RMS error of PV as the model with it simulates it from OP, % of span")
    criterion: float | None = Field(description="Schwarz's criterion (BIC) of the model with it; lower is better")
    delta_criterion: float | None = Field(
        description="criterion minus that of the model it was tried on: negative means it earned its place"
    )
    accepted: bool = False
    identifiable: bool = Field(True, description="false where the data cannot tell this cause from another")
    note: str = ""


class CannotTell(_Frozen):
    """Two answers the data cannot tell apart (their Schwarz criteria within 2: Kass & Raftery's "not
    worth more than a bare mention"; or a limit of the record itself)."""

    named: str = Field(
        description="the answer given at that step: a cause, or 'none' (nothing beyond the causes before)"
    )
    alternative: str = Field(description="a cause (or 'none') that explains PV as well")
    delta_criterion: float | None = Field(
        description="the alternative's criterion minus the named one's; null where the limit is the record's"
    )
    parameters: dict[str, float] = Field(description="the alternative's parameters, named as in the catalogue")
    note: str = ""


class Friction(_Frozen):
    """A valve's friction under one model: S (deadband + stickband, the OP travel after a reversal before the
    stem moves) and J (the slip jump) in % of span, fs and fd in % of 500 lbf (the thesis's valve)."""

    s_pct: float | None
    j_pct: float | None
    s_se_pct: float | None
    j_se_pct: float | None
    fs_pct: float | None
    fd_pct: float | None
    fs_se_pct: float | None
    fd_se_pct: float | None


class Process(_Frozen):
    """The process as identified: the nominal level process with every named process cause applied."""

    kind: Literal["integrating", "self_regulating"]
    gain: float = Field(
        description="integrating: PV rate per % of valve travel, %/s per %; self-regulating: static gain, % per %"
    )
    gain_se: float | None
    time_constant_s: float | None
    dead_time_s: float
    sensor_tau_s: float
    actuator_tau_s: float
    sample_time_s: float
    description: str
    pv_explained_share: float | None = Field(
        None,
        description="how much of PV's course the model's simulation from the measured OP explains: 1 - its mean "
        "squared error over that of the same model with the stem held still (offset, drift, initial state and a "
        "named external sine fitted); 0 or below: the valve's moves through this process explain none of PV's "
        "course, and the model describes PV a sample ahead only; null where PV has no course (since 2026-11-28)",
    )


class Residual(_Frozen):
    """Where a model fails: its one-sample prediction error over time and over frequency."""

    rms_by_tenth_pct: list[float] = Field(description="RMS error in each tenth of the record, % of span")
    peaks: list[dict[str, float]] = Field(
        description="strongest periods of the error as PV levels: period_s and share of the error's power"
    )


class ValveCheck(_Frozen):
    """OP against the measured stem position (where the export has ``mv``): the valve model on its own."""

    model: Literal["sticky", "linear"]
    delta_criterion: float = Field(description="criterion of the linear valve minus the sticky one's")
    s_pct: float | None
    j_pct: float | None
    s_se_pct: float | None = Field(None, description="one standard error of s_pct, the valve model's error included")
    j_se_pct: float | None = Field(None, description="one standard error of j_pct")
    valve: Literal["physical", "two_parameter"] | None = Field(
        None,
        description="the sticky valve that fits the stem better: the thesis's physical valve (slips while OP ramps) "
        "or Choudhury's two-parameter valve (sticks where OP turns, then follows it); null where the stem is linear",
    )
    actuator_tau_s: float
    calibration_gain: float = Field(description="stem travel per % of OP (1: calibrated)")
    calibration_offset_pct: float
    error_pct: float = Field(description="RMS error of the stem position, % of travel")


class DiagnosisReport(_Frozen):
    """What the canonical simulation gets wrong on one measured loop, why, and what fixing it gains."""

    schema_version: Literal[2] = DIAGNOSIS_VERSION
    loop_id: str
    n_samples: int
    sample_time_s: float
    cause: str = Field(description="the first cause that earned its place, or 'none'")
    causes: list[str] = Field(description="every cause that earned its place, in the order it was added")
    cannot_tell: list[CannotTell] = Field(
        default_factory=list,
        description="answers the data cannot tell from those given: read a cause here as 'or'",
    )
    parameters: dict[str, float] = Field(description="the fitted parameters of every named cause")
    parameter_ranges: dict[str, tuple[float, float]] = Field(
        default_factory=dict,
        description="about 95 % range (low, high) of each parameter in parameters, from how far the diagnosis read "
        "them on simulated loops (and, for gain_ratio, the fit's two standard errors); quantum_pct, read off the "
        "record's lattice, has none",
    )
    candidates: dict[str, CauseCandidate]
    base_error: float = Field(
        description="RMS error of PV as the canonical model simulates it from the measured OP, % of span"
    )
    extended_error: float = Field(description="the same for the extended model, % of span")
    gain_pct: float = Field(description="100 (1 - extended_error / base_error)")
    fs_pct: float | None = Field(description="static friction under the extended model, % of 500 lbf")
    fd_pct: float | None
    fs_se_pct: float | None
    fd_se_pct: float | None
    s_pct: float | None = Field(
        description="band S under the extended model, % of span: deadband + stickband, the OP travel after a "
        "reversal before the stem moves (from diagnosis schema 2; before, the static band fs/12)"
    )
    j_pct: float | None = Field(description="slip jump under the extended model, % of span")
    s_se_pct: float | None
    j_se_pct: float | None
    base_friction: Friction = Field(description="the friction the canonical model reads")
    process: Process
    stiction_delta_criterion: float = Field(
        description="criterion of the extended model with a valve that does not stick, minus the sticky one's: "
        "positive means stiction earns its place"
    )
    slips: int = Field(description="slips of the stem in the extended model")
    uses_mv: bool = Field(description="the export had the stem position and the valve was checked against it")
    valve_check: ValveCheck | None = None
    residual_base: Residual
    residual_extended: Residual
    warnings: list[str] = Field(default_factory=list)
