"""The bench's --bands, --start, --train-start, --draws and the sizing's --simulator name what the simulators draw:
the command keeps literal choices (its start-up imports no simulator), so a test holds them to
``sim.plant_families.BANDS`` and ``START``, ``sim.grid.DRAWS`` and ``bench.sizing.SIMULATORS``.  And
--network-draws and the starts reach the bench."""

import pytest

from stiction.bench.sizing import SIMULATORS
from stiction.cli import build_parser
from stiction.sim.grid import DRAWS
from stiction.sim.plant_families import BANDS, START


def test_every_band_scale_and_draw_is_accepted_and_nothing_else():
    parser = build_parser()
    for bands in BANDS:
        assert parser.parse_args(["bench", "detect", "--bands", bands]).bands == bands
    for start in START:
        args = parser.parse_args(["bench", "detect", "--start", start, "--train-start", start])
        assert (args.start, args.train_start) == (start, start)
    for draws in DRAWS:
        assert parser.parse_args(["bench", "diagnose", "--draws", draws]).draws == draws
    for simulator in SIMULATORS:
        assert parser.parse_args(["bench", "sizing", "--simulator", simulator]).simulator == simulator
    for argv in (["bench", "detect", "--bands", "huge"], ["bench", "diagnose", "--draws", "narrow"],
                 ["bench", "sizing", "--simulator", "thesis"], ["bench", "detect", "--start", "cold"]):  # fmt: skip
        with pytest.raises(SystemExit):
            parser.parse_args(argv)


def test_bench_detect_trains_its_held_out_networks_on_the_draws_asked_for_and_else_as_shipped(monkeypatch, capsys):
    import stiction.bench.detect as bench_detect_module
    from stiction.cli import main
    from stiction.trainer.window_net import WindowNetSettings

    asked, starts = [], []

    def bench(*a, **k):
        starts.append((k["start"], k["train_start"]))
        return asked.append(k["window_net"]) or {}

    monkeypatch.setattr(bench_detect_module, "bench_detect", bench)
    assert main(["bench", "detect", "--network-draws", "3", "--json", "--start", "rest"]) == 0
    assert main(["bench", "detect", "--json", "--train-start", "both"]) == 0
    capsys.readouterr()
    assert starts == [("rest", "rest"), ("operating_point", "both")]  # judged in operation unless asked
    shipped = WindowNetSettings()
    assert asked[0].seeds == 3 and asked[0].members == shipped.members and asked[0].epochs == shipped.epochs
    assert asked[1] is None  # bench_detect's own default: the shipped network's settings
