"""TIR files (the Magic Formula's parameter files, as tyre testing labs and Adams write them) to parameter sets
of library/tyres/magic_formula.mbs.

    coefficients = read_tir("tyre.tir")                   # {name: value in SI}, units converted
    text = parameter_set(coefficients, ["tyre_fl", "tyre_fr"], component_params)

A TIR file is sections `[NAME]` of `KEY = value` lines (`$` and `!` start comments). Its [UNITS] section says
in which units the dimensional entries are written; the Magic Formula coefficients themselves are
dimensionless, with slip angles and camber in radians, so an ANGLE other than radian is refused (the
coefficients would be wrong by 180/pi, not just their unit). Dimensional entries are converted to SI: the
nominal load, the unloaded radius, the vertical stiffness and damping. Errors are located at their line.
"""

from __future__ import annotations

from pathlib import Path

from mbs.language.diagnostics import Diagnostic, MbsError, Source, Span

LENGTH = {"meter": 1.0, "metre": 1.0, "m": 1.0, "mm": 1e-3, "millimeter": 1e-3, "millimetre": 1e-3, "cm": 1e-2,
          "centimeter": 1e-2, "km": 1e3, "inch": 0.0254, "in": 0.0254, "foot": 0.3048, "ft": 0.3048}
FORCE = {"newton": 1.0, "n": 1.0, "kn": 1e3, "kilonewton": 1e3, "lbf": 4.4482216152605,
         "pound_force": 4.4482216152605}
TIME = {"second": 1.0, "s": 1.0, "sec": 1.0, "millisecond": 1e-3, "ms": 1e-3}
MASS = {"kg": 1.0, "kilogram": 1.0, "g": 1e-3, "gram": 1e-3, "tonne": 1e3}
ANGLE = {"radian": 1.0, "rad": 1.0, "radians": 1.0}

#: TIR key -> (component parameter, unit as the language writes it, dimension: powers of length, force, time)
DIMENSIONAL = {
    "FNOMIN": ("FNOMIN", "N", (0, 1, 0)),
    "UNLOADED_RADIUS": ("R0", "m", (1, 0, 0)),
    "VERTICAL_STIFFNESS": ("k", "N/m", (-1, 1, 0)),
    "VERTICAL_DAMPING": ("d", "N*s/m", (-1, 1, 1)),
}


def _error(message: str, source: Source, start: int, end: int) -> Diagnostic:
    return Diagnostic("error", message, Span.at(source, start, end))


def read_tir(path: str | Path) -> dict[str, float]:
    """Every numeric entry of a TIR file by key (upper case), the dimensional ones converted to SI."""
    path = Path(path)
    text = path.read_text(encoding="utf-8", errors="replace")
    source = Source(str(path), text)
    raw: dict[str, tuple[float, int, int]] = {}
    units: dict[str, tuple[str, int, int]] = {}
    section, offset, errors = "", 0, []
    for line in text.splitlines(keepends=True):
        body = line.split("$", 1)[0].split("!", 1)[0].strip()
        start = offset + (line.index(body) if body else 0)
        offset += len(line)
        if not body:
            continue
        if body.startswith("[") and body.endswith("]"):
            section = body[1:-1].strip().upper()
            continue
        key, eq, value = body.partition("=")
        if not eq:
            errors.append(_error("expected KEY = value", source, start, start + len(body)))
            continue
        key, value = key.strip().upper(), value.strip()
        if section == "UNITS":
            units[key] = (value.strip("'\"").strip().lower(), start, start + len(body))
            continue
        try:
            raw[key] = (float(value), start, start + len(body))
        except ValueError:
            continue  # strings: file names, property formats, comments
    factors = {}
    for name, table, default in (("LENGTH", LENGTH, "meter"), ("FORCE", FORCE, "newton"), ("TIME", TIME, "second"),
                                 ("MASS", MASS, "kg"), ("ANGLE", ANGLE, "radian")):
        unit, start, end = units.get(name, (default, 0, 0))
        if unit not in table:
            hint = ("the Magic Formula coefficients are per radian; convert the file, not just its unit"
                    if name == "ANGLE" else f"known: {', '.join(sorted(table))}")
            errors.append(_error(f"[UNITS] {name} = '{unit}' is not supported ({hint})", source, start, end))
            continue
        factors[name] = table[unit]
    if errors:
        raise MbsError(errors)
    out = {}
    for key, (value, _, _) in raw.items():
        if key in DIMENSIONAL:
            length, force, time = DIMENSIONAL[key][2]
            value *= factors["LENGTH"] ** length * factors["FORCE"] ** force * factors["TIME"] ** time
        out[key] = value
    return out


def parameter_set(coefficients: dict[str, float], instances: list[str], params: set[str]) -> tuple[str, list[str]]:
    """(text of a .params file setting every instance's coefficients, TIR keys the component does not use)."""
    lines = ["# Magic Formula coefficients from a TIR file (mbs tir), SI units"]
    unused = []
    for key, value in sorted(coefficients.items()):
        name, unit = (DIMENSIONAL[key][0], DIMENSIONAL[key][1]) if key in DIMENSIONAL else (key, "")
        if name not in params:
            unused.append(key)
            continue
        for instance in instances:
            lines.append(f"{instance}.{name} = {value!r}{unit}")
    return "\n".join(lines) + "\n", unused
