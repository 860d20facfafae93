"""simulate: compile, run one or several scenes, write results and plots."""

from __future__ import annotations

import sys
from pathlib import Path
from types import SimpleNamespace

from .common import (ArgumentError, ProgressBar, check_integrator, check_scene, model_args, param_arg,
                     params_from_args)
from .hook_args import hook_arg, hooks_from_args
from .results_file import RESULT_FORMATS, write_results

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
        p.add_argument("--out", help="results file: .csv, .npz or .h5 (several scenes: one file each, NAME_SCENE.csv)")
        p.add_argument("--plot", help="plot of the outputs (or coordinates) as PNG/PDF/SVG; several scenes: the "
                                      "motion of every scene in one plot, tyre loads in NAME_tyres.png")
        p.add_argument("--integrator", help="dopri5, adams, rodasp, rodas5p, auto (in C), cvode_adams, cvode_bdf, ida "
                                            "(SUNDIALS), RK45, DOP853, Radau, BDF, LSODA (scipy), or any registered one "
                                            "(default: the scene's, else dopri5)")
        p.add_argument("--error-estimate", action="store_true",
                       help="run again at a tenth of the tolerances; print and store the estimated global error "
                            "of every output")
        p.add_argument("--rtol", type=float, help="relative tolerance of the integrator's local error (default: "
                                                  "the scene's, else 1e-8)")
        p.add_argument("--atol", type=float, help="absolute tolerance, in the units of each state (m, rad, m/s, "
                                                  "rad/s; default: the scene's, else 1e-10)")
        p.add_argument("--max-wall-time", type=float, metavar="SECONDS",
                       help="stop a run after this much wall time, keeping (and writing) the samples so far")
        param_arg(p)
        hook_arg(p)

    @staticmethod
    def run(args) -> int:
        import warnings

        from mbs.gimbal import GimbalWarning
        with warnings.catch_warnings():  # printed once, located, by _summary
            warnings.simplefilter("ignore", GimbalWarning)
            return Simulate._run(args)

    @staticmethod
    def _run(args) -> int:
        import mbs
        _check_suffixes(args)
        check_integrator(args.integrator)
        system = mbs.load(args.file, args.model)
        scenes = list(dict.fromkeys(args.scene))  # a scene named twice runs once
        for scene in scenes:
            check_scene(system, scene)  # every name checked before the first run
        args.hook_functions = hooks_from_args(args)  # each Python hook file imported once
        if len(scenes) > 1:
            return _simulate_scenes(system, scenes, args)
        scene = scenes[0] if scenes else None
        if scene is None and system.model.scenes:
            scene = system.model.scenes[0].name
        params = params_from_args(args, system)
        res = _run_scene(system, scene, params, args)
        if args.error_estimate and res.success:
            _estimate_error(system, scene, params, res, args)
        if args.out:
            write_results(res, args.out, system, scene)
        if args.plot:
            res.plot(requested_outputs(system, scene, res), args.plot,
                     title=f"{system.model.name}" + (f", scene {scene}" if scene else ""))
        _summary(system, scene, res, args)
        if not res.success:
            print(f"{args.file}: {res.message}", file=sys.stderr)
            return 130 if res.metadata.get("status") == "interrupted" else 1
        return 0


def _estimate_error(system, scene, params, res, args) -> None:
    """Second run at a tenth of the tolerances: the estimated global error per column, printed and stored."""
    from mbs.runtime.accuracy import global_error_estimate
    rtol, atol = res.metadata["rtol"], res.metadata["atol"]
    fine = system.simulate(scene, t_end=args.t_end, t_eval=res.t, params=params, integrator=args.integrator,
                           rtol=rtol / 10, atol=(atol / 10 if isinstance(atol, float) else [a / 10 for a in atol]),
                           hooks=args.hook_functions)
    if not fine.success:
        print(f"{args.file}: the error estimate's second run failed: {fine.message}", file=sys.stderr)
        return
    errors = global_error_estimate(res, fine)
    res.metadata["error_estimate"] = errors
    res.metadata["error_estimate_method"] = f"difference to a second run at rtol {rtol / 10:g}"
    units = res.metadata.get("units", {})
    shown = list(system.generate(scene).y_names) or list(errors)
    print(f"estimated global error (largest over the samples; second run at rtol {rtol / 10:g}):")
    for name in shown:
        if name in errors:
            print(f"  {name:32s} {errors[name]:.3g} {units.get(name, '')}".rstrip())


def _check_suffixes(args) -> None:
    """Refuse unknown file types before a long run, not after it."""
    if args.out and Path(args.out).suffix.lower() not in RESULT_FORMATS:
        raise ArgumentError(f"--out {args.out}: results are written as .csv, .npz or .h5")
    if args.plot and Path(args.plot).suffix.lower() not in PLOT_FORMATS:
        raise ArgumentError(f"--plot {args.plot}: plots are written as {', '.join(PLOT_FORMATS)}")
    from mbs.base.atomic import writable_problem
    for option, path in (("--out", args.out), ("--plot", args.plot)):
        why = writable_problem(path) if path else None
        if why:
            raise ArgumentError(f"{option} {path} cannot be written: {why}")
def requested_outputs(system, scene, res) -> list[str]:
    """What the scene (or model) asks to see, in its order, coordinates included (`output hinge.phi` is a
    state column, not a compiled output); without outputs the coordinates."""
    sc = system.scene(scene)
    wanted = [o.name for o in sc.outputs] if sc is not None and sc.outputs else \
        [o.name for o in system.model.outputs]
    compiled = system.generate(scene)  # the names only: no build (and no hooks needed)
    names = [n for n in dict.fromkeys(wanted + list(compiled.y_names)) if n in res]
    return names or [n for n in compiled.q_names if n in res]


def scene_path(path: str, scene: str, tag: str = "") -> Path:
    """NAME.csv -> NAME_<scene>.csv: one results file per scene, next to the one asked for."""
    p = Path(path)
    return p.with_name(f"{p.stem}_{scene}{tag}{p.suffix}")


def _run_scene(system, scene, params, args):
    """One scene's run with the command line's settings and a progress bar, closed however the run ends."""
    progress = ProgressBar()
    try:
        return system.simulate(scene, t_end=args.t_end, sample=args.sample, params=params,
                               integrator=args.integrator, rtol=args.rtol, atol=args.atol, progress=progress,
                               max_wall_time=args.max_wall_time, hooks=args.hook_functions)
    finally:
        progress.close()


def _simulate_scenes(system, scenes: list[str], args) -> int:
    """Run several scenes of one model (compiled once when their outputs agree) and compare them."""
    params = params_from_args(args, system)
    runs = {}
    for scene in scenes:
        res = _run_scene(system, scene, params, args)
        runs[scene] = res
        out = None
        if args.out:
            out = scene_path(args.out, scene)
            write_results(res, out, system, scene)
        _summary(system, scene, res, SimpleNamespace(out=out, plot=None))
    if args.plot:
        for path in plot_scenes(system, runs, args.plot):
            print(f"plot written to {path}")
    failed = [s for s, res in runs.items() if not res.success]
    for scene in failed:
        print(f"{args.file}: scene {scene}: {runs[scene].message}", file=sys.stderr)
    return 1 if failed else 0


def _is_load(name: str) -> bool:
    return name.endswith(".load") or name.endswith(".forces.fy")   # tyre loads and lateral forces


def plot_scenes(system, runs: dict, path: str) -> list[Path]:
    """The scenes overlaid: the motion outputs in PATH, the tyre loads (outputs '*.load') in PATH_tyres.

    The motion plot shows 'heave' when the scenes have it (the paper's figure 18: the vertical motion of the
    car body), else every output that is not a load (else the coordinates). Each line is labelled with the
    scene's description, which names its speed ("in-phase bump at 5 m/s"), else with the scene's name.
    """
    first = next(iter(runs.values()))
    names = [n for n in first.names if n != "time" and all(n in r for r in runs.values())]
    outputs = [n for n in requested_outputs(system, next(iter(runs)), first) if n in names]
    loads = [n for n in outputs if _is_load(n)]
    motion = ["heave"] if "heave" in outputs else [n for n in outputs if not _is_load(n)]
    if not motion and not loads:
        compiled = system.generate(next(iter(runs)))
        motion = [n for n in compiled.q_names if n in names]
    labels = {scene: _scene_label(system, scene) for scene in runs}
    written = []
    if motion:
        written.append(_overlay(runs, motion, labels, Path(path), f"{system.model.name}: "
                                + ("vertical motion of the car body" if motion == ["heave"] else "outputs")))
    if loads:
        target = Path(path).with_name(f"{Path(path).stem}_tyres{Path(path).suffix}")
        written.append(_overlay(runs, loads, labels, target, f"{system.model.name}: tyre loads"))
    return written


def _scene_label(system, scene: str) -> str:
    sc = system.scene(scene)
    return f"{scene}: {sc.description}" if sc.description else scene


def _overlay(runs: dict, names: list[str], labels: dict, path: Path, title: str) -> Path:
    """The scenes in one figure, grouped by unit, one line style per scene (runtime/plotting.py)."""
    from mbs.runtime import plotting
    fig = plotting.figure({labels[scene]: res for scene, res in runs.items()}, names, title=title)
    return plotting.save(fig, path)


def _summary(system, scene, res, args) -> None:
    for note in res.metadata.get("notes", []):
        print(note, file=sys.stderr)
    for text in res.metadata.get("warnings", ()):
        print(f"{system.model.name}: warning: {text}", file=sys.stderr)
    t = res.t
    head = f"{system.model.name}" + (f" / scene {scene}" if scene else "")
    if not len(t):
        print(f"{head}: no samples ({res.message or 'finished'})")
        return
    print(f"{head}: {len(t)} samples, t = {t[0]:g} .. {t[-1]:g} s ({res.message or 'finished'})")
    units = res.units
    for name in requested_outputs(system, scene, res) if len(res) else []:
        column = res[name]
        unit = f" {units[name]}" if units.get(name, "1") != "1" else ""  # a plain number: no unit shown
        print(f"  {name:32s} final {column[-1]: .6g}{unit}   (min {column.min(): .4g}, max {column.max(): .4g})")
    for what, path in (("results", args.out), ("plot", args.plot)):
        if path:
            print(f"  {what} written to {path}")
