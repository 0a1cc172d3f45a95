"""Messages on the Zenoh key space (spec/interfaces.md), besides the report (``schemas.report``)."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from stiction.schemas.report import SCHEMA_VERSION

MAX_BATCH_SAMPLES = 3600
"""An hour of 1 s samples: larger batches are refused (split them)."""
SAMPLE_COLUMNS = ("op", "pv", "sp", "mv", "mode")
"""A ``SampleBatch``'s columns, one value a sample each (``op`` and ``pv`` always, the others where recorded)."""


class SampleBatch(BaseModel):
    """Consecutive samples of one loop; ``seq`` numbers samples from the loop's start, without gaps."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    schema_version: Literal[1] = SCHEMA_VERSION
    loop_id: str = Field(min_length=1, max_length=200)
    seq: int = Field(ge=0, description="index of the first sample of this batch in the loop's stream")
    t0_s: float = Field(description="time of the first sample, seconds")
    ts_s: float = Field(gt=0, le=3600, description="sample time, seconds")
    op: list[float] = Field(min_length=1, max_length=MAX_BATCH_SAMPLES, description="controller output, percent")
    pv: list[float] = Field(min_length=1, max_length=MAX_BATCH_SAMPLES, description="process value, percent")
    sp: list[float] | None = Field(None, max_length=MAX_BATCH_SAMPLES)
    mv: list[float] | None = Field(None, max_length=MAX_BATCH_SAMPLES, description="valve position, percent")
    mode: list[float] | None = Field(
        None, max_length=MAX_BATCH_SAMPLES, description="controller mode as recorded (e.g. 1 auto, 0 manual)"
    )
    process: Literal["level"] | None = Field(None, description="'level' for the canonical level loop; else unknown")

    @model_validator(mode="after")
    def _equal_lengths(self):
        n = len(self.op)
        sp, mv, mode = self.sp, self.mv, self.mode
        if (len(self.pv) == n and (sp is None or len(sp) == n) and (mv is None or len(mv) == n)
                and (mode is None or len(mode) == n)):  # fmt: skip
            return self  # checked for every message an agent receives, without a generator: the common case first
        lengths = {name: len(x) for name in SAMPLE_COLUMNS if (x := getattr(self, name)) is not None}
        if len(set(lengths.values())) > 1:
            raise ValueError(f"op, pv (and sp, mv, mode) must have equal lengths, got {lengths}")
        return self


class LoopTruth(BaseModel):
    """What the simulator put into a loop, so that a demo can score the agent."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    schema_version: Literal[1] = SCHEMA_VERSION
    loop_id: str
    fs_pct: float
    fd_pct: float
    s_pct: float = Field(
        description="band S, % of span: (fs + fd)/12, the OP travel after a reversal before the "
        "stem moves (before stiction 0.2: fs/12)"
    )
    j_pct: float = Field(description="slip jump J, % of span: (fs - fd)/12")
    loop: str
    valve: str
    seed: int
    disturbance: str | None = Field(description="e.g. 'output, 0.1 gaussian'")
    extensions: dict[str, float | str] = Field(
        description="the extensions that differ from the canonical loop: numbers, and osc_shape "
        "(sine, square or triangle) where the external load is not a sine"
    )


class AgentHealth(BaseModel):
    """An agent's counters, published periodically."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    schema_version: Literal[1] = SCHEMA_VERSION
    agent_id: str
    uptime_s: float
    agents_alive: list[str]
    loops_seen: int
    loops_owned: int
    samples: int = Field(
        description="samples taken into windows, live or from a publisher's history (a live repeat of a sample the "
        "history brought is refused as a duplicate, not counted twice)"
    )
    reports: int
    rejected: dict[str, int] = Field(description="rejected messages by reason")
    latency_p50_s: float | None = Field(description="from a window's last sample arriving to its report")
    latency_p99_s: float | None
    pending_loops: int
    samples_per_s: float | None = Field(None, description="samples ingested per second since the last health message")
    reports_per_s: float | None = Field(None, description="reports published per second since the last health message")
    gaps_filled: int = Field(0, description="short gaps in loops' streams filled by interpolation")
    samples_filled: int = Field(0, description="samples interpolated across those gaps")
    readings_deferred: int = Field(
        0,
        description="reports of sticky loops whose friction reading was put off to a coming report (the agent "
        "rations readings while it catches up: a cold start of many loops, a take-over)",
    )
    loops_sized: int = Field(
        0, description="background sizings done: sticky loops of unknown process identified and S, J read under it"
    )
    loops_fitted: int = Field(
        0,
        description="background fits done: sticky level loops whose slips PV's noise hides, the valve fitted to "
        "the window (accepted or not), and trusted slip readings checked against the window (a fit where the "
        "record does not bear the reading out)",
    )
    messages_received: int = Field(
        0, description="sample messages received (of every loop on the keys this agent subscribes to, held or not)"
    )
    shards_owned: int = Field(0, description="shards of the sharded sample keys this agent owns and subscribes to")
    windows_from_history: int = Field(
        0, description="loop windows rebuilt from a publisher's history (shards taken on after a join or a death)"
    )
    cpu_s: dict[str, float] = Field(
        default_factory=dict,
        description="CPU seconds since the start by stage: ingest, verdict, readings, report, publish (the worker "
        "thread) and zenoh_and_callbacks (the rest of the process)",
    )


class BridgeHealth(BaseModel):
    """A bridge's counters (OPC UA or replay), published periodically on ``{prefix}/bridge/{id}/health``."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    schema_version: Literal[1] = SCHEMA_VERSION
    bridge_id: str
    source: str = Field(description="the OPC UA endpoint, or the replayed paths")
    connected: bool
    uptime_s: float
    loops: int = Field(description="loops in the loop file")
    loops_publishing: int = Field(description="loops whose samples went out in the last interval")
    samples_published: int
    dropped: dict[str, int] = Field(description="values dropped by reason (bad_status, not_finite, out_of_order, ...)")
    reconnects: int
    loops_missing: dict[str, str] = Field(description="loops that cannot be read, and why (a node the server lacks)")
