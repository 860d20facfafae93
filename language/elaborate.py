"""AST -> validated data model: components expanded, names resolved, units converted and checked.

Three passes over the tree of scopes (the model, and one scope per ``use`` of a component):
  declare  every name of every scope (so statements may appear in any order);
  bind     component ports to frames of the instantiating model (so port frames exist before use);
  build    the data-model objects, resolving every expression.
Problems are reported, not raised, so one run shows all of them; rules.py then checks the finished model.
"""

from __future__ import annotations

from pathlib import Path

from . import ast, catalog
from . import expr as X
from . import geometry as G
from . import hooks
from . import model as M
from . import units as U
from .diagnostics import Diagnostics, Span
from .expressions import ExprResolver, Invalid
from .loader import Loader
from .parameters import ParameterMixin
from .placement import PlacementMixin
from .scope import (FuncEntry, ImportEntry, InputEntry, InstanceEntry, InteractEntry, Module, OutputEntry,
                    ParamEntry, PartEntry, PortEntry, Scope, StateEntry, did_you_mean)
from .units import Dimension

DEFAULT_GRAVITY = (0.0, 0.0, -9.81)  # m/s^2, standard gravity along -z of the inertial frame


class Elaborator(PlacementMixin, ParameterMixin):
    def __init__(self, loader: Loader, diags: Diagnostics):
        self.loader, self.diags = loader, diags
        self._param_dims: dict[int, object] = {}
        self._param_exprs: dict[str, X.E] = {}
        self._param_spans: dict[str, tuple[Span, str | None, Dimension | None]] = {}
        self._param_units: dict[str, str | None] = {}
        self._values: dict[str, float] = {}
        self._resolving: set[int] = set()
        self._module_scopes: dict[Path, Scope] = {}
        self._call_depth = 0
        self._cyclic: set[str] = set()
        self.broken_links: set[tuple[str, str]] = set()
        self.mode_names: set[str] = set()
        self.switches: bool = True  # the model setting `switches = false` turns comparisons and kinks as events off
        self.scene_setting: ast.Setting | None = None  # `scenes = NAME`: run another model file's scenes too

    # ====================================================================================== entry
    def model(self, module: Module, block: ast.Model, harness: bool = False) -> M.Model | None:
        """Elaborate one model (or, with harness=True, a component with its ports bound to the ground)."""
        root = Scope(module, block)
        self.inertial = PartEntry(M.INERTIAL, None, {M.ORIGIN: block.name.span})
        root.entries[M.INERTIAL] = self.inertial
        self.root, self.harness = root, harness
        self.inertial_frames: list[ast.Frame] = []
        self.harness_parts: dict[str, PartEntry] = {}
        self.gravity = None
        self.hook_specs: dict = {}  # user hooks by name (hooks.py: one declaration per name in a model)
        self.declare(root, is_component=block.kind == "component")
        self.bind(root)
        parts, interactions = [], []
        self.part_frames: dict[str, list[M.Frame]] = {}
        self.build(root, parts, interactions)
        inertial = M.Part(M.INERTIAL, tuple(self._frames_of(M.INERTIAL, root, self.inertial_frames, None)), None,
                          "inertial frame", block.span)
        parts.insert(0, inertial)
        for stand_in in self.harness_parts.values():
            parts.append(M.Part(stand_in.full, (M.Frame(M.ORIGIN, G.ZERO_VEC, G.IDENTITY, block.span),), None,
                                "stands in for a port", block.span))
        parts = [M.Part(p.name, p.frames + tuple(self.part_frames.get(p.name, ())), p.body, p.description, p.span)
                 for p in parts]
        outputs = self.outputs(root)
        from .events import build_events
        events = tuple(build_events(self, root))
        from .states import build_states
        states = tuple(build_states(self, root))
        params = self.parameters()
        gravity = self.gravity or G.const_vec(DEFAULT_GRAVITY)
        built = M.Model(block.name.text, block.description, params, tuple(self.inputs(root)), tuple(outputs),
                        gravity, tuple(parts), tuple(interactions), (), block.span, events,
                        self.switches, states,
                        hooks.model_hooks(self))
        from .friction import check_friction
        return check_friction(built, self.diags)

    def module_scope(self, module: Module) -> Scope:
        if module.path not in self._module_scopes:
            dummy = ast.Model("component", ast.Ident(module.dotted, module.file.span), None, (), module.file.span)
            self._module_scopes[module.path] = Scope(module, dummy, prefix="")
        return self._module_scopes[module.path]

    # ====================================================================================== declare
    def declare(self, scope: Scope, is_component: bool) -> None:
        for st in scope.block.statements:
            name = getattr(st, "name", None)
            if isinstance(st, (ast.Param, ast.Input)) and "." in st.name.text:
                self.diags.error("a parameter or input name cannot contain '.'", scope.at(st.name.span))
                continue
            if isinstance(st, ast.Param):
                self.add(scope, st.name, ParamEntry(scope.full(st.name.text), st))
                if st.kind == "mode":
                    self.mode_names.add(scope.full(st.name.text))
            elif isinstance(st, ast.Input):
                self.add(scope, st.name, InputEntry(scope.full(st.name.text), st))
            elif isinstance(st, ast.State):
                self.add(scope, st.name, StateEntry(scope.full(st.name.text), st, scope))
            elif isinstance(st, ast.Func):
                self.add(scope, st.name, FuncEntry(st, scope))
            elif isinstance(st, hooks.HookDecl):
                self.add(scope, st.name, hooks.declare(self, scope, st))
            elif isinstance(st, ast.Output):
                if len(st.name.parts) == 1 and st.value is not None:
                    self.add(scope, st.name.parts[0], OutputEntry(scope.full(st.name.dotted), st, scope))
            elif isinstance(st, ast.Part):
                self.declare_part(scope, st)
            elif isinstance(st, ast.Port):
                if not is_component:
                    self.diags.error("ports belong to components; a model attaches to 'inertial'", scope.at(st.span))
                self.add(scope, st.name, PortEntry(st))
            elif isinstance(st, ast.Interact):
                self.add(scope, st.name, self.declare_interaction(scope, st))
            elif isinstance(st, ast.Use):
                self.instantiate(scope, st)
            elif isinstance(st, ast.Import):
                imports: dict = {}
                self.loader.import_into(imports, st, scope.module.path.parent)
                for alias, module in imports.items():
                    self.add(scope, st.alias or st.path.parts[-1], ImportEntry(module))
            elif isinstance(st, ast.Setting):
                self.model_setting(scope, st)
            del name

    def add(self, scope: Scope, name: ast.Ident, entry) -> None:
        if name.text in scope.entries:
            self.diags.error(f"'{name.text}' is already declared in this {scope.block.kind}",
                             scope.at(name.span), ("first declared here", scope.at(_decl_span(scope.entries[name.text],
                                                                                                 name.span))))
            return
        if name.text in ("t", "pi", "der", "lookup") or name.text in X.FUNCTIONS:
            self.diags.error(f"'{name.text}' is a reserved name", scope.at(name.span))
            return
        scope.entries[name.text] = entry
        scope.order.append(name.text)

    def declare_part(self, scope: Scope, st: ast.Part) -> None:
        if st.name.text == M.INERTIAL:
            if scope is not self.root or st.rigid:
                self.diags.error("'inertial' is the predefined ground part: only a model may add frames to it, "
                                 "with 'part inertial { frame ... }'", scope.at(st.name.span))
                return
            for f in st.frames:
                self.add_frame_name(scope, self.inertial, f)
            self.inertial_frames.extend(st.frames)
            return
        if st.rigid and st.body is None:
            self.diags.error(f"rigid part '{st.name.text}' needs a body {{ mass = ...; com = ...; inertia = ... }}"
                             " (use 'part' for a massless part)", scope.at(st.name.span))
        entry = PartEntry(scope.full(st.name.text), st, {M.ORIGIN: st.name.span})
        if st.rigid:
            entry.frames["com"] = st.name.span
        for f in st.frames:
            self.add_frame_name(scope, entry, f)
        self.add(scope, st.name, entry)

    def add_frame_name(self, scope: Scope, entry: PartEntry, f: ast.Frame) -> None:
        if f.name.text in entry.frames:
            what = "predefined" if f.name.text in (M.ORIGIN, "com") else "already declared on this part"
            self.diags.error(f"frame '{f.name.text}' is {what}", scope.at(f.name.span))
        else:
            entry.frames[f.name.text] = f.name.span

    def declare_interaction(self, scope: Scope, st: ast.Interact) -> InteractEntry:
        entry = InteractEntry(scope.full(st.name.text), st)
        for member in st.members:
            if isinstance(member, ast.Joint) and member.kind.text in catalog.JOINTS:
                rotation = _word_arg(member.args, "rotation") or "quaternion"
                kind = member.kind.text
                for local, dim in catalog.joint_coordinates(kind, rotation):
                    entry.coordinates[local] = dim
                quaternion = kind in ("spherical", "free") and rotation == "quaternion"
                for local, dim in catalog.joint_coordinates(kind, rotation):
                    if local.startswith("q") and quaternion:
                        continue
                    entry.speeds.setdefault(f"der_{local}", dim / U.TIME)
                if quaternion:
                    for local, dim in catalog.QUATERNION_SPEEDS:
                        entry.speeds[local] = dim
            elif isinstance(member, ast.Sensor) and member.kind.text in catalog.SENSORS:
                kind = catalog.SENSORS[member.kind.text]
                comps = kind.components
                if member.kind.text == "joint":
                    comps = tuple(entry.coordinates) or ("",)
                if member.name.text in entry.sensors:
                    self.diags.error(f"sensor '{member.name.text}' is already declared", scope.at(member.name.span))
                entry.sensors[member.name.text] = (member.kind.text, comps)
            elif isinstance(member, ast.Force) and member.name is not None:
                if member.name.text in entry.forces:
                    self.diags.error(f"force '{member.name.text}' is already declared", scope.at(member.name.span))
                entry.forces[member.name.text] = member.kind.text
        _friction_torque_sensors(entry)
        return entry

    def instantiate(self, scope: Scope, st: ast.Use) -> None:
        found = self.find_block(scope, st.component)
        if found is None:
            return
        module, block = found
        if block.kind != "component":
            self.diags.error(f"'{st.component.dotted}' is a model; only components can be instantiated",
                             scope.at(st.component.span))
            return
        if any(st.span is site for _, site in scope.via) or len(scope.via) > 20:
            self.diags.error("component instantiates itself", scope.at(st.span))
            return
        mirror = (1, 1, 1)
        overrides = []
        for arg in st.args:
            if not isinstance(arg, ast.Kwarg):
                self.diags.error("arguments of 'use' are named: use lib.part as x(k = 1 N/m)", scope.at(arg.span))
                continue
            if arg.name.text == "mirror":
                plane = arg.value.ref.dotted if isinstance(arg.value, ast.Name) else ""
                if plane not in G.MIRROR_PLANES:
                    self.diags.error("mirror takes a plane: xz, xy or yz", scope.at(arg.value.span))
                else:
                    mirror = G.MIRROR_PLANES[plane]
                continue
            overrides.append(arg)
        label = f"in instance '{scope.full(st.alias.text)}' of component '{block.name.text}', created here"
        child = Scope(module, block, prefix=scope.full(st.alias.text) + ".",
                      signs=G.compose_signs(scope.signs, mirror), via=((label, scope.at(st.span)),) + scope.via,
                      parent=scope)
        self.declare(child, is_component=True)
        for arg in overrides:
            entry = child.entries.get(arg.name.text)
            if isinstance(entry, FuncEntry):
                self.override_function(scope, child, arg)
                continue
            if isinstance(entry, InputEntry):
                entry.override, entry.override_scope = arg.value, scope
                continue
            if not isinstance(entry, ParamEntry):
                params = [n for n, e in child.entries.items() if isinstance(e, (ParamEntry, FuncEntry, InputEntry))]
                self.diags.error(f"component '{block.name.text}' has no parameter '{arg.name.text}'"
                                 f"{did_you_mean(arg.name.text, params)}", scope.at(arg.name.span))
                continue
            entry.override, entry.override_scope = arg.value, scope
        self.add(scope, st.alias, InstanceEntry(child, st))

    def override_function(self, scope: Scope, child: Scope, arg: ast.Kwarg) -> None:
        """`use tyre as t(road = left_road)`: the component's function is replaced by one of the user's (a road
        profile, a force law), which keeps its own scope. Arities must match."""
        old = child.entries[arg.name.text]
        new = None
        if isinstance(arg.value, ast.Name):
            parts = arg.value.ref.parts
            entry = scope.lookup(parts[0].text)
            if isinstance(entry, FuncEntry) and len(parts) == 1:
                new = entry
            elif isinstance(entry, ImportEntry) and len(parts) == 2 and parts[1].text in entry.module.funcs:
                new = FuncEntry(entry.module.funcs[parts[1].text], self.module_scope(entry.module))
            elif entry is None and len(parts) == 1 and parts[0].text in scope.module.funcs:
                new = FuncEntry(scope.module.funcs[parts[0].text], self.module_scope(scope.module))
        if new is None:
            self.diags.error(f"'{arg.name.text}' is a function of the component: pass the name of a function, "
                             f"e.g. {arg.name.text} = my_{arg.name.text}", scope.at(arg.value.span))
            return
        if len(new.decl.params) != len(old.decl.params):
            self.diags.error(f"function '{arg.name.text}' takes {len(old.decl.params)} argument(s); "
                             f"'{arg.value.ref.dotted}' takes {len(new.decl.params)}", scope.at(arg.value.span))
            return
        child.entries[arg.name.text] = new

    def find_block(self, scope: Scope, ref: ast.Ref) -> tuple[Module, ast.Model] | None:
        names = [p.text for p in ref.parts]
        if len(names) == 1 and names[0] in scope.module.blocks:
            return scope.module, scope.module.blocks[names[0]]
        if len(names) == 2:
            entry = scope.lookup(names[0])
            if isinstance(entry, ImportEntry) and names[1] in entry.module.blocks:
                return entry.module, entry.module.blocks[names[1]]
            if isinstance(entry, ImportEntry):
                self.diags.error(f"module '{names[0]}' has no component '{names[1]}'"
                                 f"{did_you_mean(names[1], entry.module.blocks)}", scope.at(ref.parts[1].span))
                return None
        candidates = list(scope.module.blocks) + list(scope.module.imports)
        self.diags.error(f"unknown component '{ref.dotted}'{did_you_mean(ref.dotted, candidates)} (import its module "
                         f"first: import lib.name)", scope.at(ref.span))
        return None

    def model_setting(self, scope: Scope, st: ast.Setting) -> None:
        if st.name.text == "switches" and scope is self.root:
            value = st.value.ref.dotted if isinstance(st.value, ast.Name) else None
            if value not in ("true", "false"):
                self.diags.error("switches = true or false: whether comparisons and min/max/abs/sign kinks in the "
                                 "motion become events", scope.at(st.value.span))
            self.switches = value == "true"
        elif st.name.text == "scenes" and scope is self.root:
            self.scene_setting = st  # language/shared_scenes.py: read by the front end after the model is built
        elif st.name.text != "gravity":
            self.diags.error(f"unknown model setting '{st.name.text}'"
                             f"{did_you_mean(st.name.text, ['gravity', 'switches', 'scenes'])}", scope.at(st.name.span))
        elif scope is not self.root:
            self.diags.error("gravity is set by the model, not by a component", scope.at(st.span))
        else:
            self._gravity_stmt = st

    # ====================================================================================== bind
    def bind(self, scope: Scope) -> None:
        for entry in list(scope.entries.values()):
            if isinstance(entry, InstanceEntry):
                self.bind_instance(scope, entry)
                self.bind(entry.scope)
        if self.harness and scope is self.root:
            # A component checked on its own: each port stands on a part of its own, as a user's part would.
            for name, entry in scope.entries.items():
                if isinstance(entry, PortEntry):
                    stand_in = PartEntry(f"<{name}>", None, {M.ORIGIN: entry.decl.name.span})
                    self.harness_parts[stand_in.full] = stand_in
                    self.attach_port(scope, entry, stand_in.full, M.ORIGIN, "")

    def bind_instance(self, scope: Scope, inst: InstanceEntry) -> None:
        child = inst.scope
        bound = set()
        for b in inst.decl.bindings:
            port = child.entries.get(b.port.text)
            if not isinstance(port, PortEntry):
                ports = [n for n, e in child.entries.items() if isinstance(e, PortEntry)]
                self.diags.error(f"component '{child.block.name.text}' has no port '{b.port.text}'"
                                 f"{did_you_mean(b.port.text, ports)}", scope.at(b.port.span))
                continue
            target = self.frame_ref(scope, b.target)
            if target is None:
                continue
            bound.add(b.port.text)
            self.attach_port(child, port, target.part, target.frame, child.prefix + b.port.text + ".")
        for name, entry in child.entries.items():
            if isinstance(entry, PortEntry) and name not in bound:
                self.diags.error(f"port '{name}' of component '{child.block.name.text}' is not bound: add "
                                 f"{{ {name} = part.frame }}", scope.at(inst.decl.alias.span))

    def attach_port(self, scope: Scope, port: PortEntry, part: str, frame: str, prefix: str) -> None:
        port.part, port.base_frame, port.frame_prefix = part, frame, prefix
        target = self.part_entry(part)
        for f in port.decl.frames:
            target.frames[prefix + f.name.text] = f.name.span

    def part_entry(self, full: str) -> PartEntry:
        if full == M.INERTIAL:
            return self.inertial
        if full in self.harness_parts:
            return self.harness_parts[full]
        return self._find_part(self.root, full)

    def _find_part(self, scope: Scope, full: str) -> PartEntry:
        for entry in scope.entries.values():
            if isinstance(entry, PartEntry) and entry.full == full:
                return entry
            if isinstance(entry, InstanceEntry) and full.startswith(entry.scope.prefix):
                found = self._find_part(entry.scope, full)
                if found is not None:
                    return found
        return None  # type: ignore[return-value]

    # ====================================================================================== frames
    def frame_ref(self, scope: Scope, ref: ast.Ref) -> M.FrameRef | None:
        """part | part.frame | port | port.frame | instance.(...) | inertial[.frame]"""
        names = ref.parts
        entry = scope.lookup(names[0].text)
        if entry is None and names[0].text == M.INERTIAL:
            entry = self.inertial
        if isinstance(entry, InstanceEntry) and len(names) > 1:
            return self.frame_ref(entry.scope, ast.Ref(names[1:], ref.span))
        if isinstance(entry, PartEntry):
            if len(names) == 1:
                return M.FrameRef(entry.full, M.ORIGIN)
            frame = ".".join(n.text for n in names[1:])
            if frame not in entry.frames:
                self.diags.error(f"part '{names[0].text}' has no frame '{frame}'"
                                 f"{did_you_mean(frame, entry.frames)}", scope.at(ref.span))
                return None
            entry.used_frames.add(frame)
            return M.FrameRef(entry.full, frame)
        if isinstance(entry, PortEntry):
            if entry.part is None:
                return None  # unbound port: reported at the instantiation
            if len(names) == 1:
                return M.FrameRef(entry.part, entry.base_frame)
            local = ".".join(n.text for n in names[1:])
            if local not in {f.name.text for f in entry.decl.frames}:
                self.diags.error(f"port '{names[0].text}' has no frame '{local}'"
                                 f"{did_you_mean(local, [f.name.text for f in entry.decl.frames])}",
                                 scope.at(ref.span))
                return None
            self.part_entry(entry.part).used_frames.add(entry.frame_prefix + local)
            return M.FrameRef(entry.part, entry.frame_prefix + local)
        if entry is None:
            candidates = [n for n, e in scope.entries.items() if isinstance(e, (PartEntry, PortEntry, InstanceEntry))]
            self.diags.error(f"unknown part '{names[0].text}'{did_you_mean(names[0].text, candidates + ['inertial'])}",
                             scope.at(names[0].span))
            return None
        self.diags.error(f"'{names[0].text}' is not a part, port or component instance", scope.at(names[0].span))
        return None

    # ====================================================================================== build
    def build(self, scope: Scope, parts: list, interactions: list) -> None:
        for st in scope.block.statements:
            try:
                if isinstance(st, ast.Part) and st.name.text != M.INERTIAL:
                    parts.append(self.build_part(scope, st))
                elif isinstance(st, ast.Port):
                    self.build_port_frames(scope, st)
                elif isinstance(st, ast.Interact):
                    built = self.build_interaction(scope, st)
                    if built is not None:
                        interactions.append(built)
                elif isinstance(st, ast.Use):
                    inst = scope.entries.get(st.alias.text)
                    if isinstance(inst, InstanceEntry) and inst.decl is st:
                        self.build(inst.scope, parts, interactions)
                elif isinstance(st, ast.Param):
                    entry = scope.entries.get(st.name.text)
                    if isinstance(entry, ParamEntry):
                        self.param_dimension(entry)
                elif isinstance(st, ast.Setting) and scope is self.root and st.name.text == "gravity":
                    r = ExprResolver(self, scope, allow_state=False, what="gravity")
                    vec, dim = r.vector(st.value, "gravity")
                    r.expect(dim, U.ACCELERATION, st.value.span, "gravity")
                    self.gravity = vec
            except Invalid:
                pass

    # ====================================================================================== interactions
    def build_interaction(self, scope: Scope, st: ast.Interact) -> M.Interaction | None:
        entry = scope.entries.get(st.name.text)
        if not isinstance(entry, InteractEntry) or entry.decl is not st:
            return None
        connects = [m for m in st.members if isinstance(m, ast.Connect)]
        joints = [m for m in st.members if isinstance(m, ast.Joint)]
        if not connects:
            self.diags.error(f"interaction '{st.name.text}' has no 'connect a.frame -> b.frame'", scope.at(st.name.span))
            return None
        for extra in connects[1:]:
            self.diags.error("an interaction connects exactly two frames; this is a second 'connect'",
                             scope.at(extra.span))
        for extra in joints[1:]:
            self.diags.error("an interaction has at most one joint; this is a second one", scope.at(extra.span))
        a, b = self.frame_ref(scope, connects[0].a), self.frame_ref(scope, connects[0].b)
        if a is None or b is None:
            return None
        if joints:
            # If the joint turns out to be invalid, connectivity checks must not report its parts again.
            self.broken_links.add((a.part, b.part))
        if a.part == b.part:
            self.diags.error(f"an interaction joins two different parts; both frames are on '{a.part}'",
                             scope.at(connects[0].span))
            return None
        from .members import build_forces, build_joint, build_sensors
        joint = build_joint(self, scope, entry, joints[0]) if joints else None
        if joint is not None:
            self.broken_links.discard((a.part, b.part))
        forces = build_forces(self, scope, entry, st, a)
        sensors = build_sensors(self, scope, entry, st)
        return M.Interaction(entry.full, a, b, joint, forces, sensors, st.description, scope.at(st.span))

    # ====================================================================================== block I/O
    def inputs(self, scope: Scope):
        for entry in scope.entries.values():
            if isinstance(entry, InputEntry) and entry.override is None:
                inner = self._find_scope(self.root, entry) or self.root
                try:
                    value, dim = ExprResolver(self, inner, what=f"input '{entry.full}'").scalar(entry.decl.value)
                except Invalid:
                    continue
                yield M.Input(entry.full, value, dim, entry.decl.description, inner.at(entry.decl.span))
            elif isinstance(entry, InstanceEntry):
                yield from self.inputs(entry.scope)

    def outputs(self, scope: Scope) -> list[M.Output]:
        """Outputs of the model and of every component instance (prefixed: fl.travel)."""
        out = []
        for st in scope.block.statements:
            if isinstance(st, ast.Output):
                out.extend(self.output(scope, st) or ())
            elif isinstance(st, ast.Use):
                inst = scope.entries.get(st.alias.text)
                if isinstance(inst, InstanceEntry) and inst.decl is st:
                    out.extend(self.outputs(inst.scope))
        return out

    def output(self, scope: Scope, st: ast.Output) -> list[M.Output] | None:
        """The output, or one per component when it names a vector sensor (`output hinge.load` gives
        hinge.load.fx ... hinge.load.mz); None after an error."""
        r = ExprResolver(self, scope, allow_acceleration=True, what="an output")
        if st.value is None:
            r.vector_components = []
        try:
            value, dim = r.scalar(st.value if st.value is not None else ast.Name(st.name, st.name.span))
        except Invalid:
            return None
        name, span = scope.full(st.name.dotted), scope.at(st.span)
        if r.vector_components:
            return [M.Output(f"{name}.{c}", v, st.description, span, _shown_unit(v, d))
                    for c, v, d in r.vector_components]
        return [M.Output(name, value, st.description, span, _shown_unit(value, dim))]

    def output_value(self, entry: OutputEntry, span) -> tuple[X.E, object]:
        """An output used in another expression (another output, or a scene's output list)."""
        if getattr(entry, "_resolving", False):
            self.diags.error(f"output '{entry.full}' depends on itself", entry.scope.at(span))
            raise Invalid()
        entry._resolving = True  # type: ignore[attr-defined]
        try:
            return ExprResolver(self, entry.scope, allow_acceleration=True, what="an output").scalar(entry.decl.value)
        finally:
            entry._resolving = False  # type: ignore[attr-defined]

    def warn_unused(self, scope: Scope) -> None:
        """Warn of parameters nothing uses: called after the scenes are built, which may use them too."""
        if self.diags.error_count:
            return  # warnings about a model that does not compile are noise
        for name, entry in scope.entries.items():
            if isinstance(entry, ParamEntry) and not entry.used and entry.override is None:
                self.diags.warning(f"parameter '{name}' is never used", scope.at(entry.decl.name.span))
            elif isinstance(entry, InstanceEntry):
                self.warn_unused(entry.scope)


def _decl_span(entry, fallback: Span) -> Span:
    decl = getattr(entry, "decl", None)
    if decl is not None and hasattr(decl, "name") and hasattr(decl.name, "span"):
        return decl.name.span
    return fallback


def _friction_torque_sensors(entry: InteractEntry) -> None:
    """A force sensor on the friction element of a revolute joint reads a torque (the element acts on the
    joint's angle), not the force its kind reads elsewhere."""
    angular = bool(entry.coordinates) and all(d == U.ANGLE for d in entry.coordinates.values())
    for member in entry.decl.members:
        if angular and isinstance(member, ast.Sensor) and member.kind.text == "force":
            element = _word_arg(member.args, "element") or (next(iter(entry.forces)) if len(entry.forces) == 1
                                                             else None)
            if entry.forces.get(element) == "coulomb":
                entry.sensor_dims[member.name.text] = U.TORQUE


def _word_arg(args, name: str) -> str | None:
    for a in args:
        if isinstance(a, ast.Kwarg) and a.name.text == name and isinstance(a.value, ast.Name):
            return a.value.ref.dotted
    return None


def _shown_unit(value: X.E, dim) -> str | None:
    """An output's unit for results and plots; a bare joint angle or attitude sensor reads 'rad', not '1'."""
    return U.unit_text(dim, angle=isinstance(value, X.Sym) and value.kind in ("coord", "sensor"))
