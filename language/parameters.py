"""Parameters: their dimensions and default values, resolved lazily so declaration order is free.

Part of the elaborator (mixed into Elaborator). A parameter's default may refer to other parameters (also
of other instances and modules); cycles are located errors.
"""

from __future__ import annotations

from . import expr as X
from . import model as M
from .diagnostics import Span
from .expressions import ExprResolver, Invalid
from .scope import InputEntry, InstanceEntry, Module, ParamEntry, Scope
from .units import unit_text


class ParameterMixin:
    def param_dimension(self, entry: ParamEntry):
        key = id(entry)
        if key in self._param_dims:
            return self._param_dims[key]
        if key in self._resolving:
            self.diags.error(f"parameter '{entry.full}' depends on itself", self._entry_scope_span(entry))
            self._cyclic.add(entry.full)
            return None
        self._resolving.add(key)
        try:
            expr_node, scope = entry.decl.value, self._scope_of_entry(entry)
            if entry.override is not None:
                expr_node, scope = entry.override, entry.override_scope
            r = ExprResolver(self, scope, allow_state=False, what=f"parameter '{entry.full}'")
            value, dim = r.scalar(expr_node)
            if entry.override is not None:
                own_dim = ExprResolver(self, self._scope_of_entry(entry), allow_state=False,
                                       what=f"parameter '{entry.full}'").scalar(entry.decl.value)[1]
                r.expect(dim, own_dim, expr_node.span, f"parameter '{entry.decl.name.text}'")
                dim = own_dim if own_dim is not None else dim
        except Invalid:
            value, dim = X.ZERO, None
        finally:
            self._resolving.discard(key)
        self._param_dims[key] = dim
        self._param_exprs[entry.full] = value
        self._param_spans[entry.full] = (self._entry_scope_span(entry), entry.decl.description, dim)
        self._param_units[entry.full] = unit_text(dim, getattr(entry.decl.value, "unit", None))
        return dim

    def module_param(self, module: Module, name: str, span, scope: Scope):
        """A file-level parameter: shared by every block of the file (and of files that import it)."""
        decl = module.params[name]
        full = name if module.path == self.root.module.path else f"{module.dotted}.{name}"
        entry = self._module_entries().setdefault(full, ParamEntry(full, decl))
        entry.used = True
        if id(entry) not in self._param_dims:
            self._module_param_scope[id(entry)] = self.module_scope(module)
        return X.Sym("param", full), self.param_dimension(entry)

    def _module_entries(self) -> dict:
        if not hasattr(self, "_module_param_entries"):
            self._module_param_entries: dict[str, ParamEntry] = {}
            self._module_param_scope: dict[int, Scope] = {}
        return self._module_param_entries

    def _scope_of_entry(self, entry: ParamEntry) -> Scope:
        self._module_entries()
        if id(entry) in self._module_param_scope:
            return self._module_param_scope[id(entry)]
        return self._find_scope(self.root, entry) or self.root

    def _find_scope(self, scope: Scope, entry) -> Scope | None:
        if any(e is entry for e in scope.entries.values()):
            return scope
        for e in scope.entries.values():
            if isinstance(e, InstanceEntry):
                found = self._find_scope(e.scope, entry)
                if found:
                    return found
        return None

    def _entry_scope_span(self, entry: ParamEntry) -> Span:
        scope = self._scope_of_entry(entry)
        return scope.at(entry.decl.name.span)

    def input_dimension(self, entry: InputEntry):
        scope = self._find_scope(self.root, entry) or self.root
        try:
            return ExprResolver(self, scope, what=f"input '{entry.full}'").scalar(entry.decl.value)[1]
        except Invalid:
            return None

    def constant(self, e: X.E, scope: Scope, span) -> float:
        """Numeric value of a constant expression with parameter defaults (for checks and tables)."""
        try:
            return X.evaluate(e, self.values_for(e))
        except X.EvaluationError as exc:
            self.diags.error(f"cannot evaluate this value: {exc}", scope.at(span))
            raise Invalid() from None

    def values_for(self, e: X.E) -> dict[str, float]:
        env: dict[str, float] = {}
        for sym in X.symbols(e):
            if sym.kind == "param":
                env[sym.name] = self.param_value(sym.name)
        return env

    def param_value(self, full: str, depth: int = 0) -> float:
        if full in self._values:
            return self._values[full]
        e = self._param_exprs.get(full, X.ZERO)
        if depth > 200:
            raise X.EvaluationError(f"parameter '{full}' depends on itself")
        env = {s.name: self.param_value(s.name, depth + 1) for s in X.symbols(e) if s.kind == "param"}
        value = X.evaluate(e, env)
        self._values[full] = value
        return value

    def parameters(self) -> tuple[M.Parameter, ...]:
        out = []
        for full, e in self._param_exprs.items():
            span, description, dim = self._param_spans[full]
            try:
                value = self.param_value(full)
            except X.EvaluationError as exc:
                if not self._cyclic:  # a cycle is reported once, where it is found
                    self.diags.error(f"parameter '{full}' cannot be evaluated: {exc}", span)
                value = float("nan")
            kind = "mode" if full in getattr(self, "mode_names", ()) else "param"
            out.append(M.Parameter(full, e, value, dim, description, span, self._param_units.get(full), kind))
        return tuple(out)
