"""Named parameter sets: `--params benchmark` reads `benchmark.params` next to the model file.

A parameter set is a plain text file of `name = value[unit]` lines (`#` comments), the same syntax as
`--param`, checked the same way against the model (unknown names and wrong units are located errors). It
names a configuration that every scene of a model can run with (the Iltis benchmark's massless links), so
results compare one to one with a publication without a scene per configuration. `--param` given with it
overrides it. A path (with a '/' or ending in .params) is taken as it is.
"""

from __future__ import annotations

from pathlib import Path

from mbs.language.diagnostics import Diagnostic, MbsError, Source, Span

SUFFIX = ".params"


def locate(name: str, model_path: str | None) -> Path:
    """The file of a parameter set: a path as given, else NAME.params beside the model file."""
    if "/" in name or name.endswith(SUFFIX):
        path = Path(name)
    else:
        path = Path(model_path or ".").parent / f"{name}{SUFFIX}"
    if not path.is_file():
        where = Path(model_path).parent if model_path else Path(".")
        known = sorted(p.stem for p in where.glob(f"*{SUFFIX}"))
        raise MbsError([Diagnostic("error", f"no parameter set '{name}' ({path} does not exist; sets beside the "
                                            f"model: {', '.join(known) or 'none'})", None)])
    return path


def read(path: Path, model) -> dict[str, float]:
    """The values of a parameter-set file, every line checked against the model; all errors in one run."""
    from mbs.commands.common import parse_param
    text = path.read_text(encoding="utf-8")
    source = Source(str(path), text)
    values, errors, offset = {}, [], 0
    for line in text.splitlines(keepends=True):
        body = line.split("#", 1)[0].strip()
        if body:
            start = offset + line.index(body)
            try:
                name, value = parse_param(body, model)
                values[name] = value
            except MbsError as exc:
                span = Span.at(source, start, start + len(body))
                errors += [Diagnostic("error", d.message.replace("--param ", ""), span) for d in exc.diagnostics]
        offset += len(line)
    if errors:
        raise MbsError(errors)
    return values


def model_path(model) -> str | None:
    """The file a validated model was read from (its span's source), if any."""
    span = getattr(model, "span", None)
    return span.source.path if span is not None else None
