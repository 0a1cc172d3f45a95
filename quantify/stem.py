"""The measured stem in a report: where an export records the valve's position (``mv``), the valve is read from it.

OP and PV tell a sticky valve from a healthy one only through the loop: a load, the tuning and the process stand
between the stem and PV.  A positioner's travel feedback records the stem itself, and ``ident.valve_check`` fits it
against OP with a linear valve and two sticky ones.  Where the stem sticks (a band S surely above zero and at least
``ident.valve_check.MIN_BAND_PCT``), the report's verdict is ``stiction`` and S and J are read from the stem
(``method: "stem"``) whatever OP and PV alone said; where it follows OP, the verdict stands on OP and PV and a warning
says what the stem showed (a column named ``mv`` may hold a positioner's demand, which is OP again: the stem's word
against the loop's is then the engineer's to weigh).
"""

from __future__ import annotations

import numpy as np

from stiction.ident.valve_check import ValveCheck, check_valve

SAME_AS_OP_REL = 1e-6
"""An ``mv`` within this share of OP's range of OP at every sample is OP written twice, not a measured stem."""


def stem_check(op: np.ndarray, mv: np.ndarray | None, ts_s: float) -> tuple[ValveCheck | None, str | None]:
    """The valve check of a window's measured stem, or None and why it is not read (None, None: no stem recorded)."""
    if mv is None:
        return None, None
    op, mv = np.asarray(op, float), np.asarray(mv, float)
    if mv.size != op.size or mv.size < 20:
        return None, f"the mv column has {mv.size} samples where OP has {op.size}: the stem is not read"
    tolerance = SAME_AS_OP_REL * max(float(np.ptp(op)), 1e-12)
    if np.ptp(mv) <= tolerance:
        return None, (
            f"the mv column does not move (constant at {mv[0]:.4g}) while OP moves {np.ptp(op):.3g} %: a stem that "
            "never moved, or a position not recorded; the valve is read from OP and PV alone"
        )
    if np.all(np.abs(mv - op) <= tolerance):
        return None, "the mv column repeats OP: it is no measured stem position, and is not read as one"
    return check_valve(op, mv, ts_s), None
