"""The bench's --bands, --draws and the sizing's --simulator name what the simulators draw: the command keeps literal
choices (its start-up imports no simulator), so a test holds them to ``sim.plant_families.BANDS``,
``sim.grid.DRAWS`` and ``bench.sizing.SIMULATORS``."""

import pytest

from stiction.bench.sizing import SIMULATORS
from stiction.cli import build_parser
from stiction.sim.grid import DRAWS
from stiction.sim.plant_families import BANDS


def test_every_band_scale_and_draw_is_accepted_and_nothing_else():
    parser = build_parser()
    for bands in BANDS:
        assert parser.parse_args(["bench", "detect", "--bands", bands]).bands == bands
    for draws in DRAWS:
        assert parser.parse_args(["bench", "diagnose", "--draws", draws]).draws == draws
    for simulator in SIMULATORS:
        assert parser.parse_args(["bench", "sizing", "--simulator", simulator]).simulator == simulator
    for argv in (["bench", "detect", "--bands", "huge"], ["bench", "diagnose", "--draws", "narrow"],
                 ["bench", "sizing", "--simulator", "thesis"]):  # fmt: skip
        with pytest.raises(SystemExit):
            parser.parse_args(argv)
