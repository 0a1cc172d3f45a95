"""Historian exports: aliases, overrides, and every bad input named by file, row and column."""

import numpy as np
import pytest

from stiction.bridge import historian
from stiction.bridge.historian import read_export, read_windows
from stiction.schemas.errors import InputError
from tests.measured import PLANT


def _write(tmp_path, text, name="x.csv"):
    p = tmp_path / name
    p.write_text(text)
    return p


def _rows(n=12, ts=1.0):
    return "".join(f"{k * ts:g},{np.sin(k):.4f},{np.cos(k):.4f}\n" for k in range(n))


def test_aliases_and_sample_time_from_the_time_column(tmp_path):
    e = read_export(_write(tmp_path, "Time,OP,PV\n" + _rows(ts=10.0)))
    assert e.ts_s == 10.0 and e.op.size == 12 and e.sp is None


def test_column_overrides_and_ts_flag_without_time(tmp_path):
    text = "out_a,meas_b\n" + "".join(f"{k},{k * 2}\n" for k in range(5))
    e = read_export(_write(tmp_path, text), ts_s=5.0, columns={"op": "out_a", "pv": "meas_b"})
    assert e.ts_s == 5.0 and e.pv[2] == 4.0 and e.t_s[-1] == 20.0


def test_iso_timestamps(tmp_path):
    text = "timestamp,op,pv\n" + "".join(f"2026-01-01T00:00:{k:02d},{k},{k}\n" for k in range(0, 30, 2))
    assert read_export(_write(tmp_path, text)).ts_s == 2.0


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("t,pv\n0,1\n", "no op column"),
        ("", "empty file"),
        ("t,op,pv\n", "header only"),
        ("t,op,pv\n0,1,2\n1,abc,2\n", r"row 3, column 'op': 'abc' is not a number"),
        ("t,op,pv\n0,1,2\n1,nan,2\n", r"row 3, column 'op': 'nan', expected a finite number"),
        ("t,op,pv\n0,1,2\n1,1\n", "row 3 has 2 fields"),
        ("t,op,pv\n" + _rows(5) + "3,1,1\n", "row 7: time 3 goes back"),
        ("t,op,pv\n0,1,1\n1,1,1\n1,1,1\n2,1,1\n", "row 4: time 1 repeats"),
        # a calendar time is said as the file wrote it, not as seconds since 1970
        ("timestamp,op,pv\n" + "".join(f"2026-01-01T00:00:{k:02d},1,1\n" for k in (0, 1, 1, 2)),
         r"row 4: time 2026-01-01T00:00:01 repeats the row before \(2026-01-01T00:00:01\)"),
        # steps off the sample time now and then are gaps (read past: below); this often, uneven sampling
        ("t,op,pv\n" + _rows(12) + "30,1,1\n40,1,1\n", r"row 14: time step 19 s .* \(2 such steps\)"),
    ],
)
def test_bad_exports_name_what_was_wrong(tmp_path, text, message):
    with pytest.raises(InputError, match=message):
        read_export(_write(tmp_path, text))


def test_missing_override_column_and_missing_file(tmp_path):
    with pytest.raises(InputError, match="no column 'valve_out' for op"):
        read_export(_write(tmp_path, "t,op,pv\n" + _rows()), columns={"op": "valve_out"})
    with pytest.raises(InputError, match="no such file"):
        read_export(tmp_path / "nope.csv")


def test_huge_file_is_refused_before_reading(tmp_path, monkeypatch):
    monkeypatch.setattr(historian, "MAX_BYTES", 100)
    with pytest.raises(InputError, match="more than the 100"):
        read_export(_write(tmp_path, "t,op,pv\n" + _rows(50)))


def test_binary_file_is_refused(tmp_path):
    p = tmp_path / "b.csv"
    p.write_bytes(b"t,op,pv\n\xff\xfe\x00\x01")
    with pytest.raises(InputError, match="not a text CSV"):
        read_export(p)


def test_isolated_rounded_timestamps_are_read_as_evenly_sampled(tmp_path):
    t = np.arange(100) * 10.0
    t[[20, 41]] = t[[19, 40]]  # stamped with the predecessor's time, then a double step
    t[0] = -10.0  # and a first row one step early
    text = "t_s,op,pv\n" + "".join(f"{a:g},{k},{k}\n" for k, a in enumerate(t))
    e = read_export(_write(tmp_path, text))
    np.testing.assert_array_equal(e.t_s, np.arange(100) * 10.0)
    assert any("3 timestamps" in w for w in e.warnings)


def test_op_outside_percent_warns(tmp_path):
    text = "t,op,pv\n" + "".join(f"{k},{2000 + 300 * np.sin(k):.1f},1\n" for k in range(12))
    assert any("outside 0-100" in w for w in read_export(_write(tmp_path, text)).warnings)


def test_pv_in_engineering_units_warns_and_pv_in_percent_does_not(tmp_path):
    def warnings(pv_of):
        text = "t,op,pv\n" + "".join(f"{k},{50 + 3 * np.sin(k):.2f},{pv_of(k):.2f}\n" for k in range(12))
        return [w for w in read_export(_write(tmp_path, text)).warnings if w.startswith("pv runs")]

    assert warnings(lambda k: 48000 + 500 * np.sin(k / 3)), "a flow of 48,000 kg/h read as percent without a word"
    assert not warnings(lambda k: 48 + 5 * np.sin(k / 3))


def test_fraction_op_and_mode_changes_warn(tmp_path):
    text = "t,op,pv,mode\n" + "".join(f"{k},{0.5 + 0.1 * np.sin(k):.3f},1,{int(k > 5)}\n" for k in range(12))
    warnings = " ".join(read_export(_write(tmp_path, text)).warnings)
    assert "fraction" in warnings and "manual" in warnings


@pytest.mark.skipif(not PLANT.is_dir(), reason="shared/data not beside the checkout")
def test_every_measured_plant_loop_reads_as_it_is():
    files = sorted(PLANT.glob("*.csv"))
    assert len(files) == 60
    for f in files:
        e = read_export(f)
        assert e.op.size >= 100 and e.ts_s in (10.0, 60.0), f


def _big(path, n):
    t = np.arange(n) * 1.0
    np.savetxt(path, np.c_[t, np.sin(t / 50), np.cos(t / 50)], fmt="%.4f", delimiter=",", header="t,op,pv", comments="")
    return path


def test_memory_follows_the_window_not_the_file(tmp_path, monkeypatch):
    import tracemalloc

    monkeypatch.setattr(historian, "BLOCK_ROWS", 20_000)
    peaks = []
    for n in (60_000, 240_000):
        path = _big(tmp_path / f"big{n}.csv", n)
        tracemalloc.start()
        e = read_export(path, last=500)
        peaks.append(tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()
        assert e.op.size == 500 and e.first_row == n - 500 + 2 and e.t_s[-1] == n - 1
        assert any(f"rows {n - 498}-{n + 1} of the file analysed (500 of {n} samples)" in w for w in e.warnings)
    assert peaks[1] < 1.3 * peaks[0], peaks  # four times the file, about the same memory


def test_windows_are_slices_of_the_whole_file(tmp_path, monkeypatch):
    monkeypatch.setattr(historian, "BLOCK_ROWS", 333)  # windows straddle blocks
    path = _big(tmp_path / "w.csv", 2000)
    whole = read_export(path)
    windows = list(historian.read_windows(path, length=700, every=450))
    assert [w.first_row for w in windows] == [2, 452, 902, 1302]
    for w in windows:
        k = w.first_row - 2
        np.testing.assert_array_equal(w.op, whole.op[k : k + 700])
        np.testing.assert_array_equal(w.t_s, whole.t_s[k : k + 700])
    short = list(historian.read_windows(path, length=5000, every=100))
    assert len(short) == 1 and short[0].op.size == 2000


@pytest.mark.parametrize(
    ("text", "encoding"),
    [
        ("Zeit;OP;PV\n" + "".join(f"{k};{k},5;{2 * k},25\n" for k in range(12)), "utf-8"),
        ("t\top\tpv\n" + "".join(f"{k}\t{k}.5\t{2 * k}.25\n" for k in range(12)), "utf-8"),
        ("t|op|pv\n" + "".join(f"{k}|{k}.5|{2 * k}.25\n" for k in range(12)), "utf-8"),
        ("t;op;pv;unit\n" + "".join(f"{k};{k},5;{2 * k},25;°C\n" for k in range(12)), "cp1252"),
    ],
    ids=["semicolon-decimal-comma", "tab", "pipe", "windows-1252"],
)
def test_separators_and_decimal_marks_are_read_from_the_content(tmp_path, text, encoding):
    p = tmp_path / "x.csv"
    p.write_bytes(text.encode(encoding))
    e = read_export(p, ts_s=1.0, columns={"t": "Zeit"} if text.startswith("Zeit") else None)
    np.testing.assert_allclose(e.op, np.arange(12) + 0.5)
    np.testing.assert_allclose(e.pv, 2 * np.arange(12) + 0.25)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("t op pv\n0 1 2\n", "one column: expected columns separated by"),
        ("0,1,2\n1,1,2\n", "the first row '0,1,2' is numbers: expected a header row"),
        ("t,op,pv\n0,1,2\n1,,2\n", r"row 3, column 'op': '' is an empty field"),
        ("t,op,pv\n0,1,2\n1,1,1e300\n", r"row 3, column 'pv': '1e300' is no percent of span"),
        ("t,op,pv\nyesterday,1,2\n", r"row 2, column 't': 'yesterday' is neither seconds nor an ISO 8601 time"),
    ],
)
def test_unreadable_layouts_are_named(tmp_path, text, message):
    with pytest.raises(InputError, match=message):
        read_export(_write(tmp_path, text))


def test_blank_lines_are_skipped_and_rows_still_counted(tmp_path):
    text = "t,op,pv\n0,1,2\n\n1,1,2\n2,x,2\n"
    with pytest.raises(InputError, match="row 5, column 'op'"):
        read_export(_write(tmp_path, text))
    assert read_export(_write(tmp_path, "t,op,pv\n0,1,2\n1,1,2\n\n")).op.size == 2


def test_rows_of_separators_alone_are_skipped_as_blank_lines_are(tmp_path):
    """Spreadsheets end an export with rows of separators (``,,``): no samples, not a bad cell."""
    assert read_export(_write(tmp_path, "t,op,pv\n0,1,2\n1,1,2\n,,\n ,\t, \n")).op.size == 2
    with pytest.raises(InputError, match="row 5, column 'op'"):  # the file's rows still counted across them
        read_export(_write(tmp_path, "t,op,pv\n0,1,2\n,,\n1,1,2\n2,x,2\n"))
    with pytest.raises(InputError, match="row 3, column 'pv'"):  # a row with some values is a row, its empty cell named
        read_export(_write(tmp_path, "t,op,pv\n0,1,2\n1,1,\n"))


def test_a_mode_column_in_words_is_read_and_an_open_loop_stretch_named(tmp_path):
    """Control systems write the mode as a word (AUTO, MAN, CAS, ...): read, the samples in an open loop counted."""
    words = ["AUTO"] * 100 + ["man"] * 30 + ["Cas"] * 70
    rows = "".join(f"{k},{50 + np.sin(k):.3f},{40 + np.cos(k):.3f},{w}\n" for k, w in enumerate(words))
    text = "t,op,pv,mode\n" + rows
    e = read_export(_write(tmp_path, text))
    assert e.mode.tolist() == [1.0] * 100 + [0.0] * 30 + [1.0] * 70
    said = [w for w in e.warnings if "mode column" in w]
    assert len(said) == 1 and "(MAN) on 30 of the 200 samples" in said[0]
    closed = "t,op,pv,mode\n" + "".join(f"{k},{50 + np.sin(k):.3f},1,AUTO\n" for k in range(200))
    assert not [w for w in read_export(_write(tmp_path, closed)).warnings if "mode" in w]
    pa = pytest.importorskip("pyarrow")
    import pyarrow.parquet as pq

    pq.write_table(pa.table({"t": np.arange(200.0), "op": np.sin(np.arange(200.0)), "pv": np.ones(200), "mode": words}),
                   tmp_path / "modes.parquet")  # fmt: skip
    assert read_export(tmp_path / "modes.parquet").mode.tolist() == e.mode.tolist()
    bad = text.replace("Cas", "BOGUS", 1)
    with pytest.raises(InputError, match=r"row 132, column 'mode': 'BOGUS' is no controller mode"):
        read_export(_write(tmp_path, bad))


def test_parquet_is_read_by_content_whatever_its_name(tmp_path):
    pa = pytest.importorskip("pyarrow")
    import pyarrow.parquet as pq

    table = pa.table({"t": np.arange(150.0) * 2, "OP": np.sin(np.arange(150.0)), "PV": np.cos(np.arange(150.0))})
    pq.write_table(table, tmp_path / "export.dat")
    e = read_export(tmp_path / "export.dat")
    assert e.ts_s == 2.0 and e.op.size == 150 and e.pv[0] == 1.0


def _export_at(tmp_path, times, name):
    rows = "".join(f"{k},{50 + np.sin(k / 30):.4f},{40 + np.cos(k / 30):.4f}\n" for k in times)
    return _write(tmp_path, "t,op,pv\n" + rows, name)


def test_a_gap_in_a_long_export_leaves_the_stretch_after_it_read_and_says_so(tmp_path):
    """A historian's outage in an hour's export.  A long one (more than a tenth of the window) cuts it: the samples
    after it are read, and the warnings say where it was; asked for samples that all lie after it, nothing is cut.  A
    short one is filled in by linear interpolation, as the agent bridges a short gap in a stream."""
    path = _export_at(tmp_path, [k for k in range(3600) if not 1000 <= k < 1500], "x.csv")
    export = read_export(path)
    assert export.op.size == 2100 and export.t_s[0] == 1500 and export.first_row == 1002 and export.interpolated == 0
    (note,) = [w for w in export.warnings if "gap" in w]
    assert "row 1002" in note and "501 s" in note and "only the 2100 samples after the last long gap" in note
    # short gaps: filled, the even grid restored, the samples counted, the rows said as the file's
    short = _export_at(tmp_path, [k for k in range(3600) if k not in (700, 1800, 1801, 2900)], "short.csv")
    filled = read_export(short)
    assert filled.op.size == 3600 and filled.interpolated == 4 and np.all(np.diff(filled.t_s) == 1)
    assert filled.op[700] == pytest.approx(0.5 * (filled.op[699] + filled.op[701])) and filled.last_row == 3597
    assert any("4 samples filled in by linear interpolation across 3 short gaps" in w for w in filled.warnings)
    # a long gap late in the window leaves little after it: the longer stretch before it is read
    late = read_export(_export_at(tmp_path, [k for k in range(3600) if not 3100 <= k < 3500], "late.csv"))
    assert late.t_s[0] == 0 and late.t_s[-1] == 3099 and late.op.size == 3100
    assert any("longest stretch between long gaps (after the last, only 100)" in w for w in late.warnings)
    later = read_export(path, last=2000)
    assert later.op.size == 2000 and any("before the samples read" in w for w in later.warnings)
    # windows every N samples never span a gap: they start afresh after it, the first saying so
    once = _export_at(tmp_path, [k for k in range(3600) if not 1000 <= k < 1020], "once.csv")
    windows = list(read_windows(once, 600, 300))
    ends = [w.t_s[-1] for w in windows]
    assert ends == [599, 899, 1619, 1919, 2219, 2519, 2819, 3119, 3419, 3599]
    assert all(np.all(np.diff(w.t_s) == 1) for w in windows)
    assert [any("start afresh" in n for n in w.warnings) for w in windows] == [False] * 2 + [True] + [False] * 7
    # a time column off its sample time at every few samples is uneven sampling, refused either way
    uneven = _write(tmp_path, "t,op,pv\n" + "".join(f"{k + (k // 10) * 0.5},1,{k % 7}\n" for k in range(400)),
                    "uneven.csv")  # fmt: skip
    for read in (lambda: read_export(uneven), lambda: list(read_windows(uneven, 100, 50))):
        with pytest.raises(InputError, match="such steps"):
            read()


def test_the_reader_forgets_the_gaps_no_window_holds_and_still_counts_them(tmp_path):
    # gaps every 150 rows (under a hundredth: read past); the reader keeps only those the last window may hold, so
    # a file of millions of rows with a gap every few holds no list as long as the file, and the note counts them all
    times = [k for k in range(30000) if k % 150 != 75]
    path = _export_at(tmp_path, times, "many.csv")
    reader, tail = historian._Reader(path, None, None), historian._Tail(600)
    reader.gaps_allowed = True
    for block in reader.blocks():
        tail.add(block)
        reader.forget_gaps(tail.seen - 600)
    assert reader.gap_count == 200 and len(reader.gaps) <= 5
    export = read_export(path, last=600)
    assert export.gap_note.startswith("200 gaps in the time column") and export.warnings[0] == export.gap_note
    assert export.interpolated == 4 and np.all(np.diff(export.t_s) == 1)
