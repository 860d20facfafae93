"""The front end's public face: a file in, validated models out (or every located error of the file).

    load(path)                       -> the model of a file (its scenes attached)
    check(path)                      -> every model of a file, with warnings and notes
    load_text(text)                  -> the same for text in memory (tests, tools)
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

from . import ast
from . import model as M
from .checked import CheckResult, pick
from .diagnostics import Diagnostics, MbsError, Source, Span
from .elaborate import Elaborator
from .inertia_check import check_inertia
from .loader import Loader
from .parser import parse_source, without_cycle_collection
from .repeat import expand
from .rules import check_model
from .scenes import build_scene, scene_model_name
from .shared_scenes import borrowed_scenes, source_module
from .scope import Module


def check(path: str | Path) -> CheckResult:
    """Validate every model and component of a file; raise MbsError listing all errors if any."""
    return check_sources(path)[0]


@dataclass(frozen=True)
class Sources:
    """What a check read: every file (resolved path -> its text as parsed) and every path an import looked at
    first and found no file (a file created there would change the result)."""

    texts: dict[Path, str] = field(default_factory=dict)
    missing: tuple[Path, ...] = ()


def check_sources(path: str | Path) -> tuple[CheckResult, Sources]:
    """check, and the sources its result depends on (for the model cache, mbs/model_cache.py)."""
    with without_cycle_collection():
        diags = Diagnostics()
        loader = Loader(diags)
        module = loader.load_path(Path(path))
        result = _check_module(module, loader, diags)
        return result, Sources({p: s.text for p, s in loader.sources.items()}, tuple(loader.missing))


def check_text(text: str, path: str = "<string>", directory: str | Path = ".") -> CheckResult:
    with without_cycle_collection():
        return _check_text(text, path, directory)


def _check_text(text: str, path: str, directory: str | Path) -> CheckResult:
    diags = Diagnostics()
    loader = Loader(diags)
    source = Source(path, text)
    try:
        file = expand(parse_source(source, diags), diags)
    except MbsError:
        raise MbsError(diags.items) from None
    module = Module(path=Path(directory).resolve() / Path(path).name, dotted=Path(path).stem, file=file)
    loader._declare(module)
    return _check_module(module, loader, diags)


def _check_module(module: Module | None, loader: Loader, diags: Diagnostics) -> CheckResult:
    if module is None:
        raise MbsError(diags.items)
    models, components = [], []
    for name, block in module.blocks.items():
        elab = Elaborator(loader, diags)
        built = elab.model(module, block, harness=block.kind == "component")
        if built is None:
            continue
        check_model(built, diags, component=block.kind == "component", assumed_links=elab.broken_links)
        if block.kind != "component" and not diags.error_count:  # a part whose body had errors has none
            check_inertia(built, diags)
        if block.kind == "component":
            elab.warn_unused(elab.root)
            components.append(name)
            continue
        scenes = []
        for scene in module.scenes.values():
            target, where = scene_model_name(scene)
            if target == name or (target is None and _only_model(module) == name):
                built_scene = build_scene(elab, elab.root, built, scene)
                if built_scene is not None:
                    scenes.append(built_scene)
        if elab.scene_setting is not None:
            st = elab.scene_setting
            source = source_module(module, st, diags, _span(st))
            if source is not None:
                scenes += borrowed_scenes(elab, built, source, {s.name for s in scenes}, _span(st))
        elab.warn_unused(elab.root)  # after the scenes: a parameter used only in a scene is used
        models.append(dataclasses.replace(built, scenes=tuple(scenes)))
    for scene in module.scenes.values():
        target, where = scene_model_name(scene)
        if target is not None and target not in module.blocks:
            diags.error(f"scene '{scene.name.text}' names an unknown model '{target}'", _span(where))
        elif target is None and _only_model(module) is None:
            diags.error(f"scene '{scene.name.text}' must say which model it runs: model = name", scene.name.span)
    diags.check()
    return CheckResult(tuple(models), tuple(components), tuple(diags.items))


def _only_model(module: Module) -> str | None:
    names = [n for n, b in module.blocks.items() if b.kind == "model"]
    return names[0] if len(names) == 1 else None


def _span(node) -> Span | None:
    return getattr(node, "span", None)


def load(path: str | Path, model: str | None = None) -> M.Model:
    """The named model of a file (or its only one)."""
    result = check(path)
    return pick(result, model, str(path))


def load_text(text: str, path: str = "<string>", model: str | None = None, directory: str | Path = ".") -> M.Model:
    return pick(check_text(text, path, directory), model, path)


__all__ = ["check", "check_sources", "check_text", "load", "load_text", "CheckResult", "Sources", "ast"]
