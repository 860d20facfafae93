"""One small class per ``mbs`` subcommand: its arguments and what it runs (the work lives in the stages)."""

from __future__ import annotations

import sys
from pathlib import Path
from types import SimpleNamespace


class Check:
    help = "parse and validate model files; report every error with its location"

    @staticmethod
    def arguments(p):
        p.add_argument("files", nargs="+", metavar="FILE")
        p.add_argument("-v", "--verbose", action="store_true", help="also print a summary of each model")
        p.add_argument("-W", "--no-warnings", action="store_true", help="hide warnings and notes")

    @staticmethod
    def run(args) -> int:
        from mbs.language.diagnostics import MbsError
        from mbs.language.frontend import check
        status = 0
        for path in args.files:
            try:
                result = check(path)
            except MbsError as err:
                from .cli import _render
                print(_render(err), file=sys.stderr)
                status = 1
                continue
            if not args.no_warnings:
                for d in result.diagnostics:
                    print(d.render(), file=sys.stderr)
            if args.verbose:
                for m in result.models:
                    print(summary(m))
            names = [m.name for m in result.models] + [f"{c} (component)" for c in result.components]
            print(f"{path}: ok ({', '.join(names) or 'no models'})")
        return status


def summary(model) -> str:
    from mbs.language.rules import degrees_of_freedom_estimate
    bodies = sum(1 for p in model.parts if p.body is not None)
    joints = sum(1 for i in model.interactions if i.joint is not None)
    coords = ", ".join(c.name + (" (prescribed)" if c.prescribed is not None else "") for c in model.coordinates)
    return (f"model {model.name}: {len(model.parts)} parts ({bodies} rigid), {len(model.interactions)} interactions "
            f"({joints} joints), {len(model.parameters)} parameters, {degrees_of_freedom_estimate(model)} joint "
            f"velocities\n  coordinates: {coords or 'none'}\n  scenes: "
            f"{', '.join(s.name for s in model.scenes) or 'none'}")


class Fmt:
    help = "print model files in canonical layout (or rewrite them with --in-place)"

    @staticmethod
    def arguments(p):
        p.add_argument("files", nargs="+", metavar="FILE")
        g = p.add_mutually_exclusive_group()
        g.add_argument("-i", "--in-place", action="store_true", help="rewrite the file (atomically)")
        g.add_argument("--check", action="store_true", help="exit 1 if the file is not formatted")

    @staticmethod
    def run(args) -> int:
        from mbs.atomic import write_text_atomic
        from mbs.language.formatter import format_source
        from mbs.language.parser import parse_source, read_source
        status = 0
        for path in args.files:
            source = read_source(path)
            text = format_source(parse_source(source), source)
            if args.check:
                if text != source.text:
                    print(f"{path}: not formatted", file=sys.stderr)
                    status = 1
            elif args.in_place:
                write_text_atomic(Path(path), text)
            else:
                sys.stdout.write(text)
        return status


class Export:
    help = "export the validated data model (method-independent, documented JSON schema)"

    @staticmethod
    def arguments(p):
        p.add_argument("file", metavar="FILE")
        p.add_argument("--json", action="store_true", required=True, help="JSON output (the only format)")
        p.add_argument("--model", help="model name when the file has several")
        p.add_argument("-o", "--output", help="write to this file (atomically) instead of stdout")

    @staticmethod
    def run(args) -> int:
        from mbs.language.export import model_to_json
        from mbs.language.frontend import load
        text = model_to_json(load(args.file, args.model))
        if args.output:
            from mbs.atomic import write_text_atomic
            write_text_atomic(Path(args.output), text)
        else:
            sys.stdout.write(text)
        return 0


COMMANDS = {"check": Check, "fmt": Fmt, "export": Export}


# ------------------------------------------------------------------------------------------ compiling and running
def _model_args(p):
    p.add_argument("file", metavar="FILE")
    p.add_argument("--model", help="model name when the file has several")


def _param_arg(p) -> None:
    p.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                   help="override a parameter, unit optional: --param l=2m (repeatable; no recompile)")


def _params(args, system) -> dict[str, float]:
    """The --param overrides, checked against the model (an unknown name or unit is a located error)."""
    return dict(_parse_param(text, system.model) for text in args.param)


def _parse_param(text: str, model):
    """--param name=value with an optional unit (l=2m, v=36km/h), checked against the parameter's dimension."""
    from mbs.language import units as U
    from mbs.language.diagnostics import Diagnostic, MbsError
    import re
    name, _, value = text.partition("=")
    name = name.strip()
    match = re.fullmatch(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(\S*)\s*", value)
    if not _ or match is None:
        raise MbsError([Diagnostic("error", f"--param expects name=value[unit], e.g. l=2m; got '{text}'", None)])
    if name not in model.parameter_map:
        from mbs.language.scope import did_you_mean
        raise MbsError([Diagnostic("error", f"model '{model.name}' has no parameter '{name}'"
                                            f"{did_you_mean(name, model.parameter_map)}", None)])
    number, unit = float(match.group(1)), match.group(2)
    if not unit:
        return name, number
    try:
        factor, dim = U.parse_unit(unit)
    except U.UnitError as exc:
        raise MbsError([Diagnostic("error", f"--param {name}: {exc.message}", None)]) from None
    wanted = model.parameter_map[name].dimension
    if wanted is not None and dim != wanted:
        raise MbsError([Diagnostic("error", f"--param {name}: expected {U.describe(wanted)}, got {U.describe(dim)}",
                                   None)])
    return name, number * factor


class _ProgressBar:
    """A progress line on stderr for runs that take longer than a second (and only on a terminal)."""

    DELAY = 1.0

    def __init__(self):
        import time
        self.start = time.perf_counter()
        self.shown = False
        self.enabled = sys.stderr.isatty()

    def __call__(self, t: float, t_end: float):
        import time
        if not self.enabled or time.perf_counter() - self.start < self.DELAY:
            return None
        fraction = 0.0 if t_end <= 0 else min(1.0, t / t_end)
        bar = "#" * int(30 * fraction)
        sys.stderr.write(f"\r[{bar:<30}] {100 * fraction:5.1f} %  t = {t:.4g} / {t_end:.4g} s")
        sys.stderr.flush()
        self.shown = True
        return None

    def close(self):
        if self.shown:
            sys.stderr.write("\n")


class Simulate:
    help = "compile (cached) and simulate a model or one of its scenes; write results and plots atomically"

    @staticmethod
    def arguments(p):
        _model_args(p)
        p.add_argument("--scene", action="append", default=[],
                       help="scene to run (default: the model's first scene, if any); repeat it to run several "
                            "and compare them in one plot")
        p.add_argument("--t-end", type=float, help="end time [s]")
        p.add_argument("--sample", type=float, help="output interval [s]")
        p.add_argument("--out", help="results file: .csv or .npz (several scenes: one file each, NAME_SCENE.csv)")
        p.add_argument("--plot", help="plot of the outputs (or coordinates) as PNG/PDF/SVG; several scenes: the "
                                      "motion of every scene in one plot, tyre loads in NAME_tyres.png")
        p.add_argument("--integrator", help="dopri5, rodasp (in C), RK45, DOP853, Radau, BDF, LSODA (scipy)")
        p.add_argument("--rtol", type=float)
        p.add_argument("--atol", type=float)
        _param_arg(p)

    @staticmethod
    def run(args) -> int:
        import mbs
        _check_suffixes(args)
        system = mbs.load(args.file, args.model)
        scenes = list(dict.fromkeys(args.scene))  # a scene named twice runs once
        if len(scenes) > 1:
            return _simulate_scenes(system, scenes, args)
        scene = scenes[0] if scenes else None
        if scene is None and system.model.scenes:
            scene = system.model.scenes[0].name
        params = _params(args, system)
        progress = _ProgressBar()
        try:
            res = system.simulate(scene, t_end=args.t_end, sample=args.sample, params=params,
                                  integrator=args.integrator, rtol=args.rtol, atol=args.atol, progress=progress)
        finally:
            progress.close()
        if args.out:
            (res.to_npz if args.out.endswith(".npz") else res.to_csv)(args.out)
        if args.plot:
            compiled = system.compile(scene)
            names = list(compiled.y_names) or list(compiled.q_names)
            res.plot(names, args.plot, title=f"{system.model.name}" + (f", scene {scene}" if scene else ""))
        _summary(system, scene, res, args)
        if not res.success:
            print(f"{args.file}: {res.message}", file=sys.stderr)
            return 1
        return 0


PLOT_FORMATS = (".png", ".pdf", ".svg")


def _check_suffixes(args) -> None:
    """Refuse unknown file types before a long run, not after it."""
    from mbs.language.diagnostics import Diagnostic, MbsError
    if args.out and Path(args.out).suffix.lower() not in (".csv", ".npz"):
        raise MbsError([Diagnostic("error", f"--out {args.out}: results are written as .csv or .npz", None)])
    if args.plot and Path(args.plot).suffix.lower() not in PLOT_FORMATS:
        raise MbsError([Diagnostic("error", f"--plot {args.plot}: plots are written as "
                                            f"{', '.join(PLOT_FORMATS)}", None)])


def scene_path(path: str, scene: str, tag: str = "") -> Path:
    """NAME.csv -> NAME_<scene>.csv: one results file per scene, next to the one asked for."""
    p = Path(path)
    return p.with_name(f"{p.stem}_{scene}{tag}{p.suffix}")


def _simulate_scenes(system, scenes: list[str], args) -> int:
    """Run several scenes of one model (compiled once when their outputs agree) and compare them."""
    for scene in scenes:
        system.scene(scene)  # every name checked before the first run
    params = _params(args, system)
    runs = {}
    for scene in scenes:
        progress = _ProgressBar()
        try:
            res = system.simulate(scene, t_end=args.t_end, sample=args.sample, params=params,
                                  integrator=args.integrator, rtol=args.rtol, atol=args.atol, progress=progress)
        finally:
            progress.close()
        runs[scene] = res
        out = None
        if args.out:
            out = scene_path(args.out, scene)
            (res.to_npz if out.suffix == ".npz" else res.to_csv)(out)
        _summary(system, scene, res, SimpleNamespace(out=out, plot=None))
    if args.plot:
        for path in plot_scenes(system, runs, args.plot):
            print(f"plot written to {path}")
    failed = [s for s, res in runs.items() if not res.success]
    for scene in failed:
        print(f"{args.file}: scene {scene}: {runs[scene].message}", file=sys.stderr)
    return 1 if failed else 0


def _is_load(name: str) -> bool:
    return name.endswith(".load")


def plot_scenes(system, runs: dict, path: str) -> list[Path]:
    """The scenes overlaid: the motion outputs in PATH, the tyre loads (outputs '*.load') in PATH_tyres.

    The motion plot shows 'heave' when the scenes have it (the paper's figure 18: the vertical motion of the
    car body), else every output that is not a load (else the coordinates). Each line is labelled with the
    scene's description, which names its speed ("in-phase bump at 5 m/s"), else with the scene's name.
    """
    first = next(iter(runs.values()))
    names = [n for n in first.names if n != "time" and all(n in r for r in runs.values())]
    sc = system.scene(next(iter(runs)))
    wanted = [o.name for o in sc.outputs] if sc is not None and sc.outputs else []
    wanted = wanted or list(system.compile(next(iter(runs))).y_names)  # a scene's outputs may be coordinates
    outputs = [n for n in wanted if n in names]
    loads = [n for n in outputs if _is_load(n)]
    motion = ["heave"] if "heave" in outputs else [n for n in outputs if not _is_load(n)]
    if not motion and not loads:
        compiled = system.compile(next(iter(runs)))
        motion = [n for n in compiled.q_names if n in names]
    units = _output_units(system, names, first.metadata.get("units", {}))
    labels = {scene: _scene_label(system, scene) for scene in runs}
    written = []
    if motion:
        written.append(_overlay(runs, motion, units, labels, Path(path), f"{system.model.name}: "
                                + ("vertical motion of the car body" if motion == ["heave"] else "outputs")))
    if loads:
        target = Path(path).with_name(f"{Path(path).stem}_tyres{Path(path).suffix}")
        written.append(_overlay(runs, loads, units, labels, target, f"{system.model.name}: tyre loads"))
    return written


def _scene_label(system, scene: str) -> str:
    sc = system.scene(scene)
    return f"{scene}: {sc.description}" if sc.description else scene


def _output_units(system, names, known: dict) -> dict[str, str]:
    """Units of outputs that are a sensor (heave = attitude.cg.z: m) or a coordinate (heave = lift.s).

    Outputs carry no dimension in the data model; an output that is an expression stays without a unit.
    """
    from mbs.language import expr as X
    kinds = {"position": "m", "distance": "m", "velocity": "m/s", "acceleration": "m/s^2", "angles": "rad",
             "force": "N"}
    sensors = {s.name: s.kind for i in system.model.interactions for s in i.sensors}
    values = {o.name: o.value for o in system.model.outputs}

    def sensor_unit(name: str):
        for key in (name, name.rpartition(".")[0]):
            if key in sensors:
                return kinds.get(sensors[key])
        return None

    units = {}
    for name in names:
        value = values.get(name)
        if isinstance(value, X.Sym) and value.kind == "coord":
            unit = known.get(value.name)
        elif isinstance(value, X.Sym) and value.kind == "sensor":
            unit = sensor_unit(value.name)
        else:
            unit = known.get(name) or sensor_unit(name)
        if unit:
            units[name] = unit
    return units


def _overlay(runs: dict, names: list[str], units: dict, labels: dict, path: Path, title: str) -> Path:
    """One panel per output, one line per scene; written atomically (matplotlib's object API, no pyplot)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from mbs.atomic import atomic_path
    fig = Figure(figsize=(8, 2.2 + 2.0 * len(names)), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(len(names), 1, sharex=True, squeeze=False)[:, 0]
    for ax, name in zip(axes, names):
        for scene, res in runs.items():
            unit = units.get(name) or res.metadata.get("units", {}).get(name)
            ax.plot(res.t, res[name], label=labels[scene])
            ax.set_ylabel(f"{name} [{unit}]" if unit else name)
            if not res.success:
                ax.axvline(res.t[-1], color="tab:red", lw=0.8, ls=":")
        ax.grid(True, alpha=0.3)
    fig.legend(*axes[0].get_legend_handles_labels(), loc="outside lower center", fontsize=8, ncols=1)
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(title)
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        fig.savefig(f, format=path.suffix.lstrip(".").lower() or "png")
    return path


def _summary(system, scene, res, args) -> None:
    t = res.t
    head = f"{system.model.name}" + (f" / scene {scene}" if scene else "")
    print(f"{head}: {len(t)} samples, t = {t[0]:g} .. {t[-1]:g} s ({res.message or 'finished'})")
    for name in [n for n in res.names if n != "time"][:12]:
        print(f"  {name:32s} final {res[name][-1]: .6g}")
    for what, path in (("results", args.out), ("plot", args.plot)):
        if path:
            print(f"  {what} written to {path}")


class Compile:
    help = "generate C for a model (or scene) and build it: DIR/<model>.c, .h and lib<model>.so"

    @staticmethod
    def arguments(p):
        _model_args(p)
        p.add_argument("--scene", help="scene whose outputs to generate")
        p.add_argument("-o", "--output", default=".", metavar="DIR", help="output folder (default: .)")

    @staticmethod
    def run(args) -> int:
        import mbs
        from .standalone import write_standalone
        system = mbs.load(args.file, args.model)
        gen = system.generate(args.scene)
        paths = write_standalone(gen, Path(args.output))
        for path in paths:
            print(path)
        return 0


class Eom:
    help = "print the equations of motion M(y,t) y'' + k(y,y',t) = q(y,y',t) of a small model"

    MAX_VELOCITIES = 6  # beyond this the written-out expressions are too long to read

    @staticmethod
    def arguments(p):
        _model_args(p)
        p.add_argument("--latex", action="store_true", help="LaTeX instead of plain text")
        p.add_argument("--no-simplify", action="store_true", help="skip sympy's simplification (faster)")

    @staticmethod
    def run(args) -> int:
        import sympy as sp
        import mbs
        from mbs.compiler.equations import display_equations
        from mbs.compiler.lower import lower
        from mbs.language.diagnostics import Diagnostic, MbsError
        system = mbs.load(args.file, args.model)
        lowered = lower(system.model)
        tree = lowered.tree
        if tree.nv > Eom.MAX_VELOCITIES:
            raise MbsError([Diagnostic("error", f"model '{system.model.name}' has {tree.nv} velocities; mbs eom "
                                                f"writes equations out for at most {Eom.MAX_VELOCITIES}", None)])
        M, k, q = display_equations(lowered.kinematics, simplify=not args.no_simplify)
        from .pipeline import display_name
        shown = {s: sp.Symbol(display_name(s.name)) for s in tree.q_symbols + tree.v_symbols}
        M, k, q = (m.xreplace(shown) for m in (M, k, q))
        y = sp.Matrix([shown[s] for s in tree.q_symbols])
        v = sp.Matrix([shown[s] for s in tree.v_symbols])
        if args.latex:
            print(f"% {system.model.name}: M(y, t) \\dot v + k(y, v, t) = q(y, v, t)")
            print(f"y = {sp.latex(y)}, \\quad v = {sp.latex(v)}")
            print(f"M = {sp.latex(M)}")
            print(f"k = {sp.latex(k)}")
            print(f"q = {sp.latex(q)}")
        else:
            print(f"{system.model.name}: M(y, t) v' + k(y, v, t) = q(y, v, t)")
            print(f"y = {list(y)}\nv = {list(v)}\n")
            for label, mat in (("M", M), ("k", k), ("q", q)):
                print(f"{label} =")
                print(sp.pretty(mat, use_unicode=False, wrap_line=False))
                print()
        return 0


class Info:
    help = "topology, coordinates and degrees of freedom of a model"

    @staticmethod
    def arguments(p):
        _model_args(p)
        p.add_argument("--assemble", action="store_true",
                       help="close the loops at the start (compiles the model): rank, degrees of freedom, "
                            "redundant constraints, what assembly changed")
        p.add_argument("--scene", help="with --assemble: the scene whose start to assemble")

    @staticmethod
    def run(args) -> int:
        import mbs
        from mbs.compiler.topology import build_topology
        system = mbs.load(args.file, args.model)
        model = system.model
        topo = build_topology(model)
        print(summary(model))
        print("  spanning tree (parent first):")
        for i, (body, joint) in enumerate(zip(topo.bodies, topo.joints)):
            parent = "inertial" if topo.parent_index[i] < 0 else topo.bodies[topo.parent_index[i]]
            flipped = " (written child -> parent)" if joint.flipped else ""
            print(f"    {body:24s} <- {joint.interaction.joint.kind:11s} {joint.interaction.name} from {parent}{flipped}")
        for cut in topo.cuts:
            print(f"  loop closed by {cut.name} ({cut.joint.kind})")
        if args.assemble and topo.cuts:
            _print_assembly(system.assemble(args.scene), system.generate(args.scene))
        return 0


def _print_assembly(assembly, generated) -> None:
    """The mobility of the assembled start: rank and DOF from the constraint Jacobian, not from counting."""
    nc = generated.constraints.nc
    print(f"  assembled at the start: {nc} constraint rows of rank {assembly.rank}, "
          f"{assembly.dof} degree(s) of freedom, max |g| = {assembly.residual:.2g}")
    if assembly.idle:
        print(f"  idle: {len(assembly.idle)} row(s) hold by the geometry alone (no motion can violate them): "
              f"{', '.join(assembly.idle)}")
    if assembly.redundant:
        joints = sorted({name.rsplit(".", 1)[0] for name in assembly.redundant})
        n = nc - len(assembly.idle) - assembly.rank
        print(f"  redundant: {n} row(s) depend on others, among {', '.join(assembly.redundant)} (joints "
              f"{', '.join(joints)}): overconstrained but mobile; the solver drops the dependent rows, whose "
              "reactions rigid-body mechanics cannot determine")
    for name, given, after in assembly.changed:
        print(f"  assembly moved {name}: {given:.6g} -> {after:.6g}")


COMMANDS.update({"simulate": Simulate, "compile": Compile, "eom": Eom, "info": Info})


class Equilibrium:
    help = "find the static equilibrium of a model (it settles on its springs) and report it"

    @staticmethod
    def arguments(p):
        _model_args(p)
        p.add_argument("--scene", help="scene whose parameters and outputs to use")
        _param_arg(p)

    @staticmethod
    def run(args) -> int:
        import mbs
        system = mbs.load(args.file, args.model)
        params = _params(args, system)
        result, outputs = system.equilibrium(args.scene, params=params)
        compiled = system.compile(args.scene)
        print(f"{system.model.name}: static equilibrium, max |acceleration| {result.residual:.3g} "
              f"({result.steps} relaxation steps, {result.resets} restarts)")
        for name, value in zip(compiled.q_names, result.x[:compiled.nq]):
            print(f"  {name:32s} {value: .9g}")
        for name, value in outputs.items():
            print(f"  {name:32s} {value: .9g}  (output)")
        return 0


COMMANDS["equilibrium"] = Equilibrium


class Linearize:
    help = "linearise a model about its static equilibrium: natural frequencies, damping ratios, mode shapes"

    @staticmethod
    def arguments(p):
        _model_args(p)
        p.add_argument("--scene", help="scene whose parameters to use")
        _param_arg(p)
        p.add_argument("--at", choices=("equilibrium", "initial"), default="equilibrium",
                       help="linearise about the static equilibrium (default) or the initial state")

    @staticmethod
    def run(args) -> int:
        import mbs
        system = mbs.load(args.file, args.model)
        params = _params(args, system)
        lin = system.linearize(args.scene, params=params, at=args.at)
        head = f"{system.model.name}" + (f" / scene {args.scene}" if args.scene else "")
        print(f"{head}: linearised about the {'static equilibrium' if args.at == 'equilibrium' else 'initial state'}"
              f", {lin.dof} degree{'s' if lin.dof != 1 else ''} of freedom")
        print(lin.table())
        if lin.dof:
            print("undamped natural frequencies [Hz]: " + ", ".join(f"{f:.5g}" for f in lin.undamped_frequencies))
        return 0


COMMANDS["linearize"] = Linearize
