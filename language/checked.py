"""What checking a file gives (its validated models, the names of its components, its warnings and notes) and
picking one model of it: apart from the front end itself, so that a model taken from the model cache
(mbs/model_cache.py) is picked without loading the parser and the validator."""

from __future__ import annotations

from dataclasses import dataclass

from . import model as M
from .diagnostics import Diagnostic, MbsError


@dataclass(frozen=True)
class CheckResult:
    models: tuple[M.Model, ...]
    components: tuple[str, ...]
    diagnostics: tuple[Diagnostic, ...]

    def model(self, name: str | None = None) -> M.Model:
        if name is None:
            return self.models[0]
        for m in self.models:
            if m.name == name:
                return m
        raise KeyError(name)


def pick(result: CheckResult, name: str | None, path: str) -> M.Model:
    """The model `name` of a checked file (None: its first), or a located-free error naming the file's models."""
    if name is not None:
        try:
            return result.model(name)
        except KeyError:
            names = ", ".join(m.name for m in result.models) or "none"
            raise MbsError([Diagnostic("error", f"{path}: no model '{name}' (models: {names})", None)]) from None
    if not result.models:
        raise MbsError([Diagnostic("error", f"{path}: the file defines no model (only components: "
                                            f"{', '.join(result.components) or 'none'})", None)])
    return result.models[0]
