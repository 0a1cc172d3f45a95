"""``stiction bench detect`` end to end on a small set: every figure it prints is there and is a share."""

import numpy as np
import pytest

from stiction.bench.detect import METHODS, bench_detect, print_table
from stiction.sim.plant_families import FAMILIES, FAULTS
from stiction.trainer.window_net import WindowNetSettings


def test_bench_detect_reports_held_out_families_and_measured_tags_beside_the_published_tests(capsys, plant_dir):
    tiny = WindowNetSettings(seeds=1, n_per_cause=1, members=1, epochs=1)
    fig = bench_detect([plant_dir], n_per_class=1, seed=2026, train_per_class=2, window_net=tiny, windows=True,
                       start="operating_point", train_start="both")  # fmt: skip
    assert fig["window_net"]["windows"] > 0 and (fig["start"], fig["train_start"]) == ("operating_point", "both")
    assert set(fig["families"]) == set(FAMILIES) and fig["bands"] == "plant"
    for row in fig["families"].values():
        for m in METHODS:
            assert 0.0 <= row[m]["specificity"] <= 1.0 and 0.0 <= row[m]["balanced"] <= 1.0
        assert 0.0 <= row["cannot_tell"] <= 1.0 and 0 <= row["show_fault"] <= row["n"]
    shown = [r for r in fig["by_band"].values() if r["show_fault"]]
    faults = sum(r["show_fault"] for r in fig["families"].values())
    assert sum(r["show_fault"] for r in fig["by_band"].values()) == faults
    assert sum(r["show_fault"] for r in fig["by_slip_noise"].values()) == faults
    assert shown and all(0.0 <= r["called"] <= 1.0 for r in shown)
    # every window that shows a fault had its stem slip; some that slipped the noise hid
    slipped = sum(r["show_fault"] for r in fig["by_effect_noise"].values())
    assert slipped >= faults and fig["by_effect_noise"]["0-1"]["show_fault"] == slipped - faults
    assert all(0.0 <= r["ours_stem_slipped"]["balanced"] <= 1.0 for r in fig["families"].values())
    m = fig["measured"]
    assert m["windows"] == 60 and m["sticky"] == 27
    for key in METHODS:
        assert all(0.0 <= m[key][k] <= 1.0 for k in ("accuracy", "sensitivity", "specificity"))
    assert 0 <= m["near_threshold"] <= m["windows"]
    assert set(fig["two_parameter"]) == {"flow", "level"}  # another simulator, held out from training
    for row in fig["two_parameter"].values():
        assert 0 <= row["show_fault"] <= row["n"] and all(0.0 <= row[k]["specificity"] <= 1.0 for k in METHODS)
    # each window's figures (--windows): the family windows, the other simulator's and the measured ones, whose
    # probabilities give back the rates above
    assert len(fig["windows"]) == sum(r["n"] for r in fig["families"].values())
    assert len(fig["two_parameter_windows"]) == sum(r["n"] for r in fig["two_parameter"].values())
    # where the windows that show a fault go, from the windows: the four shares of each family's faults
    for f, row in fig["families"].items():
        faults = [w for w in fig["windows"] if w["family"] == f and w["shows_fault"]]
        o = row["fault_outcomes"]
        if not faults:
            assert o["called"] is None
            continue
        assert sum(o.values()) == pytest.approx(1.0)
        assert o["called"] == pytest.approx(np.mean([not w["blocked"] and w["p"] >= 0.5 for w in faults]))
        assert o["bad_data"] == pytest.approx(np.mean([w["blocked"] for w in faults]))
    # each simulated window says its valve's band and slip (a healthy valve's are 0; backlash slips 0)
    assert all(w["s_pct"] >= w["j_pct"] >= 0 for w in fig["windows"] + fig["two_parameter_windows"])
    assert any(w["j_pct"] > 0 for w in fig["windows"]) and any(w["j_pct"] > 0 for w in fig["two_parameter_windows"])
    measured = fig["measured_windows"]
    assert len(measured) == m["windows"] and sum(w["sticky"] for w in measured) == m["sticky"]
    called = [w["p"] >= 0.5 and not w["blocked"] for w in measured]
    assert sum(c == w["sticky"] for c, w in zip(called, measured, strict=True)) / len(measured) == m["ours"]["accuracy"]
    # the settled figures count neither the windows it cannot tell (p 0.35-0.5) nor those it cannot read
    settled = [(c, w["sticky"]) for c, w in zip(called, measured, strict=True)
               if not w["blocked"] and not 0.35 <= w["p"] < 0.5]  # fmt: skip
    assert m["ours_settled"]["n"] == len(settled) <= m["windows"] - m["bad_data"]
    assert m["ours_settled"]["accuracy"] == sum(c == s for c, s in settled) / len(settled)
    # the settled false alarms, split by the valve the window was given, give back each family's windows
    for f, row in fig["families"].items():
        alarms = [w for w in fig["windows"] if w["family"] == f and not w["shows_fault"] and not w["blocked"]
                  and not 0.35 <= w["p"] < 0.5]  # fmt: skip
        for split, valve in (("healthy_valve", False), ("faulty_valve_not_shown", True)):
            mine = [w for w in alarms if (w["cause"] in FAULTS) == valve]
            assert row["false_alarms"][split] == {"called": sum(w["p"] >= 0.5 for w in mine), "of": len(mine)}
        assert sum(a["of"] for a in row["false_alarms"].values()) == len(alarms)
    print_table(fig)
    out = capsys.readouterr().out
    assert "leave-one-family-out" in out and "leave-one-tag-out" in out and "cannot tell" in out
    assert "another simulator" in out
    assert "judged on plant-scale bands" in out and "by band S" in out and "slip J over the noise" in out
    assert "effect on PV over the noise" in out and "the label before" in out
    assert "measured windows it settles" in out and "of faulty valves whose window does not show" in out
    assert "+- two standard errors" in out and "where the windows that show a fault go" in out
    # the independent simulator's settled figures, from its windows: the unsettled and the unread counted neither way
    for kind, row in fig["two_parameter"].items():
        mine = [w for w in fig["two_parameter_windows"] if w["kind"] == kind]
        settled = [(w["p"] >= 0.5, w["shows_fault"]) for w in mine if not w["blocked"] and not 0.35 <= w["p"] < 0.5]
        assert row["ours_settled"]["n"] == len(settled)
        assert row["cannot_tell"] == pytest.approx(1 - len(settled) / len(mine))
        if settled:
            assert row["ours_settled"]["accuracy"] == sum(c == s for c, s in settled) / len(settled)
    assert "ours settled" in out


def test_a_folder_without_labelled_exports_is_named_not_judged_on_nothing(tmp_path):
    """Given the folder above the exports (the shared data's layout: loops.json beside csv/), the bench said
    nothing of the measured windows and printed no error."""
    import json

    from stiction.bench.measured import labelled_exports
    from stiction.schemas.errors import InputError

    (tmp_path / "csv").mkdir()
    rows = "".join(f"{k},{50 + (k % 7)},{50 - (k % 5)}\n" for k in range(300))
    (tmp_path / "csv" / "a.csv").write_text("t,op,pv\n" + rows)
    (tmp_path / "loops.json").write_text(json.dumps([{"csv": "csv/a.csv", "tag": "T1", "label": "stiction"}]))
    with pytest.raises(InputError, match=r"no labelled export here .*its folders: csv"):
        labelled_exports([tmp_path])
    [(tag, sticky, export)] = labelled_exports([tmp_path / "csv"])
    assert tag == "T1" and sticky and len(export.op) == 300


def test_the_balanced_accuracys_standard_error_is_its_spread_over_draws_of_the_same_loops():
    """``_balanced_se`` against a simple reference: the spread of the balanced accuracy over repeated draws of
    windows whose calls are right with the shares observed."""
    import numpy as np

    from stiction.bench.detect import _rates

    rng = np.random.default_rng(3)
    truth = np.array([True] * 30 + [False] * 70)
    draws = [
        _rates(np.concatenate([rng.random(30) < 25 / 30, rng.random(70) < 7 / 70]), truth)["balanced"]
        for _ in range(3000)
    ]
    observed = _rates(np.array([True] * 25 + [False] * 5 + [True] * 7 + [False] * 63), truth)
    assert observed["balanced"] == pytest.approx((25 / 30 + 63 / 70) / 2)
    assert observed["balanced_se"] == pytest.approx(np.std(draws), rel=0.15)
    perfect = _rates(np.array([True] * 20 + [False] * 20), np.array([True] * 20 + [False] * 20))
    assert perfect["balanced"] == 1.0 and perfect["balanced_se"] > 0.02  # 20 of 20 is not certainty
    assert np.isnan(_rates(np.array([True, False]), np.array([True, True]))["balanced_se"])  # one class: unknown
