"""sweep: a parameter variation of one scene on Dask, one row per variant, written as CSV/HDF5 and plotted."""

from __future__ import annotations

import sys
from pathlib import Path

from .common import model_args, parse_param
from .hook_args import hook_arg, hooks_from_args

TABLE_FORMATS = (".csv", ".h5", ".hdf5")


class Sweep:
    help = "parameter variation on Dask: run a scene over a design of parameter values, one row of metrics each"

    @staticmethod
    def arguments(p):
        model_args(p)
        p.add_argument("--scene", help="scene to vary (default: the model's first scene, if any)")
        p.add_argument("--param", action="append", default=[], metavar="NAME=V1,V2,...",
                       help="values of a parameter, units optional: --param l=0.5m,1m,2m (repeatable; several "
                            "values are swept, a single value is set in every run)")
        p.add_argument("--design", nargs="+", default=["grid"], metavar="KIND",
                       help="grid (every combination, the default) or 'lhs N': a Latin hypercube of N points "
                            "between the smallest and largest value of each parameter")
        p.add_argument("--seed", type=int, default=0, help="random seed of the lhs design (default 0)")
        p.add_argument("--metric", action="append", default=[], metavar="EXPR",
                       help="a number per run: peak, min, rms, mean, final, range or period of an output, or an "
                            "expression of them, e.g. 'peak(heave) - min(heave)' (repeatable; default: peak and "
                            "final of each output)")
        p.add_argument("--scheduler", metavar="ADDRESS",
                       help="run on an existing Dask cluster (tcp://host:8786); default: a local cluster, one "
                            "worker per core")
        p.add_argument("--workers", type=int, help="workers of the local cluster (default: the number of cores)")
        p.add_argument("--out", action="append", default=[], help="the table: .csv or .h5 (repeatable)")
        p.add_argument("--plot", help="each metric against the first swept parameter (PNG/PDF/SVG)")
        p.add_argument("--t-end", type=float, help="end time [s]")
        p.add_argument("--sample", type=float, help="output interval [s]")
        p.add_argument("--integrator")
        p.add_argument("--rtol", type=float)
        p.add_argument("--atol", type=float)
        hook_arg(p)

    @staticmethod
    def run(args) -> int:
        import mbs
        from mbs.studies import sweep

        from .simulate import PLOT_FORMATS
        _check_outputs(args, PLOT_FORMATS)
        system = mbs.load(args.file, args.model)
        scene = args.scene or (system.model.scenes[0].name if system.model.scenes else None)
        system.scene(scene)
        swept, fixed = sweep_values(args.param, system.model)
        hooks = hooks_from_args(args)
        kind, n = _design(args.design)
        bar = CountBar()
        try:
            table = sweep(system, scene, swept, design=kind, n=n, seed=args.seed, metrics=args.metric or None,
                          fixed=fixed, scheduler=args.scheduler, workers=args.workers, progress=bar,
                          t_end=args.t_end, sample=args.sample, integrator=args.integrator, rtol=args.rtol,
                          atol=args.atol, hooks=hooks)
        finally:
            bar.close()
        for path in args.out:
            (table.to_csv if Path(path).suffix.lower() == ".csv" else table.to_hdf5)(path)
            print(f"table written to {path}")
        if args.plot:
            table.plot(args.plot, title=f"{system.model.name}" + (f", scene {scene}" if scene else ""))
            print(f"plot written to {args.plot}")
        _print_table(table)
        for row in table.failed:
            print(f"{args.file}: variant {row.index} ({_values(row.values)}): {row.message}", file=sys.stderr)
        return 1 if table.failed else 0


def sweep_values(texts: list[str], model) -> tuple[dict[str, list[float]], dict[str, float]]:
    """--param NAME=v1,v2,... -> ({swept: values}, {fixed: value}); each value checked with its unit."""
    from mbs.language.diagnostics import Diagnostic, MbsError
    swept, fixed = {}, {}
    for text in texts:
        name, eq, values = text.partition("=")
        items = [item for item in values.split(",") if item.strip()]
        if not eq or not items:
            raise MbsError([Diagnostic("error", f"--param expects NAME=v1,v2,...; got '{text}'", None)])
        numbers = [parse_param(f"{name}={item}", model)[1] for item in items]
        if len(numbers) == 1:
            fixed[name.strip()] = numbers[0]
        else:
            swept[name.strip()] = numbers
    return swept, fixed


def _design(words: list[str]) -> tuple[str, int | None]:
    from mbs.language.diagnostics import Diagnostic, MbsError
    if words[0] == "grid" and len(words) == 1:
        return "grid", None
    if words[0] == "lhs" and len(words) == 2 and words[1].isdigit():
        return "lhs", int(words[1])
    raise MbsError([Diagnostic("error", f"--design {' '.join(words)}: expected 'grid' or 'lhs N'", None)])


def _check_outputs(args, plot_formats) -> None:
    """Refuse unknown file types before the study, not after it."""
    from mbs.language.diagnostics import Diagnostic, MbsError
    for path in args.out:
        if Path(path).suffix.lower() not in TABLE_FORMATS:
            raise MbsError([Diagnostic("error", f"--out {path}: a study is written as .csv or .h5", None)])
    if args.plot and Path(args.plot).suffix.lower() not in plot_formats:
        raise MbsError([Diagnostic("error", f"--plot {args.plot}: plots are written as {', '.join(plot_formats)}",
                                   None)])


def _values(values: dict) -> str:
    return ", ".join(f"{k} = {v:.6g}" for k, v in values.items())


def _print_table(table) -> None:
    names = list(table.parameters) + list(table.metrics)
    width = max(12, *(min(len(n), 28) for n in names))
    print("  ".join(f"{n[:28]:>{width}}" for n in names) + "  status")
    for row in table.rows:
        numbers = [row.values[p] for p in table.parameters] + [row.metrics.get(m, float("nan"))
                                                               for m in table.metrics]
        print("  ".join(f"{x:>{width}.6g}" for x in numbers) + f"  {row.status}")


class CountBar:
    """Variants done out of all, on stderr when it is a terminal."""

    def __init__(self):
        self.enabled = sys.stderr.isatty()
        self.shown = False

    def __call__(self, done: int, total: int) -> None:
        if not self.enabled:
            return
        fraction = done / total if total else 1.0
        sys.stderr.write(f"\r[{'#' * int(30 * fraction):<30}] {done}/{total} variants")
        sys.stderr.flush()
        self.shown = True

    def close(self) -> None:
        if self.shown:
            sys.stderr.write("\n")
