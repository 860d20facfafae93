"""Physical units of model literals: parse unit text such as ``N*s/m``, convert to SI, check dimensions.

Everything after parsing is SI, so the compiler never carries a unit past this module: a literal
``10 km/h`` becomes the float ``10 * factor`` together with the :class:`Dimension` of a velocity, and a
parameter declared as a stiffness can be checked with ``dim == STIFFNESS``.

Angle is dimensionless (SI convention): ``rad`` is the factor 1 and ``deg`` the factor pi/180, so ``rad/s``
and ``1/s`` are the same dimension, and so are torque ``N*m`` and rotational stiffness ``N*m/rad``.
``t`` is deliberately not a unit: the model language reserves it for time.
"""

from __future__ import annotations

import functools
import math
import re
from dataclasses import dataclass


class UnitError(Exception):
    """A unit text that cannot be parsed; ``offset``/``length`` locate the culprit inside that text."""

    def __init__(self, message: str, offset: int, length: int):
        super().__init__(message)
        self.message = message
        self.offset = offset
        self.length = length


@dataclass(frozen=True)
class Dimension:
    """Integer exponents over mass M (kg), length L (m) and time T (s); immutable and hashable.

    Integer exponents suffice for every unit a literal can spell: the unit grammar has integer exponents only.
    """

    M: int = 0
    L: int = 0
    T: int = 0

    def __mul__(self, other: Dimension) -> Dimension:
        return Dimension(self.M + other.M, self.L + other.L, self.T + other.T)

    def __truediv__(self, other: Dimension) -> Dimension:
        return Dimension(self.M - other.M, self.L - other.L, self.T - other.T)

    def __pow__(self, n: int) -> Dimension:
        if not isinstance(n, int) or isinstance(n, bool):
            raise TypeError(f"a dimension can only be raised to an integer power, not {n!r}")
        return Dimension(self.M * n, self.L * n, self.T * n)

    @property
    def is_dimensionless(self) -> bool:
        return self.M == 0 and self.L == 0 and self.T == 0

    def __str__(self) -> str:
        """SI product such as ``kg*m^2/s^2``; it parses back with :func:`parse_unit` (``a/b/c`` = a/(b*c))."""
        if self.is_dimensionless:
            return "1"

        def power(symbol: str, n: int) -> str:
            return symbol if n == 1 else f"{symbol}^{n}"

        pairs = (("kg", self.M), ("m", self.L), ("s", self.T))
        num = [power(s, n) for s, n in pairs if n > 0]
        den = [power(s, -n) for s, n in pairs if n < 0]
        return "/".join(["*".join(num) or "1", *den])


DIMENSIONLESS = Dimension()
MASS = Dimension(M=1)
LENGTH = Dimension(L=1)
TIME = Dimension(T=1)
ANGLE = DIMENSIONLESS  # SI: rad = m/m
VELOCITY = LENGTH / TIME
ACCELERATION = VELOCITY / TIME
FREQUENCY = DIMENSIONLESS / TIME
ANGULAR_VELOCITY = ANGLE / TIME  # == FREQUENCY
FORCE = MASS * ACCELERATION
TORQUE = FORCE * LENGTH
ENERGY = FORCE * LENGTH  # == TORQUE
POWER = ENERGY / TIME
PRESSURE = FORCE / LENGTH**2
STIFFNESS = FORCE / LENGTH
DAMPING = FORCE * TIME / LENGTH
ROT_STIFFNESS = TORQUE / ANGLE  # == TORQUE
ROT_DAMPING = TORQUE * TIME / ANGLE
INERTIA = MASS * LENGTH**2

# name -> (factor to SI, dimension). Data only: add a row to add a unit. Compound units (km/h, N*s/m) are
# spelled in the text, not listed here; a row exists only for a single-word name (Nm, rpm, kN).
UNITS: dict[str, tuple[float, Dimension]] = {
    "kg": (1.0, MASS),
    "g": (1e-3, MASS),
    "m": (1.0, LENGTH),
    "mm": (1e-3, LENGTH),
    "cm": (1e-2, LENGTH),
    "km": (1e3, LENGTH),
    "s": (1.0, TIME),
    "ms": (1e-3, TIME),
    "min": (60.0, TIME),
    "h": (3600.0, TIME),
    "N": (1.0, FORCE),
    "kN": (1e3, FORCE),
    "Nm": (1.0, TORQUE),
    "J": (1.0, ENERGY),
    "kJ": (1e3, ENERGY),
    "W": (1.0, POWER),
    "kW": (1e3, POWER),
    "Pa": (1.0, PRESSURE),
    "kPa": (1e3, PRESSURE),
    "MPa": (1e6, PRESSURE),
    "GPa": (1e9, PRESSURE),
    "bar": (1e5, PRESSURE),
    "rad": (1.0, ANGLE),
    "deg": (math.pi / 180.0, ANGLE),
    "rev": (2.0 * math.pi, ANGLE),
    "rpm": (2.0 * math.pi / 60.0, ANGULAR_VELOCITY),
    "Hz": (1.0, FREQUENCY),
    "mph": (0.44704, VELOCITY),  # international mile 1609.344 m per 3600 s, exact
    "%": (1e-2, DIMENSIONLESS),
}

# Names that are not units but that users write; the hint replaces the difflib guess.
_HINTS = {
    "t": "'t' is reserved for time; write 1000 kg for a tonne",
    "kmh": "did you mean 'km/h'?",
    "kph": "did you mean 'km/h'?",
    "sec": "did you mean 's'?",
}

# Readable name and symbol of the dimensions users meet; several units share a dimension because angle is
# dimensionless, so rad/s and 1/s, or N*m and N*m/rad, get one description each.
_FRIENDLY: dict[Dimension, tuple[str, str]] = {
    MASS: ("mass", "kg"),
    LENGTH: ("length", "m"),
    TIME: ("time", "s"),
    VELOCITY: ("velocity", "m/s"),
    ACCELERATION: ("acceleration", "m/s^2"),
    FREQUENCY: ("angular velocity or frequency", "1/s"),
    FORCE: ("force", "N"),
    TORQUE: ("torque", "N*m"),
    POWER: ("power", "W"),
    PRESSURE: ("pressure", "Pa"),
    STIFFNESS: ("stiffness", "N/m"),
    DAMPING: ("damping", "N*s/m"),
    ROT_DAMPING: ("rotational damping", "N*m*s/rad"),
    INERTIA: ("inertia", "kg*m^2"),
}

_NAME = re.compile(r"[A-Za-z%]+")
_EXPONENT = re.compile(r"-?[0-9]+")


def _unknown(name: str, offset: int) -> UnitError:
    message = f"unknown unit '{name}'"
    folded = {n.casefold(): n for n in UNITS}
    if name in _HINTS:
        message += f"; {_HINTS[name]}"
    elif name.casefold() in folded:
        message += f"; did you mean '{folded[name.casefold()]}'?"
    else:
        import difflib  # only for a message: a run that parses no unit text does not load it
        close = difflib.get_close_matches(name, UNITS, n=1)
        if close:
            message += f"; did you mean '{close[0]}'?"
    return UnitError(message, offset, len(name))


@functools.lru_cache(maxsize=4096)
def parse_unit(text: str) -> tuple[float, Dimension]:
    """Parse a unit token (no spaces) into (factor to SI, dimension).

    Grammar: ``["1/"] factor (("*" | "/") factor)*`` with ``factor = name ["^" ["-"] digits]``, evaluated
    left to right, so ``N*s/m`` = (N*s)/m, ``m/s^2`` = m/(s^2) and ``a/b/c`` = a/(b*c).
    A literal's SI value is ``number * factor``. Raises :class:`UnitError` on unknown names and malformed
    text. Cached: large models repeat the same few units thousands of times.
    """
    if not text:
        raise UnitError("empty unit", 0, 0)
    factor, dim = 1.0, DIMENSIONLESS
    pos, op = 0, "*"
    if text.startswith("1/"):
        pos, op = 2, "/"
    while True:
        name_match = _NAME.match(text, pos)
        if name_match is None:
            after = f" after '{text[pos - 1]}'" if pos else ""
            found, length = (f"'{text[pos]}'", 1) if pos < len(text) else ("end of unit", 0)
            raise UnitError(f"expected a unit name{after}, found {found} in '{text}'", pos, length)
        name = name_match.group()
        if name not in UNITS:
            raise _unknown(name, pos)
        f, d = UNITS[name]
        pos = name_match.end()
        if text.startswith("^", pos):
            exp_match = _EXPONENT.match(text, pos + 1)
            if exp_match is None:
                raise UnitError(f"expected an integer exponent after '^' in '{text}'", pos, 1)
            n = int(exp_match.group())
            f, d = f**n, d**n
            pos = exp_match.end()
        factor, dim = (factor * f, dim * d) if op == "*" else (factor / f, dim / d)
        if pos == len(text):
            return factor, dim
        op = text[pos]
        if op.isdigit():
            digits = re.match(r"[0-9]+", text[pos:]).group()
            hint = f"write an exponent as '{name}^{digits}'"
            raise UnitError(f"unexpected '{digits}' in unit '{text}'; {hint}", pos, len(digits))
        if op not in "*/":
            raise UnitError(f"unexpected '{op}' in unit '{text}'; join units with '*' or '/'", pos, 1)
        pos += 1


def describe(dim: Dimension) -> str:
    """Words for a dimension in messages: ``"stiffness (N/m)"``, ``"dimensionless"``, else the SI product."""
    if dim.is_dimensionless:
        return "dimensionless"
    if dim in _FRIENDLY:
        quantity, symbol = _FRIENDLY[dim]
        return f"{quantity} ({symbol})"
    return str(dim)


def format_quantity(value_si: float, dim: Dimension) -> str:
    """Short readable SI quantity for messages: ``format_quantity(35906.0, STIFFNESS) == "35906 N/m"``."""
    if dim.is_dimensionless:
        return "%g" % value_si
    symbol = _FRIENDLY[dim][1] if dim in _FRIENDLY else str(dim)
    return "%g %s" % (value_si, symbol)


# The named unit results, plots and tables show for a dimension (values are SI, so only factor-1 units).
# Angle is dimensionless: 1/s is shown as rad/s, the common case in multibody results (a joint rate).
_SHOWN: dict[Dimension, str] = {
    MASS: "kg", LENGTH: "m", TIME: "s", VELOCITY: "m/s", ACCELERATION: "m/s^2", FREQUENCY: "rad/s",
    FREQUENCY / TIME: "rad/s^2", FORCE: "N", TORQUE: "N*m", POWER: "W", PRESSURE: "Pa", STIFFNESS: "N/m",
    DAMPING: "N*s/m", ROT_DAMPING: "N*m*s/rad", INERTIA: "kg*m^2", LENGTH**2: "m^2", LENGTH**3: "m^3",
    FORCE * TIME: "N*s", TORQUE * TIME: "N*m*s", MASS / LENGTH**3: "kg/m^3", LENGTH / TIME**3: "m/s^3",
}


def unit_text(dim: Dimension | None, written: str | None = None, *, angle: bool = False) -> str | None:
    """The unit a value of dimension `dim` in SI is shown with: the unit the model wrote when it is an SI one
    (`N*m/rad` stays `N*m/rad`), else the named SI unit (`N*m`, not `kg*m^2/s^2`), else the SI product.
    A dimensionless value is 'rad' when `angle` (a joint angle, an attitude), else '1'; None: no dimension."""
    if dim is None:
        return None
    if written:
        try:
            factor, parsed = parse_unit(written)
        except UnitError:
            factor, parsed = 0.0, None
        if parsed == dim and abs(factor - 1.0) <= 1e-12:
            return written
    if dim.is_dimensionless:
        return "rad" if angle or (written and re.search(r"rad|deg|rev", written)) else "1"
    return _SHOWN.get(dim, str(dim))
