"""A tape of named temporaries: the straight-line program the recursive algorithms are executed on.

Every intermediate quantity of the symbolic O(n) algorithms (a rotation-matrix entry, a component of a spatial
velocity, ...) is a small sympy expression of earlier temporaries. `Tape.temp` assigns it to a fresh symbol, unless

* it folds to a number or a plain symbol (`0`, `1`, `q1`, `-w3`, `2*m`): then it is returned as it is, so that no
  temporary ever stands for a constant or a copy, and `0*x`/`1*x` vanish in sympy's own arithmetic;
* the same expression (or its negative) is already on the tape: then the existing temporary is returned, which is
  the common-subexpression elimination (by hashing, before a temporary is created).

Expressions are therefore never expanded: the size of the tape grows with the number of operations of the
algorithm, not with the size of the written-out equations. The tape also records guards: a temporary that divides
(1/D in the articulated-body algorithm) is only computed after checking that D > 0, which the C emitter turns into
an early `return 1`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import sympy as sp

ZERO, ONE = sp.S.Zero, sp.S.One


@dataclass
class Entry:
    """One assignment `symbol = expr` of the tape.

    name: the temporary's identifier (unique on the tape; the C emitter uses it).
    section: a human-readable label of the algorithm step that created it (becomes a comment in C).
    guard: None, or an expression that must be > 0 before this entry is evaluated.
    """

    symbol: sp.Dummy
    expr: sp.Expr
    name: str
    section: str
    guard: sp.Expr | None = None
    _deps: frozenset | None = field(default=None, repr=False)
    _symbols: frozenset | None = field(default=None, repr=False)
    _reads: dict | None = field(default=None, repr=False)
    place: int = field(default=-1, repr=False)  # its index in the tape's entries (and in those of its forks)
    _dep_places: tuple | None = field(default=None, repr=False)


_GENERIC_FREE_SYMBOLS = sp.Basic.free_symbols  # the property of every node that binds no symbols


def symbols_of(expr) -> set:
    """expr.free_symbols, found by one walk over the arguments: sympy's builds a set at every node (and a
    generator around it), which made free symbols a tenth of the time of slicing and printing the tape. A node
    that binds symbols (a Derivative, an Integral: any class with free_symbols of its own) is asked itself."""
    if expr.is_Symbol:
        return {expr}
    if type(expr).free_symbols is not _GENERIC_FREE_SYMBOLS:
        return set(expr.free_symbols)
    found = set()
    stack = [expr]
    while stack:
        for arg in stack.pop().args:
            if arg.is_Symbol:
                found.add(arg)
            elif arg.args:
                if type(arg).free_symbols is _GENERIC_FREE_SYMBOLS:
                    stack.append(arg)
                else:
                    found |= arg.free_symbols
    return found


def count_reads(expr, symbols, counts: dict, weight: int = 1) -> None:
    """Add to counts[s] how often `expr` reads each s of `symbols` (a container of symbols, the temporaries): x**n
    reads x |n| times (printed as a product)."""
    if expr.is_Symbol:  # (only a symbol is one of `symbols`, and it reads nothing: no hash of other nodes)
        if expr in symbols:
            counts[expr] = counts.get(expr, 0) + weight
    elif expr.is_Pow and expr.exp.is_Integer:
        count_reads(expr.base, symbols, counts, weight * abs(int(expr.exp)))
    else:
        for arg in expr.args:
            count_reads(arg, symbols, counts, weight)


def is_trivial(expr: sp.Expr) -> bool:
    """True for a number, a symbol, or a number times a symbol: values not worth a temporary."""
    if expr.is_Atom:
        return True
    args = expr.args
    return expr.is_Mul and len(args) == 2 and args[0].is_Number and args[1].is_Atom


def _unsigned_term(term) -> tuple:
    """A term without the sign of its numeric coefficient: (|c|, the other factors), the same for -term."""
    if term.is_Mul:
        args = term.args
        first = args[0]
        if first.is_Number:
            return _magnitude(first), args[1:]
        return _UNIT, args
    if term.is_Number:
        return _magnitude(term), ()
    return _UNIT, (term,)


_UNIT = (1, 1)  # _magnitude of 1 and -1


def _magnitude(number) -> object:
    """|number| as something hashable, without sympy's Rational(|p|, q) and its gcd."""
    p = getattr(number, "p", None)  # Integer, Rational
    return (abs(p), number.q) if p is not None else abs(number)


def sign_key(expr) -> tuple:
    """A key that `expr` and sympy's `-expr` share (a sum negates term by term, a product its coefficient), and
    that is cheap: computing -expr for a sum re-sorts all its terms, which made the negative lookup in `Tape.temp`
    a seventh of the derivation's time; now -expr is only built when an entry on the tape has this key."""
    if expr.is_Add:
        return True, frozenset(map(_unsigned_term, expr.args))
    return False, _unsigned_term(expr)


class Tape:
    """An append-only list of assignments to named temporaries, with hashing-based sharing.

    The temporaries are `sympy.Dummy` symbols, so they can never be confused with parameters or coordinates of the
    same name. Use `temp`, `vector` and `inverse` to add entries, `entries_for` to slice out what some outputs
    need, and `expand` to substitute everything back (only sensible for small models).
    """

    def __init__(self):
        self.entries: list[Entry] = []
        self._by_expr: dict[sp.Expr, sp.Dummy] = {}
        self._sign_keys: set = set()  # sign_key of every expression in _by_expr
        self._entry_of: dict[sp.Dummy, Entry] = {}
        self._names: set[str] = set()
        self._section = ""

    def __len__(self) -> int:
        return len(self.entries)

    def fork(self) -> "Tape":
        """A new tape that starts with this one's entries and shares none of its future ones: what a later stage
        (differentiation) adds to the fork leaves the original, and so every function already planned on it,
        unchanged."""
        other = Tape()
        other.entries = list(self.entries)
        other._by_expr = dict(self._by_expr)
        other._sign_keys = set(self._sign_keys)
        other._entry_of = dict(self._entry_of)
        other._names = set(self._names)
        other._section = self._section
        return other

    def rewrite(self, symbol: sp.Dummy, expr: sp.Expr) -> None:
        """The temporary `symbol` holds `expr` instead, an expression of the same value (same name and place): for a
        fork that one function is printed from (compiler/angle_free.py), never for a tape others were planned on."""
        old = self._entry_of[symbol]
        new = replace(old, expr=expr, _deps=None, _symbols=None, _reads=None, _dep_places=None)
        self.entries[old.place] = new
        self._entry_of[symbol] = new

    def section(self, label: str) -> None:
        """Label the entries created from now on (e.g. "body 3 (link3): velocity")."""
        self._section = label

    @property
    def current_section(self) -> str:
        """The label new entries get (to return to it after a digression)."""
        return self._section

    def is_temp(self, symbol) -> bool:
        return symbol in self._entry_of

    def entry(self, symbol: sp.Dummy) -> Entry:
        return self._entry_of[symbol]

    def temp(self, expr, name: str) -> sp.Expr:
        """The value of `expr` as a temporary named like `name` (or `expr` itself when trivial)."""
        if not isinstance(expr, sp.Basic):
            expr = sp.sympify(expr)
        if is_trivial(expr):
            return expr
        hit = self._by_expr.get(expr)
        if hit is not None:
            return hit
        # x and -x share one temporary; a new one holds the value as asked, so that its name tells the truth.
        key = sign_key(expr)
        if key in self._sign_keys:
            hit = self._by_expr.get(-expr)
            if hit is not None:
                return -hit
        return self._add(expr, name, key)

    def vector(self, exprs, name: str) -> tuple:
        """Temporaries `name_0`, `name_1`, ... for the entries of a vector."""
        return tuple(self.temp(e, f"{name}_{k}") for k, e in enumerate(exprs))

    def inverse(self, expr, name: str) -> sp.Expr:
        """1/expr as a temporary guarded by `expr > 0` (the caller guarantees positivity mathematically, e.g. a
        pivot of a positive definite matrix; the guard catches degenerate parameters at run time)."""
        expr = sp.sympify(expr)
        if expr.is_number:
            if not expr > 0:
                raise ZeroDivisionError(f"{name}: structurally singular (pivot {expr})")
            return 1 / expr
        inv = self._by_expr.get(1 / expr) or self._add(1 / expr, name)
        entry = self._entry_of[inv]
        entry.guard, entry._deps, entry._symbols, entry._reads, entry._dep_places = expr, None, None, None, None
        return inv

    def _add(self, expr: sp.Expr, name: str, key: tuple | None = None) -> sp.Dummy:
        name = self._unique(name)
        symbol = sp.Dummy(name)
        entry = Entry(symbol, expr, name, self._section, place=len(self.entries))
        self.entries.append(entry)
        self._by_expr[expr] = symbol
        self._sign_keys.add(sign_key(expr) if key is None else key)
        self._entry_of[symbol] = entry
        return symbol

    def _unique(self, name: str) -> str:
        if name not in self._names:
            self._names.add(name)
            return name
        k = 2
        while f"{name}x{k}" in self._names:
            k += 1
        self._names.add(f"{name}x{k}")
        return f"{name}x{k}"

    def dependencies(self, entry: Entry) -> frozenset:
        """The temporaries `entry` reads (its expression's and its guard's)."""
        if entry._deps is None:
            entry._deps = frozenset(s for s in self.symbols_read(entry) if s in self._entry_of)
        return entry._deps

    @staticmethod
    def symbols_read(entry: Entry) -> frozenset:
        """Every symbol `entry` reads (its expression's and its guard's), kept on the entry: the functions of a
        file slice the same entries many times over."""
        if entry._symbols is None:
            symbols = symbols_of(entry.expr)
            if entry.guard is not None:
                symbols |= symbols_of(entry.guard)
            entry._symbols = frozenset(symbols)
        return entry._symbols

    def reads(self, entry: Entry) -> dict:
        """How often `entry` reads each temporary (its expression's and its guard's; x**2 reads x twice, as it is
        printed x*x), kept on the entry: every function that slices it counts its reads (emit_common.read_counts)."""
        if entry._reads is None:
            counts: dict = {}
            count_reads(entry.expr, self._entry_of, counts)
            if entry.guard is not None:
                count_reads(entry.guard, self._entry_of, counts)
            entry._reads = counts
        return entry._reads

    def entries_for(self, outputs) -> list[Entry]:
        """The entries needed to evaluate `outputs` (an iterable of expressions), in tape order: found from the
        outputs' temporaries through what each reads, by their places on the tape (not by a pass over the whole
        tape for every function of a file)."""
        entry_of, entries = self._entry_of, self.entries
        todo = [entry_of[s].place for e in outputs for s in symbols_of(sp.sympify(e)) if s in entry_of]
        found = set()
        while todo:
            k = todo.pop()
            if k not in found:
                found.add(k)
                entry = entries[k]
                places = entry._dep_places
                if places is None:
                    places = entry._dep_places = tuple(entry_of[s].place for s in self.dependencies(entry))
                todo.extend(places)
        return [entries[k] for k in sorted(found)]

    def free_symbols(self, outputs) -> set:
        """The non-temporary symbols (coordinates, parameters, t) that `outputs` depend on."""
        outputs = [sp.sympify(e) for e in outputs]
        found = set().union(*map(symbols_of, outputs))
        for entry in self.entries_for(outputs):
            found |= self.symbols_read(entry)
        return {s for s in found if s not in self._entry_of}

    def expand(self, outputs) -> list[sp.Expr]:
        """`outputs` with every temporary substituted back: the fully written expressions (small models only)."""
        outputs = [sp.sympify(e) for e in outputs]
        values: dict = {}
        for entry in self.entries_for(outputs):
            values[entry.symbol] = entry.expr.xreplace(values)
        return [e.xreplace(values) for e in outputs]
