"""Read a loop file (TOML, or YAML where PyYAML is installed) into a validated ``LoopFile``."""

from __future__ import annotations

import tomllib
from pathlib import Path

from pydantic import ValidationError

from stiction.schemas.errors import InputError
from stiction.schemas.loop_file import LoopFile


def load(path: Path | str) -> LoopFile:
    """The loop file at ``path``; anything wrong is one ``InputError`` naming the file and the field."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise InputError(f"{path}: cannot read the loop file ({e.__class__.__name__}: {e})") from None
    return parse(text, path.suffix.lower(), str(path))


def parse(text: str, suffix: str, name: str = "loop file") -> LoopFile:
    if suffix in (".yaml", ".yml"):
        try:
            import yaml
        except ImportError:
            raise InputError(f"{name}: YAML loop files need PyYAML (pip install pyyaml), or write it as TOML") from None
        try:
            data = yaml.safe_load(text)
        except yaml.YAMLError as e:
            raise InputError(f"{name}: not valid YAML ({str(e).splitlines()[0]})") from None
    else:
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as e:
            raise InputError(f"{name}: not valid TOML ({e})") from None
    if not isinstance(data, dict):
        raise InputError(f"{name}: expected a table with 'loops', got {type(data).__name__}")
    try:
        return LoopFile.model_validate(data)
    except ValidationError as e:
        first = e.errors()[0]
        where = ".".join(str(p) for p in first["loc"]) or "the file"
        shown = repr(first["input"])
        value = f" (got {shown})" if first["type"] not in ("missing", "extra_forbidden") and len(shown) <= 80 else ""
        more = f"; {e.error_count() - 1} more problem(s)" if e.error_count() > 1 else ""
        msg = first["msg"].replace(
            "String should match pattern", "expected an OPC UA node id like 'ns=2;s=Tag.PV', pattern"
        )
        raise InputError(f"{name}: {where}: {msg}{value}{more}") from None


def dumps(loop_file: LoopFile) -> str:
    """The loop file as TOML (what ``stiction plant`` writes for the bridge)."""
    out = [f"sample_time_s = {loop_file.sample_time_s!r}"]
    if loop_file.server is not None:
        out.append("\n[server]")
        out += [f"{k} = {_toml(v)}" for k, v in loop_file.server.model_dump(exclude_none=True).items()]
    for loop_id, nodes in loop_file.loops.items():
        out.append(f'\n[loops."{loop_id}"]')
        out += [f"{k} = {_toml(v)}" for k, v in nodes.model_dump(exclude_none=True).items()]
    return "\n".join(out) + "\n"


def _toml(value) -> str:
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    return repr(value)
