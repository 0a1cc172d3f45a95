"""The suite's order: the files that hold a test marked ``slow`` (half a minute or more on the slowest two-core
machine here, a minute or more with a bench beside it) run first.

``bash scripts/test`` runs two workers that take a file at a time (``--dist loadfile``), in this order
(``--no-loadscope-reorder``; pytest-xdist's own order puts the files with most tests first, which left the two one-
and two-minute tests of the independent simulator's diagnosis to the end, on one worker, while the other sat idle).
Long files first, the short ones fill in behind them on whichever worker is free."""

from __future__ import annotations


def pytest_collection_modifyitems(items) -> None:
    slow_files = {item.path for item in items if item.get_closest_marker("slow") is not None}
    items.sort(key=lambda item: item.path not in slow_files)  # stable: each file's own order is kept
