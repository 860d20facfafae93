"""Quantities with units from people, not model files: `--param l=2m` on the command line, and
`params={"l": "0.6 m"}` or `inputs={"torque": "2 N*m"}` from Python. One parser for both, checked against the
dimension the model declared, so `"2 kg"` for a length is the same located error everywhere."""

from __future__ import annotations

import re
from typing import Mapping

from mbs.language import units as U
from mbs.language.diagnostics import Diagnostic, MbsError

_QUANTITY = re.compile(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(\S*)\s*")


def quantity(text: str, wanted: U.Dimension | None, what: str) -> float:
    """'0.6 m', '36km/h', '2' -> the SI value; a unit must match `wanted` (None: any unit, a bare number)."""
    match = _QUANTITY.fullmatch(text)
    if match is None:
        raise MbsError([Diagnostic("error", f"{what}: expected a number with an optional unit such as '0.6 m', "
                                            f"got '{text}'", None)])
    number, unit = float(match.group(1)), match.group(2)
    if not unit:
        return number
    try:
        factor, dim = U.parse_unit(unit)
    except U.UnitError as exc:
        raise MbsError([Diagnostic("error", f"{what}: {exc.message}", None)]) from None
    if wanted is not None and dim != wanted:
        raise MbsError([Diagnostic("error", f"{what}: expected {U.describe(wanted)}, got {U.describe(dim)}", None)])
    return number * factor


def parameter_overrides(model, params: Mapping[str, object] | None) -> dict:
    """Parameter overrides with every string quantity ('0.6 m') in SI; unknown names are located errors."""
    out = {}
    for name, value in (params or {}).items():
        if name not in model.parameter_map:
            from mbs.language.scope import did_you_mean
            raise MbsError([Diagnostic("error", f"model '{model.name}' has no parameter '{name}'"
                                                f"{did_you_mean(name, model.parameter_map)}", None)])
        if isinstance(value, str):
            value = quantity(value, model.parameter_map[name].dimension, f"parameter {name}")
        out[name] = value
    return out
