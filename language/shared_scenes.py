"""Scenes shared between model files: `scenes = NAME` in a model (NAME an imported model file) runs that file's
scenes on this model as well, so that a variant of a vehicle (free hubs instead of prescribed spin, other tyres)
runs every manoeuvre of the original by name without copying it. The variant's own scenes of the same name win.

Each borrowed scene is checked against the variant like its own scenes are; one that does not fit (it sets a
parameter or asks for an output the variant lacks) is left out with a warning that says why, rather than
making the variant unusable when the original grows a scene it cannot run."""

from __future__ import annotations

from typing import TYPE_CHECKING

from . import ast
from . import model as M
from .diagnostics import Diagnostics
from .scenes import build_scene, scene_model_name
from .scope import Module

if TYPE_CHECKING:
    from .context import ElaborationContext

SETTING = "scenes"


def source_module(module: Module, st: ast.Setting, diags: Diagnostics, span) -> Module | None:
    """The imported model file a `scenes = NAME` setting names (a located error if it names none)."""
    name = st.value.ref.dotted if isinstance(st.value, ast.Name) else None
    source = module.imports.get(name) if name else None
    if source is None or not any(b.kind == "model" for b in source.blocks.values()):
        diags.error("scenes = NAME: NAME must be a model file imported by this file (import iltis.vehicle as base, "
                    "then scenes = base), whose scenes this model runs too", span)
        return None
    return source


def borrowed_scenes(elab: "ElaborationContext", model: M.Model, source: Module, own: set[str],
                    where) -> list[M.Scene]:
    """The scenes of `source`'s model (not those named in `own`), built against `model`."""
    models = [n for n, b in source.blocks.items() if b.kind == "model"]
    scenes, saved = [], elab.diags
    for scene in source.scenes.values():
        target, _ = scene_model_name(scene)
        runs_on = target if target is not None else (models[0] if len(models) == 1 else None)
        if scene.name.text in own or runs_on != models[0]:     # the file's first model's scenes
            continue
        trial = Diagnostics()
        elab.diags = trial
        try:
            built = build_scene(elab, elab.root, model, scene)
        finally:
            elab.diags = saved
        if built is None or trial.error_count:
            reason = trial.errors[0].message if trial.errors else "it does not build"
            saved.warning(f"scene '{scene.name.text}' of {source.dotted} is left out: {reason}", where)
            continue
        saved.extend(trial.items)
        scenes.append(built)
    return scenes


__all__ = ["SETTING", "source_module", "borrowed_scenes"]
