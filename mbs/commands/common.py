"""What several subcommands share: model and --param arguments, the progress bar, error rendering."""

from __future__ import annotations

import sys

from mbs.language.diagnostics import Diagnostic, MbsError


class ArgumentError(MbsError):
    """A command-line argument that parsed but makes no sense (unknown scene, parameter or integrator, a
    results file type we do not write): exit status 2, like argparse's own usage errors."""

    def __init__(self, message: str):
        super().__init__([Diagnostic("error", message, None)])


def usage_errors(function):
    """Run `function`, turning the model errors it raises about the arguments into ArgumentErrors."""
    def checked(*args, **kwargs):
        try:
            return function(*args, **kwargs)
        except MbsError as err:
            raise ArgumentError("\n".join(d.message for d in err.diagnostics)) from None
    return checked


def is_usage_error(err) -> bool:
    """Exit status 2: our ArgumentError, or the run-time layer's UsageError (only if that layer was loaded)."""
    runtime_errors = sys.modules.get("mbs.runtime.errors")
    return isinstance(err, ArgumentError) or (runtime_errors is not None
                                              and isinstance(err, runtime_errors.UsageError))


def model_args(p):
    p.add_argument("file", metavar="FILE")
    p.add_argument("--model", help="model name when the file has several")


def param_arg(p) -> None:
    p.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                   help="override a parameter, unit optional: --param l=2m (repeatable; no recompile)")
    p.add_argument("--params", metavar="SET", help="a named parameter set: SET.params beside the model file "
                                                   "(e.g. --params benchmark), or a path; --param overrides it")


@usage_errors
def params_from_args(args, system) -> dict[str, float]:
    """The --params set and the --param overrides, checked against the model (an unknown name or unit is a
    usage error, exit status 2)."""
    values = {}
    if getattr(args, "params", None):
        from mbs import paramsets
        values.update(paramsets.read(paramsets.locate(args.params, paramsets.model_path(system.model)),
                                     system.model))
    values.update(parse_param(text, system.model) for text in args.param)
    return values


@usage_errors
def check_scene(system, name: str | None) -> None:
    """An unknown --scene is a usage error (listing the scenes)."""
    system.scene(name)


def check_integrator(name: str | None) -> None:
    """--integrator against the registered methods (exit status 2, listing them)."""
    if name is None:
        return
    from mbs.runtime.integrators import available
    if name.lower() not in {n.lower() for n in available()}:
        raise ArgumentError(f"unknown integrator '{name}' (available: {', '.join(available())})")


def parse_param(text: str, model):
    """--param name=value with an optional unit (l=2m, v=36km/h), checked against the parameter's dimension."""
    from mbs.quantities import parameter_overrides
    name, sep, value = text.partition("=")
    if not sep:
        raise MbsError([Diagnostic("error", f"--param expects name=value[unit], e.g. l=2m; got '{text}'", None)])
    name = name.strip()
    return name, parameter_overrides(model, {name: value})[name]


def split_assignment(text: str, option: str, example: str):
    """(name, number, (unit factor, dimension) or None) of an option's NAME=VALUE[unit] text; a located error
    when it is not one or the unit is unknown."""
    import re

    from mbs.language import units as U
    from mbs.language.diagnostics import Diagnostic, MbsError
    name, sep, value = text.partition("=")
    name = name.strip()
    match = re.fullmatch(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(\S*)\s*", value)
    if not sep or match is None:
        raise MbsError([Diagnostic("error", f"{option} expects name=value[unit], e.g. {example}; got '{text}'",
                                   None)])
    number, unit = float(match.group(1)), match.group(2)
    if not unit:
        return name, number, None
    try:
        return name, number, U.parse_unit(unit)
    except U.UnitError as exc:
        raise MbsError([Diagnostic("error", f"{option} {name}: {exc.message}", None)]) from None


class ProgressBar:
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


def render_error(err) -> str:
    """Every diagnostic of an MbsError, located, and a count of the errors."""
    errors = sum(1 for d in err.diagnostics if d.severity == "error")
    text = "\n".join(d.render() for d in err.diagnostics)
    return f"{text}\n{errors} error{'s' if errors != 1 else ''}" if errors else text
