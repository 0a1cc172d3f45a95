"""The demo's table says why a loop has no friction numbers, not only that it has none."""

import numpy as np

from stiction.commands.demo import _table
from stiction.quantify.pipeline import Quantifier, Window
from stiction.schemas.messages import LoopTruth
from stiction.sim.grid import case_specs
from stiction.sim.loop import simulate


def _truth(loop_id):
    return LoopTruth(
        loop_id=loop_id, fs_pct=50.0, fd_pct=10.0, s_pct=4.2, j_pct=3.3, loop="level", valve="thesis", seed=1,
        disturbance=None, extensions={},
    )  # fmt: skip


def test_rows_without_numbers_name_the_verdict_or_the_put_off_reading():
    specs = case_specs(seed=7)
    r = simulate([specs["C1"]]).kept()
    rng = np.random.default_rng(1)
    reports = Quantifier().quantify(
        [
            Window("a-quiet", rng.normal(50, 0.3, 1000), rng.normal(50, 0.3, 1000)),
            Window("b-put-off", r.op[0], r.pv[0], defer_reading=True),
            Window("c-read", r.op[0], r.pv[0]),
        ]
    )
    truths = {x: _truth(x) for x in ("a-quiet", "b-put-off", "c-read", "d-new")}
    lines = _table({rep.loop_id: rep for rep in reports}, truths, rows=10, elapsed=1.0, published=1, loops=4)
    row = {line.split()[0]: line for line in lines.splitlines()[2:]}
    assert row["a-quiet"].endswith("verdict no oscillation")
    assert row["b-put-off"].endswith("friction not read in this report")
    assert "waiting for its first report" in row["d-new"]
    assert "physical" in row["c-read"] or "learned" in row["c-read"]
