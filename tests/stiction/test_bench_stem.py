"""``stiction bench stem``: simulated stems of three kinds, each with the band it was given, through the valve check."""

import json

import numpy as np

from stiction.bench.stem import KINDS, _stems
from stiction.cli import main


def test_each_kind_of_stem_is_driven_by_an_op_and_carries_its_truth():
    stems = _stems(2, 11)
    assert [s["kind"] for s in stems] == list(KINDS) * 2
    for s in stems:
        assert s["op"].shape == s["mv"].shape and s["ts_s"] > 0
        assert (s["s"] > 0) == (s["kind"] != "linear") and 0 <= s["j"] <= s["s"]
        assert not np.allclose(s["mv"], s["op"])  # a stem, calibrated and noisy, not OP again


def test_the_bench_prints_its_figures_by_kind_and_refuses_no_stems(capsys):
    assert main(["bench", "stem", "--stems", "1", "--seed", "11", "--json"]) == 0
    fig = json.loads(capsys.readouterr().out)
    assert set(fig["kinds"]) == set(KINDS) and fig["host"]["cpus"] >= 1
    assert all(0 <= row["called_sticky"] <= 1 for row in fig["kinds"].values())
    assert main(["bench", "stem", "--stems", "0"]) == 2
    assert "--stems 0" in capsys.readouterr().err
