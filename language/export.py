"""``mbs export --json``: the validated data model as JSON for other tools (schema: docs/model.schema.json).

The export is method-independent, as the founding paper asks of its data model: parts with frames and
bodies, interactions with connect and members, parameters, inputs, outputs and scenes; no coordinates
chosen by a formalism, no generated code. Quantities are in SI; expressions are trees so that a reader
needs no parser: {"const": 1.5}, {"sym": "param", "name": "m"}, {"op": "+", "args": [...]},
{"table": {"x": ..., "xs": [...], "ys": [...], "method": "linear"}}.
"""

from __future__ import annotations

import json

from . import expr as X
from . import model as M

SCHEMA_VERSION = "1"


def expr_json(e: X.E):
    if isinstance(e, X.Const):
        return {"const": e.value}
    if isinstance(e, X.Sym):
        return {"sym": e.kind, "name": e.name}
    if isinstance(e, X.Table):
        return {"table": {"x": expr_json(e.x), "xs": list(e.xs), "ys": list(e.ys), "method": e.method}}
    if isinstance(e, X.Hook):
        return {"hook": e.name, "result": e.result, "args": [expr_json(a) for a in e.args]}
    return {"op": e.op, "args": [expr_json(a) for a in e.args]}


def _vec(v) -> list:
    return [expr_json(c) for c in v]


def _mat(m) -> list:
    return [_vec(row) for row in m]


def _value(v):
    if isinstance(v, M.FrameRef):
        return {"part": v.part, "frame": v.frame}
    if isinstance(v, tuple):
        return _vec(v)
    if isinstance(v, (str, bool)):   # words and flags (a tyre's vertical = true)
        return v
    return expr_json(v)


def _dim(d) -> str | None:
    return None if d is None else str(d)


def model_to_dict(model: M.Model) -> dict:
    return {
        "schema": f"baukasten-model/{SCHEMA_VERSION}",
        "name": model.name,
        "description": model.description,
        "parameters": [{"name": p.name, "default": expr_json(p.default), "value": p.value,
                        "unit": _dim(p.dimension), "description": p.description} for p in model.parameters],
        "inputs": [{"name": i.name, "value": expr_json(i.value), "unit": _dim(i.dimension),
                    "description": i.description} for i in model.inputs],
        "outputs": [{"name": o.name, "value": expr_json(o.value), "description": o.description}
                    for o in model.outputs],
        "gravity": _vec(model.gravity),
        "parts": [_part(p) for p in model.parts],
        "interactions": [_interaction(i) for i in model.interactions],
        "scenes": [_scene(s) for s in model.scenes],
        **({"states": [{"name": s.name, "init": expr_json(s.init), "rate": expr_json(s.rate), "unit": _dim(s.dimension),
                        "description": s.description} for s in model.states]} if model.states else {}),
    }


def _part(p: M.Part) -> dict:
    out = {"name": p.name, "kind": "rigid" if p.body else "part", "description": p.description,
           "frames": [{"name": f.name, "position": _vec(f.position), "rotation": _mat(f.rotation)} for f in p.frames]}
    if p.body is not None:
        out["body"] = {"mass": expr_json(p.body.mass), "com": _vec(p.body.com), "inertia": _mat(p.body.inertia)}
    return out


def _interaction(i: M.Interaction) -> dict:
    member: dict = {"forces": [{"name": f.name, "kind": f.kind, "args": {k: _value(v) for k, v in f.args}}
                               for f in i.forces],
                    "sensors": [{"name": s.name, "kind": s.kind, "args": {k: _value(v) for k, v in s.args},
                                 "components": list(s.components)} for s in i.sensors]}
    if i.joint is not None:
        j = i.joint
        member["joint"] = {
            "kind": j.kind, "axes": [_vec(a) for a in j.axes], "rotation": j.rotation or None, "cut": j.cut,
            "coordinates": [{"name": c.name, "unit": _dim(c.dimension), "init": expr_json(c.init),
                             "init_speed": expr_json(c.init_speed),
                             "prescribed": None if c.prescribed is None else expr_json(c.prescribed)}
                            for c in j.coordinates]}
    return {"name": i.name, "description": i.description,
            "connect": {"a": _value(i.a), "b": _value(i.b)}, "member": member}


def _scene(s: M.Scene) -> dict:
    return {"name": s.name, "model": s.model, "description": s.description,
            "params": {k: expr_json(v) for k, v in s.params}, "inputs": {k: expr_json(v) for k, v in s.inputs},
            "inits": [{"coordinate": c, "speed": sp, "value": expr_json(v)} for c, sp, v in s.inits],
            "outputs": [{"name": o.name, "value": expr_json(o.value)} for o in s.outputs],
            "t_end": s.t_end, "sample": s.sample, "integrator": s.integrator, "rtol": s.rtol, "atol": s.atol,
            "start": s.start}


def model_to_json(model: M.Model) -> str:
    return json.dumps(model_to_dict(model), indent=1, allow_nan=False) + "\n"
