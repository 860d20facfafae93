"""The members of an interaction (joint, force elements, sensors) checked against catalog.py."""

from __future__ import annotations

from typing import TYPE_CHECKING

from . import ast, catalog
from . import expr as X
from . import model as M
from . import units as U
from .expressions import ExprResolver, Invalid
from .quaternions import QUATERNION_COMPONENTS, QUATERNION_SPEED_OF
from .scope import InteractEntry, Scope, did_you_mean

if TYPE_CHECKING:
    from .context import ElaborationContext

# Rotational axes transform as axial vectors under mirroring (joint angles keep their sign on both sides);
# translational ones as polar vectors.
AXIAL_AXES = {("revolute", "axis"), ("universal", "axis1"), ("universal", "axis2"), ("planar", "normal")}


def _match_args(elab: "ElaborationContext", scope: Scope, args, spec: tuple[catalog.Arg, ...], what: str,
                span, extra: bool = False) -> dict[str, ast.Expr]:
    """Positional then named arguments against a kind's argument list; reports unknown and missing ones."""
    names = [a.name for a in spec]
    matched: dict[str, ast.Expr] = {}
    positional = [a for a in args if not isinstance(a, ast.Kwarg)]
    if len(positional) > len(spec):
        elab.diags.error(f"{what} takes at most {len(spec)} positional argument(s)", scope.at(positional[len(spec)].span))
    for arg_spec, node in zip(spec, positional):
        matched[arg_spec.name] = node
    for a in args:
        if not isinstance(a, ast.Kwarg):
            continue
        if a.name.text in matched:
            elab.diags.error(f"argument '{a.name.text}' is given twice", scope.at(a.name.span))
        elif a.name.text not in names and not extra:
            hint = did_you_mean(a.name.text, names)
            shown = ", ".join(names) if names else "none"
            elab.diags.error(f"{what} has no argument '{a.name.text}'{hint} (arguments: {shown})",
                             scope.at(a.name.span))
        else:
            matched[a.name.text] = a.value
    for arg_spec in spec:
        if arg_spec.name not in matched and arg_spec.default is None and not arg_spec.optional:
            elab.diags.error(f"{what} needs the argument '{arg_spec.name}'", scope.at(span))
    return matched


def _word(elab, scope, node, arg: catalog.Arg) -> str:
    value = node.ref.dotted if isinstance(node, ast.Name) else (node.value if isinstance(node, ast.String) else None)
    if value not in arg.choices:
        elab.diags.error(f"'{arg.name}' must be one of {', '.join(arg.choices)}", scope.at(node.span))
        raise Invalid()
    return value


def _flag(elab, scope, node) -> bool:
    if isinstance(node, ast.Name) and node.ref.dotted in ("true", "false"):
        return node.ref.dotted == "true"
    elab.diags.error("expected true or false", scope.at(node.span))
    raise Invalid()


# ------------------------------------------------------------------------------------------ joints
def build_joint(elab: "ElaborationContext", scope: Scope, entry: InteractEntry, st: ast.Joint) -> M.Joint | None:
    kind = catalog.JOINTS.get(st.kind.text)
    if kind is None:
        elab.diags.error(f"unknown joint kind '{st.kind.text}'{did_you_mean(st.kind.text, catalog.JOINTS)} "
                         f"(kinds: {', '.join(catalog.JOINTS)})", scope.at(st.kind.span))
        return None
    args = _match_args(elab, scope, st.args, kind.args, f"joint '{kind.name}'", st.span)
    axes, rotation, cut = [], "", None
    try:
        for arg in kind.args:
            node = args.get(arg.name)
            if arg.kind == "axis":
                axial = (kind.name, arg.name) in AXIAL_AXES
                if node is None:
                    from . import geometry as G
                    vec = G.const_vec(G.UNIT_AXES[arg.default])
                    axes.append(G.mirror_axial(scope.signs, vec) if axial else G.mirror_vec(scope.signs, vec))
                else:
                    axes.append(elab.axis(scope, node, f"the {arg.name} of a {kind.name} joint", axial=axial))
            elif arg.name == "rotation":
                rotation = _word(elab, scope, node, arg) if node is not None else arg.default
            elif arg.name == "cut" and node is not None:
                cut = _flag(elab, scope, node)
    except Invalid:
        return None
    coordinates = _coordinates(elab, scope, entry, st, kind.name, rotation)
    if kind.name == "planar" and len(axes) == 2:
        _check_perpendicular(elab, scope, axes, st)
    return M.Joint(kind.name, tuple(axes), rotation, tuple(coordinates), cut, scope.at(st.span))


def _check_perpendicular(elab, scope, axes, st) -> None:
    n, u = axes
    if all(isinstance(c, X.Const) for c in n + u):
        dot = sum(a.value * b.value for a, b in zip(n, u))
        if abs(dot) > 1e-9:
            elab.diags.error("the direction of a planar joint must be perpendicular to its normal", scope.at(st.span))


def _coordinates(elab, scope: Scope, entry: InteractEntry, st: ast.Joint, kind: str, rotation: str):
    coords = catalog.joint_coordinates(kind, rotation)
    local_names = [c[0] for c in coords]
    speeds = catalog.speed_names(kind, rotation)
    inits: dict[str, X.E] = {}
    speed_inits: dict[str, X.E] = {}
    prescribed: dict[str, X.E] = {}
    dims = dict(coords)
    for s in st.statements:
        target = s.target.dotted
        if isinstance(s, ast.Init):
            is_speed = s.derivative or (target in speeds and target not in local_names)
            if s.derivative and target in QUATERNION_COMPONENTS and target in local_names:
                elab.diags.error(f"der({target}) is not a speed of a quaternion joint: the derivative of a quaternion "
                                 "component is not an angular velocity; set the angular velocity in frame b: "
                                 "wx, wy, wz", scope.at(s.target.span))
                continue
            if s.derivative and target in QUATERNION_SPEED_OF.values() and "qw" in local_names:
                elab.diags.error(f"'{target}' is a speed already: init {target} = ...", scope.at(s.target.span))
                continue
            valid = speeds if is_speed else local_names
            if target not in valid:
                elab.diags.error(f"a {kind} joint has no {'speed' if is_speed else 'coordinate'} '{target}'"
                                 f"{did_you_mean(target, valid)} (coordinates: {', '.join(local_names)})",
                                 scope.at(s.target.span))
                continue
            wanted = _speed_dim(dims, target) if is_speed else dims[target]
            value = _constant_expr(elab, scope, s.value, wanted, f"the initial value of '{target}'")
            if value is not None:
                (speed_inits if is_speed else inits)[target] = value
        else:
            if target not in local_names:
                elab.diags.error(f"a {kind} joint has no coordinate '{target}'{did_you_mean(target, local_names)}",
                                 scope.at(s.target.span))
                continue
            if kind in ("spherical", "free") and target.startswith("q"):
                elab.diags.error("quaternion coordinates cannot be prescribed; use rotation = cardan",
                                 scope.at(s.target.span))
                continue
            r = ExprResolver(elab, scope, what=f"the prescribed motion of '{target}'")
            try:
                value, dim = r.scalar(s.value)
            except Invalid:
                continue
            bad = [sym for sym in X.symbols(value) if sym.kind in ("coord", "speed", "sensor")]
            if bad:
                elab.diags.error("a prescribed motion is a function of time and parameters only "
                                 f"(it uses '{bad[0].name}')", scope.at(s.value.span))
                continue
            r.expect(dim, dims[target], s.value.span, f"the motion of '{target}'")
            prescribed[target] = value
    out = []
    for local, dim in coords:
        default = X.ONE if local == "qw" else X.ZERO
        speed_name = {"qx": "wx", "qy": "wy", "qz": "wz"}.get(local, local)
        if local == "qw":
            speed_name = ""
        out.append(M.Coordinate(f"{entry.full}.{local}", local, dim, inits.get(local, default),
                                speed_inits.get(speed_name, X.ZERO), prescribed.get(local), scope.at(st.span)))
    return out


def _speed_dim(dims, name):
    if name in ("wx", "wy", "wz"):
        return U.ANGULAR_VELOCITY
    return dims[name] / U.TIME


def _constant_expr(elab, scope, node, wanted, what):
    r = ExprResolver(elab, scope, allow_state=False, what=what)
    try:
        value, dim = r.scalar(node)
    except Invalid:
        return None
    r.expect(dim, wanted, node.span, what)
    return value


# ------------------------------------------------------------------------------------------ forces
def _interaction_locals(entry: InteractEntry) -> dict:
    """Inside an interaction its own coordinates are visible by their short names: joint(phi = -d*der(phi))."""
    out = {}
    for local, dim in entry.coordinates.items():
        out[local] = (X.Sym("coord", f"{entry.full}.{local}"), dim)
    return out


def build_forces(elab: "ElaborationContext", scope: Scope, entry: InteractEntry, st: ast.Interact, a: M.FrameRef):
    forces = []
    count = 0
    for member in st.members:
        if not isinstance(member, ast.Force):
            continue
        count += 1
        kind = catalog.FORCES.get(member.kind.text)
        if kind is None:
            elab.diags.error(f"unknown force kind '{member.kind.text}'{did_you_mean(member.kind.text, catalog.FORCES)}"
                             f" (kinds: {', '.join(catalog.FORCES)})", scope.at(member.kind.span))
            continue
        name = member.name.text if member.name else f"{kind.name}{count}"
        try:
            args = _element_args(elab, scope, entry, member, kind, f"force '{kind.name}'")
        except Invalid:
            continue
        if kind.name == "point" and "force" not in args and "torque" not in args:
            elab.diags.error("a point force needs force = (...) or torque = (...)", scope.at(member.span))
            continue
        forces.append(M.Force(f"{entry.full}.{name}", kind.name, tuple(args.items()), scope.at(member.span)))
    return tuple(forces)


def _element_args(elab, scope, entry, member, kind: catalog.ElementKind, what) -> dict:
    matched = _match_args(elab, scope, member.args, kind.args, what, member.span, extra=kind.extra_args)
    spec = {a.name: a for a in kind.args}
    out: dict[str, object] = {}
    locals_ = _interaction_locals(entry)
    ok = True
    for name, node in matched.items():
        arg = spec.get(name)
        try:
            if arg is None:  # joint force: one generalized force per coordinate
                if name not in entry.coordinates:
                    elab.diags.error(f"the joint of this interaction has no coordinate '{name}'"
                                     f"{did_you_mean(name, entry.coordinates)}", scope.at(node.span))
                    ok = False
                    continue
                r = ExprResolver(elab, scope, locals_, what="a force law", interaction=entry)
                value, dim = r.scalar(node)
                coord_dim = entry.coordinates[name]
                r.expect(dim, U.TORQUE if coord_dim == U.ANGLE else U.FORCE, node.span, f"the force on '{name}'")
                out[name] = value
            elif arg.kind in ("scalar", "law"):
                extra = {n: (X.Sym("local", n), d) for n, d in kind.locals} if arg.kind == "law" else {}
                r = ExprResolver(elab, scope, {**locals_, **extra}, what="a force law", interaction=entry)
                value, dim = r.scalar(node)
                r.expect(dim, arg.dimension, node.span, f"'{name}'")
                out[name] = value
            elif arg.kind == "vector":
                r = ExprResolver(elab, scope, locals_, what="a force law", interaction=entry)
                vec, dim = r.vector(node, f"'{name}'")
                r.expect(dim, arg.dimension, node.span, f"'{name}'")
                from . import geometry as G
                out[name] = G.mirror_axial(scope.signs, vec) if name == "torque" else G.mirror_vec(scope.signs, vec)
            elif arg.kind == "axis":
                out[name] = elab.axis(scope, node, f"'{name}'")
            elif arg.kind == "flag":
                out[name] = _flag(elab, scope, node)
            elif arg.kind == "frame":
                if not isinstance(node, ast.Name):
                    elab.diags.error(f"'{name}' takes a frame, such as inertial or part.frame", scope.at(node.span))
                    ok = False
                    continue
                ref = elab.frame_ref(scope, node.ref)
                if ref is None:
                    ok = False
                    continue
                out[name] = ref
            elif arg.kind == "word":
                if arg.choices:
                    out[name] = _word(elab, scope, node, arg)
                elif isinstance(node, ast.Name):
                    out[name] = node.ref.dotted
                else:
                    elab.diags.error(f"'{name}' takes a name", scope.at(node.span))
                    ok = False
        except Invalid:
            ok = False
    for arg in kind.args:
        if arg.name not in out and arg.default is not None and arg.kind in ("scalar", "word"):
            out[arg.name] = X.const(arg.default) if arg.kind == "scalar" else arg.default
    if not ok:
        raise Invalid()
    return out


# ------------------------------------------------------------------------------------------ sensors
def build_sensors(elab: "ElaborationContext", scope: Scope, entry: InteractEntry, st: ast.Interact):
    sensors = []
    for member in st.members:
        if not isinstance(member, ast.Sensor):
            continue
        kind = catalog.SENSORS.get(member.kind.text)
        if kind is None:
            elab.diags.error(f"unknown sensor kind '{member.kind.text}'"
                             f"{did_you_mean(member.kind.text, catalog.SENSORS)} (kinds: {', '.join(catalog.SENSORS)})",
                             scope.at(member.kind.span))
            continue
        try:
            args = _element_args(elab, scope, entry, member, kind, f"sensor '{kind.name}'")
        except Invalid:
            continue
        if kind.name in ("force", "tyre"):
            element = args.get("element")
            if element is None and len(entry.forces) == 1:
                element = next(iter(entry.forces))
            if element not in entry.forces:
                elab.diags.error("a force sensor names one force element of its interaction: "
                                 f"force(element = name){did_you_mean(str(element), entry.forces)}",
                                 scope.at(member.span))
                continue
            if kind.name == "tyre" and entry.forces[element] != "tyre":
                elab.diags.error(f"a tyre sensor reads a tyre force element, and '{element}' is a "
                                 f"{entry.forces[element]} force", scope.at(member.span))
                continue
            args["element"] = f"{entry.full}.{element}"
        if kind.name in ("joint", "reaction") and not any(isinstance(m, ast.Joint) for m in st.members):
            elab.diags.error(f"a {kind.name} sensor needs a joint in its interaction", scope.at(member.span))
            continue
        components = entry.sensors.get(member.name.text, (kind.name, kind.components))[1]
        sensors.append(M.Sensor(f"{entry.full}.{member.name.text}", kind.name, tuple(args.items()), components,
                                scope.at(member.span)))
    return tuple(sensors)
