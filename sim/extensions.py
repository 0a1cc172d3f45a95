"""Extensions of the canonical loop: the causes of ``stiction diagnose`` (spec/interfaces.md).

Each is one named parameter on top of the canonical loop; the defaults switch
every one off, so ``Extensions()`` is the canonical loop of spec/thesis-loop.md.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields

import numpy as np

CATALOGUE: dict[str, tuple[str, ...]] = {
    "none": (),
    "dead_time": ("dead_time_s",),
    "deadband": ("deadband_pct",),
    "actuator_lag": ("actuator_tau_s",),
    "sensor_lag": ("sensor_tau_s",),
    "quantization": ("quantum_pct",),
    "process_gain": ("gain_ratio",),
    "external_oscillation": ("osc_period_s", "osc_amplitude_pct"),
    "process_type": ("time_constant_s",),
}
"""Cause name -> its parameters, as named in the diagnose catalogue."""
OSC_SHAPES = ("sine", "square", "triangle")
OSC_FILTER_SHARE = 0.1
"""A square or triangle load passes a first-order lag of this share of its period (as
``sim.two_parameter``'s square load does): an upstream loop's cycle smoothed by the line between."""


@dataclass(frozen=True)
class Extensions:
    dead_time_s: float = 0.0
    """Transport delay between the valve's flow and the process."""
    deadband_pct: float = 0.0
    """Backlash (full width, % of OP) between OP and the actuator's drive."""
    actuator_tau_s: float = 0.0
    """First-order lag between OP and the drive of the valve."""
    sensor_tau_s: float = 0.0
    """First-order filter on the PV measurement."""
    quantum_pct: float = 0.0
    """Step in which the historian stores PV and OP (the loop itself is unaffected)."""
    gain_ratio: float = 1.0
    """Process gain over its nominal value."""
    osc_period_s: float = 0.0
    osc_amplitude_pct: float = 0.0
    """An external oscillating load on the process input, percent of span (its peak)."""
    osc_shape: str = "sine"
    """That load's shape (``OSC_SHAPES``): a sine, or a square or triangle wave through a first-order lag of
    ``OSC_FILTER_SHARE`` of its period, the cycle an upstream loop's sticky valve sends down the line.  The
    diagnose catalogue fits the sine; the shape is the simulator's, for the look-alikes a detector must
    leave alone."""
    time_constant_s: float | None = None
    """Self-regulating process of this time constant in place of the integrating one."""

    def __post_init__(self):
        if self.osc_shape not in OSC_SHAPES:
            raise ValueError(f"extension osc_shape {self.osc_shape!r}: one of {', '.join(OSC_SHAPES)}")
        for f in fields(self):
            value = getattr(self, f.name)
            if value is None or f.name == "osc_shape":
                continue
            if not np.isfinite(value):
                raise ValueError(f"extension {f.name} must be finite, got {value}")
            lower_ok = value > 0 if f.name in ("gain_ratio", "time_constant_s") else value >= 0
            if not lower_ok:
                raise ValueError(f"extension {f.name} out of range: {value}")
        if (self.osc_period_s > 0) != (self.osc_amplitude_pct > 0):
            raise ValueError("external oscillation needs both osc_period_s and osc_amplitude_pct > 0")
        if self.osc_shape != "sine" and self.osc_period_s == 0:
            raise ValueError(f"extension osc_shape {self.osc_shape!r} needs an external oscillation (osc_period_s)")

    def active(self) -> dict[str, float | str]:
        """The parameters that differ from the canonical loop."""
        default = Extensions()
        return {k: v for k, v in asdict(self).items() if v != getattr(default, k)}

    def causes(self) -> list[str]:
        active = self.active()
        return [cause for cause, params in CATALOGUE.items() if params and any(p in active for p in params)]


def backlash(drive_pct: np.ndarray, out_pct: np.ndarray, width_pct: np.ndarray) -> np.ndarray:
    """Play of total width ``width_pct``: the output follows only once the input has taken it up."""
    half = width_pct / 2
    return np.clip(out_pct, drive_pct - half, drive_pct + half)
