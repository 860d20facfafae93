"""`mbs.load(path)`: a validated model you can compile and simulate, in the manner of numpy and scipy.

    sys = mbs.load("library/examples/pendulum.mbs")
    res = sys.simulate(t_end=10, sample=0.01)              # compiles once (cached), then runs
    res["hinge.phi"], res.t
    res = sys.simulate("swing", params={"l": 2.0})         # a scene, a parameter changed: no recompile
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Callable, Mapping

import numpy as np

from mbs.language import model as M
from mbs.language.catalog import SCENE_DEFAULTS
from mbs.language.diagnostics import Diagnostic, MbsError
from mbs.runtime import build as _build
from mbs.runtime import hooks as _hooks
from mbs.runtime.assembly import assemble, assembled_state
from mbs.runtime.derived import derived
from mbs.runtime.equilibrium import static_equilibrium
from mbs.runtime.model import CompiledModel, load_c, load_numpy
from mbs.runtime.results import Results
from mbs.runtime.simulate import simulate as _simulate
from mbs.runtime.workspace import Workspace

from . import derivation_cache, model_cache, pipeline
from .quantities import parameter_overrides
from .gimbal import cardan_joints, warn_gimbal

#: Parameter bindings a System keeps, the last ones asked for (System._binding): a scene run again with
#: the same overrides binds and checks its parameters once; a sweep over many values keeps no more than these.
KEPT_BINDINGS = 8
#: Start states a System keeps (System._kept_start): a scene started again with the same compiled model, parameters
#: and initial state begins where the last start did without assembling its loops and solving its static
#: equilibrium again (the Iltis bump: 4.3 ms of a 74-ms simulate; both are functions of those alone). A sweep over
#: many values keeps no more than these.
KEPT_STARTS = 8

#: Whether a compile leaves a tree's cold functions (the mass matrix and the forces, which no integrator calls)
#: to a library of their own, derived and built the first time something calls one (mbs.pipeline.generate
#: cold_apart, runtime/backends.py ColdLibrary). False: compiled with the rest, as before (bench/compile_time.py
#: flips it for its baseline).
COLD_APART = True


@dataclass
class System:
    """A validated model and its compilations (one per scene: a scene decides which outputs exist)."""

    model: M.Model
    cache_dir: str | None = None
    backend: str = "auto"  # "c", "numpy", or "auto": C when a compiler runs
    _compiled: dict = field(default_factory=dict, repr=False)
    _bindings: dict = field(default_factory=dict, repr=False, compare=False)
    _starts: dict = field(default_factory=dict, repr=False, compare=False)

    def scene(self, name: str | None) -> M.Scene | None:
        if name is None:
            return None
        try:
            return self.model.scene(name)
        except KeyError:
            names = ", ".join(s.name for s in self.model.scenes) or "none"
            raise MbsError([Diagnostic("error", f"model '{self.model.name}' has no scene '{name}' "
                                                f"(scenes: {names})", None)]) from None

    def generate(self, scene: str | None = None, *, jacobian: bool | None = None, parameter_jacobian: bool = False,
                 dynamics: bool = False, frames: tuple[str, ...] = (), equations_ready=None,
                 closed_form: bool = True, cold_apart: bool | None = None) -> pipeline.Generated:
        """The generated code of a scene; jacobian: with mbs_jacobian (None: when the scene's integrator uses it);
        parameter_jacobian: with mbs_param_jacobian (for sensitivities); dynamics: also the dynamics functions,
        and the kinematics of the named frames (mbs.dynamics); equations_ready: called with the C of the equations
        as soon as it is written (pipeline.generate); closed_form: False for the numeric loop solver alone.
        A tree's c_source is written without its cold functions (cold_apart, None: COLD_APART): whole_source has
        them."""
        cold_apart = COLD_APART if cold_apart is None else cold_apart
        key = ("generated", scene, jacobian, parameter_jacobian, dynamics, tuple(frames), closed_form, cold_apart)
        if key not in self._compiled:
            self._compiled[key] = derivation_cache.generate(
                self.model, self.scene(scene), cache_dir=self.cache_dir, jacobian=jacobian,
                parameter_jacobian=parameter_jacobian, dynamics=dynamics, frames=tuple(frames),
                equations_ready=equations_ready, closed_form=closed_form, cold_apart=cold_apart)
        return self._compiled[key]

    def compile(self, scene: str | None = None, *, jacobian: bool | None = None, parameter_jacobian: bool = False,
                dynamics: bool = False, frames: tuple[str, ...] = (), hooks=None,
                closed_form: bool = True) -> CompiledModel:
        """The compiled model of a scene (its outputs) or of the model's own outputs; options as for generate.
        hooks: the implementations of the model's user hooks ({name: callable or 'file.c'}, runtime/hooks.py)."""
        binding = _hooks.bind(self.model.hooks, hooks, self.model.name)
        key = ("compiled", scene, jacobian, parameter_jacobian, dynamics, tuple(frames),
               binding.key if binding is not None else None, closed_form, COLD_APART)
        if key not in self._compiled:
            c_back_end = self.backend == "c" or (self.backend == "auto" and _build.have_c_compiler())
            # the C compiler starts on the runtime unit as the derivation starts and on the equations while the
            # outputs are derived (runtime/build.py Prebuilds)
            sc = self.scene(scene)  # (a scene without outputs: its file has no outputs' part, its glue unit differs)
            wanted = sc.outputs if sc is not None and sc.outputs else self.model.outputs
            prebuild = _build.Prebuilds(self.cache_dir, bool(wanted)) if c_back_end else None
            gen = self.generate(scene, jacobian=jacobian, parameter_jacobian=parameter_jacobian, dynamics=dynamics,
                                frames=frames, equations_ready=prebuild, closed_form=closed_form)
            params = pipeline.parameter_values(self.model, pipeline.scene_overrides(gen.scene))
            info = dict(name=self.model.name, q_names=gen.q_names, v_names=gen.v_names, z_names=gen.z_names,
                        p_names=gen.p_names,
                        y_names=gen.y_names, p_default=[params.get(n, 0.0) for n in gen.p_names],
                        events=gen.events,
                        x0=pipeline.initial_state(gen, params), units=pipeline.units_of(gen))
            if gen.layout.constraint_rows is not None and not (self.backend != "numpy" and _build.have_c_compiler()):
                raise MbsError([Diagnostic("error", f"model '{self.model.name}' has closed kinematic loops, which "
                                                    "need the C back end (no C compiler found)", None)])
            if self.backend == "c" or (self.backend == "auto" and _build.have_c_compiler()):
                code = gen.c_source + (binding.c_source() if binding is not None else "")
                whole = (lambda: gen.whole_source) if gen.cold_apart else None  # (no hooks then: pipeline)
                self._compiled[key] = load_c(code=code, cache_dir=self.cache_dir, cold=whole, **info)
            else:
                _hooks.check_numpy(binding)
                self._compiled[key] = load_numpy(_numpy_module(gen), **info)
        return self._compiled[key]

    def simulate(self, scene: str | None = None, *, t_end: float | None = None, sample: float | None = None,
                 t_eval=None, params: Mapping[str, float | str] | None = None, x0=None, integrator: str | None = None,
                 rtol: float | None = None, atol: float | None = None,
                 progress: Callable[[float, float], bool | None] | None = None, inputs: Mapping | None = None,
                 hooks: Mapping | None = None, **options) -> Results:
        """Run a scene (or the model with default settings); arguments given here override the scene's.
        inputs: {input: number, quantity ('2 N*m'), callable u(t) or u(t, x) in SI, or table (times, values)} replace
        the model's input expressions (mbs.inputs: the model is compiled once more with switchable inputs).
        hooks: {hook: Python callable or 'file.c'}, the implementations of the model's user hooks (runtime/hooks.py);
        a failing hook ends the run with its name, the time and its arguments, the samples up to it kept."""
        binding = _hooks.bind(self.model.hooks, hooks, self.model.name)  # checked before anything compiles
        if inputs:
            from .inputs import driven_run
            system, params, drive, integrator = driven_run(self, scene, inputs, params, integrator)
            return system.simulate(scene, t_end=t_end, sample=sample, t_eval=t_eval, params=params, x0=x0,
                                   integrator=integrator, rtol=rtol, atol=atol, progress=progress, _drive=drive,
                                   hooks=hooks, **options)
        drive = options.pop("_drive", None)
        data, settings = self.start(scene, params=params, x0=x0, t_end=t_end, sample=sample,
                                    integrator=integrator, rtol=rtol, atol=atol, drive=drive, hooks=binding)
        compiled = data.model
        if t_eval is not None:
            settings.pop("sample", None)
        options.setdefault("owners", self._owners(compiled))
        results = _simulate(compiled, data, settings.pop("t_end"), t_eval=t_eval, progress=progress,
                            **settings, **options)
        if binding is not None:
            _hooks.report(binding, compiled, results)
        joints = self._cardan_joints()
        if joints:  # (a model without Cardan joints has nothing to check: no walk over its interactions per run)
            warn_gimbal(self.model, results, joints)
        return results

    def _cardan_joints(self) -> tuple[str, ...]:
        """gimbal.cardan_joints of the model, worked out once (the model is immutable)."""
        key = ("cardan_joints",)
        if key not in self._compiled:
            self._compiled[key] = cardan_joints(self.model)
        return self._compiled[key]

    def _owners(self, compiled: CompiledModel) -> Mapping[str, str]:
        """coordinate_owners, worked out once per model's coordinates: a read-only view (the run only reads it; no
        copy per run)."""
        key = ("owners", compiled.q_names)
        if key not in self._compiled:
            self._compiled[key] = MappingProxyType(self.coordinate_owners(compiled))
        return self._compiled[key]

    def _parameter_values(self, sc: M.Scene | None, params: Mapping[str, float | str] | None) -> dict[str, float]:
        """Every parameter's value of a scene with the caller's overrides (pipeline.parameter_values: checked),
        kept for the last KEPT_BINDINGS overrides (System._binding); a copy, which the caller may change."""
        return dict(self._binding(sc, params)[0])

    def _binding(self, sc: M.Scene | None, params: Mapping[str, float | str] | None) -> tuple[dict, dict | None]:
        """(every parameter's value, the start vectors kept with them): the values pipeline.parameter_values binds
        and checks for a scene's and the caller's overrides, kept for the last KEPT_BINDINGS overrides (the model is
        immutable: the same overrides bind the same values), with a dict for what is worked out of them alone
        (System._start_vectors), None for values bound afresh (an unhashable override). Both are the System's:
        read, never changed by the caller."""
        overrides = {**pipeline.scene_overrides(sc), **parameter_overrides(self.model, params)}
        try:
            key = frozenset(overrides.items())
        except TypeError:  # an unhashable value (an array): bound afresh
            return pipeline.parameter_values(self.model, overrides), None
        kept = self._bindings.pop(key, None)
        if kept is None:
            kept = (pipeline.parameter_values(self.model, overrides), {})
            while len(self._bindings) >= KEPT_BINDINGS:
                del self._bindings[next(iter(self._bindings))]
        self._bindings[key] = kept  # the most recent last
        return kept

    def coordinate_owners(self, compiled: CompiledModel) -> dict[str, str]:
        """Coordinate name -> "interaction NAME: force A, B", to name the culprit of a diagnosis."""
        owners, first = {}, {}
        for k, i in enumerate(self.model.interactions):
            first.setdefault(i.name, (k, i))
        for name in compiled.q_names:  # of the interactions whose name is a prefix of it, the first declared
            heads = [first[head] for head in _dotted_heads(name) if head in first]
            interaction = min(heads, key=lambda found: found[0])[1] if heads else None
            if interaction is not None:
                forces = ", ".join(f.name for f in interaction.forces)
                owners[name] = f"interaction {interaction.name}" + (f": force {forces}" if forces else "")
        return owners

    def start(self, scene: str | None = None, *, params: Mapping[str, float | str] | None = None, x0=None,
              jacobian: bool | None = None, parameter_jacobian: bool = False, drive=None, hooks=None,
              **overrides) -> tuple[Workspace, dict]:
        """(workspace at the scene's start, run settings): what a run of the scene begins with. overrides:
        t_end, sample, integrator, rtol, atol as for simulate. jacobian, parameter_jacobian: as for compile.
        drive: sets the run-time inputs on the workspace (mbs.inputs). hooks: as for compile."""
        sc = self.scene(scene)
        settings = _settings(sc, *(overrides.get(k) for k in ("t_end", "sample", "integrator", "rtol", "atol")))
        if jacobian is None and settings["integrator"] and pipeline.needs_jacobian(None, settings["integrator"]):
            jacobian = True
        values, vectors = self._binding(sc, params)  # parameters checked before the (slow) first compile
        binding = _hooks.bind(self.model.hooks, hooks, self.model.name)
        compiled = self.compile(scene, jacobian=jacobian, parameter_jacobian=parameter_jacobian, hooks=binding)
        if binding is not None:
            binding.attach(compiled)
        gen = self.generate(scene, jacobian=jacobian, parameter_jacobian=parameter_jacobian)
        equilibrium = x0 is None and sc is not None and sc.start == "equilibrium"
        if binding is None and drive is None and x0 is None:  # a function of the model, p and x0 alone: kept
            return self._kept_start(compiled, gen, values, equilibrium, vectors), settings
        data = self._start(compiled, gen, dict(values), report=False)[0]
        if drive is not None:
            drive(data)
        if x0 is not None:
            data.x = np.asarray(x0, dtype=float)
        elif equilibrium:
            data.x = static_equilibrium(compiled, data, data.x).x
        return data, settings

    def forget_starts(self) -> None:
        """Let go of the start states kept (System._kept_start): the next start of every scene assembles its loops
        and solves its equilibrium again (benches that time a first start call this before each run)."""
        self._starts.clear()

    def _kept_start(self, compiled: CompiledModel, gen: pipeline.Generated, values: Mapping[str, float],
                    equilibrium: bool, vectors: dict | None = None) -> Workspace:
        """A workspace at the start of a run without hooks, inputs or a given x0: the loops assembled near the
        initial state, then the static equilibrium when asked for, as `start` makes them, or the state and the work
        memory the last such start with the same compiled model, parameters and initial state left (KEPT_STARTS of
        them). The work memory goes with the state: the loop solver keeps its partition there from call to call,
        and the run goes on from the one the equilibrium's last call chose, as after a fresh start. vectors: the
        binding's (System._binding), where p and the initial state are kept."""
        p, x0 = System._start_vectors(compiled, gen, values, vectors)
        key = (id(compiled), equilibrium, p.tobytes(), x0.tobytes())
        kept = self._starts.pop(key, None)
        if kept is None or kept[0] is not compiled:  # (an id is reused only after its object is gone)
            data = Workspace(compiled)
            data.p, data.x = p, x0
            System._assemble_into(data, gen)
            if equilibrium:
                data.x = static_equilibrium(compiled, data, data.x).x
            kept = (compiled, data.x.copy(), data.work.copy())
            while len(self._starts) >= KEPT_STARTS:  # the oldest first (no error if another thread took it)
                self._starts.pop(next(iter(self._starts), None), None)
        else:  # (its work memory copied once, not zeroed first)
            data = Workspace._resumed(compiled, p, kept[1], kept[2])
        self._starts[key] = kept  # the most recent last
        return data

    @staticmethod
    def _start_vectors(compiled: CompiledModel, gen: pipeline.Generated, values: Mapping[str, float],
                       vectors: dict | None) -> tuple[np.ndarray, np.ndarray]:
        """(p, x0) of a start: pipeline.parameter_vector and pipeline.initial_state of the parameters' values, kept in
        the binding's `vectors` (None: worked out afresh) per compiled model and generated code, of which and of the
        values they are functions alone (evaluating the Iltis' 73 initial values and its 165 parameters in order cost
        a 20th of the Python of its start). Read-only: the workspace copies them."""
        key = (id(compiled), id(gen))
        kept = vectors.get(key) if vectors is not None else None
        if kept is None or kept[0] is not compiled or kept[1] is not gen:  # (an id is reused only after it is gone)
            p = np.array(pipeline.parameter_vector(compiled.p_names, values), dtype=float)
            x0 = pipeline.initial_state(gen, values)
            for a in (p, x0):
                a.flags.writeable = False
            kept = (compiled, gen, p, x0)
            if vectors is not None:
                vectors[key] = kept
        return kept[2], kept[3]

    def accuracy(self, scene: str | None = None, *, params: Mapping[str, float] | None = None,
                 t_end: float | None = None, hooks: Mapping | None = None, **options):
        """The work-precision table of a scene (mbs.runtime.accuracy.work_precision; options: integrators,
        tolerances, repeats), built with the generated Jacobian for the stiff integrators. hooks: as for
        simulate."""
        from mbs.runtime.accuracy import work_precision
        from mbs.runtime.simulate import output_times
        data, settings = self.start(scene, params=params, jacobian=True, hooks=hooks)
        t_end = settings["t_end"] if t_end is None else t_end
        times = output_times(data.t, t_end, sample=settings.get("sample"))
        return work_precision(data.model, data, t_end, t_eval=times, **options)

    @staticmethod
    def _workspace(compiled: CompiledModel, gen: pipeline.Generated, values: Mapping[str, float]) -> Workspace:
        """A workspace with the parameters set and the initial state (closed loops assembled near the inits)."""
        return System._start(compiled, gen, values)[0]

    @staticmethod
    def _start(compiled: CompiledModel, gen: pipeline.Generated, values: Mapping[str, float], report: bool = True):
        """(workspace, Assembly or None): the initial state, and how the loops were closed (None: no loops, or
        report False: the same state without the assembly's report)."""
        data = Workspace(compiled)
        data.p = pipeline.parameter_vector(compiled.p_names, values)
        data.x = pipeline.initial_state(gen, values)
        if gen.layout.constraint_rows is None:
            return data, None
        if not report:
            System._assemble_into(data, gen)
            return data, None
        assembly = assemble(compiled, data, **System._assembly_arguments(gen))
        data.x = assembly.x
        return data, assembly

    @staticmethod
    def _assembly_arguments(gen: pipeline.Generated) -> dict:
        """What the loops' assembly reads of a scene's generated code (worked out once per generated code)."""
        spans = derived(gen, "cut_spans", lambda: MappingProxyType({name: gen.model.interaction_map[name].span
                                                                    for name in gen.layout.cuts}))
        fixed = derived(gen, "fixed_state_names", lambda: tuple(pipeline.fixed_state_names(gen)))
        return dict(fixed=fixed, row_names=gen.layout.constraint_rows, spans=spans)

    @staticmethod
    def _assemble_into(data: Workspace, gen: pipeline.Generated) -> None:
        """data.x: the loops closed near it (no report; nothing without loops)."""
        if gen.layout.constraint_rows is not None:
            data.x = assembled_state(data.model, data, **System._assembly_arguments(gen))

    def _scene_parameters(self, scene: str | None, params: Mapping[str, float | str] | None, hooks=None):
        """(compiled model, generated code, every parameter's value) of a scene with the caller's overrides;
        hooks: the implementations of the model's user hooks, connected to the compiled model."""
        binding = _hooks.bind(self.model.hooks, hooks, self.model.name)
        values = self._parameter_values(self.scene(scene), params)  # checked before the (slow) first compile
        compiled = self.compile(scene, hooks=binding)
        if binding is not None:
            binding.attach(compiled)
        return compiled, self.generate(scene), values

    def assemble(self, scene: str | None = None, *, params: Mapping[str, float | str] | None = None,
                 hooks: Mapping | None = None):
        """How the closed loops of a scene's start are closed (mbs.runtime.assembly.Assembly: the consistent state,
        what changed, rank, degrees of freedom, redundant rows), or None for a model without loops. hooks: as
        for simulate."""
        return self._start(*self._scene_parameters(scene, params, hooks))[1]

    def equilibrium(self, scene: str | None = None, *, params: Mapping[str, float | str] | None = None,
                    hooks: Mapping | None = None):
        """(Equilibrium, {output: value}) of a scene's parameters: where the system rests. hooks: as for simulate."""
        compiled, gen, values = self._scene_parameters(scene, params, hooks)
        data = self._workspace(compiled, gen, values)
        result = static_equilibrium(compiled, data, data.x)
        outputs = dict(zip(compiled.y_names, data.outputs(0.0, result.x))) if compiled.ny else {}
        return result, outputs

    def linearize(self, scene: str | None = None, *, params: Mapping[str, float | str] | None = None,
                  at="equilibrium", t: float = 0.0, hooks: Mapping | None = None):
        """The linear model (eigenvalues, natural frequencies, damping ratios, mode shapes, and A, B, C, D for
        the declared inputs and the outputs: .to_scipy(), .to_control()) about the static
        equilibrium at rest (at="equilibrium"; modes are only defined about a state that stays put, so the
        initial speeds of the scene are dropped), the initial state (at="initial") or a given state (an
        array [q; v]). hooks: as for simulate (the linear model then comes from finite differences)."""
        from mbs.runtime.linearize import linearize as _linearize
        from .inputs import drivable_inputs, is_driven, linearization_system, state_space_of
        if drivable_inputs(self.model) and not is_driven(self.model):
            system, params = linearization_system(self, scene, params, t)  # B and D need switchable inputs
            return system.linearize(scene, params=params, at=at, t=t, hooks=hooks)
        compiled, gen, values = self._scene_parameters(scene, params, hooks)
        data = self._workspace(compiled, gen, values)
        if isinstance(at, str):
            if at == "equilibrium":  # at rest: the scene's initial speeds (a car cruising) are not kept
                x = static_equilibrium(compiled, data, data.x, t).x
                x[compiled.nq:compiled.nq + compiled.nv] = 0.0  # extra states keep their rest values
            elif at == "initial":
                x = data.x.copy()
            else:
                raise MbsError([Diagnostic("error", f"linearize at '{at}': expected 'equilibrium', 'initial' or "
                                                    "a state vector", None)])
        else:
            x = np.asarray(at, dtype=float)
            if x.shape != (compiled.nx,):
                raise MbsError([Diagnostic("error", f"linearize: the state needs {compiled.nx} values "
                                                    f"({', '.join(compiled.x_names)}), got shape {x.shape}", None)])
        from mbs.runtime.mode_energy import part_groups
        lin = _linearize(compiled, data, t, x, groups=part_groups(self.model))
        return state_space_of(self, scene, compiled, data, lin)


def _dotted_heads(name: str):
    """'a.b.c' -> 'a', 'a.b': the prefixes before each dot."""
    dot = name.find(".")
    while dot >= 0:
        yield name[:dot]
        dot = name.find(".", dot + 1)


def _numpy_module(gen: pipeline.Generated):
    """Load the generated NumPy source as a module (text we generated from sympy, never model text)."""
    import types
    module = types.ModuleType(f"mbs_numpy_{gen.model.name}")
    exec(compile(gen.numpy_source, f"<generated numpy code of {gen.model.name}>", "exec"), module.__dict__)
    return module


def _settings(scene, t_end, sample, integrator, rtol, atol) -> dict:
    """Scene settings, overridden by explicit arguments; without a scene: 1 s, DOP853-like defaults."""
    out = {"t_end": SCENE_DEFAULTS["t_end"], "sample": None, "integrator": None, "rtol": SCENE_DEFAULTS["rtol"],
           "atol": SCENE_DEFAULTS["atol"]}
    if scene is not None:
        out.update(t_end=scene.t_end, sample=scene.sample, integrator=scene.integrator, rtol=scene.rtol,
                   atol=scene.atol)
    for key, value in (("t_end", t_end), ("sample", sample), ("integrator", integrator), ("rtol", rtol),
                       ("atol", atol)):
        if value is not None:
            out[key] = value
    return out


def load(path: str | Path, model: str | None = None, *, cache_dir: str | None = None, backend: str = "auto") -> System:
    """Read and validate a model file (taken from the model cache when it and its imports are unchanged,
    mbs/model_cache.py); raises MbsError listing every problem."""
    return System(model_cache.load(path, model, cache_dir=cache_dir), cache_dir=cache_dir, backend=backend)


def loads(text: str, model: str | None = None, *, path: str = "<string>", cache_dir: str | None = None,
          backend: str = "auto") -> System:
    """The same from text in memory."""
    from mbs.language.frontend import load_text
    return System(load_text(text, path, model), cache_dir=cache_dir, backend=backend)
