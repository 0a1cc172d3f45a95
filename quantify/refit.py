"""The fitted reading (``ident.open_loop``) of a window the agent reported without it, made on a worker process.

The agent's reports cannot wait the seconds a fit takes (``agent.service.FIT_VALVE``): a noisy level loop's report
goes out at once with the reading it has and ``UNFITTED_WARNING``, and the same window is quantified again here as
``stiction quantify`` does it, the valve fitted.  Where the fit is accepted the agent carries its reading in the
loop's next reports (``agent.core.AgentCore.adopt``); where it is not, the report already said all there was.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from stiction.quantify.pipeline import FITTED_WARNING, Quantifier
from stiction.quantify.window import Reading, Window
from stiction.schemas.report import StictionReport

_QUANTIFIERS: dict[tuple, Quantifier] = {}
"""A worker's quantifier, loaded at its first fit (its models: a second or two)."""


def worker_window(w: Window) -> Window:
    """``w`` as a worker is sent it: its arrays copied (an agent's window is a view of its rolling buffer, which the
    pool pickles later), and read afresh (no carried reading, none put off)."""

    def copy(x):
        return None if x is None else np.array(x)

    return replace(w, op=copy(w.op), pv=copy(w.pv), sp=copy(w.sp), mv=copy(w.mv), carry=None, defer_reading=False)


def fit_in_worker(w: Window, models_dir: Path | None = None, sequence_chunks: int = 1
                  ) -> tuple[Reading, StictionReport] | None:  # fmt: skip
    """The window's fitted reading and its report's draft, or None where the fit was not accepted (or the window
    not called sticky).  ``models_dir`` and ``sequence_chunks`` as the agent's own quantifier has them, so that
    the verdict is the one the agent reported."""
    key = (models_dir, sequence_chunks)
    quantifier = _QUANTIFIERS.get(key)
    if quantifier is None:
        quantifier = _QUANTIFIERS[key] = Quantifier(models_dir, sequence_chunks=sequence_chunks, fit_valve=True)
    result = quantifier.results([w])[0]
    if result.reading is None or FITTED_WARNING not in result.reading.warnings:
        return None
    return result.reading, result.draft
