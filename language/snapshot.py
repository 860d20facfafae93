"""The validated model as plain JSON data and back, so that the model cache (mbs/model_cache.py) can keep what
parsing and validation made and a second run need not parse again.

    data = to_plain(check_result)     # raises NotPlain for anything outside the allow-list below
    same = from_plain(data)           # equal to the original, field by field, sharing as it shared

The data is a table of objects, children before parents, each ``[class index, field values...]`` (a tuple:
``[-1, items...]``; a module's own constant such as expr.ZERO: ``[-2, "module:name"]``); a value is a JSON
number, string, boolean or null, or ``[index]``, a reference to an earlier object. Every object is written
once: what the model shares (a Source and its text, common subexpressions) stays shared, and the constants that
later stages tell apart by identity stay the module's own objects (pipeline.fixed_state_names tells a joint's
default start value, expr.ZERO, from a written ``init = 0`` that way).

Why loading it is safe, as safe as the derivation cache's JSON entries (runtime/cache.py), which hold only text
and numbers: the data names classes only from ALLOWED, the validated model's own frozen dataclasses (model,
expression nodes, dimensions, spans, diagnostics, hooks' signatures), and its constants only from CONSTANT_MODULES.
An object is made by ``object.__new__`` and filling its fields: no ``__init__``, ``__post_init__``,
``__reduce__``, ``__setstate__`` or other code of the data's choosing runs, and no module the data names is
imported unless it is one of ours on the list. A damaged or crafted entry can at worst give a wrong model,
and the cache reads only entries whose record (size, SHA-256) matches and that only their owner can write.
"""

from __future__ import annotations

import dataclasses
import importlib

#: "module:class" of every class a snapshot may hold: the validated model's data, nothing with behaviour.
ALLOWED = frozenset({
    *(f"mbs.language.model:{name}" for name in (
        "Parameter", "Input", "Output", "Frame", "Body", "Part", "FrameRef", "Coordinate", "Joint", "Force",
        "Sensor", "Interaction", "Scene", "Action", "Event", "State", "Model")),
    *(f"mbs.language.expr:{name}" for name in ("Const", "Sym", "Op", "Table", "Hook")),
    "mbs.language.units:Dimension",
    "mbs.language.diagnostics:Source", "mbs.language.diagnostics:Span", "mbs.language.diagnostics:Diagnostic",
    "mbs.language.hooks:Slot", "mbs.language.hooks:HookSpec",
    "mbs.language.checked:CheckResult",
})
#: Modules whose module-level instances of allowed classes are written by name and read back as themselves.
CONSTANT_MODULES = ("mbs.language.expr", "mbs.language.units")
_SCALARS = (str, float, int, bool, type(None))


class NotPlain(Exception):
    """The object holds something a snapshot cannot keep (it is then not cached)."""


def to_plain(root) -> dict:
    """The JSON-ready snapshot of `root` (a CheckResult, a Model or anything built of allowed classes)."""
    constants = _constants()
    classes: list[str] = []
    class_index: dict[type, int] = {}
    field_names: dict[type, tuple] = {}  # (dataclasses.fields builds its tuple anew at every call)
    objects: list[list] = []
    index: dict[int, int] = {}   # id(object) -> its row in objects
    alive = []                   # what the ids refer to stays alive while they are used

    def value(obj):
        kind = type(obj)
        if kind in _SCALARS:
            return obj
        row = index.get(id(obj))
        if row is not None:
            return [row]
        if id(obj) in constants:
            entry = [-2, constants[id(obj)]]
        elif kind is tuple:
            entry = [-1, *[value(item) for item in obj]]
        else:
            names = field_names.get(kind)
            if names is None:  # a class met for the first time
                name = f"{kind.__module__}:{kind.__qualname__}"
                if name not in ALLOWED:
                    raise NotPlain(f"a {name} is not model data")
                class_index[kind] = len(classes)
                classes.append(name)
                names = field_names[kind] = tuple(f.name for f in dataclasses.fields(kind))
            entry = [class_index[kind], *[value(getattr(obj, f)) for f in names]]
        index[id(obj)] = len(objects)
        objects.append(entry)
        alive.append(obj)
        return [len(objects) - 1]

    try:
        top = value(root)
    except RecursionError:
        raise NotPlain("the model is nested too deeply") from None
    return {"classes": classes, "objects": objects, "root": top}


def from_plain(data: dict):
    """The object a snapshot was made of. Raises ValueError when the data is not a snapshot of allowed objects."""
    try:
        classes = [_allowed_class(name) for name in data["classes"]]
        names = [tuple(f.name for f in dataclasses.fields(cls)) for cls in classes]
        built: list = []
        new = object.__new__
        for entry in data["objects"]:
            tag = entry[0]
            if tag == -2:
                built.append(_constant(entry[1]))
                continue
            # a reference is [index] of an object made before (a later or negative one is refused below)
            values = [built[v[0]] if type(v) is list else v for v in entry[1:]]
            if tag == -1:
                built.append(tuple(values))
            elif 0 <= tag < len(classes) and len(values) == len(names[tag]):
                obj = new(classes[tag])
                obj.__dict__.update(zip(names[tag], values))
                built.append(obj)
            else:
                raise ValueError(f"object {len(built)}: class {tag} with {len(values)} fields")
        _check_values(data)
        root = data["root"]
        return built[root[0]] if type(root) is list else root
    except (KeyError, IndexError, TypeError, AttributeError) as exc:
        raise ValueError(f"not a model snapshot ({type(exc).__name__}: {exc})") from None


def _check_values(data: dict) -> None:
    """Every value a JSON scalar or a reference to an object made before it (refused otherwise: a dict or a
    list of other length would be data of the wrong shape, a negative index another object than written)."""
    for row, entry in enumerate(data["objects"]):
        for v in entry[1:]:
            if type(v) is list:
                if len(v) != 1 or type(v[0]) is not int or not 0 <= v[0] < row:
                    raise ValueError(f"object {row}: a reference {v} to an object not made before it")
            elif type(v) not in _SCALARS:
                raise ValueError(f"object {row}: a {type(v).__name__} where a value belongs")


def _allowed_class(name: str) -> type:
    if name not in ALLOWED:
        raise ValueError(f"class {name} is not model data")
    module, _, qualname = name.partition(":")
    return getattr(importlib.import_module(module), qualname)


def _constant(name: str):
    module, _, attribute = str(name).partition(":")
    if module not in CONSTANT_MODULES:
        raise ValueError(f"{name} is not a constant of the model's modules")
    obj = getattr(importlib.import_module(module), attribute)
    if f"{type(obj).__module__}:{type(obj).__qualname__}" not in ALLOWED:
        raise ValueError(f"{name} is not model data")
    return obj


def _constants() -> dict[int, str]:
    """id -> "module:name" of the constant modules' own instances of allowed classes (the first name of each)."""
    out: dict[int, str] = {}
    for module_name in CONSTANT_MODULES:
        module = importlib.import_module(module_name)
        for attribute, obj in vars(module).items():
            if f"{type(obj).__module__}:{type(obj).__qualname__}" in ALLOWED and id(obj) not in out:
                out[id(obj)] = f"{module_name}:{attribute}"
    return out
