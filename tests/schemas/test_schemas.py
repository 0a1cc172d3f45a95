import json

import pytest
from pydantic import ValidationError

from stiction.schemas import keys
from stiction.schemas.export import JSON_DIR, schemas
from stiction.schemas.messages import MAX_BATCH_SAMPLES, SampleBatch


def test_exported_json_schemas_are_current():
    """Run ``python -m stiction.schemas.export`` after changing a message model."""
    for name, text in schemas().items():
        assert (JSON_DIR / name).read_text() == text, name


def test_every_key_is_built_and_parsed_in_one_place():
    p = "plant/a"
    assert keys.samples(p, "FIC-101") == "plant/a/loop/FIC-101/samples"
    assert keys.loop_id_of(p, keys.report(p, "FIC-101")) == "FIC-101"
    assert keys.loop_id_of(p, "plant/a/loop/x/y/samples") is None
    assert keys.agent_id_of(p, keys.agent_token(p, "ag1")) == "ag1"
    assert keys.agent_id_of(p, keys.agent_health(p, "ag1")) is None
    for bad in ("a/b", "*", "x$", ""):
        with pytest.raises(ValueError):
            keys.samples(p, bad)
    with pytest.raises(ValueError):
        keys.check_prefix("plant/*")


def _batch(**kw):
    base = {"loop_id": "L", "seq": 0, "t0_s": 0.0, "ts_s": 1.0, "op": [1.0, 2.0], "pv": [0.0, 0.5]}
    return base | kw


def test_sample_batch_refuses_what_a_window_cannot_hold():
    SampleBatch.model_validate(_batch())
    SampleBatch.model_validate(_batch(sp=[1.0, 1.0], mv=[0.0, 1.0], mode=[1.0, 1.0]))
    for bad in (
        _batch(pv=[0.0]),
        _batch(sp=[1.0]),
        _batch(mv=[1.0, 1.0, 1.0]),
        _batch(sp=[1.0, 1.0], mode=[1.0]),
        _batch(ts_s=0),
        _batch(seq=-1),
        _batch(op=[]),
        _batch(schema_version=2),
        _batch(extra=1),
        _batch(op=[1.0] * (MAX_BATCH_SAMPLES + 1), pv=[1.0] * (MAX_BATCH_SAMPLES + 1)),
    ):
        with pytest.raises(ValidationError):
            SampleBatch.model_validate(bad)
    with pytest.raises(ValidationError):
        SampleBatch.model_validate_json(json.dumps(_batch()).replace("2.0", "NaN"))
