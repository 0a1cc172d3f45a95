"""Where the measured data lie beside a checkout (``../shared/data``); tests that read them skip where they do not."""

from pathlib import Path

SHARED_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
PLANT = SHARED_DATA / "stictiongpt_plant" / "csv"
"""The StictionGPT plant's labelled windows."""
