"""The validated data model: the method-independent objects of Leister and Schiehlen, immutable.

block (parameters, inputs, outputs) -> mbs (parts + interactions) -> part (frames) / rigid (body + frames)
-> interact (connect a -> b; member: joint, forces, sensors). Components are already expanded: names are
flat and instance-prefixed ("fl.leaf"), geometry of mirrored instances already mirrored. All quantities
are model expressions (expr.py) in SI; parameters stay symbolic so later stages can make them run-time
inputs. Every object keeps the span of the text it came from, for errors found in later stages.
"""

from __future__ import annotations

import dataclasses
import hashlib
from dataclasses import dataclass, field
from functools import cached_property

from .diagnostics import Span
from .expr import E
from .units import Dimension

Vec3 = tuple[E, E, E]
Mat3 = tuple[Vec3, Vec3, Vec3]

INERTIAL = "inertial"  # the predefined part every model has; its frame 'origin' is the world frame
ORIGIN = "origin"      # every part has a frame 'origin', its body-fixed reference frame


@dataclass(frozen=True)
class Parameter:
    """A run-time input of the compiled model. ``default`` may refer to other parameters."""

    name: str
    default: E
    value: float           # the default evaluated in SI
    dimension: Dimension | None  # None: a bare number, any dimension accepted
    description: str | None
    span: Span = field(compare=False)
    unit: str | None = field(default=None, compare=False)  # shown unit (results, tables): as written if SI
    kind: str = field(default="param", compare=False)  # "mode": a discrete value that events switch


@dataclass(frozen=True)
class Input:
    """A function of time (steering, road) fed into the block; a scene may replace its expression."""

    name: str
    value: E
    dimension: Dimension | None
    description: str | None
    span: Span = field(compare=False)


@dataclass(frozen=True)
class Output:
    name: str
    value: E
    description: str | None
    span: Span = field(compare=False)
    unit: str | None = field(default=None, compare=False)  # the named SI unit of its checked dimension


@dataclass(frozen=True)
class Frame:
    """A body-fixed frame: position of its origin and rotation (columns: its axes) in the part's frame."""

    name: str
    position: Vec3
    rotation: Mat3
    span: Span = field(compare=False)


@dataclass(frozen=True)
class Body:
    """Mass geometry: mass, centre of mass in the part frame, inertia about the CoM in part-frame axes."""

    mass: E
    com: Vec3
    inertia: Mat3
    span: Span = field(compare=False)
    about: str = field(default="", compare=False)  # the frame the user gave the inertia about ('': the CoM)


@dataclass(frozen=True)
class Part:
    name: str
    frames: tuple[Frame, ...]
    body: Body | None  # None: a massless part
    description: str | None
    span: Span = field(compare=False)

    @cached_property
    def frame_map(self) -> dict[str, Frame]:
        return {f.name: f for f in self.frames}

    @property
    def rigid(self) -> bool:
        return self.body is not None


@dataclass(frozen=True)
class FrameRef:
    part: str
    frame: str

    def __str__(self) -> str:
        return f"{self.part}.{self.frame}"


@dataclass(frozen=True)
class Coordinate:
    """A joint coordinate ``<interaction>.<name>``: its start value and speed, or a prescribed motion."""

    name: str
    local: str
    dimension: Dimension
    init: E
    init_speed: E
    prescribed: E | None
    span: Span = field(compare=False)


@dataclass(frozen=True)
class Joint:
    """Relative motion of frame b with respect to frame a; all coordinates zero means a and b coincide."""

    kind: str
    axes: tuple[Vec3, ...]
    rotation: str  # 'quaternion' | 'cardan' for spherical and free joints, '' otherwise
    coordinates: tuple[Coordinate, ...]
    cut: bool | None  # the user's choice of loop-cut joint; None: the compiler chooses
    span: Span = field(compare=False)


@dataclass(frozen=True)
class Force:
    """A force element; ``args`` are the kind's arguments (catalog.py) as model expressions.

    Force laws may use the locals the kind binds (for line forces: l, v) and any state quantity.
    """

    name: str
    kind: str
    args: tuple[tuple[str, object], ...]
    span: Span = field(compare=False)

    def arg(self, key, default=None):
        return dict(self.args).get(key, default)


@dataclass(frozen=True)
class Sensor:
    name: str
    kind: str
    args: tuple[tuple[str, object], ...]
    components: tuple[str, ...]  # names of the values it produces ("" for a scalar sensor)
    span: Span = field(compare=False)

    def arg(self, key, default=None):
        return dict(self.args).get(key, default)


@dataclass(frozen=True)
class Interaction:
    name: str
    a: FrameRef
    b: FrameRef
    joint: Joint | None
    forces: tuple[Force, ...]
    sensors: tuple[Sensor, ...]
    description: str | None
    span: Span = field(compare=False)


@dataclass(frozen=True)
class Scene:
    """A run: which model, overrides, initial conditions, wanted outputs, integration settings."""

    name: str
    model: str
    params: tuple[tuple[str, E], ...]
    inputs: tuple[tuple[str, E], ...]
    inits: tuple[tuple[str, bool, E], ...]  # (coordinate, is_speed, value)
    outputs: tuple[Output, ...]
    t_end: float
    sample: float | None
    integrator: str
    rtol: float
    atol: float
    start: str  # 'initial' | 'equilibrium'
    description: str | None
    span: Span = field(compare=False)


@dataclass(frozen=True)
class Action:
    """What an event does: ``kind`` "speed" (reinit a joint speed; ``target`` names the coordinate), "state"
    (reinit an extra state) or "set"
    (a mode or parameter takes a new value); ``value`` is evaluated just before the event (Modelica's pre())."""

    kind: str
    target: str
    value: E
    span: Span = field(compare=False)


@dataclass(frozen=True)
class Event:
    """A zero crossing of the scalar ``indicator`` in ``direction`` (+1 rising, -1 falling, 0 either) and its
    actions; ``terminal`` ends the run there."""

    name: str
    indicator: E
    direction: int
    actions: tuple[Action, ...]
    terminal: bool
    description: str | None
    span: Span = field(compare=False)


@dataclass(frozen=True)
class State:
    """An extra differential state ``name`` (actuator lag, controller integrator, bristle deflection): x' = rate,
    x(0) = init; ``dimension`` from the initial value (None: a plain number), ``rate`` has dimension / time."""

    name: str
    init: E
    dimension: Dimension | None
    rate: E
    description: str | None
    span: Span = field(compare=False)


@dataclass(frozen=True)
class Model:
    name: str
    description: str | None
    parameters: tuple[Parameter, ...]
    inputs: tuple[Input, ...]
    outputs: tuple[Output, ...]
    gravity: Vec3
    parts: tuple[Part, ...]
    interactions: tuple[Interaction, ...]
    scenes: tuple[Scene, ...]
    span: Span = field(compare=False)
    events: tuple[Event, ...] = ()
    switches: bool = True  # comparisons and kinks in the motion become events (compiler/events.py)
    states: tuple[State, ...] = ()  # extra differential states, after the mechanical state (states.py)
    hooks: tuple = ()  # language.hooks.HookSpec: user routines supplied when running (runtime/hooks.py)

    @cached_property
    def part_map(self) -> dict[str, Part]:
        return {p.name: p for p in self.parts}

    @cached_property
    def parameter_map(self) -> dict[str, Parameter]:
        return {p.name: p for p in self.parameters}

    @cached_property
    def interaction_map(self) -> dict[str, Interaction]:
        return {i.name: i for i in self.interactions}

    @cached_property
    def coordinates(self) -> tuple[Coordinate, ...]:
        return tuple(c for i in self.interactions if i.joint for c in i.joint.coordinates)

    @cached_property
    def content_digest(self) -> str | None:
        """The hex SHA-256 of the model's text representation with its scenes left out: everything the equations
        are derived from (the derivation cache keys on it). None when that text is not stable (it holds an object's
        address, which differs in every process). Writing the text of a vehicle takes a tenth of a second: the
        model cache (mbs/model_cache.py) keeps the digest with the model, so a warm start does not."""
        text = repr(dataclasses.replace(self, scenes=()))
        return None if " at 0x" in text else hashlib.sha256(text.encode()).hexdigest()

    def scene(self, name: str) -> Scene:
        for s in self.scenes:
            if s.name == name:
                return s
        raise KeyError(name)
