"""The machine a benchmark ran on, in every benchmark's figures (machines of one kind differ up to 2x)."""

from __future__ import annotations

import os
import platform
from pathlib import Path


def machine() -> dict:
    return {
        "python": platform.python_version(),
        "cpus": os.cpu_count(),
        "cpu": cpu_model(),
        "machine": platform.machine(),
    }


def cpu_model() -> str:
    """The CPU's model name, with its family and model numbers."""
    try:
        lines = Path("/proc/cpuinfo").read_text().splitlines()
    except OSError:
        return platform.processor() or "unknown"
    info = dict(line.split(":", 1) for line in lines if ":" in line)
    name = {k.strip(): v.strip() for k, v in info.items()}
    return f"{name.get('model name', 'unknown')} (family {name.get('cpu family', '?')} model {name.get('model', '?')})"
