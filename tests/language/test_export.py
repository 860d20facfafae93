"""`mbs export --json`: valid against the documented schema, and a faithful picture of the data model."""

import json
from pathlib import Path

import jsonschema
import pytest

from mbs.language.export import model_to_dict
from mbs.language.frontend import check
from tests.conftest import ROOT, SHIPPED_MODELS

SCHEMA = json.loads((ROOT / "docs" / "model.schema.json").read_text())


@pytest.mark.parametrize("path", SHIPPED_MODELS, ids=lambda p: p.name)
def test_export_of_every_shipped_model_matches_the_schema(path):
    for model in check(path).models:
        data = json.loads(json.dumps(model_to_dict(model)))
        jsonschema.validate(data, SCHEMA)


def test_export_content_of_the_pendulum():
    model = check(Path("library/examples/pendulum.mbs")).models[0]
    data = model_to_dict(model)
    assert [p["name"] for p in data["parts"]] == ["inertial", "bob"]
    bob = data["parts"][1]
    assert bob["body"]["mass"] == {"sym": "param", "name": "m"}
    hinge = data["interactions"][0]
    assert hinge["connect"] == {"a": {"part": "inertial", "frame": "origin"}, "b": {"part": "bob", "frame": "pivot"}}
    assert hinge["member"]["joint"]["kind"] == "revolute"
    assert hinge["member"]["joint"]["coordinates"][0]["init"]["const"] == pytest.approx(0.5235987755982988)
    assert data["parameters"][1] == {"name": "l", "default": {"const": 1.0}, "value": 1.0, "unit": "m",
                                     "description": "rod length"}
