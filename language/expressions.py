"""AST expressions -> model expressions in SI, with names resolved and dimensions checked.

Dimension rules: a literal with a unit has that unit's dimension; a bare number has none ("free": it
takes the dimension its context needs, so the data sheet's `35906 * (L - 0.152)` reads naturally), and so
does a parameter whose default is a bare number. Everything else is checked: adding a length to a mass, a
sine of a length, or a mass where a stiffness belongs is a located error.
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import TYPE_CHECKING

from . import ast
from . import catalog
from . import expr as X
from . import tables
from . import units as U
from .hooks import HookEntry
from .hooks import call as hook_call
from .scope import (FuncEntry, ImportEntry, InputEntry, InstanceEntry, InteractEntry, OutputEntry, ParamEntry,
                    PartEntry, PortEntry, Scope, StateEntry, did_you_mean)

if TYPE_CHECKING:
    from .context import ElaborationContext

Dim = U.Dimension | None  # None: free (a bare number)
SENSOR_DIMENSIONS = {
    "position": U.LENGTH, "velocity": U.VELOCITY, "acceleration": U.ACCELERATION, "angles": U.ANGLE,
    "distance": U.LENGTH, "force": U.FORCE,
}
# Sensors that depend on accelerations cannot feed forces (the forces determine the accelerations).
ACCELERATION_SENSORS = ("acceleration", "reaction")
BUILTIN_CONSTANTS = {"pi": math.pi}


class Invalid(Exception):
    """An expression could not be resolved; the diagnostic has already been reported."""


class ExprResolver:
    """Resolves expressions of one scope. ``locals_`` are names bound by a function or a force law."""

    def __init__(self, elab: "ElaborationContext", scope: Scope, locals_: dict[str, tuple[X.E, Dim]] | None = None,
                 allow_state: bool = True, allow_acceleration: bool = False, what: str = "expression",
                 interaction: InteractEntry | None = None):
        self.elab, self.scope, self.interaction = elab, scope, interaction
        self.locals = locals_ or {}
        self.allow_state, self.allow_acceleration, self.what = allow_state, allow_acceleration, what
        # Set by a caller that takes a whole vector sensor (`output hinge.load`): instead of an error, the
        # sensor's components are recorded here as (component, expression, dimension).
        self.vector_components: list | None = None

    def error(self, message: str, span) -> Invalid:
        self.elab.diags.error(message, self.scope.at(span))
        return Invalid()

    # -------------------------------------------------------------------------------------- scalars
    def scalar(self, node: ast.Expr) -> tuple[X.E, Dim]:
        try:
            value, dim = self._scalar(node)
        except OverflowError:
            raise self.error("this value overflows: its magnitude is beyond 1.8e308", node.span) from None
        if isinstance(value, X.Const) and not math.isfinite(value.value):
            raise self.error(f"this value is not a finite number ({value.value}): its magnitude is beyond 1.8e308",
                             node.span)
        return value, dim

    def _scalar(self, node: ast.Expr) -> tuple[X.E, Dim]:
        if isinstance(node, ast.Number):
            value = _number(node.text)
            if node.unit is None:
                return X.const(value), None
            factor, dim = self.unit(node.unit, node.unit_span)
            return X.const(value * factor), dim
        if isinstance(node, ast.WithUnit):
            factor, dim = self.unit(node.unit, node.unit_span)
            inner, inner_dim = self.scalar(node.expr)
            return self._with_unit(inner, inner_dim, factor, dim, node)
        if isinstance(node, ast.Name):
            return self.name(node.ref)
        if isinstance(node, ast.Unary):
            value, dim = self.scalar(node.operand)
            if node.op == "-":
                return X.neg(value), dim
            if node.op == "not":
                return X.Op("not", (value,)), U.DIMENSIONLESS
            return value, dim
        if isinstance(node, ast.Binary):
            return self.binary(node)
        if isinstance(node, ast.Call):
            return self.call(node)
        if isinstance(node, ast.Vector):
            raise self.error(f"expected a single value here, got a vector of {len(node.items)} components", node.span)
        if isinstance(node, ast.Matrix):
            raise self.error("expected a single value here, got a list", node.span)
        if isinstance(node, ast.String):
            raise self.error("expected a number here, got a string", node.span)
        raise self.error("unsupported expression", node.span)

    def unit(self, text: str, span) -> tuple[float, U.Dimension]:
        try:
            return U.parse_unit(text)
        except U.UnitError as exc:
            start = span.start + exc.offset
            from .diagnostics import Span
            bad = Span.at(span.source, start, start + max(1, exc.length))
            raise self.error(exc.message, bad) from None

    def _with_unit(self, value: X.E, dim: Dim, factor: float, unit_dim: U.Dimension, node) -> tuple[X.E, Dim]:
        """A unit after a bracket applies to what has no unit yet: in `(x_axle, 0.1585, 0.6) m` the
        numbers are metres and the length parameter stays as it is. A value that already carries the
        unit's dimension is accepted only for SI units, where no scaling can be misread."""
        if dim is None or (dim.is_dimensionless and not unit_dim.is_dimensionless):
            return X.mul(value, X.const(factor)), unit_dim
        if dim == unit_dim and factor == 1.0:
            return value, dim
        raise self.error(f"the unit '{node.unit}' applies to a value that already has a unit "
                         f"({U.describe(dim)}); write the unit on the numbers inside", node.unit_span)

    def binary(self, node: ast.Binary) -> tuple[X.E, Dim]:
        left, ld = self.scalar(node.left)
        right, rd = self.scalar(node.right)
        op = node.op
        if op in ("+", "-") or op in ("<", "<=", ">", ">=", "==", "!="):
            dim = self.same(ld, rd, node, "add" if op in "+-" else "compare")
            if op == "+":
                return X.add(left, right), dim
            if op == "-":
                return X.add(left, X.neg(right)), dim
            return X.Op(op, (left, right)), U.DIMENSIONLESS
        if op in ("and", "or"):
            return X.Op(op, (left, right)), U.DIMENSIONLESS
        if op == "*":
            return X.mul(left, right), _mul_dim(ld, rd, left, right)
        if op == "/":
            if right == X.ZERO:
                raise self.error("division by zero", node.right.span)
            if isinstance(left, X.Const) and isinstance(right, X.Const):
                value = X.const(left.value / right.value)
            else:
                value = X.Op("/", (left, right))
            return value, _mul_dim(ld, _inverse(rd), left, right)
        if op == "^":
            return self.power(left, ld, right, rd, node)
        raise self.error(f"unknown operator '{op}'", node.span)

    def power(self, base, bd, exponent, ed, node) -> tuple[X.E, Dim]:
        if ed is not None and not ed.is_dimensionless:
            raise self.error(f"an exponent must be dimensionless, not {U.describe(ed)}", node.right.span)
        value = X.const(base.value ** exponent.value) if isinstance(base, X.Const) and isinstance(exponent, X.Const) \
            and (base.value > 0 or float(exponent.value).is_integer()) else X.Op("^", (base, exponent))
        if bd is None or bd.is_dimensionless:
            return value, bd
        if not isinstance(exponent, X.Const):
            raise self.error(f"a quantity with a unit ({U.describe(bd)}) can only be raised to a constant power",
                             node.span)
        result = _dim_pow(bd, Fraction(exponent.value).limit_denominator(12))
        if result is None:
            raise self.error(f"{U.describe(bd)} raised to {exponent.value:g} has no physical unit", node.span)
        return value, result

    def same(self, a: Dim, b: Dim, node, verb: str) -> Dim:
        if a is None:
            return b
        if b is None or a == b:
            return a
        raise self.error(f"cannot {verb} {U.describe(a)} and {U.describe(b)}", node.span)

    def expect(self, dim: Dim, wanted: U.Dimension | None, span, what: str) -> None:
        """Check a slot of known dimension (a mass, a stiffness, ...)."""
        if wanted is None or dim is None or dim == wanted:
            return
        wanted_text = U.describe(wanted)
        if wanted.is_dimensionless:
            wanted_text = "an angle or a plain number (rad, deg or no unit)"
        self.elab.diags.error(f"{what} must be {wanted_text}, but this is {U.describe(dim)}", self.scope.at(span))

    # -------------------------------------------------------------------------------------- names
    def name(self, ref: ast.Ref) -> tuple[X.E, Dim]:
        first, rest = ref.parts[0], ref.parts[1:]
        if not rest and first.text in self.locals:
            return self.locals[first.text]
        own = self.interaction
        if own is not None and (first.text in own.sensors or (rest and first.text in own.coordinates)):
            # inside an interaction its own sensors are visible by their short names: centre.z
            return self.interaction_member(own, first, ref.parts, ref)
        scope = self.scope
        entry = scope.lookup(first.text)
        if entry is None and not rest:
            if first.text == "t":
                self.state_used(ref)
                return X.TIME, U.TIME
            if first.text in BUILTIN_CONSTANTS:
                return X.const(BUILTIN_CONSTANTS[first.text]), U.DIMENSIONLESS
            if first.text in scope.module.params:
                return self.elab.module_param(scope.module, first.text, ref.span, scope)
        if entry is None:
            candidates = scope.visible_names() + list(self.locals) + ["t", "pi"]
            raise self.error(f"unknown name '{first.text}'{did_you_mean(first.text, candidates)}", first.span)
        return self.entry_value(entry, first, rest, ref)

    def entry_value(self, entry, head: ast.Ident, rest, ref: ast.Ref) -> tuple[X.E, Dim]:
        if isinstance(entry, ParamEntry):
            if rest:
                raise self.error(f"'{head.text}' is a parameter and has no member '{rest[0].text}'", rest[0].span)
            entry.used = True
            return X.Sym("param", entry.full), self.elab.param_dimension(entry)
        if isinstance(entry, OutputEntry):
            if rest:
                raise self.error(f"'{head.text}' is an output and has no member '{rest[0].text}'", rest[0].span)
            return self.elab.output_value(entry, ref.span)
        if isinstance(entry, InputEntry) and entry.override is not None:
            # an input connected at instantiation is the user's expression, in the user's scope
            entry.used = True
            return ExprResolver(self.elab, entry.override_scope, None, self.allow_state,
                                self.allow_acceleration, self.what).scalar(entry.override)
        if isinstance(entry, InputEntry):
            entry.used = True
            self.state_used(ref)
            return X.Sym("input", entry.full), self.elab.input_dimension(entry)
        if isinstance(entry, StateEntry):
            if rest:
                raise self.error(f"'{head.text}' is a state and has no member '{rest[0].text}'", rest[0].span)
            self.state_used(ref)
            return X.Sym("state", entry.full), state_value(self.elab, entry)[1]
        if isinstance(entry, InteractEntry):
            return self.interaction_member(entry, head, rest, ref)
        if isinstance(entry, InstanceEntry):
            if not rest:
                raise self.error(f"'{head.text}' is a component instance, not a value", head.span)
            inner = entry.scope.lookup(rest[0].text)
            if inner is None or isinstance(inner, (ImportEntry, FuncEntry)):
                raise self.error(f"instance '{head.text}' has no '{rest[0].text}'"
                                 f"{did_you_mean(rest[0].text, entry.scope.entries)}", rest[0].span)
            inside = ExprResolver(self.elab, entry.scope, None, self.allow_state, self.allow_acceleration, self.what)
            inside.vector_components = self.vector_components  # a vector sensor of the instance expands too
            return inside.entry_value(inner, rest[0], rest[1:], ref)
        if isinstance(entry, ImportEntry):
            if len(rest) == 1 and rest[0].text in entry.module.params:
                return self.elab.module_param(entry.module, rest[0].text, ref.span, self.scope)
            raise self.error(f"module '{head.text}' has no parameter '{rest[0].text if rest else ''}'", ref.span)
        if isinstance(entry, FuncEntry):
            raise self.error(f"'{head.text}' is a function: call it as {head.text}(...)", ref.span)
        if isinstance(entry, (PartEntry, PortEntry)):
            raise self.error(f"'{head.text}' is a part, not a value: measure it with a sensor", ref.span)
        raise self.error(f"'{ref.dotted}' is not a value", ref.span)

    def interaction_member(self, entry: InteractEntry, head, rest, ref) -> tuple[X.E, Dim]:
        if not rest:
            raise self.error(f"'{head.text}' is an interaction: name one of its coordinates or sensors, "
                             f"e.g. {head.text}.{next(iter(entry.coordinates or entry.sensors or {'phi': 0}))}",
                             ref.span)
        member = rest[0].text
        self.state_used(ref)
        if member in entry.coordinates and len(rest) == 1:
            return X.Sym("coord", f"{entry.full}.{member}"), entry.coordinates[member]
        if member in entry.speeds and len(rest) == 1:
            return X.Sym("speed", f"{entry.full}.{member}"), entry.speeds[member]
        if member in entry.sensors:
            kind, components = entry.sensors[member]
            if kind in ACCELERATION_SENSORS and not self.allow_acceleration:
                raise self.error(f"sensor '{ref.dotted}' depends on accelerations and cannot be used in {self.what}",
                                 ref.span)
            dim = entry.sensor_dims.get(member, SENSOR_DIMENSIONS.get(kind))
            if components == ("",) and len(rest) == 1:
                return X.Sym("sensor", f"{entry.full}.{member}"), dim
            if len(rest) == 1 and components and self.vector_components is not None:
                self.vector_components[:] = [
                    (c, X.Sym("sensor", f"{entry.full}.{member}.{c}"),
                     (U.FORCE if c.startswith("f") else U.TORQUE) if kind == "reaction"
                     else catalog.TYRE_OUTPUTS[c] if kind == "tyre" else dim)
                    for c in components]
                return self.vector_components[0][1:]
            if len(rest) == 2 and rest[1].text in components:
                if kind == "tyre":
                    dim = catalog.TYRE_OUTPUTS[rest[1].text]
                if kind == "reaction":
                    dim = U.FORCE if rest[1].text.startswith("f") else U.TORQUE
                return X.Sym("sensor", f"{entry.full}.{member}.{rest[1].text}"), dim
            shown = ", ".join(components) if components != ("",) else "none: it is a scalar"
            raise self.error(f"sensor '{head.text}.{member}' has components {shown}", ref.span)
        names = list(entry.coordinates) + list(entry.sensors)
        raise self.error(f"interaction '{head.text}' has no coordinate or sensor '{member}'"
                         f"{did_you_mean(member, names)}", rest[0].span)

    def state_used(self, ref) -> None:
        if not self.allow_state:
            raise self.error(f"{self.what} must be constant: it cannot depend on time or on the motion "
                             f"('{ref.dotted if hasattr(ref, 'dotted') else ref}')", ref.span)

    # -------------------------------------------------------------------------------------- calls
    def call(self, node: ast.Call) -> tuple[X.E, Dim]:
        fname = node.func.dotted
        if fname == "der":
            return self.derivative(node)
        if fname == "lookup":
            return self.lookup_table(node)
        if fname == "iso8608":
            return self.random_road(node)
        entry = self.scope.lookup(node.func.parts[0].text)
        func = None
        if isinstance(entry, FuncEntry) and len(node.func.parts) == 1:
            func = (entry.decl, entry.scope)
        elif isinstance(entry, ImportEntry) and len(node.func.parts) == 2:
            decl = entry.module.funcs.get(node.func.parts[1].text)
            if decl is not None:
                func = (decl, self.elab.module_scope(entry.module))
        elif entry is None and fname in self.scope.module.funcs:
            func = (self.scope.module.funcs[fname], self.elab.module_scope(self.scope.module))
        if func is not None:
            return self.user_function(node, *func)
        if isinstance(entry, HookEntry):
            return hook_call(self, node, entry)
        if fname not in X.FUNCTIONS:
            candidates = list(X.FUNCTIONS) + ["der", "lookup"] + [n for n, e in self.scope.entries.items()
                                                                  if isinstance(e, FuncEntry)]
            raise self.error(f"unknown function '{fname}'{did_you_mean(fname, candidates)}", node.func.span)
        arity = X.FUNCTIONS[fname][0]
        if node.kwargs:
            raise self.error(f"{fname}() takes no named arguments", node.kwargs[0].span)
        if len(node.args) != arity:
            raise self.error(f"{fname}() takes {arity} argument{'s' if arity > 1 else ''}, got {len(node.args)}",
                             node.span)
        args = [self.scalar(a) for a in node.args]
        return self.builtin(fname, args, node)

    def builtin(self, fname, args, node) -> tuple[X.E, Dim]:
        values = tuple(a[0] for a in args)
        dims = [a[1] for a in args]
        if fname == "if":
            dim = self.same(dims[1], dims[2], node, "choose between")
        elif fname in ("abs", "min", "max", "sign"):
            dim = dims[0] if fname in ("abs", "sign") else self.same(dims[0], dims[1], node, "compare")
            dim = U.DIMENSIONLESS if fname == "sign" else dim
        elif fname == "atan2":
            self.same(dims[0], dims[1], node, "compare")
            dim = U.DIMENSIONLESS
        elif fname == "sqrt":
            dim = None if dims[0] is None else _dim_pow(dims[0], Fraction(1, 2))
            if dims[0] is not None and dim is None:
                raise self.error(f"the square root of {U.describe(dims[0])} has no physical unit", node.span)
        elif fname == "smoothstep":
            self.same(self.same(dims[0], dims[1], node, "compare"), dims[2], node, "compare")
            dim = U.DIMENSIONLESS
        else:
            for d, a in zip(dims, node.args):
                if d is not None and not d.is_dimensionless:
                    raise self.error(f"{fname}() needs a dimensionless argument, not {U.describe(d)}", a.span)
            dim = U.DIMENSIONLESS
        if all(isinstance(v, X.Const) for v in values):
            try:
                return X.const(X.evaluate(X.Op(fname, values), {})), dim
            except X.EvaluationError as exc:
                raise self.error(f"{fname}(): {exc}", node.span) from None
        return X.Op(fname, values), dim

    def derivative(self, node: ast.Call) -> tuple[X.E, Dim]:
        if len(node.args) != 1 or not isinstance(node.args[0], ast.Name):
            raise self.error("der() takes one joint coordinate, e.g. der(hinge.phi)", node.span)
        value, dim = self.scalar(node.args[0])
        if isinstance(value, X.Sym) and value.kind == "state":  # the right-hand side of its equation
            return X.Sym("rate", value.name), (dim or U.DIMENSIONLESS) / U.TIME
        if not (isinstance(value, X.Sym) and value.kind == "coord"):
            raise self.error("der() applies to joint coordinates and states only", node.args[0].span)
        return X.Sym("speed", value.name), (None if dim is None else dim / U.TIME)

    def lookup_table(self, node: ast.Call) -> tuple[X.E, Dim]:
        """lookup(x, [[x0, y0], [x1, y1], ...], "linear" | "smooth")"""
        if len(node.args) not in (2, 3) or not isinstance(node.args[1], (ast.Matrix, ast.WithUnit)):
            raise self.error('lookup() takes (x, [[x0, y0], [x1, y1], ...], "linear" or "smooth")', node.span)
        x, xd = self.scalar(node.args[0])
        method = "linear"
        if len(node.args) == 3:
            m = node.args[2]
            method = m.value if isinstance(m, ast.String) else (m.ref.dotted if isinstance(m, ast.Name) else "")
            if method not in ("linear", "smooth"):
                raise self.error('interpolation must be "linear" or "smooth"', m.span)
        rows = node.args[1].items if isinstance(node.args[1], ast.Matrix) else ()
        xs, ys, knots, tx, ty = [], [], [], None, None
        for row in rows:
            if not isinstance(row, ast.Matrix) or len(row.items) != 2:
                raise self.error("each table row is a pair [x, y]", row.span)
            (a, ad), (b, bd) = ExprResolver(self.elab, self.scope, None, False, False, "a table entry").scalar(
                row.items[0]), ExprResolver(self.elab, self.scope, None, False, False, "a table entry").scalar(
                row.items[1])
            # checked with the parameters' defaults; kept as expressions where they use parameters
            value_a, value_b = self.elab.constant(a, self.scope, row.span), self.elab.constant(b, self.scope, row.span)
            tx, ty = self.same(tx, ad, row, "mix"), self.same(ty, bd, row, "mix")
            xs.append(value_a)
            ys.append(value_b)
            knots.append((a, b))
        if len(xs) < 2:
            raise self.error("a table needs at least two rows", node.args[1].span)
        if any(b <= a for a, b in zip(xs, xs[1:])):
            raise self.error("table x values must increase strictly", node.args[1].span)
        self.same(xd, tx, node, "look up")
        if any(tables.depends_on_parameters(a) or tables.depends_on_parameters(b) for a, b in knots):
            return tables.parametric_table(x, [a for a, _ in knots], [b for _, b in knots], method), ty
        return X.Table(x, tuple(xs), tuple(ys), method), ty

    def random_road(self, node: ast.Call) -> tuple[X.E, Dim]:
        """iso8608(x, C, seed, length [, track = right, width = 1.23 m, gd = 256e-6 m^3, waviness = 2]): a random
        road of an ISO 8608 class (or of the level gd = Gd(n0)), reproducible by its seed; see language/roads.py."""
        from . import roads
        usage = "iso8608() takes (x, class, seed, length), e.g. iso8608(x, C, 42, 500 m)"
        if len(node.args) != 4:
            raise self.error(usage, node.span)
        x, xd = self.scalar(node.args[0])
        self.same(xd, U.LENGTH, node.args[0], "use")
        cls = node.args[1]
        letter = cls.ref.dotted if isinstance(cls, ast.Name) else (cls.value if isinstance(cls, ast.String) else "")
        if letter not in roads.CLASSES:
            raise self.error(f"an ISO 8608 road class is one of {', '.join(roads.CLASSES)}", cls.span)
        constant = ExprResolver(self.elab, self.scope, None, False, False, "a road definition")

        def value(expr, dim, what=None):
            e, d = constant.scalar(expr)
            if dim is not None:
                self.same(d, dim, expr, "use")
            if tables.depends_on_parameters(e):  # the profile is drawn once, when the model is built
                raise self.error("the seed and length of a random road are fixed when the model is built: give "
                                 "numbers, not parameters (a parameter changed at run time could not reach them)",
                                 expr.span)
            return self.elab.constant(e, self.scope, expr.span)
        seed = value(node.args[2], None)
        length = value(node.args[3], U.LENGTH)
        if seed != int(seed) or seed < 0:
            raise self.error("the seed is a whole number >= 0", node.args[2].span)
        if not 0 < length <= 100_000:
            raise self.error("the road length must be positive and at most 100 km", node.args[3].span)
        options = {"track": "left", "width": 0.0, "waviness": 2.0}
        level: str | float = letter
        for kw in node.kwargs:
            key = kw.name.text
            if key == "track":
                side = kw.value.ref.dotted if isinstance(kw.value, ast.Name) else ""
                if side not in ("left", "right"):
                    raise self.error("track is left or right", kw.value.span)
                options["track"] = side
            elif key == "width":
                options["width"] = value(kw.value, U.LENGTH, key)
            elif key == "waviness":
                options["waviness"] = value(kw.value, U.DIMENSIONLESS, key)
            elif key == "gd":
                level = value(kw.value, U.LENGTH ** 3, key)
                if level <= 0:
                    raise self.error("gd, the PSD at 0.1 cycles/m, must be positive", kw.value.span)
            else:
                raise self.error(f"iso8608() has no option '{key}' (track, width, gd, waviness)", kw.name.span)
        xs, zs = roads.profile(level, int(seed), length, **options)
        return X.Table(x, tuple(float(v) for v in xs), tuple(float(v) for v in zs), "linear"), U.LENGTH

    def user_function(self, node: ast.Call, decl: ast.Func, scope: Scope) -> tuple[X.E, Dim]:
        if len(node.args) != len(decl.params) or node.kwargs:
            raise self.error(f"{decl.name.text}() takes {len(decl.params)} argument(s), got "
                             f"{len(node.args) + len(node.kwargs)}", node.span)
        depth = getattr(self.elab, "_call_depth", 0)
        if depth > 50:
            raise self.error(f"function '{decl.name.text}' calls itself (recursion is not allowed)", node.span)
        bound = {p.text: self.scalar(a) for p, a in zip(decl.params, node.args)}
        self.elab._call_depth = depth + 1
        try:
            inner = ExprResolver(self.elab, scope, bound, self.allow_state, self.allow_acceleration, self.what)
            return inner.scalar(decl.body)
        finally:
            self.elab._call_depth = depth

    # -------------------------------------------------------------------------------------- vectors
    def vector(self, node: ast.Expr, what: str) -> tuple[tuple[X.E, X.E, X.E], Dim]:
        factor, unit_dim, inner = 1.0, None, node
        if isinstance(node, ast.WithUnit):
            factor, unit_dim = self.unit(node.unit, node.unit_span)
            inner = node.expr
        if not isinstance(inner, ast.Vector) or len(inner.items) != 3:
            raise self.error(f"{what} must be a vector of three components, e.g. (0, 0, 1)", node.span)
        comps, dim = [], None
        for item in inner.items:
            value, d = self.scalar(item)
            if unit_dim is not None:
                value, d = self._with_unit(value, d, factor, unit_dim, node)
            dim = self.same(dim, d, item, "mix")
            comps.append(value)
        return tuple(comps), dim  # type: ignore[return-value]


def state_value(elab, entry: StateEntry) -> tuple[X.E | None, Dim]:
    """(initial value, dimension) of a declared state (states.py), resolved once: the initial value is an
    expression of parameters and fixes the state's unit."""
    if entry.resolved is None:
        entry.resolved = (None, None)  # an initial value that names its own state stays unresolved
        r = ExprResolver(elab, entry.scope, allow_state=False, what=f"the initial value of state '{entry.full}'")
        try:
            entry.resolved = r.scalar(entry.decl.value)
        except Invalid:
            pass
    return entry.resolved


def _number(text: str) -> float:
    return float(text)


def _dim_pow(d: U.Dimension, p: Fraction) -> U.Dimension | None:
    exps = [Fraction(e) * p for e in (d.M, d.L, d.T)]
    if any(e.denominator != 1 for e in exps):
        return None
    return U.Dimension(*(int(e) for e in exps))


def _inverse(d: Dim) -> Dim:
    return None if d is None else U.DIMENSIONLESS / d


def _mul_dim(a: Dim, b: Dim, left: X.E, right: X.E) -> Dim:
    """A product with a free operand is free: in `35906 * (Z - 0.1)` the bare number carries the unit N/m
    that the data sheet left unwritten, so nothing can be concluded about the product."""
    if a is None or b is None:
        return None
    return a * b
