"""The whole pipeline as pure functions of the previous stage's output:

    text -> (language) validated Model -> (compiler) Lowered -> Equations -> C / NumPy source
         -> (runtime) CompiledModel -> simulate -> Results

plus what connects them: run-time parameter values (defaults may be expressions of other parameters,
so overriding one re-evaluates the rest) and the initial state (joint init values, scene overrides,
quaternions normalised).
"""

from __future__ import annotations

import functools
import logging
import math
import time
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import TYPE_CHECKING, Callable, Mapping

import numpy as np

from mbs.compiler.gc_pause import paused
from mbs.compiler.integrator_names import JACOBIAN_INTEGRATORS
from mbs.compiler.tyre_relaxation import model_inputs, relaxation_states
from mbs.language import binding
from mbs.language import expr as X
from mbs.language import model as M
from mbs.language import units as U
from mbs.language.diagnostics import Diagnostic, MbsError
from mbs.language.quaternions import norm_problem
from mbs.runtime.translation_units import COLD_APART

if TYPE_CHECKING:  # the symbolic stages (sympy) load only when something is derived: a cached run needs none
    from mbs.compiler.constraints import Constraints
    from mbs.compiler.equations import Equations
    from mbs.compiler.lower import Lowered

_log = logging.getLogger(__name__)


@dataclass(frozen=True)
class StateLayout:
    """What the start of a run needs to know of the tree (plain names and numbers, so that the derivation cache,
    mbs/derivation_cache.py, can keep it without the symbolic stages)."""

    q_symbols: tuple[str, ...]   # the tree's coordinate symbols in state order ("body.phi")
    v_symbols: tuple[str, ...]   # its velocity symbols ("body.der(phi)", "body.wx")
    quaternions: tuple[tuple[str, tuple[int, ...]], ...] = ()   # (body, indices of qw, qx, qy, qz in x)
    cuts: tuple[str, ...] = ()   # the interactions that close loops
    constraint_rows: tuple[str, ...] | None = None   # loop-closure rows (None: a tree)
    z_symbols: tuple[str, ...] = ()   # the extra differential states after q and v (language/states.py)

    @classmethod
    def of(cls, tree, cuts=(), constraints: Constraints | None = None) -> "StateLayout":
        quaternions = tuple((body.name, tuple(tree.q_slots[i][-4:])) for i, body in enumerate(tree.bodies)
                            if body.joint.uses_quaternion)
        return cls(tuple(s.name for s in tree.q_symbols), tuple(s.name for s in tree.v_symbols), quaternions,
                   tuple(c.name for c in cuts), tuple(constraints.names) if constraints is not None else None,
                   tuple(s.name for s in tree.states))


@dataclass(frozen=True)
class Symbolic:
    """The symbolic stages behind generated code."""

    lowered: Lowered
    equations: Equations
    constraints: Constraints | None   # loop-closure constraints of the cut joints (None: a tree)


@dataclass(frozen=True)
class Generated:
    """The code generator's output and what the runtime needs to know about it.

    The symbolic stages (lowered, equations, constraints) come from `derive` when first asked for: code taken
    from the derivation cache runs without them, and derives them again only for a caller that needs them. The
    NumPy module (a tree's functions for the NumPy back end) is printed when first asked for, by `print_numpy`:
    a run on the C back end never needs it, and printing it took about a quarter of a 40-link chain's
    derivation."""

    model: M.Model
    scene: M.Scene | None
    c_source: str
    numpy_text: str | None   # the NumPy module's text, None while not printed (numpy_source prints it)
    q_names: tuple[str, ...]
    v_names: tuple[str, ...]
    p_names: tuple[str, ...]
    y_names: tuple[str, ...]
    layout: StateLayout
    events: tuple = ()   # per indicator of mbs_events: name, direction, terminal, assignments, switch (events.py)
    derive: Callable[[], Symbolic] | None = field(default=None, compare=False, repr=False)
    #: where c_source's outputs part starts (compiler/ccode.py generate_c_outputs); None: written with the rest
    outputs_at: int | None = None
    print_numpy: Callable[[], str] | None = field(default=None, compare=False, repr=False)
    #: (c_source written without the cold functions) what derives the whole file: generate with cold_apart False
    complete: Callable[[], "Generated"] | None = field(default=None, compare=False, repr=False)

    @property
    def cold_apart(self) -> bool:
        """Whether c_source was written without a tree's cold functions (the mass matrix, the forces: no
        integrator calls them; compiler/ccode.py cold_apart): the runtime builds them from whole_source into a
        library of their own when one is first called (runtime/backends.py ColdLibrary)."""
        return f"#define {COLD_APART} " in self.c_source

    @cached_property
    def whole_source(self) -> str:
        """The whole C file, the cold functions included (what a standalone library, an FMU or `mbs compile`
        needs): c_source, or the same model derived with them when c_source was written without (the derivation
        cache keeps it by content, so this derives once)."""
        return self.complete().c_source if self.cold_apart else self.c_source

    @cached_property
    def symbolic(self) -> Symbolic:
        return self.derive()

    @cached_property
    def numpy_source(self) -> str:
        """The same functions as c_source in NumPy, for machines without a C compiler ("" with loops)."""
        return self.numpy_text if self.numpy_text is not None else self.print_numpy()

    @property
    def lowered(self) -> Lowered:
        return self.symbolic.lowered

    @property
    def equations(self) -> Equations:
        return self.symbolic.equations

    @property
    def constraints(self) -> Constraints | None:
        return self.symbolic.constraints if self.layout.constraint_rows is not None else None

    @property
    def z_names(self) -> tuple[str, ...]:
        """Names of the extra differential states (language/states.py), after q and v in the state."""
        return self.layout.z_symbols


def display_name(symbol_name: str) -> str:
    """'hinge.der(phi)' -> 'der(hinge.phi)', the language's own spelling of a speed."""
    if symbol_name.endswith(")") and ".der(" in symbol_name:
        head, local = symbol_name[:-1].split(".der(")
        return f"der({head}.{local})"
    return symbol_name


def structurally_singular(lowered, text: str) -> Diagnostic:
    """The joint whose articulated-body pivot ('iD<body><coordinate>' in `text`) is zero whatever the parameters:
    nothing it carries has mass or inertia along one of its free directions."""
    import re
    joints = lowered.topology.joints
    digits = (re.search(r"iD(\d+)", text) or re.search(r"(\d+)", text + "0")).group(1)
    for candidate in (digits, digits[:-1]):
        if candidate and 1 <= int(candidate) <= len(joints):
            inter = joints[int(candidate) - 1].interaction
            free = ", ".join(c.name for c in inter.joint.coordinates if c.prescribed is None) or inter.name
            return Diagnostic("error", f"no mass or inertia determines the motion of {free}: nothing joint "
                                       f"'{inter.name}' moves ({joints[int(candidate) - 1].child} and what it "
                                       "carries) has mass or inertia along one of its free directions (a point "
                                       "mass turning about itself?); give it inertia or prescribe the coordinate",
                              inter.joint.span)
    return Diagnostic("error", f"the mass matrix is singular for every parameter value ({text})", lowered.model.span)


def needs_jacobian(scene: M.Scene | None, integrator: str | None = None) -> bool:
    """Whether the run's integrator (given, else the scene's) uses the generated Jacobian of the right-hand side."""
    name = integrator or (scene.integrator if scene is not None else None)
    return bool(name) and str(name).lower() in JACOBIAN_INTEGRATORS


@paused  # (compiler/gc_pause.py)
def generate(model: M.Model, scene: M.Scene | None = None, *, jacobian: bool | None = None,
             parameter_jacobian: bool = False, dynamics: bool = False, frames: tuple[str, ...] = (),
             equations_ready: Callable[[str], None] | None = None, closed_form: bool = True,
             cold_apart: bool = False) -> Generated:
    """Validated model -> generated source (symbolic derivation included). `dynamics`: also the dynamics
    functions (inverse dynamics, bias and gravity forces; compiler/dynamics_functions.py); `frames`: with
    them the positions, velocities and Jacobians of these frames ("part.frame").

    parameter_jacobian: also emit mbs_param_jacobian (d xdot/d p, for sensitivities; trees only).

    closed_form: try to close the loops in closed form (compiler/closed_form_loops.py; False: the numeric loop
    solver alone, the baseline bench/loops.py measures it against).

    jacobian: emit mbs_jacobian (None: when the scene's integrator uses it). A model whose right-hand side has
    no printable derivative (a lookup table) gets none: its stiff integrators use finite differences.

    The C file is written in two parts where it can be: the equations (whatever the scene's outputs) and, at
    its end from Generated.outputs_at on, the outputs (compiler/ccode.py generate_c_outputs), lowered after the
    equations were written. The derivation cache keeps the parts apart and the build compiles the outputs as a
    unit of their own, so a scene asking for other outputs derives and compiles only those. `equations_ready` is
    called with the equations' part as soon as it is written (runtime/build.py prebuild starts compiling it
    while the outputs are derived); its method `derivation_started`, if it has one, first (runtime/build.py
    Prebuilds: the runtime unit, which depends on no model, compiles while the model is derived), and its method
    `head_written`, if it has one, with the file's head and the tape's length before the functions are printed
    (compiler/ccode.py CEmitter.source: the glue unit compiles while they are).

    cold_apart: a tree's file is written without the functions no integrator calls (the mass matrix and the
    forces, runtime/translation_units.py COLD_FUNCTIONS; cold_apart_applies says when), which the runtime builds
    from the whole file (Generated.whole_source, this function with cold_apart False) when one is first called.
    The equations are derived whole all the same: the tape, and so every other function's text, is the one of the
    whole file (deriving the right-hand side alone would share other temporaries and round otherwise)."""
    from mbs.compiler.ccode import NotSeparable
    options = dict(jacobian=jacobian, parameter_jacobian=parameter_jacobian, dynamics=dynamics, frames=frames,
                   closed_form=closed_form, cold_apart=cold_apart)
    clock = _Phases(model.name + (f", scene {scene.name}" if scene is not None else ""))
    started = getattr(equations_ready, "derivation_started", None)
    if started is not None:
        started()
    try:
        generated = _generate(model, scene, clock, separate=True, equations_ready=equations_ready, **options)
    except NotSeparable as exc:  # (outputs that call a hook or add a switch) the file whole
        _log.info("%s: the outputs are written with the equations (%s)", clock.what, exc)
        generated = _generate(model, scene, clock, separate=False, **options)
    if not generated.cold_apart:
        return generated
    return replace(generated, complete=lambda: generate(model, scene, **{**options, "cold_apart": False}))


def cold_apart_applies(model: M.Model, constraints, dynamics: bool, frames) -> bool:
    """Whether the cold functions may be left out of a file: a tree (with loops the loop solver calls the mass
    matrix and the forces, or reads them off its loop terms), without the dynamics functions (asked for, they are
    wanted) and without user hooks (their implementations are attached to the model's library alone)."""
    return constraints is None and not dynamics and not frames and not model.hooks


@paused  # (compiler/gc_pause.py)
def generate_outputs(model: M.Model, scene: M.Scene | None, equations_source: str, *,
                     jacobian: bool | None = None, parameter_jacobian: bool = False, dynamics: bool = False,
                     frames: tuple[str, ...] = (), closed_form: bool = True, cold_apart: bool = False
                     ) -> tuple[str, str, tuple[str, ...], Symbolic]:
    """(outputs part, the NumPy module's printer, output names, symbolic stages or None) of a scene whose equations part
    (generate's c_source up to outputs_at, with the same options) is `equations_source`: the model is lowered
    again (the outputs are expressions on its tape) and its equations of motion derived, as generate has them
    on the tape when it lowers the outputs, but not printed: with loops the outputs' part is written with
    outputs_equations (symbolic stages None), a tree's equations serve its NumPy module; the text is the one
    generate gives, whichever scene the cache met first.
    Raises compiler.ccode.NotSeparable when the outputs cannot stand apart. (closed_form: as for generate; the
    outputs do not depend on it: they read the loop solver's rates.)"""
    del closed_form, cold_apart  # (nor on whether the cold functions are in the equations' part)
    from mbs.compiler.ccode import generate_c_outputs
    from mbs.compiler.lower import lower_outputs
    from mbs.compiler.pycode import generate_numpy
    clock = _Phases(model.name + (f", scene {scene.name}" if scene is not None else "") + " (outputs only)")
    # the equations of motion are derived (not printed) as generate derives them before it lowers the outputs:
    # the outputs share their temporaries on the tape (inertias, positions); without them the outputs' text, and
    # its round-off, depended on the scene the cache had met first (the Iltis's bump_5 after settle, and its
    # quarter car's: other parts and carries, the vehicle's bearing reactions 1.9e-12 apart)
    lowered, constraints, equations, parameters, friction = _derive(model, scene, dynamics, clock)
    if constraints is not None and friction is None:
        equations = None  # the outputs' part reads the loop solver's accelerations at run time (outputs_equations)
    if equations is None:  # loops: no NumPy module, and the outputs read the accelerations at run time
        options = {}
    else:  # what generate does before it lowers the outputs, so that the tape they share is the same
        options, _ = _code_options(model, scene, lowered, equations, constraints, parameters, jacobian,
                                   parameter_jacobian, dynamics, frames)
    first_table = len(lowered.tables.tables)
    with_outputs = _outputs_apart(lowered, lower_outputs(lowered))
    clock("lowered the outputs")
    c_outputs = generate_c_outputs(equations or outputs_equations(lowered), parameters, equations_source,
                                   first_table, outputs=with_outputs.outputs, tables=with_outputs.tables,
                                   constraints=constraints, run_time_inputs=with_outputs.run_time_inputs,
                                   friction=friction)
    def print_numpy() -> str:
        if equations is None or constraints is not None:
            return ""
        options.update(outputs=with_outputs.outputs, tables=with_outputs.tables,
                       run_time_inputs=with_outputs.run_time_inputs)
        return generate_numpy(equations, parameters, model.name, **options)
    clock("generated the outputs' C")
    return c_outputs, print_numpy, tuple(name for name, _ in with_outputs.outputs), \
        Symbolic(with_outputs, equations, constraints) if equations is not None else None


def join_parts(equations_source: str, outputs_source: str) -> str:
    """The whole C file of its equations' part and its outputs' part (which starts at len(equations_source) + 1)."""
    return equations_source + "\n" + outputs_source if outputs_source else equations_source


def _outputs_apart(before, after):
    """`after` (the lowering with its outputs), unless lowering them added a switch (its flag would be a
    parameter of the equations) or found one the equations read continuously jumping in an output (the event
    table, made with the equations, would say it is continuous): then NotSeparable."""
    from mbs.compiler.ccode import NotSeparable
    if len(after.switches) != len(before.switches):
        raise NotSeparable("an output adds a switch")
    if [s.continuous for s in after.switches] != [s.continuous for s in before.switches]:
        raise NotSeparable("an output reads a switch where it jumps")  # the event table says it is continuous
    return after


def outputs_equations(lowered):
    """Equations without the equations of motion, on the lowering's tape: all the outputs' part of a model with
    loops reads of them (its tree, tape and sizes; the outputs read the accelerations and multipliers the loop
    solver gives at run time, not the symbolic M, f or vdot), so that a scene asking for other outputs does not
    derive the equations again (mbs/derivation_cache.py). generate writes that part with the same stand-in, so
    the text is the same whichever wrote it."""
    import sympy as sp

    from mbs.compiler.equations import Equations
    tree, zero = lowered.tree, sp.S.Zero
    return Equations(lowered.kinematics, tuple((zero,) * tree.nv for _ in range(tree.nv)), (zero,) * tree.nv,
                     (zero,) * tree.nq, None, (zero,) * len(lowered.state_rates))


def _derive(model: M.Model, scene: M.Scene | None, dynamics: bool, clock, *, outputs: bool = False):
    """(lowered, constraints, equations, parameters, friction): the model lowered (with its outputs only if
    `outputs`), its equations of motion derived, and the routines of bearing friction in loops (or None)."""
    from mbs.compiler.constraints import derive_constraints
    from mbs.compiler.equations import derive_equations
    from mbs.compiler.friction_loops import with_friction_rows
    from mbs.compiler.lower import lower_model, lower_outputs
    lowered = lower_model(model, scene)
    if outputs:
        lowered = lower_outputs(lowered)
    clock("lowered to a tree")
    constraints = derive_constraints(lowered.kinematics, lowered.cuts) if lowered.cuts else None
    if constraints is not None:  # sticking friction elements lock their joints with rows of their own
        constraints = with_friction_rows(constraints, lowered.friction_rows)
    if constraints is not None and not constraints.nc:  # a free joint closing a "loop" constrains nothing
        constraints = None
    # with loops the articulated-body vdot is not used (and divides by zero for massless parts)
    if lowered.tree.states and dynamics:
        where = model.states[0].span if model.states else model.span
        raise MbsError([Diagnostic("error", "extra states (declared, or a tyre's relaxation) are not supported in "
                                            "the dynamics functions yet", where)])
    try:
        equations = derive_equations(lowered.kinematics, forward_dynamics=constraints is None,
                                     state_rates=lowered.state_rates)
    except ZeroDivisionError as exc:  # a pivot of the articulated-body algorithm is zero for every parameter
        raise MbsError([structurally_singular(lowered, str(exc))]) from None
    clock("derived the equations of motion")
    friction = None
    if lowered.bearing_friction is not None and constraints is not None:  # bearing friction in the loops
        from mbs.compiler.friction_loops import bearing_routines
        equations, friction = bearing_routines(equations, lowered.bearing_friction, constraints.nc)
    parameters = run_parameters(model, lowered)
    used = list(equations.parameters()) + list(constraints.parameters() if constraints is not None else ())
    extra = [s for s in used if s not in set(parameters)]
    if extra:
        raise MbsError([Diagnostic("error", f"internal: symbols without a parameter: {extra}", model.span)])
    return lowered, constraints, equations, parameters, friction


def _code_options(model, scene, lowered, equations, constraints, parameters, jacobian, parameter_jacobian,
                  dynamics, frames) -> tuple[dict, tuple]:
    """(the code generators' options, the event table) of a derived model."""
    from mbs.compiler.dynamics_functions import dynamics_routines, frame_routines, named_frames
    from mbs.compiler.events import event_code
    asked = None
    if dynamics:  # of the spanning tree; with loops, tau = G^T lambda (mbs_constraint_jacobian, multipliers)
        routines, inputs = dynamics_routines(lowered.kinematics)
        if frames:
            routines += frame_routines(lowered.kinematics, named_frames(lowered, frames))
        asked = (routines, inputs, tuple(frames))
    # the model's file only: scenes that differ in parameters, inputs or settings generate the same text and so
    # share one compiled library in the build cache (a scene's name here would give each its own)
    origin = f"{model.span.source.path}"
    state_names = tuple(display_name(s.name) for s in lowered.tree.x_symbols)
    p_names = tuple(s.name for s in parameters)
    indicators, action_values, event_table = event_code(lowered.events, lowered.switches, state_names,
                                                        lowered.tree.nq, p_names)
    options = dict(outputs=lowered.outputs, tables=lowered.tables, origin=origin,
                   run_time_inputs=lowered.run_time_inputs, events=indicators, actions=action_values, dynamics=asked)
    if needs_jacobian(scene) if jacobian is None else jacobian:
        options["jacobian"] = True
    if parameter_jacobian and constraints is None:
        options["parameter_jacobian"] = True
    return options, event_table


def closed_form_of(model: M.Model, lowered, constraints, equations, friction):
    """The loops closed in closed form (compiler/closed_form_loops.py) on the branch of the model's own initial
    state at its default parameters (not a scene's: scenes share one generated text), or None: no loops, friction
    in them, or the closed form refused (then the numeric loop solver alone, as before)."""
    from mbs.compiler.closed_form_loops import Refused, closed_form, structural_refusal
    if constraints is None or friction is not None or lowered.friction_rows:
        return None
    reason = structural_refusal(constraints, equations)  # (before the values: the Iltis's quaternion refuses it)
    if reason is not None:
        _log.info("%s: loops not closed in closed form (%s)", model.name, reason)
        return None
    values = parameter_values(model)
    x0 = initial_state_of(model, None, lowered.tree, values)
    by_name = {s.name: s for s in constraints.parameters()}
    try:
        return closed_form(constraints, equations, {s: values[n] for n, s in by_name.items() if n in values},
                           x0[:lowered.tree.nq])
    except Refused as exc:
        _log.info("%s: loops not closed in closed form (%s)", model.name, exc)
        return None


def _generate(model, scene, clock, *, separate: bool, jacobian, parameter_jacobian, dynamics, frames,
              equations_ready=None, closed_form: bool = True, cold_apart: bool = False) -> Generated:
    """generate, with the outputs written apart (`separate`) or with the rest of the file."""
    from mbs.compiler.ccode import generate_c, generate_c_outputs
    from mbs.compiler.lower import lower_outputs
    from mbs.compiler.pycode import generate_numpy
    lowered, constraints, equations, parameters, friction = _derive(model, scene, dynamics, clock,
                                                                    outputs=not separate)
    options, event_table = _code_options(model, scene, lowered, equations, constraints, parameters, jacobian,
                                         parameter_jacobian, dynamics, frames)
    form = closed_form_of(model, lowered, constraints, equations, friction) if closed_form else None
    if form is not None:
        clock("closed the loops in closed form")
    cold_apart = cold_apart and cold_apart_applies(model, constraints, dynamics, frames)
    outputs_at = None
    if separate:
        first_table = len(lowered.tables.tables)
        c_source = generate_c(equations, parameters, model.name, constraints=constraints, friction=friction,
                              separate_outputs=True, closed_form=form, cold_apart=cold_apart,
                              head_ready=getattr(equations_ready, "head_written", None), **options)
        clock("generated the equations' C")
        if equations_ready is not None:
            equations_ready(c_source)
        before, lowered = lowered, lower_outputs(lowered)
        _outputs_apart(before, lowered)
        clock("lowered the outputs")
        outputs_at = len(c_source) + 1
        written = outputs_equations(lowered) if constraints is not None and friction is None else equations
        c_source = join_parts(c_source, generate_c_outputs(written, parameters, c_source, first_table,
                                                           outputs=lowered.outputs, tables=lowered.tables,
                                                           constraints=constraints,
                                                           run_time_inputs=lowered.run_time_inputs,
                                                           friction=friction))
        options.update(outputs=lowered.outputs, tables=lowered.tables, run_time_inputs=lowered.run_time_inputs)
    else:
        c_source = generate_c(equations, parameters, model.name, constraints=constraints, friction=friction,
                              closed_form=form, cold_apart=cold_apart, **options)
    clock("generated C")

    def print_numpy() -> str:
        # closed loops need the loop solver in C (runtime/c/loops.c): no NumPy module for them
        return generate_numpy(equations, parameters, model.name, **options) if constraints is None else ""
    symbolic = Symbolic(lowered, equations, constraints)
    tree = lowered.tree
    return Generated(model, scene, c_source, None,
                     tuple(display_name(s.name) for s in tree.q_symbols),
                     tuple(display_name(s.name) for s in tree.v_symbols),
                     tuple(s.name for s in parameters), tuple(name for name, _ in lowered.outputs),
                     StateLayout.of(tree, lowered.cuts, constraints), event_table, lambda: symbolic, outputs_at,
                     print_numpy)


def run_parameters(model: M.Model, lowered) -> list:
    """The symbols of the run-time vector p: the model's parameters, then the switches' branch flags and the frozen
    flag (compiler/events.py; none in a model without comparisons or kinks of the motion)."""
    from mbs.compiler.events import FROZEN
    from mbs.compiler.symbolic import parameter_symbol
    flags = [s.symbol for s in lowered.switches]
    return [parameter_symbol(p.name) for p in model.parameters] + flags + ([FROZEN] if flags else [])


def parameter_vector(p_names, values: Mapping[str, float]) -> list[float]:
    """p in run-time order from the parameters' values: the switches' branch flags and the frozen flag (not
    parameters of the model) start at 0, every comparison evaluated as written until a run freezes them."""
    return [values.get(n, 0.0) if flag else values[n] for n, flag in zip(p_names, _run_flags(tuple(p_names)))]


@functools.lru_cache(maxsize=64)
def _run_flags(p_names: tuple[str, ...]) -> tuple[bool, ...]:
    """Per name of p: whether it is a switch's flag (or the frozen flag), once per model's names."""
    return tuple(n.startswith("switch.") for n in p_names)


#: Log level of a compile phase that took longer than SLOW_PHASE seconds: between INFO and WARNING, shown by
#: the command line unless -q, so a compile of half a minute says what it is doing even without a terminal.
NOTE = 25
SLOW_PHASE = 1.0
logging.addLevelName(NOTE, "NOTE")


class _Phases:
    """Logs each compile phase with its time (all of them with `mbs -v`, the slow ones always)."""

    def __init__(self, what: str):
        self.what = what
        self.last = time.perf_counter()
        _log.info("compiling %s", what)

    def __call__(self, phase: str) -> None:
        now = time.perf_counter()
        took = now - self.last
        _log.log(NOTE if took > SLOW_PHASE else logging.INFO, "%s: %s in %.2f s", self.what, phase, took)
        self.last = now


# ------------------------------------------------------------------------------------------ parameters
def parameter_values(model: M.Model, overrides: Mapping[str, float | X.E] | None = None) -> dict[str, float]:
    """Every parameter's value (overrides as given, the rest from their defaults), checked: a mass or inertia
    that the overrides make unphysical is an error located at the body and the parameter."""
    values = binding.parameter_values(model, overrides)
    binding.check_bound_values(model, values, {name: None for name in overrides or {}}, how="overridden")
    return values


def scene_overrides(scene: M.Scene | None) -> dict[str, X.E]:
    return dict(scene.params) if scene is not None else {}


# ------------------------------------------------------------------------------------------ initial state
def initial_state(generated: Generated, params: Mapping[str, float]) -> np.ndarray:
    """x0 = [q0; v0] in state order: joint init values, then the scene's init statements (initial_state_in; the
    expression of every state worked out once per generated code, then evaluated with these parameters; an init a
    scene overrides is not evaluated)."""
    from mbs.runtime.derived import derived
    plan = derived(generated, "initial_state_plan",
                   lambda: _initial_expressions(generated.model, generated.scene, generated.layout))
    x = np.array([X.evaluate(e, params) for e in plan], dtype=float)
    return _normalise_quaternions(x, generated.layout)


def initial_state_of(model: M.Model, scene: M.Scene | None, tree, params: Mapping[str, float]) -> np.ndarray:
    """initial_state for a model, a scene (or None) and the tree of their lowering."""
    return initial_state_in(model, scene, StateLayout.of(tree), params)


def initial_state_in(model: M.Model, scene: M.Scene | None, layout: StateLayout,
                     params: Mapping[str, float]) -> np.ndarray:
    """initial_state for a model, a scene (or None) and the state layout of their lowering."""
    env = dict(params)
    x = np.array([X.evaluate(e, env) for e in _initial_expressions(model, scene, layout)], dtype=float)
    return _normalise_quaternions(x, layout)


def _initial_expressions(model: M.Model, scene: M.Scene | None, layout: StateLayout) -> tuple:
    """The expression of each state's initial value, in state order (q, v, z): joint init values, then the
    scene's init statements."""
    coords = {c.name: c for c in model.coordinates}
    inits: dict[tuple[str, bool], X.E] = {}
    for c in coords.values():
        inits[(c.name, False)] = c.init
        inits[(c.name, True)] = c.init_speed
    if scene is not None:
        for name, is_speed, value in scene.inits:
            inits[(name, is_speed)] = value
    q0 = [inits[(name, False)] for name in layout.q_symbols]
    v0 = []
    for name in layout.v_symbols:
        if name.endswith(")") and ".der(" in name:
            head, local = name[:-1].split(".der(")
            v0.append(inits[(f"{head}.{local}", True)])
        else:  # quaternion joint: wx, wy, wz are stored as the speeds of qx, qy, qz
            head, local = name.rsplit(".", 1)
            v0.append(inits[(f"{head}.q{local[1]}", True)])
    declared = {s.name: s for s in model.states}  # the others are states of force elements (tyre relaxation)
    z0 = [inits[(name, False)] if (name, False) in inits
          else declared[name].init if name in declared else X.ZERO for name in layout.z_symbols]
    return tuple(q0 + v0 + z0)


def fixed_state_names(generated: Generated) -> list[str]:
    """Names (as in the compiled model: "j.phi", "der(j.phi)", "j.wx") of the coordinates and speeds the user
    gave initial values, in the joint or the scene: assembling the loops keeps them. (A joint's init statement
    makes a new expression; the defaults are the shared X.ZERO and X.ONE.)"""
    def speed(name: str) -> str:
        head, local = name.rsplit(".", 1)
        return f"{head}.w{local[1]}" if local in ("qx", "qy", "qz") else f"der({name})"
    names = []
    for c in generated.model.coordinates:
        if c.init is not (X.ONE if c.local == "qw" else X.ZERO):
            names.append(c.name)
        if c.init_speed is not X.ZERO:
            names.append(speed(c.name))
    if generated.scene is not None:
        names += [speed(name) if is_speed else name for name, is_speed, _ in generated.scene.inits]
    return names


def _normalise_quaternions(x: np.ndarray, layout: StateLayout) -> np.ndarray:
    for body, slots in layout.quaternions:
        q = x[list(slots)]
        norm = math.sqrt(float(q @ q))
        problem = norm_problem(norm, body)
        if problem is not None and problem[0] == "error":
            raise MbsError([Diagnostic("error", problem[1], None)])
        x[list(slots)] = q / norm
    return x


def units_of(generated: Generated) -> dict[str, str]:
    """Unit text of every state, parameter and output name, for result files, plots and tables: the unit the
    model wrote for a parameter when it is an SI one, the named SI unit otherwise (N*m, not kg*m^2/s^2)."""
    units: dict[str, str] = {}
    for c in generated.model.coordinates:
        if c.local in ("qw", "qx", "qy", "qz"):  # unit quaternion components; their speeds are j.wx ...
            units[c.name] = "1"
            if c.local != "qw":
                units[f"{c.name.rsplit('.', 1)[0]}.w{c.local[1]}"] = "rad/s"
            continue
        angle = c.dimension.is_dimensionless
        units[c.name] = U.unit_text(c.dimension, angle=angle)
        units[f"der({c.name})"] = U.unit_text(c.dimension / U.TIME, angle=angle)
    units.update(relaxation_states(generated.model, model_inputs(generated.model, generated.scene)))
    for s in generated.model.states:
        if s.dimension is not None:  # a bare-number initial value leaves the unit free
            units[s.name] = U.unit_text(s.dimension)
    for p in generated.model.parameters:
        unit = p.unit or U.unit_text(p.dimension)
        if unit is not None:
            units[p.name] = unit
    scene_outputs = generated.scene.outputs if generated.scene is not None else ()
    for o in (*generated.model.outputs, *scene_outputs):
        if o.unit is not None and o.name in generated.y_names:
            units[o.name] = o.unit
    return units


__all__ = ["Generated", "generate", "parameter_values", "initial_state", "display_name", "units_of"]
