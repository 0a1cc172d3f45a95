"""The bridge's loop file: which OPC UA nodes are each loop's OP, PV, SP, MV and mode.

TOML (or YAML) on disk, validated by ``LoopFile``; its JSON Schema is exported beside the
messages (``schemas/json/loop_file.schema.json``) for tools that write loop files.

    sample_time_s = 1.0
    [server]
    endpoint = "opc.tcp://plant:4840"
    [loops.FIC101]
    op = "ns=2;s=FIC101.OP"
    pv = "ns=2;s=FIC101.PV"
    sp = "ns=2;s=FIC101.SP"
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator

from stiction.schemas import keys

NODE_ID = r"^(ns=\d+;|nsu=[^;]+;)?[isgb]=.+$"
"""An OPC UA node id in its string form: ``ns=2;s=Tag.PV``, ``ns=3;i=1042``, ``i=2258``."""
ROLES = ("op", "pv", "sp", "mv", "mode")


class LoopNodes(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")

    op: str = Field(pattern=NODE_ID, description="controller output, percent")
    pv: str = Field(pattern=NODE_ID, description="process value, percent of span")
    sp: str | None = Field(None, pattern=NODE_ID)
    mv: str | None = Field(None, pattern=NODE_ID, description="valve position, where measured")
    mode: str | None = Field(None, pattern=NODE_ID, description="controller mode (1 auto, 0 manual)")
    process: Literal["level"] | None = Field(None, description="'level' for the canonical level loop")

    def nodes(self) -> dict[str, str]:
        return {role: n for role in ROLES if (n := getattr(self, role)) is not None}


class OpcuaServer(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")

    endpoint: str = Field(pattern=r"^opc\.tcp://.+", description="e.g. opc.tcp://plant:4840")
    security: str | None = Field(
        None,
        description="'Policy,Mode,certificate,private_key', e.g. 'Basic256Sha256,SignAndEncrypt,cert.der,key.pem'",
    )
    user: str | None = None
    password_env: str | None = Field(
        None, description="the environment variable holding the password (passwords never sit in the file)"
    )


class LoopFile(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")

    sample_time_s: float = Field(1.0, gt=0, le=3600, description="the grid the bridge samples every loop on")
    server: OpcuaServer | None = None
    loops: dict[str, LoopNodes] = Field(min_length=1)

    @field_validator("loops")
    @classmethod
    def _ids_are_key_chunks(cls, loops: dict[str, LoopNodes]) -> dict[str, LoopNodes]:
        for loop_id in loops:
            keys.check_id(loop_id)
        return loops
