"""What several subcommands share: model and --param arguments, the progress bar, error rendering."""

from __future__ import annotations

import sys


def model_args(p):
    p.add_argument("file", metavar="FILE")
    p.add_argument("--model", help="model name when the file has several")


def param_arg(p) -> None:
    p.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                   help="override a parameter, unit optional: --param l=2m (repeatable; no recompile)")


def params_from_args(args, system) -> dict[str, float]:
    """The --param overrides, checked against the model (an unknown name or unit is a located error)."""
    return dict(parse_param(text, system.model) for text in args.param)


def parse_param(text: str, model):
    """--param name=value with an optional unit (l=2m, v=36km/h), checked against the parameter's dimension."""
    from mbs.language import units as U
    from mbs.language.diagnostics import Diagnostic, MbsError
    name, number, unit = split_assignment(text, "--param", "l=2m")
    if name not in model.parameter_map:
        from mbs.language.scope import did_you_mean
        raise MbsError([Diagnostic("error", f"model '{model.name}' has no parameter '{name}'"
                                            f"{did_you_mean(name, model.parameter_map)}", None)])
    if unit is None:
        return name, number
    factor, dim = unit
    wanted = model.parameter_map[name].dimension
    if wanted is not None and dim != wanted:
        raise MbsError([Diagnostic("error", f"--param {name}: expected {U.describe(wanted)}, got {U.describe(dim)}",
                                   None)])
    return name, number * factor


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
