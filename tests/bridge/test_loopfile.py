"""Loop files: TOML and YAML read the same; every mistake is one line naming the file and the field."""

import pytest

from stiction.bridge.loopfile import dumps, load, parse
from stiction.schemas.errors import InputError

GOOD = """
sample_time_s = 0.5
[server]
endpoint = "opc.tcp://plant:4840"
user = "reader"
password_env = "PLANT_PASSWORD"
[loops.FIC101]
op = "ns=2;s=FIC101.OP"
pv = "ns=2;s=FIC101.PV"
sp = "ns=2;i=1042"
[loops."LIC-7"]
op = "ns=3;s=LIC7/OUT"
pv = "ns=3;s=LIC7/PV"
process = "level"
"""


def test_toml_yaml_and_our_own_dump_read_the_same(tmp_path):
    toml = tmp_path / "loops.toml"
    toml.write_text(GOOD)
    lf = load(toml)
    assert lf.sample_time_s == 0.5 and lf.server.user == "reader"
    assert lf.loops["FIC101"].nodes() == {"op": "ns=2;s=FIC101.OP", "pv": "ns=2;s=FIC101.PV", "sp": "ns=2;i=1042"}
    assert lf.loops["LIC-7"].process == "level"
    assert parse(dumps(lf), ".toml") == lf
    yaml = pytest.importorskip("yaml")
    (y := tmp_path / "loops.yaml").write_text(yaml.safe_dump(lf.model_dump(exclude_none=True)))
    assert load(y) == lf


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('[loops.A]\nop = "FIC101.OP"\npv = "ns=2;s=a"', "loops.A.op: expected an OPC UA node id"),
        ('[loops."a/b"]\nop = "i=1"\npv = "i=2"', "loop id 'a/b'"),
        ('[loops.A]\npv = "i=2"', "loops.A.op: Field required"),
        ('[loops.A]\nop = "i=1"\npv = "i=2"\nvalve = "i=3"', "loops.A.valve: Extra inputs"),
        ("sample_time_s = 0\n[loops.A]\nop = 'i=1'\npv = 'i=2'", "sample_time_s"),
        ("[server]\nendpoint = 'http://plant'\n[loops.A]\nop = 'i=1'\npv = 'i=2'", "server.endpoint"),
        ("loops = {}", "loops"),
        ("loops = [", "not valid TOML"),
    ],
)
def test_every_mistake_is_one_line_naming_the_field(tmp_path, text, message):
    (f := tmp_path / "loops.toml").write_text(text)
    with pytest.raises(InputError) as e:
        load(f)
    assert message in str(e.value) and str(e.value).startswith(str(f)) and "\n" not in str(e.value)


def test_a_missing_file_is_named(tmp_path):
    with pytest.raises(InputError, match="nope.toml: cannot read"):
        load(tmp_path / "nope.toml")
