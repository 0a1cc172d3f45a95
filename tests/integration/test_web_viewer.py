"""The served rerun web viewer renders the loops (Debian's chromium driven by playwright-core).

Skips with the reason where chromium or playwright-core is missing; ``bash scripts/test``
installs both where it can.  The screenshot is kept in ``build/web-viewer.png``.
"""

import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from stiction.bridge import zenoh_session

ROOT = Path(__file__).resolve().parents[2]
PLAYWRIGHT = ROOT / "build" / "browser" / "node_modules" / "playwright-core"
SHOT_JS = Path(__file__).with_name("web_viewer_shot.js")


def _port() -> int:
    return int(zenoh_session.free_loopback_endpoint().rsplit(":", 1)[1])


@pytest.mark.skipif(shutil.which("chromium") is None, reason="no Debian chromium (bash scripts/test installs it)")
@pytest.mark.skipif(
    not PLAYWRIGHT.is_dir(), reason="no playwright-core in build/browser (bash scripts/test installs it)"
)
def test_served_web_viewer_shows_the_op_pv_loops(quantifier):
    pytest.importorskip("rerun")
    from stiction.agent.viewer import RerunSink
    from stiction.quantify.pipeline import Window
    from stiction.sim.grid import case_specs
    from stiction.sim.loop import simulate

    names = ["C2", "C4", "N4", "C9"]
    specs = case_specs(seed=2)
    r = simulate([specs[n] for n in names]).kept()
    web_port, grpc_port = _port(), _port()
    sink = RerunSink("serve", web_port=web_port, grpc_port=grpc_port)
    windows = [Window(n, r.op[i], r.pv[i], 1.0, float(r.t_s[-1]), "level") for i, n in enumerate(names)]
    for w, (report, details) in zip(windows, quantifier.quantify_with_details(windows), strict=True):
        sink.log_report(report, w, details, (specs[w.loop_id].fs_pct, specs[w.loop_id].fd_pct))
    sink.recording.flush()
    out = ROOT / "build" / "web-viewer.png"
    out.parent.mkdir(exist_ok=True)
    done = subprocess.run(
        ["node", str(SHOT_JS), sink.web_url(), str(out), "20000"],
        capture_output=True,
        text=True,
        timeout=120,
        env=os.environ | {"PW_CORE": str(PLAYWRIGHT)},
    )
    assert done.returncode == 0, done.stderr[-2000:]
    import matplotlib.image as mpimg

    img = (mpimg.imread(out)[..., :3] * 255).astype(int)
    red = np.all(np.abs(img - [214, 39, 40]) < 40, axis=-1).sum()  # the INLPCA curves
    blue = np.all(np.abs(img - [31, 119, 180]) < 40, axis=-1).sum()  # each sample on its curve
    assert red > 200 and blue > 200, f"curves {red} px, clean loops {blue} px: the loops are not on screen"
