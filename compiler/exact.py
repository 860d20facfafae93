"""Exact numbers for the constants of a model, so that exact zeros cancel in the symbolic equations.

The language evaluates constant geometry to doubles: the axis (1, 0, 1) becomes (0.7071067811865475, 0,
0.7071067811865475), `30 deg` becomes 0.5235987755982988, cos(30 deg) 0.8660254037844387. Entered as sympy
Floats these leave round-off terms that should be zero (`4.16e-17*sqrt(2)*ftip*sin(phi)` in a mass matrix)
and hide the structure of the equations. Here each double is mapped back to the exact number it rounds:

* a short decimal (at most DECIMAL_DIGITS significant digits, as people write data): that decimal, a Rational;
* +-sqrt(p/q) with small q (normalised axes, sin and cos of multiples of 30 and 45 deg): the radical;
* a rational multiple of pi (angles in degrees converted to radians): that multiple;
* the sine or cosine of a whole or tenth of a degree: sympy's cos(pi k/n) (exact, simplified where sympy can).

A double is matched only when the exact number rounds to exactly that double (to MATCH_ULPS units in the last
place, the round-off of the one or two operations that made it); anything else stays a Float, as before.
"""

from __future__ import annotations

import math
from fractions import Fraction
from functools import lru_cache

import sympy as sp

DECIMAL_DIGITS = 12      # '0.052', '35906', '9.81': written data; 17 digits are the result of arithmetic
MAX_DENOMINATOR = 10000  # of p/q under a square root and of angles / pi (0.1 deg steps are 1800ths of pi)
MATCH_ULPS = 4           # the doubles above come from a few correctly rounded operations


def _close(exact: float, value: float) -> bool:
    return abs(exact - value) <= MATCH_ULPS * math.ulp(value)


@lru_cache(maxsize=None)
def exact_number(value: float) -> sp.Expr:
    """The exact sympy number a double stands for, or the double as a Float when none is recognised."""
    if value == 0:
        return sp.Integer(0)
    if value.is_integer() and abs(value) < 2**53:
        return sp.Integer(int(value))
    text = repr(value)
    mantissa = text.split("e")[0].replace("-", "").replace(".", "").strip("0")
    if len(mantissa) <= DECIMAL_DIGITS:
        return sp.Rational(text)
    sign = -1 if value < 0 else 1
    magnitude = abs(value)
    square = Fraction(magnitude * magnitude).limit_denominator(MAX_DENOMINATOR)
    if square.numerator < 10**6 and _close(math.sqrt(square.numerator / square.denominator), magnitude):
        return sign * sp.sqrt(sp.Rational(square.numerator, square.denominator))
    turns = Fraction(magnitude / math.pi).limit_denominator(MAX_DENOMINATOR)
    if turns.numerator < 10**6 and _close(math.pi * turns.numerator / turns.denominator, magnitude):
        return sign * sp.Rational(turns.numerator, turns.denominator) * sp.pi
    found = _trigonometric().get(value)
    if found is not None:
        negative, function, k = found
        exact = (sp.cos if function == "cos" else sp.sin)(sp.pi * sp.Rational(k, _TENTHS_IN_PI))
        return -exact if negative else exact
    digits = max(15, len(mantissa))
    return sp.Float(text, digits)


_TENTHS_IN_PI = 1800


@lru_cache(maxsize=1)
def _trigonometric() -> dict[float, tuple[bool, str, int]]:
    """cos and sin of every tenth of a degree in (0, 90) deg, as the doubles the language may compute (angle in
    radians as k pi / 1800 or as radians(k / 10)) -> (negated, function, k)."""
    table: dict[float, tuple[bool, str, int]] = {}
    for k in range(1, _TENTHS_IN_PI // 2):
        for name, fn in (("cos", math.cos), ("sin", math.sin)):
            for radians in (k * math.pi / _TENTHS_IN_PI, math.radians(k / 10), k / 10 * (math.pi / 180)):
                value = fn(radians)
                table.setdefault(value, (False, name, k))
                table.setdefault(-value, (True, name, k))
    return table


__all__ = ["exact_number"]
