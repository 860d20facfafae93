"""optimize: minimise a metric of a scene over parameters within bounds, with constraints on other metrics."""

from __future__ import annotations

import sys
from pathlib import Path

from .common import model_args, parse_param
from .hook_args import hook_arg, hooks_from_args


class Optimize:
    help = ("minimise a metric over parameters (bounds, constraints on other metrics) by differential evolution "
            "on Dask; the optimum is written as a scene")

    @staticmethod
    def arguments(p):
        model_args(p)
        p.add_argument("--scene", help="scene to optimise (default: the model's first scene, if any)")
        p.add_argument("--param", action="append", default=[], metavar="NAME=LOW:HIGH",
                       help="a parameter to optimise within bounds, units optional: d_susp=500:5000 (repeatable); "
                            "NAME=VALUE sets a parameter in every run")
        goal = p.add_mutually_exclusive_group(required=True)
        goal.add_argument("--minimize", metavar="METRIC", help="the metric to minimise, as in mbs sweep")
        goal.add_argument("--maximize", metavar="METRIC", help="the metric to maximise (its negative is minimised)")
        p.add_argument("--constraint", action="append", default=[], metavar="'METRIC <= NUMBER'",
                       help="a bound on another metric (repeatable)")
        p.add_argument("--maxiter", type=int, default=20, help="generations at most (default 20)")
        p.add_argument("--popsize", type=int, default=6, help="members per parameter and generation (default 6)")
        p.add_argument("--seed", type=int, default=0)
        p.add_argument("--scheduler", metavar="ADDRESS", help="an existing Dask cluster (default: a local one)")
        p.add_argument("--out", help="every evaluated design as a table (.csv or .h5)")
        p.add_argument("-o", "--output", metavar="FILE.mbs",
                       help="write the model file with the optimum appended as scene SCENE_optimum (imports resolve "
                            "next to FILE, else in the library)")
        hook_arg(p)

    @staticmethod
    def run(args) -> int:
        import mbs
        from mbs.language.diagnostics import Diagnostic, MbsError
        from mbs.studies.optimize import optimize
        from mbs.studies.table import StudyTable
        if args.output and not args.output.endswith(".mbs"):
            raise MbsError([Diagnostic("error", f"-o {args.output}: the optimum is written as a .mbs file", None)])
        if args.out and Path(args.out).suffix.lower() not in (".csv", ".h5", ".hdf5"):
            raise MbsError([Diagnostic("error", f"--out {args.out}: a table is written as .csv or .h5", None)])
        system = mbs.load(args.file, args.model)
        scene = args.scene or (system.model.scenes[0].name if system.model.scenes else None)
        system.scene(scene)
        bounds, fixed = parameter_bounds(args.param, system.model)
        hooks = hooks_from_args(args)

        def log(entry):
            x = ", ".join(f"{k} = {v:.6g}" for k, v in entry["x"].items())
            print(f"generation {entry['iteration']:3d}  runs {entry['evaluations']:4d}  best {entry['value']:.8g}"
                  f"  at {x}", flush=True)

        objective = args.minimize or f"-({args.maximize})"
        opt = optimize(system, scene, objective, bounds, constraints=args.constraint, fixed=fixed,
                       maxiter=args.maxiter, popsize=args.popsize, seed=args.seed, scheduler=args.scheduler,
                       log=log, hooks=hooks)
        x = ", ".join(f"{k} = {v:.10g}" for k, v in opt.x.items())
        print(f"optimum: {objective} = {opt.value:.8g} at {x} ({opt.evaluations} runs; {opt.message})")
        for metric, value in opt.constraints.items():
            print(f"  {metric} = {value:.8g}")
        if args.out:
            table = StudyTable(tuple(bounds), (opt.objective, *opt.constraints), opt.rows,
                               {"model": system.model.name, "scene": scene, "objective": objective,
                                "constraints": list(args.constraint)})
            (table.to_csv if args.out.endswith(".csv") else table.to_hdf5)(args.out)
            print(f"every run written to {args.out}")
        if args.output:
            from mbs.base.atomic import write_text_atomic
            source = Path(args.file).read_text(encoding="utf-8")
            write_text_atomic(args.output, source.rstrip("\n") + "\n\n" + opt.scene_text)
            name = f"{scene}_optimum" if scene else "optimum"
            hooks = "".join(f" --hook {text}" for text in args.hook)
            print(f"optimum written to {args.output}: mbs simulate {args.output} --scene {name}{hooks}")
        else:
            print("\n" + opt.scene_text)
        if not opt.feasible:
            print(f"{args.file}: no design within the bounds satisfies every constraint", file=sys.stderr)
            return 1
        return 0


def parameter_bounds(texts: list[str], model) -> tuple[dict[str, tuple[float, float]], dict[str, float]]:
    """--param NAME=LOW:HIGH -> bounds (SI); NAME=VALUE -> fixed."""
    from mbs.language.diagnostics import Diagnostic, MbsError
    bounds, fixed = {}, {}
    for text in texts:
        name, eq, value = text.partition("=")
        if not eq:
            raise MbsError([Diagnostic("error", f"--param expects NAME=LOW:HIGH or NAME=VALUE; got '{text}'", None)])
        if ":" in value:
            low, _, high = value.partition(":")
            bounds[name.strip()] = (parse_param(f"{name}={low}", model)[1], parse_param(f"{name}={high}", model)[1])
        else:
            fixed[name.strip()] = parse_param(text, model)[1]
    return bounds, fixed
