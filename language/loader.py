"""Finding and reading .mbs modules: ``import iltis.suspension`` looks in the importing file's folder, then
in the shipped library. Every file is parsed once per run; import cycles are located errors. The loader notes
what the result depends on (every file read, every place an import looked in vain), which is what the model
cache (mbs/model_cache.py) checks before it reuses a result."""

from __future__ import annotations

from pathlib import Path

from . import ast
from .diagnostics import Diagnostics, MbsError, Source
from .parser import parse_source, read_source
from .repeat import expand
from .scope import Module

LIBRARY_ROOT = Path(__file__).resolve().parent.parent / "library"
SUFFIX = ".mbs"


class Loader:
    def __init__(self, diags: Diagnostics, library_root: Path = LIBRARY_ROOT):
        self.diags = diags
        self.library_root = library_root
        self.modules: dict[Path, Module] = {}
        self._loading: list[Path] = []
        self.sources: dict[Path, Source] = {}   # every file read (resolved path): its text as parsed
        self.missing: list[Path] = []           # places an import looked first, in vain (a new file there wins)

    def load_path(self, path: Path, dotted: str | None = None, shown: str | None = None) -> Module | None:
        key = path.resolve()
        if key in self.modules:
            return self.modules[key]
        try:
            source = read_source(path, shown or _shown_path(path))
            self.sources[key] = source
            file = expand(parse_source(source, self.diags), self.diags)
        except MbsError as err:
            self.diags.extend(err.diagnostics)
            return None
        module = Module(path=key, dotted=dotted or path.stem, file=file)
        self.modules[key] = module
        self._loading.append(key)
        try:
            self._declare(module)
        finally:
            self._loading.pop()
        return module

    def resolve(self, dotted: ast.Ref, from_dir: Path) -> Path | None:
        parts = [p.text for p in dotted.parts]
        candidates = [from_dir.joinpath(*parts).with_suffix(SUFFIX)]
        lib_parts = parts[1:] if parts[0] == "library" else parts
        if lib_parts:
            candidates.append(self.library_root.joinpath(*lib_parts).with_suffix(SUFFIX))
        for c in candidates:
            if c.is_file():
                return c
            self.missing.append(c)
        return None

    def _declare(self, module: Module) -> None:
        """Index a file's top-level declarations and load its imports."""
        for item in module.file.items:
            table = None
            if isinstance(item, ast.Import):
                self.import_into(module.imports, item, module.path.parent)
                continue
            if isinstance(item, ast.Param):
                table, name = module.params, item.name
            elif isinstance(item, ast.Func):
                table, name = module.funcs, item.name
            elif isinstance(item, ast.Model):
                table, name = module.blocks, item.name
            elif isinstance(item, ast.Scene):
                table, name = module.scenes, item.name
            else:
                self.diags.error("inputs and outputs belong inside a model or component", item.span)
                continue
            if name.text in table:
                self.diags.error(f"'{name.text}' is declared twice in this file", name.span,
                                 ("first declared here", table[name.text].name.span))
            else:
                table[name.text] = item

    def import_into(self, table: dict, item: ast.Import, from_dir: Path) -> None:
        path = self.resolve(item.path, from_dir)
        alias = (item.alias.text if item.alias else item.path.parts[-1].text)
        if path is None:
            self.diags.error(f"cannot find module '{item.path.dotted}' (looked for "
                             f"{'/'.join(p.text for p in item.path.parts)}{SUFFIX} next to this file and in the "
                             f"library)", item.path.span)
            return
        if path.resolve() in self._loading:
            self.diags.error(f"import cycle: '{item.path.dotted}' imports this file again", item.path.span)
            return
        module = self.load_path(path, item.path.dotted)
        if module is not None:
            table[alias] = module


def _shown_path(path: Path) -> str:
    """Paths in messages: relative to the working directory when below it, else as given."""
    try:
        return str(path.resolve().relative_to(Path.cwd()))
    except ValueError:
        return str(path)
