"""Validated model (+ scene) -> a Tree with its loads and outputs: the input of the symbolic derivation.

Each tree body is one part; it carries the name of the interaction whose joint moves it, so that the state
symbols come out as the language names them (``hinge.phi``). Its body frame has the part's axes and its origin at
that joint (the joint's frame on the part: `_Lowering._body_origin`), and every position on the part enters the
kinematics from there (`_Lowering.local`). Frames become joint placements, bodies become mass geometry, force
elements become loads on the kinematics, sensors and outputs become expressions of the state. Only what the scene
asks for is lowered: a scene that wants two outputs does not pay for the rest.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import sympy as sp

from mbs.language import expr as X
from mbs.language import model as M
from mbs.language.diagnostics import Diagnostic, MbsError

from .constraints import CutJoint
from .events import LoweredEvent, SwitchRegistry, lower_events
from .friction import FrictionLowering
from .instances import SharedLaws
from .kinematics import Kinematics
from .reactions import AccelerationTerms, in_frame
from .spatial import cross, dot
from .symbolic import TableRegistry, ToSympy, parameter_symbol, safe_atan2
from .topology import Topology, build_topology
from .tyre import attach_tyre
from .tyre_relaxation import model_inputs, relaxation_states
from .tree import JointSpec, Tree, TreeBody, t


@dataclass(frozen=True)
class Lowered:
    """The derivation's input: kinematics with loads attached, wanted outputs, and naming metadata."""

    model: M.Model
    scene: M.Scene | None
    topology: Topology
    kinematics: Kinematics
    outputs: tuple[tuple[str, sp.Expr], ...]   # (name, expression of state, t, parameters)
    tables: TableRegistry
    cuts: tuple[CutJoint, ...] = ()            # the loop-closing joints, in `topology.cuts` order
    run_time_inputs: tuple = ()                # (symbol, array, index): accelerations and multipliers the
                                               # outputs read (reaction and acceleration sensors)
    events: tuple[LoweredEvent, ...] = ()      # the model's events (compiler/events.py)
    switches: tuple = ()                       # comparisons and kinks held by run-time flags (Switch)
    state_rates: tuple = ()                    # z' of the extra states (tree.states), language/states.py
    friction_rows: tuple = ()                  # sticking friction as constraint rows (compiler/friction_loops.py)
    bearing_friction: object = None            # bearing friction in a loop model (friction_loops.LoadedFriction)
    lowering: object = field(default=None, compare=False, repr=False)   # lower_outputs continues it
    body_origins: tuple = ()                   # per tree body: its frame's origin in its part's coordinates
                                               # (the child frame of its joint: _Lowering._body_origin)

    @property
    def tree(self) -> Tree:
        return self.kinematics.tree


def _error(message: str, span) -> MbsError:
    return MbsError([Diagnostic("error", message, span)])


class _Lowering:
    def __init__(self, model: M.Model, scene: M.Scene | None):
        self.model, self.scene = model, scene
        self.tables = TableRegistry()
        self.inputs = model_inputs(model, scene)
        self.geometry = ToSympy(self._no_state, self.tables)
        # comparisons and kinks of min/max/abs/sign in the motion become switches in every model, unless it says
        # `switches = false` (model.switches); those on time in a prescribed motion too (self.timed)
        self.switches = SwitchRegistry(frozenset(p.name for p in model.parameters)) if model.switches else None
        self.timed = ToSympy(self._timed_symbol, self.tables, self.switches)
        self.topology = build_topology(model)
        self.body_of_part = {M.INERTIAL: -1}
        self.body_of_interaction: dict[str, int] = {}
        self.origins: dict[str, sp.Matrix] = {}   # per part: its body frame's origin in part coordinates
        for i, (part, joint) in enumerate(zip(self.topology.bodies, self.topology.joints)):
            self.body_of_part[part] = i
            self.body_of_interaction[joint.interaction.name] = i
            self.origins[part] = self._body_origin(i)
        tree = Tree(tuple(self._tree_body(i) for i in range(len(self.topology.bodies))),
                    tuple(self.geometry(g) for g in model.gravity), tuple(state_symbols(model, self.inputs)))
        self.element_rates: dict[sp.Symbol, sp.Expr] = {}  # rates of states force elements add (tyre relaxation)
        self.kin = Kinematics(tree)
        self.cuts = tuple(self._cut_joint(inter) for inter in self.topology.cuts)
        self.state = ToSympy(self._state_symbol, self.tables, self.switches)
        self.model_states = {s.name: s for s in model.states}
        self._sensor_cache: dict[str, sp.Expr] = {}
        self.acceleration_terms = AccelerationTerms(self.kin, self.cuts)
        self.friction = FrictionLowering(self)
        self.shared_laws = SharedLaws()  # force laws converted once for all instances of a component

    # ---------------------------------------------------------------------------------------- tree
    def _no_state(self, sym: X.Sym) -> sp.Expr:
        if sym.kind == "input":
            return self.geometry(self.inputs[sym.name])
        raise _error(f"'{sym.name}' cannot appear in geometry or mass data", self.model.span)

    def _timed_symbol(self, sym: X.Sym) -> sp.Expr:
        if sym.kind == "input":
            return self.timed(self.inputs[sym.name])
        return self._no_state(sym)

    def _part_pose(self, ref: M.FrameRef):
        """(R, r): the frame's rotation and origin in its part's coordinates, as the model gives them."""
        frame = self.model.part_map[ref.part].frame_map[ref.frame]
        R = sp.Matrix(3, 3, [self.geometry(c) for row in frame.rotation for c in row])
        r = sp.Matrix([self.geometry(c) for c in frame.position])
        return R, r

    def _body_origin(self, i: int) -> sp.Matrix:
        """The origin of tree body i's frame in its part's coordinates: the origin of the child frame of the joint
        that moves it (the body frame has the part's axes). At the joint, a revolute or spherical joint's motion
        subspace S has no linear part and the prismatic's no angular one: the mass matrix columns I S and the
        joint forces S.f read entries where they multiplied, and the offsets of the bodies in their parents are
        the joints' positions, constants (the Iltis's loop terms: 27,390 -> 20,900 instructions a call)."""
        tj = self.topology.joints[i]
        return self._part_pose(tj.interaction.a if tj.flipped else tj.interaction.b)[1]

    def local(self, part: str, r) -> list:
        """A point given in the coordinates of `part` in its body frame (_body_origin)."""
        origin = self.origins.get(part)
        return list(r) if origin is None else [x - o for x, o in zip(r, origin)]

    def _pose(self, ref: M.FrameRef):
        """(R, r): the frame's rotation and origin in its part's body frame."""
        R, r = self._part_pose(ref)
        return R, sp.Matrix(self.local(ref.part, r))

    def _tree_body(self, i: int) -> TreeBody:
        tj = self.topology.joints[i]
        inter = tj.interaction
        joint = inter.joint
        parent_frame, child_frame = (inter.b, inter.a) if tj.flipped else (inter.a, inter.b)
        sign = -1 if tj.flipped else 1
        axes = tuple(tuple(sign * self.geometry(c) for c in axis) for axis in joint.axes)
        spec = JointSpec(joint.kind, axes, joint.rotation or "quaternion")
        part = self.model.part_map[tj.child]
        if part.body is not None:
            mass = self.geometry(part.body.mass)
            com = self.local(tj.child, [self.geometry(c) for c in part.body.com])
            inertia = sp.Matrix(3, 3, [self.geometry(c) for row in part.body.inertia for c in row])
            # Data rotated into part axes (`inertia = ... in frame`) or symmetric only to the checker's
            # tolerance carries round-off asymmetry; the dynamics relies on exact symmetry.
            inertia = sp.Matrix(3, 3, lambda i, j: inertia[i, j] if inertia[i, j] == inertia[j, i]
                                else (inertia[i, j] + inertia[j, i]) / 2)
        else:
            mass, com, inertia = sp.Integer(0), [0, 0, 0], sp.zeros(3, 3)
        prescribed = tuple(None if c.prescribed is None else self._prescribed(c) for c in joint.coordinates)
        parent = self.topology.parent_index[i]
        return TreeBody(inter.name, parent, spec, self._pose(parent_frame), self._pose(child_frame), mass,
                        com, inertia, prescribed)

    def _prescribed(self, coordinate: M.Coordinate) -> sp.Expr:
        """A prescribed motion, refused when its speed jumps (a ramp that stops, written with min or max): the
        drive would need an impulse, which would change the speeds of the parts it carries at that instant,
        and a right-hand side cannot apply it."""
        e = self.geometry(coordinate.prescribed)
        if may_kink(e) and sp.diff(e, t, 2).has(sp.DiracDelta):
            raise _error(f"the prescribed motion of '{coordinate.name}' has a kink: its speed jumps at an instant, "
                         "which needs an infinite drive force; blend it, e.g. ramp * smoothstep(t, t0, t1)",
                         coordinate.span)
        if self.switches is None:
            return e
        # an if() on time (a ramp that starts) is allowed, its speed stepping: a switch, so that the run locates
        # the instant instead of stepping across it
        self.switches.context = f"the prescribed motion of {coordinate.name}"
        e = self.timed(coordinate.prescribed)
        self.switches.prescribed_motion(e)
        return e

    def _cut_joint(self, inter: M.Interaction) -> CutJoint:
        """A joint outside the spanning tree: its frames and kind become loop-closure constraints."""
        joint = inter.joint
        if any(c.prescribed is not None for c in joint.coordinates):
            raise _error(f"joint '{inter.name}' closes a kinematic loop and cannot prescribe a motion; mark another "
                         "joint of the loop with 'cut = true'", joint.span)
        axes = tuple(tuple(self.geometry(c) for c in axis) for axis in joint.axes)
        if not all(c.is_number for axis in axes for c in axis):
            raise _error(f"the axes of joint '{inter.name}', which closes a kinematic loop, must be numbers",
                         joint.span)
        return CutJoint(inter.name, JointSpec(joint.kind, axes), self.body(inter.a.part), self._pose(inter.a),
                        self.body(inter.b.part), self._pose(inter.b))

    # ---------------------------------------------------------------------------------------- state
    def _state_symbol(self, sym: X.Sym) -> sp.Expr:
        if sym.kind == "input":
            return self.state(self.inputs[sym.name])
        if sym.kind in ("coord", "speed"):
            inter_name, local = sym.name.rsplit(".", 1)
            body = self.body_of_interaction.get(inter_name)
            if body is None:
                raise _error(f"'{sym.name}' belongs to a joint that closes a loop", self.model.span)
            joint = self.model.interaction_map[inter_name].joint
            locals_ = [c.local for c in joint.coordinates]
            if sym.kind == "coord":
                return self.kin.joint_coordinate(body, locals_.index(local))
            return self.kin.joint_velocity(body, _speed_index(joint, local))
        if sym.kind == "sensor":
            return self.sensor_value(sym.name)
        if sym.kind == "state":
            return sp.Symbol(sym.name)
        if sym.kind == "rate":  # der(z) of an extra state: the right-hand side of its equation
            return self.state_rate(sym.name)
        raise _error(f"'{sym.name}' cannot be used here", self.model.span)

    def state_rate(self, name: str) -> sp.Expr:
        """z' of the extra state `name` as one temporary: forces that use der(z) and the right-hand side share it."""
        tape = self.kin.tape
        rate = self.state(self.model_states[name].rate)  # its sensors' temporaries keep their own sections
        before = tape.current_section
        tape.section(f"extra state {name}: rate")
        value = tape.temp(rate, "zdot")
        tape.section(before)
        return value

    def body(self, part: str) -> int:
        return self.body_of_part[part]

    def frame_world(self, ref: M.FrameRef):
        frame = self.model.part_map[ref.part].frame_map[ref.frame]
        local_p = self.local(ref.part, [self.geometry(c) for c in frame.position])
        local_R = tuple(tuple(self.geometry(c) for c in row) for row in frame.rotation)
        b = self.body(ref.part)
        return b, local_p, self.kin.frame_position(b, local_p), self.kin.frame_rotation(b, local_R)

    # ---------------------------------------------------------------------------------------- sensors
    def sensor_value(self, name: str) -> sp.Expr:
        """``inter.sensor`` or ``inter.sensor.component`` as a tape expression (computed once)."""
        if name in self._sensor_cache:
            return self._sensor_cache[name]
        parts = name.split(".")
        for cut in range(len(parts) - 1, 0, -1):
            inter = self.model.interaction_map.get(".".join(parts[:cut]))
            if inter is not None:
                break
        sensor_name = f"{inter.name}.{parts[cut]}"
        sensor = next(s for s in inter.sensors if s.name == sensor_name)
        component = parts[cut + 1] if len(parts) > cut + 1 else ""
        values = self._sensor_values(inter, sensor)
        for comp, value in zip(sensor.components, values):
            self._sensor_cache[sensor_name + (f".{comp}" if comp else "")] = value
        return self._sensor_cache[name if component else sensor_name]

    def _sensor_values(self, inter: M.Interaction, sensor: M.Sensor):
        tape = self.kin.tape
        _, _, pa, Ra = self.frame_world(inter.a)
        bb, pb_local, pb, _ = self.frame_world(inter.b)
        ba = self.body(inter.a.part)
        d = [y - x for x, y in zip(pa, pb)]
        in_ref = sensor.arg("in") or inter.a
        if sensor.kind == "distance":
            return (tape.temp(sp.sqrt(dot(d, d)), "dist"),)
        if sensor.kind == "position":
            R_in = self.frame_world(in_ref)[3]
            return tuple(tape.temp(dot([R_in[k][c] for k in range(3)], d), "pos") for c in range(3))
        if sensor.kind == "velocity":
            a_local = self.frame_world(inter.a)[1]
            va = self.kin.frame_velocity(ba, a_local)
            vb = self.kin.frame_velocity(bb, pb_local)
            R_in = self.frame_world(in_ref)[3]
            dv = [y - x for x, y in zip(va, vb)]
            return tuple(tape.temp(dot([R_in[k][c] for k in range(3)], dv), "vel") for c in range(3))
        if sensor.kind == "acceleration":
            a_local = self.frame_world(inter.a)[1]
            terms = self.acceleration_terms
            da = [y - x for x, y in zip(terms.point_acceleration(ba, a_local), terms.point_acceleration(bb, pb_local))]
            return in_frame(tape, self.frame_world(in_ref)[3], da, "acc")
        if sensor.kind == "reaction":
            force, moment = self._reaction(inter, pb)
            R_in = self.frame_world(in_ref)[3]
            return in_frame(tape, R_in, force, "reacf") + in_frame(tape, R_in, moment, "reacm")
        if sensor.kind == "angles":
            Rb = self.frame_world(inter.b)[3]
            Rrel = [[tape.temp(dot([Ra[k][i] for k in range(3)], [Rb[k][j] for k in range(3)]), "rrel")
                     for j in range(3)] for i in range(3)]
            return _angles(Rrel, sensor.arg("sequence") or "xyz")
        if sensor.kind == "joint":
            body = self.body_of_interaction[inter.name]
            return tuple(self.kin.joint_coordinate(body, k) for k in range(len(inter.joint.coordinates)))
        if sensor.kind == "force":
            element = sensor.arg("element")
            return (self._force_values[element],)
        if sensor.kind == "tyre":
            values = self._tyre_values[sensor.arg("element")]
            return tuple(values[c] for c in sensor.components)
        raise _error(f"sensor kind '{sensor.kind}' is not supported by the compiler", sensor.span)

    def _reaction(self, inter: M.Interaction, pb) -> tuple:
        """(force, moment about frame b's origin) in world components that the joint exerts on frame b's part."""
        terms = self.acceleration_terms
        body = self.body_of_interaction.get(inter.name)
        if body is None:  # a loop-closing joint: its rows' multipliers
            j = next(k for k, cut in enumerate(self.cuts) if cut.name == inter.name)
            return terms.cut_load(j)
        # the tree carries the joint's load onto its child, which is part b unless the joint was flipped
        return terms.tree_joint_load(body, not self.topology.joints[body].flipped, pb)

    # ---------------------------------------------------------------------------------------- forces
    def attach_forces(self) -> None:
        self._force_values: dict[str, sp.Expr] = {}
        self._tyre_values: dict[str, dict[str, sp.Expr]] = {}
        for inter in self.model.interactions:
            for force in inter.forces:
                self._attach(inter, force)
        forces, self.friction_events = self.friction.resolve()
        self._force_values = {name: sp.sympify(v).xreplace(forces) for name, v in self._force_values.items()}

    def _attach(self, inter: M.Interaction, force: M.Force) -> None:
        if self.switches is not None:
            self.switches.context = force.name
        kind = force.kind
        if kind == "joint":
            self._joint_force(inter, force)
            return
        if kind == "coulomb":
            self._force_values[force.name] = self.friction.attach(inter, force)
            return
        if kind == "tyre":
            self._tyre_values[force.name] = attach_tyre(self, inter, force)
            self._force_values[force.name] = self._tyre_values[force.name]["fz"]
            return
        ba, pa_local, pa, Ra = self.frame_world(inter.a)
        bb, pb_local, pb, _ = self.frame_world(inter.b)
        if kind == "point":
            self._point_force(inter, force, ba, bb, pb_local, pb)
            return
        law = self._line_law(force)
        along = force.arg("along")
        if along is None:
            length, rate, tension = self.kin.add_line_force(ba, pa_local, bb, pb_local, law)
            self._force_values[force.name] = tension
            return
        # along a fixed axis of frame a: deflection = projection of b - a on it
        tape = self.kin.tape
        axis_local = [self.geometry(c) for c in along]
        frame = self.kin.load_frame(ba, bb)
        if frame >= 0:
            self._force_values[force.name] = self._axis_force_in(frame, inter, ba, pa_local, bb, pb_local,
                                                                 axis_local, law)
            return
        e = [tape.temp(dot(Ra[k], axis_local), "ax") for k in range(3)]
        d = [y - x for x, y in zip(pa, pb)]
        va = self.kin.frame_velocity(ba, pa_local)
        vb = self.kin.frame_velocity(bb, pb_local)
        omega_a = self.kin.body_angular_velocity(ba)
        de = cross(omega_a, e)
        length = tape.temp(dot(e, d), "proj")
        rate = tape.temp(dot(e, [y - x for x, y in zip(va, vb)]) + dot(de, d), "projrate")
        tension = tape.temp(law(length, rate), "tension")
        self._force_values[force.name] = tension
        self.kin.add_force(bb, pb_local, [-tension * c for c in e])
        if ba >= 0:
            self.kin.add_force(ba, pa_local, [tension * c for c in e])

    def _axis_force_in(self, frame: int, inter, ba, pa_local, bb, pb_local, axis_local, law):
        """The tension of a force along a fixed axis of frame a between two bodies below body `frame`, computed in
        that body's frame (as Kinematics.add_line_force: no world poses, the load on `frame` in its components)."""
        tape, kin = self.kin.tape, self.kin
        frame_a = self.model.part_map[inter.a.part].frame_map[inter.a.frame]
        R_local = [[self.geometry(c) for c in row] for row in frame_a.rotation]
        e, omega_a = kin.direction_in(frame, ba, [dot(row, axis_local) for row in R_local])
        (pa, va), (pb, vb) = kin.point_in(frame, ba, pa_local), kin.point_in(frame, bb, pb_local)
        d = [y - x for x, y in zip(pa, pb)]
        length = tape.temp(dot(e, d), "proj")
        rate = tape.temp(dot(e, [y - x for x, y in zip(va, vb)]) + dot(cross(omega_a, e), d), "projrate")
        tension = tape.temp(law(length, rate), "tension")
        kin.add_force_along(frame, bb, pb_local, e, -tension)
        kin.add_force_along(frame, ba, pa_local, e, tension)
        return tension

    def _line_law(self, force: M.Force):
        kind = force.kind

        def law(length, rate):
            locals_ = {"l": length, "v": rate}
            conv = ToSympy(lambda s: locals_[s.name] if s.kind == "local" else self._state_symbol(s), self.tables,
                           self.switches)
            if kind == "line":
                return conv(force.arg("f"))
            value = sp.Integer(0)
            if kind in ("spring", "spring_damper"):
                value += conv(force.arg("k")) * (length - conv(force.arg("l0")))
            if kind in ("damper", "spring_damper"):
                value += conv(force.arg("d")) * rate
            return value
        return law

    def _point_force(self, inter, force, ba, bb, pb_local, pb) -> None:
        in_ref = force.arg("in") or inter.a
        R_in = self.frame_world(in_ref)[3]
        world = lambda vec: [sum((R_in[r][c] * self.state(vec[c]) for c in range(3)), sp.Integer(0))  # noqa
                             for r in range(3)]
        F = world(force.arg("force")) if force.arg("force") is not None else None
        T = world(force.arg("torque")) if force.arg("torque") is not None else None
        if F is not None:
            self.kin.add_force(bb, pb_local, F)
            if ba >= 0:  # the reaction acts on a at the same point in space
                Rwa, rwa = self.kin.world_pose(ba)
                local = [dot([Rwa[k][c] for k in range(3)], [p - r for p, r in zip(pb, rwa)]) for c in range(3)]
                self.kin.add_force(ba, local, [-f for f in F])
            self._force_values[force.name] = sp.sqrt(dot(F, F))
        if T is not None:
            self.kin.add_torque(bb, T)
            if ba >= 0:
                self.kin.add_torque(ba, [-x for x in T])

    def _joint_force(self, inter: M.Interaction, force: M.Force) -> None:
        body = self.body_of_interaction.get(inter.name)
        if body is None:
            raise _error("joint forces on a loop-closing joint are not supported yet", force.span)
        joint = inter.joint
        total = sp.Integer(0)
        for local, value in force.args:
            k = _speed_index(joint, local)
            expr = self.state(value)
            self.kin.add_generalized_force(body, k, expr)
            total += expr
        self._force_values[force.name] = total

    # ---------------------------------------------------------------------------------------- outputs
    def outputs(self) -> tuple[tuple[str, sp.Expr], ...]:
        """The scene's outputs (else the model's), less those that are states already (`output hinge.phi`)."""
        wanted = self.scene.outputs if self.scene is not None and self.scene.outputs else self.model.outputs
        states = {c.name for c in self.model.coordinates}
        return tuple((o.name, self.state(o.value)) for o in wanted
                     if not (o.name in states and o.value == X.Sym("coord", o.name)))


#: Node types whose derivatives are made of these types again (a Piecewise's of its pieces, its conditions kept),
#: never of a step or a DiracDelta: an expression of them alone has no kink in any derivative.
_SMOOTH = (sp.Symbol, sp.Number, sp.NumberSymbol, sp.Add, sp.Mul, sp.Pow, sp.Piecewise, sp.sin, sp.cos, sp.tan,
           sp.asin, sp.acos, sp.atan, sp.atan2, sp.sinh, sp.cosh, sp.tanh, sp.exp, sp.log,
           sp.logic.boolalg.Boolean, sp.Tuple)  # (conditions, and a Piecewise's (expression, condition) pairs)


def may_kink(expr) -> bool:
    """Whether a derivative of `expr` may hold a DiracDelta (it has a min, max, abs, sign, step or a function of
    unknown derivative): only then does a prescribed motion need its second derivative to show it has no kink
    (sympy's second derivative of a long motion took a twentieth of the Iltis's lowering)."""
    return not all(isinstance(node, _SMOOTH) for node in sp.preorder_traversal(expr))


def _speed_index(joint: M.Joint, local: str) -> int:
    """Velocity index of a coordinate's speed (quaternion joints: wx, wy, wz after the translations)."""
    names = [c.local for c in joint.coordinates if c.local != "qw"]
    names = [{"qx": "wx", "qy": "wy", "qz": "wz"}.get(n, n) for n in names]
    return names.index(local)


def _angles(R, sequence: str):
    """Angles of a rotation matrix for the sequences the sensor offers (principal branch)."""
    if sequence == "xyz":
        return (safe_atan2(-R[1][2], R[2][2]), sp.asin(R[0][2]), safe_atan2(-R[0][1], R[0][0]))
    if sequence == "zyx":
        return (safe_atan2(R[1][0], R[0][0]), sp.asin(-R[2][0]), safe_atan2(R[2][1], R[2][2]))
    return (safe_atan2(R[0][2], -R[1][2]), sp.acos(R[2][2]), safe_atan2(R[2][0], R[2][1]))  # zxz


def lower(model: M.Model, scene: M.Scene | None = None) -> Lowered:
    """The tree, loads and outputs of a model; raises MbsError (located) for what the compiler cannot do."""
    return lower_outputs(lower_model(model, scene))


def lower_model(model: M.Model, scene: M.Scene | None = None) -> Lowered:
    """`lower` without the outputs (Lowered.outputs empty): what the equations of motion read. The outputs come
    last, from lower_outputs, so that the tape of the equations is the same whatever outputs a scene asks for
    (mbs/derivation_cache.py keeps the equations apart from a scene's outputs)."""
    lowering = _Lowering(model, scene)
    lowering.attach_forces()
    if lowering.switches is not None:
        lowering.switches.context = "events"
    events = lower_events(model.events, lowering.state) + lowering.friction_events
    if lowering.switches is not None:
        lowering.switches.context = "state equations"
    rates = tuple(lowering.state_rate(s.name) for s in model.states)
    rates += tuple(lowering.element_rates[s] for s in lowering.kin.tree.states[len(rates):])
    switches = lowering.switches.final() if lowering.switches is not None else ()
    return Lowered(model, scene, lowering.topology, lowering.kin, (), lowering.tables, lowering.cuts,
                   lowering.acceleration_terms.inputs() + lowering.friction.inputs, events, switches, rates,
                   lowering.friction.rows, lowering.friction.bearing, lowering,
                   tuple(tuple(lowering.origins[part]) for part in lowering.topology.bodies))


def lower_outputs(lowered: Lowered) -> Lowered:
    """`lowered` (from lower_model) with the outputs, lowered onto the end of its tape: their sensors, the
    run-time inputs they read (accelerations, multipliers) and any switch they add."""
    lowering = lowered.lowering
    if lowering.switches is not None:
        lowering.switches.context = "outputs"
    outputs = lowering.outputs()
    switches = lowering.switches.final() if lowering.switches is not None else ()
    return replace(lowered, outputs=outputs, switches=switches,
                   run_time_inputs=lowering.acceleration_terms.inputs() + lowering.friction.inputs)


def state_symbols(model: M.Model, inputs=None) -> list[sp.Symbol]:
    """The symbols of the extra states, named as the model names them; a name a parameter also has is refused
    (both would be the same symbol). `inputs`: the model's as the scene replaces them (a tyre relaxation
    length that is 0 adds no state, compiler/tyre_relaxation.py)."""
    params = {p.name for p in model.parameters}
    for s in model.states:
        if s.name in params:
            raise _error(f"state '{s.name}' has the name of a parameter; rename one of them", s.span)
    return [sp.Symbol(s.name) for s in model.states] + [sp.Symbol(name) for name, _ in relaxation_states(model, inputs)]


__all__ = ["Lowered", "lower", "lower_model", "lower_outputs", "parameter_symbol"]
