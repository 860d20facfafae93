"""Name resolution: what a name means in a model or in one instance of a component.

A Scope holds the declarations of one block (a model, or one ``use`` of a component) under a name prefix
("fl."), with the mirror signs and the chain of instantiation sites that apply to it. Dotted names are
resolved one step at a time: ``fl.arm.phi`` is instance ``fl``, then interaction ``arm``, then its
coordinate ``phi``. Near misses get a "did you mean" from every name visible at that step.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass, field
from pathlib import Path

from . import ast
from .diagnostics import Span
from .units import Dimension


@dataclass
class Module:
    """One parsed .mbs file and its file-level declarations."""

    path: Path
    dotted: str
    file: ast.File
    imports: dict[str, "Module"] = field(default_factory=dict)
    params: dict[str, ast.Param] = field(default_factory=dict)
    funcs: dict[str, ast.Func] = field(default_factory=dict)
    blocks: dict[str, ast.Model] = field(default_factory=dict)
    scenes: dict[str, ast.Scene] = field(default_factory=dict)


# ------------------------------------------------------------------------------------------ entries
@dataclass
class ParamEntry:
    full: str
    decl: ast.Param
    override: ast.Expr | None = None       # from the instantiating 'use', resolved in override_scope
    override_scope: "Scope | None" = None
    used: bool = False


@dataclass
class InputEntry:
    full: str
    decl: ast.Input
    used: bool = False
    override: ast.Expr | None = None        # connected by the instantiating 'use' (steer = -steer)
    override_scope: "Scope | None" = None


@dataclass
class OutputEntry:
    full: str
    decl: ast.Output
    scope: "Scope"


@dataclass
class FuncEntry:
    decl: ast.Func
    scope: "Scope"


@dataclass
class PartEntry:
    full: str
    decl: ast.Part | None  # None: the predefined inertial part
    frames: dict[str, Span] = field(default_factory=dict)  # local frame names -> declaring span
    used_frames: set[str] = field(default_factory=set)


@dataclass
class PortEntry:
    """A component's attachment: its frames live on the part the instantiating model binds it to."""

    decl: ast.Port
    part: str | None = None        # full name of the bound part
    base_frame: str | None = None  # frame of that part the port is bound to
    frame_prefix: str = ""         # port frames become '<frame_prefix><name>' on the bound part


@dataclass
class InteractEntry:
    full: str
    decl: ast.Interact
    coordinates: dict[str, Dimension] = field(default_factory=dict)  # local name -> dimension
    speeds: dict[str, Dimension] = field(default_factory=dict)       # names usable in der() or directly
    sensors: dict[str, tuple[str, tuple[str, ...]]] = field(default_factory=dict)  # local -> (kind, comps)
    forces: dict[str, str] = field(default_factory=dict)             # local -> kind
    sensor_dims: dict[str, Dimension] = field(default_factory=dict)  # a sensor's dimension where not its kind's


@dataclass
class StateEntry:
    """``state name = value``: an extra differential state; its dimension is that of its initial value
    (states.py resolves it on first use)."""

    full: str
    decl: ast.State
    scope: "Scope"
    resolved: tuple | None = None  # (initial value, dimension) once resolved; (None, None) when it failed


@dataclass
class InstanceEntry:
    scope: "Scope"
    decl: ast.Use


@dataclass
class ImportEntry:
    module: Module


Entry = (ParamEntry | InputEntry | OutputEntry | FuncEntry | PartEntry | PortEntry | InteractEntry | InstanceEntry
         | ImportEntry | StateEntry)


@dataclass
class Scope:
    module: Module
    block: ast.Model
    prefix: str = ""
    signs: tuple[int, int, int] = (1, 1, 1)
    via: tuple[tuple[str, Span], ...] = ()
    parent: "Scope | None" = None
    entries: dict[str, Entry] = field(default_factory=dict)
    order: list[str] = field(default_factory=list)

    @property
    def mirrored(self) -> bool:
        return self.signs != (1, 1, 1)

    def at(self, span: Span) -> Span:
        """The span as the user should see it: inside an instance it also names the 'use' sites."""
        return _chain(span, self.via)

    def full(self, local: str) -> str:
        return self.prefix + local

    def lookup(self, name: str) -> Entry | None:
        if name in self.entries:
            return self.entries[name]
        if name in self.module.imports:
            return ImportEntry(self.module.imports[name])
        return None

    def visible_names(self) -> list[str]:
        return list(self.entries) + list(self.module.imports) + list(self.module.params) + list(self.module.funcs)

    def root(self) -> "Scope":
        scope = self
        while scope.parent is not None:
            scope = scope.parent
        return scope


def _chain(span: Span, via) -> Span:
    for label, site in via:
        span = span.instantiated(label, site)
    return span


def did_you_mean(name: str, candidates) -> str:
    """' (did you mean 'x'?)' for a near miss, else ''."""
    close = difflib.get_close_matches(name, sorted(set(candidates)), n=1, cutoff=0.6)
    return f"; did you mean '{close[0]}'?" if close else ""
