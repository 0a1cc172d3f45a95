"""The installed package works from outside the checkout: one import name, compiled kernels that load."""

import os
import subprocess
import sys

CODE = """
import sys
from stiction.quantify.pipeline import warm_up
warm_up()  # INLPCA, the evidence and the PI fit: every compiled kernel, from its cache or compiled now
bare = sorted({m.split('.')[0] for m in sys.modules} & {'sim', 'ident', 'detect', 'bridge', 'trainer', 'agent',
                                                     'quantify', 'schemas', 'bench'})
print(bare)
"""


def test_the_package_and_its_compiled_kernels_load_outside_the_checkout(tmp_path):
    """Run from another folder, nothing of the tree is on the path but what is installed under
    ``stiction``: a kernel cached under a module name that no longer exists would fail here."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    done = subprocess.run(
        [sys.executable, "-c", CODE], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip() == "[]"
