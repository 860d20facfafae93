"""Event indicators without the sines and cosines of angles they do not depend on (a wheel's spin), and without the
lookups a parameter at zero scales away (a road's random profile, off).

A tyre's indicators read the world velocity of its wheel's centre, which the tape composes from the spinning wheel's
rotation and its velocity in its own frame: the product is the same for every spin angle (c^2 + s^2 = 1), yet
mbs_events evaluated the sine and cosine of each wheel's spin.  `angle_free_tape` forks the tape for mbs_events
alone (compiler/ccode.py CEmitter._printed) with such products reduced exactly; the right-hand side keeps its tape.
`python bench/indicators.py` measures it against the former text (ANGLE_FREE_INDICATORS False).
"""

from __future__ import annotations

import random

import sympy as sp

from .emit_common import TABLE_FUNCTION
from .tape import symbols_of


#: Largest expansion (operations) of a temporary in the sine and cosine of one angle that angle_free_tape examines:
#: beyond it the temporary counts as depending on the angle (a wheel's spin cancels in a few dozen operations; the
#: chains below a suspension arm's bearing, which do depend on its angle, grow past it within a few temporaries).
ANGLE_EXPANSION_MAX_OPS = 120
#: The generated mbs_events with the indicators as the tape has them (False): the same-run baseline of
#: bench/indicators.py.  (The derivation cache does not see it: that bench generates the
#: former text through mbs.pipeline.generate.)
ANGLE_FREE_INDICATORS = True


def trig_pairs(tape, entries) -> list[tuple[sp.Symbol, sp.Symbol]]:
    """(cos, sin) temporaries of the same argument among `entries`: a revolute joint's angle, a wheel's spin."""
    found: dict = {}
    for entry in entries:
        if isinstance(entry.expr, (sp.cos, sp.sin)) and entry.guard is None:
            found.setdefault(entry.expr.args[0], {})[type(entry.expr)] = entry.symbol
    return [(pair[sp.cos], pair[sp.sin]) for pair in found.values() if len(pair) == 2]


class _Opaque(Exception):
    """An expression that is no polynomial of bounded size in the cosine and sine examined."""


def _in_angle(expr, c, s, written: dict) -> tuple[dict, int]:
    """expr as {(i, j): coefficient of c^i s^j} with coefficients free of c and s (`written`: the same of the
    temporaries that read them), and its size (nodes, each temporary of `written` counted with its own).  Raises
    _Opaque for a function of c or s, a division by one, or a size beyond ANGLE_EXPANSION_MAX_OPS."""
    if expr in written:  # (the pair's own entries too: dict lookups, not sympy's slow ==)
        return written[expr]
    if expr.is_Add or expr.is_Mul:
        terms, size = None, 0
        for arg in expr.args:
            part, n = _in_angle(arg, c, s, written)
            size += n + 1
            if terms is None:
                terms = part
            elif expr.is_Add:
                terms = {k: terms.get(k, sp.S.Zero) + part.get(k, sp.S.Zero) for k in terms.keys() | part.keys()}
            else:
                product: dict = {}
                for (i, j), a in terms.items():
                    for (k, m), b in part.items():
                        product[(i + k, j + m)] = product.get((i + k, j + m), sp.S.Zero) + a * b
                terms = product
            if size > ANGLE_EXPANSION_MAX_OPS or len(terms) > 9:
                raise _Opaque
        return terms, size
    if expr.is_Pow and expr.exp.is_Integer and 0 < expr.exp <= 4 and _reads(expr.base, c, s, written):
        return _in_angle(sp.Mul(*([expr.base] * int(expr.exp)), evaluate=False), c, s, written)
    if _reads(expr, c, s, written):
        raise _Opaque
    return {(0, 0): expr}, 1


def _reads(expr, c, s, written: dict) -> bool:
    return any(x in written for x in symbols_of(expr))


def _free_of_angle(terms: dict):
    """The expression of the c^i s^j terms `terms` without c and s when its value does not depend on the angle (its
    remainder modulo c^2 + s^2 - 1, which is unique, is then a constant of the angle), else None."""
    reduced: dict = {}
    for (i, j), a in terms.items():
        pending = [(i, j, a)]
        while pending:  # s^2 = 1 - c^2 until s is of degree 1 at most
            i, j, a = pending.pop()
            if j >= 2:
                pending += [(i, j - 2, a), (i + 2, j - 2, -a)]
            else:
                reduced[(i, j)] = reduced.get((i, j), sp.S.Zero) + a
    angle_terms = [a for key, a in reduced.items() if key != (0, 0)]
    if any(not _near_zero_somewhere(a) for a in angle_terms) or any(sp.expand(a) != 0 for a in angle_terms):
        return None  # (a coefficient not zero at a point of its symbols is not zero: expand only the others)
    return reduced.get((0, 0), sp.S.Zero)


def _near_zero_somewhere(expr) -> bool:
    """Whether expr is 0 to round-off at one seeded point of its symbols, relative to its terms' sizes there (a quick
    test before the exact one: False only for an expression that is not 0)."""
    rng = random.Random(7)
    point = {x: sp.Float(rng.uniform(0.5, 1.5)) for x in sorted(symbols_of(expr), key=str)}
    try:
        terms = [complex(term.xreplace(point)) for term in sp.Add.make_args(expr)]
    except (TypeError, ValueError, ZeroDivisionError):
        return True  # (cannot tell: the exact test decides)
    return abs(sum(terms)) <= 1e-9 * sum(abs(term) for term in terms)


def angle_free_tape(tape, outputs):
    """A fork of `tape` on which `outputs` (the indicators) read no sine and cosine of an angle their values do not
    depend on, or `tape` itself when they read none.

    A tyre's indicators (its deflection, its force's sign) read the world velocity of its wheel's centre, which the
    tape composes from the rotation of the spinning wheel and the wheel's velocity in its own frame: their product
    is the same for every spin angle (c^2 + s^2 = 1), but mbs_events evaluated its sine and cosine (four wheels: a
    seventh of the Iltis's indicators' instructions).  Here each temporary that reads the cosine c and sine s of
    one argument is written as a polynomial in c and s with coefficients free of them (up to
    ANGLE_EXPANSION_MAX_OPS nodes); where one that multiplies two such factors has a remainder modulo
    c^2 + s^2 - 1 free of c and s (its value does not depend on the angle), the fork's entry holds that remainder,
    when the outputs then read neither c nor s (else they are evaluated anyway, and the remainder may cost more than
    the product it replaces).  Exact algebra: the values change by round-off only.  The right-hand side keeps its
    tape (it needs the wheel's rotation for its forces)."""
    if not ANGLE_FREE_INDICATORS:
        return tape
    outputs = [sp.sympify(e) for e in outputs]
    fork = None
    for c, s in trig_pairs(tape, tape.entries_for(outputs)):
        current = fork or tape
        # temporary reading c or s -> (its c^i s^j terms, size), or None: not a polynomial; c and s themselves
        written: dict = {c: ({(1, 0): sp.S.One}, 1), s: ({(0, 1): sp.S.One}, 1)}
        replaced = []
        for entry in current.entries_for(outputs):
            if entry.symbol in written:
                continue
            tainted = [d for d in current.dependencies(entry) if d in written]
            if not tainted:
                continue
            if entry.guard is not None or any(written.get(d, 0) is None for d in tainted):
                written[entry.symbol] = None
                continue
            try:
                terms, size = _in_angle(entry.expr, c, s, written)
            except _Opaque:
                written[entry.symbol] = None
                continue
            reads = current.reads(entry)  # a product of two factors reading c or s: the angle may cancel
            free = _free_of_angle(terms) if sum(reads.get(d, 1) for d in tainted) > 1 else None
            if free is None:
                written[entry.symbol] = (terms, size)
            else:
                replaced.append((entry, free))  # read as itself from now on: its readers see no c, s through it
        if not replaced:
            continue
        trial = current.fork()
        for entry, free in replaced:
            trial.rewrite(entry.symbol, free)
        if not {c, s} & {e.symbol for e in trial.entries_for(outputs)}:  # (else the rewrite saves no sin, cos)
            fork = trial
    return fork or tape


#: The generated mbs_events with every lookup evaluated, also where a parameter at zero scales it away (False): the
#: same-run baseline of python bench/indicators.py --lookups.
GATED_LOOKUPS = True


def gated_lookups(tape, outputs, parameters):
    """(tape, outputs) with each product of a run-time parameter and a lookup table's value that `outputs` (the
    indicators) read evaluated only where the parameter is not 0 (0 where it is): the tape's entries on a fork of it
    (`tape` itself when they read none), the outputs' own expressions rewritten alike.

    The Iltis's tyres read their road's height, the bump plus `rough` times a random profile (an ISO 8608 table of
    thousands of knots): with `rough` at 0, as in every bump scene, mbs_events looked up the four wheels' tables at
    every call for nothing (81 instructions each, a tenth of its instructions).  A table's value is finite (its data
    are, and it interpolates between them or holds its ends), so the product is then 0 (to the sign of zero, which
    the sum it is part of loses).  The right-hand side keeps its tape."""
    outputs = [sp.sympify(e) for e in outputs]
    if not GATED_LOOKUPS:
        return tape, outputs
    gates = {x for x in parameters if isinstance(x, sp.Symbol)}
    fork = None
    for entry in tape.entries_for(outputs):
        expr = _gated(entry.expr, gates)
        if expr != entry.expr:
            fork = fork or tape.fork()
            fork.rewrite(entry.symbol, expr)
    return fork or tape, [_gated(e, gates) for e in outputs]


def _gated(expr, gates):
    """expr with each product of a parameter of `gates` and a lookup table's value gated by the parameter."""
    return expr.replace(lambda e: _lookup_gate(e, gates) is not None,
                        lambda e: sp.Piecewise((e, sp.Ne(_lookup_gate(e, gates), 0)), (0, True)))


def _lookup_gate(expr, gates):
    """The parameter of `gates` that a product of it and a lookup table's value is scaled by, or None."""
    if not expr.is_Mul or not any(TABLE_FUNCTION.match(type(a).__name__) for a in expr.args if a.is_Function):
        return None
    return next((a for a in expr.args if a in gates), None)
