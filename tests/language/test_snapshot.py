"""The validated model as plain JSON data (language/snapshot.py): every shipped model comes back equal, with the same
text, sharing what it shared and keeping the language's constants as themselves; data that names anything but the
model's own classes and constants is refused without running it."""

from __future__ import annotations

import json

import pytest

from mbs.language import expr as X
from mbs.language import frontend, snapshot
from mbs.language.diagnostics import Span
from mbs.language.model import Model

from tests.conftest import SHIPPED_MODELS


def _round_trip(obj):
    return snapshot.from_plain(json.loads(json.dumps(snapshot.to_plain(obj))))


@pytest.mark.parametrize("path", SHIPPED_MODELS, ids=lambda p: p.stem)
def test_every_shipped_model_comes_back_as_it_was(path):
    result = frontend.check(path)
    back = _round_trip(result)
    assert back == result and repr(back) == repr(result)
    for fresh, model in zip(result.models, back.models):
        assert model.content_digest == fresh.content_digest
        # spans (compare=False) come back too: later stages locate their errors with them
        assert [(p.span.source.path, p.span.line, p.span.col) for p in model.parameters] == \
            [(p.span.source.path, p.span.line, p.span.col) for p in fresh.parameters]
        # the constants tell a default start value from a written one by identity (pipeline.fixed_state_names)
        assert [c.init is X.ZERO for c in model.coordinates] == [c.init is X.ZERO for c in fresh.coordinates]
        assert [c.init_speed is X.ZERO for c in model.coordinates] == \
            [c.init_speed is X.ZERO for c in fresh.coordinates]


def test_what_the_model_shares_stays_shared():
    model = frontend.load(SHIPPED_MODELS[0])
    back = _round_trip(model)
    sources = {id(s.span.source) for s in (back, *back.parameters, *back.parts)}
    assert len(sources) == len({id(s.span.source) for s in (model, *model.parameters, *model.parts)})
    assert back.span.source.line_text(back.span.line) == model.span.source.line_text(model.span.line)


def test_a_model_is_built_without_running_its_classes_code(monkeypatch):
    plain = snapshot.to_plain(frontend.load(SHIPPED_MODELS[0]))

    def refuse(*args, **kwargs):
        raise AssertionError("__init__ ran")

    monkeypatch.setattr(Model, "__init__", refuse)
    monkeypatch.setattr(Span, "__init__", refuse)
    assert isinstance(snapshot.from_plain(plain), Model)


@pytest.mark.parametrize("data", [
    {"classes": ["os:system"], "objects": [[0, "echo"]], "root": [0]},
    {"classes": ["subprocess:Popen"], "objects": [], "root": None},
    {"classes": [], "objects": [[-2, "builtins:print"]], "root": [0]},
    {"classes": [], "objects": [[-2, "mbs.language.expr:evaluate"]], "root": [0]},
    {"classes": ["mbs.language.expr:Const"], "objects": [[0, 1.0, 2.0]], "root": [0]},
    {"classes": ["mbs.language.expr:Const"], "objects": [[0, 1.0]], "root": [1]},
    {"classes": ["mbs.language.expr:Const"], "objects": [[0, {"a": 1}]], "root": [0]},
    {"classes": ["mbs.language.expr:Const"], "objects": [[3, 1.0]], "root": [0]},
])
def test_data_naming_anything_else_is_refused(data):
    with pytest.raises(ValueError):
        snapshot.from_plain(data)


def test_what_is_not_model_data_is_not_snapshot():
    with pytest.raises(snapshot.NotPlain):
        snapshot.to_plain((X.Const(1.0), [1, 2]))
    with pytest.raises(snapshot.NotPlain):
        snapshot.to_plain(X.Op("sin", (object(),)))
