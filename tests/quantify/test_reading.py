"""A friction reading held between an agent's reports: packed, and unpacked to what the report needs."""

import math
import tracemalloc

from stiction.quantify.window import Reading
from stiction.schemas.report import Estimate


def _fields(fs: float) -> dict:
    return {
        "fs_pct": fs,
        "fd_pct": 3.25,
        "s_se_pct": None,
        "stiction_kind": "stick_slip",
        "denoised": True,
        "method": "learned",
        "thesis": Estimate(fs_pct=fs + 1.0, fd_pct=2.0, fs_se_pct=None, fd_se_pct=None),
        "physical": None,
        "learned": Estimate(fs_pct=fs, fd_pct=3.25, fs_se_pct=0.5, fd_se_pct=0.75),
        "estimate_t_end_s": 1000.0,
    }


def test_a_reading_gives_back_every_field_as_the_report_validates_it():
    fields = _fields(12.5)
    reading = Reading(fields, ("a warning",), 1000.0)
    back = reading.fields
    assert list(back) == list(fields)
    for key, value in fields.items():
        expected = value.model_dump() if isinstance(value, Estimate) else value
        assert back[key] == expected, key
    assert Estimate.model_validate(back["thesis"]) == fields["thesis"]
    assert reading.warnings == ("a warning",) and reading.t_end_s == 1000.0
    assert reading == Reading(_fields(12.5), ("a warning",), 1000.0) != Reading(_fields(12.6), ("a warning",), 1000.0)
    assert math.isnan(Reading({"fs_pct": math.nan}).fields["fs_pct"])  # a number stays a number


def test_thousands_of_readings_hold_a_few_hundred_bytes_each():
    """An agent keeps one for each loop it calls sticky: 20,000 of them were 41 MB as dicts of the report's
    values."""
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        kept = [Reading(_fields(float(i)), (), float(i)) for i in range(2000)]
        per_reading = (tracemalloc.get_traced_memory()[0] - before) / len(kept)
    finally:
        tracemalloc.stop()
    assert per_reading < 600, per_reading


def test_a_reading_sent_from_a_worker_process_comes_back_equal_and_shares_its_layout_again():
    import pickle

    reading = Reading(_fields(12.5), ("fitted",), 1000.0)
    back = pickle.loads(pickle.dumps(reading))
    assert back == reading and back.fields == reading.fields and back.warnings == ("fitted",)
    assert back._layout is reading._layout  # one layout for thousands of readings, not one each
