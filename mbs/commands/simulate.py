"""simulate: compile, run one or several scenes, write results and plots."""

from __future__ import annotations

import sys
from pathlib import Path
from types import SimpleNamespace

from .common import ProgressBar, model_args, param_arg, params_from_args

PLOT_FORMATS = (".png", ".pdf", ".svg")


class Simulate:
    help = "compile (cached) and simulate a model or one of its scenes; write results and plots atomically"

    @staticmethod
    def arguments(p):
        model_args(p)
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
        param_arg(p)

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
        params = params_from_args(args, system)
        progress = ProgressBar()
        try:
            res = system.simulate(scene, t_end=args.t_end, sample=args.sample, params=params,
                                  integrator=args.integrator, rtol=args.rtol, atol=args.atol, progress=progress)
        finally:
            progress.close()
        if args.out:
            (res.to_npz if args.out.endswith(".npz") else res.to_csv)(args.out)
            if system.compile(scene).events:  # the event log beside the samples: run.csv -> run.events.csv
                res.to_events_csv(events_path(args.out))
        if args.plot:
            compiled = system.compile(scene)
            names = list(compiled.y_names) or list(compiled.q_names)
            res.plot(names, args.plot, title=f"{system.model.name}" + (f", scene {scene}" if scene else ""))
        _summary(system, scene, res, args)
        if not res.success:
            print(f"{args.file}: {res.message}", file=sys.stderr)
            return 1
        return 0




def _check_suffixes(args) -> None:
    """Refuse unknown file types before a long run, not after it."""
    from mbs.language.diagnostics import Diagnostic, MbsError
    if args.out and Path(args.out).suffix.lower() not in (".csv", ".npz"):
        raise MbsError([Diagnostic("error", f"--out {args.out}: results are written as .csv or .npz", None)])
    if args.plot and Path(args.plot).suffix.lower() not in PLOT_FORMATS:
        raise MbsError([Diagnostic("error", f"--plot {args.plot}: plots are written as "
                                            f"{', '.join(PLOT_FORMATS)}", None)])


def events_path(path: str) -> Path:
    """run.csv -> run.events.csv: the event log next to the samples."""
    p = Path(path)
    return p.with_name(f"{p.stem}.events.csv")


def scene_path(path: str, scene: str, tag: str = "") -> Path:
    """NAME.csv -> NAME_<scene>.csv: one results file per scene, next to the one asked for."""
    p = Path(path)
    return p.with_name(f"{p.stem}_{scene}{tag}{p.suffix}")


def _simulate_scenes(system, scenes: list[str], args) -> int:
    """Run several scenes of one model (compiled once when their outputs agree) and compare them."""
    for scene in scenes:
        system.scene(scene)  # every name checked before the first run
    params = params_from_args(args, system)
    runs = {}
    for scene in scenes:
        progress = ProgressBar()
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
            if system.compile(scene).events:
                res.to_events_csv(events_path(str(out)))
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
