"""The symbolic derivation alone (model text to generated C text, empty caches) with the current code path
against the three before it, measured in the same run.

    python bench/derive.py [--models iltis chain40 quarter] [--repeat 5] [--paths current fourth ...] [--printer]

Per model: `mbs.loads(text, cache_dir=<empty>).generate(scene)` (parse, lower, derive, print the C; a tree's
NumPy module is printed when first asked for, after the timing, and compared too), its CPU seconds (this process;
the machine is shared and noisy, so CPU rather than wall time), each run in a process of its own (as a fresh
compile: sympy's caches empty; the modules of the pipeline are imported before the clock starts), the code paths
interleaved, medians of --repeat. Also printed: the CPU until the equations' C is handed to the C compiler
(`equations_ready`: what a fresh compile waits for before its C compiler starts).

--printer: the equations' C alone (ccode.generate_c of one derivation, in one process), printed again and again
with the current printer and the one before the fourth pass alternating, medians of --repeat: the printer's part
of the fourth pass, without the noise of whole fresh derivations (sympy's caches are warm for both after the
first round, as they are for the printer in a derivation).

The code path before issue 12's fourth pass (the switch `before_fourth_pass`; `--paths current fourth` compares
these two alone):

* every function of a file counted the reads of each temporary it slices anew (now once per entry: Tape.reads);
* a function's entries found by a pass over the whole tape (now through what each reads, by their places:
  Tape.entries_for);
* the temporaries written in place looked up for every node of their readers (now for their symbols only:
  fast_arith.replaced_symbols);
* the identifiers of a part's texts found anew by each of the cuts, the parts and the statements' order (now once:
  ccode_parts.names_in);
* a prescribed motion's second derivative taken to find a kink even without min, max, abs or a step in it (now only
  when it may have one: lower.may_kink);
* the parameters' values and the initial state evaluated for the loops' closed form before it refused loops with
  extra states or quaternions, the Iltis's (now refused first: closed_form_loops.structural_refusal);
* every temporary's name put through identifier's regex substitutions (now only a name that is not plain:
  emit_common._safe).

The previous code path (the switch `previous_derivation`, before issue 12's third derivation pass; the fourth
pass's changes switched off as well):

* every tyre's unswitched laws (the lateral force, the aligning torque) converted to sympy on their own (now
  the first tyre's conversion renamed for the other tyres of its component: compiler/instances.py);
* the canonical order of a sum's or a product's arguments by a key for atoms and nodes of atoms only, made anew
  at every sort (now kept per node, and one level deeper: fast_arith.sort_key);
* sympy's constructor postprocessors looked up for every argument of every sum and product built (now once
  per type of argument: fast_arith.postprocessed);
* the parameters of the equations and of the loop constraints found anew each time they are asked for (now
  once: Equations._parameters, Constraints._parameters);
* Python's cyclic garbage collector running during the derivation (now paused: compiler/gc_pause.py).

The former code path (the switch `former_derivation`, before issue 12's second pass; the previous path's changes
switched off as well):

* sympy's own `a*b`, `Mul(...)`, `a + b` and `-a` in the spatial algebra, the forward derivatives and the
  printer's substitution (compiler/fast_arith.py builds the common cases directly, sympy's expressions);
* sympy's assumptions for a number's sign in the printer (emit_common.negative_number);
* sympy's free_symbols where the tape is sliced, printed and differentiated (tape.symbols_of walks once);
* sympy's xreplace where the printer writes a temporary into its reader (fast_arith.replaced);
* the forward derivatives' |u|, max/min and step functions rewritten for every symbol a temporary reads (now
  once per temporary).

(Not switched: Tape.temp's sympify of what already is a sympy expression, a few percent of its time.) All three
code paths must give the same text: the bench says so (bench/derive_texts.py compares the texts of every library
and test model with those of another checkout's code).

Issue 12's targets (a fresh compile, derivation and C compiler together): the Iltis under 5 s, the 40-link chain
under 10 s; bench/compile_time.py measures the whole compile.
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import sympy as sp

import mbs
from mbs import pipeline, system  # noqa: F401 (imported before the clock starts, with the modules below)
from mbs.compiler import (ccode, ccode_parts, differentiate, emit_common, fast_arith, gc_pause, instances,  # noqa
                          lower, pycode, tape)
from mbs.compiler.constraints import Constraints
from mbs.compiler.equations import Equations
from mbs.language import frontend  # noqa: F401

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "bench"))
from chain import chain_text  # noqa: E402


def model_text(name: str) -> tuple[str, str, str | None]:
    """(model text, its path, the scene to derive)."""
    if name == "iltis":
        path = ROOT / "library" / "iltis" / "vehicle.mbs"
        return path.read_text(), str(path), "bump_5"
    if name == "quarter":
        path = ROOT / "library" / "iltis" / "quarter_car.mbs"
        return path.read_text(), str(path), None
    return chain_text(int(name.removeprefix("chain"))), "<chain>", None


def _former_negative_number(number, extended: bool = False) -> bool:
    return bool(number.is_extended_negative if extended else number.is_negative)


def _former_differentiate(expr, seeds: dict, derivative: dict) -> dict:
    """differentiate._differentiate as it was: |u|, max/min and the steps rewritten for every symbol read."""
    total: dict = {}
    for a in expr.free_symbols:
        if a in seeds:
            inner = {seeds[a]: sp.S.One}
        else:
            inner = derivative.get(a)
            if not inner:
                continue
        partial = differentiate.partial_derivative(expr, a)
        if partial == 0:
            continue
        for k, d in inner.items():
            total[k] = total.get(k, sp.S.Zero) + partial * d
    return {k: total[k] for k in sorted(total) if total[k] != 0}


def _former_read_counts(tape_, entries, outputs) -> dict:
    """emit_common.read_counts as it was: every entry's expression walked for every function that slices it."""
    counts = {e.symbol: 0 for e in entries}

    def visit(expr, weight=1):
        if expr in counts:
            counts[expr] += weight
        elif expr.is_Pow and expr.exp.is_Integer:
            visit(expr.base, weight * abs(int(expr.exp)))
        else:
            for arg in expr.args:
                visit(arg, weight)

    for e in entries:
        visit(e.expr)
        if e.guard is not None:
            visit(e.guard)
    for o in outputs:
        visit(sp.sympify(o))
    return counts


def _former_entries_for(self, outputs) -> list:
    """Tape.entries_for as it was: a pass over the whole tape."""
    needed = set()
    for e in outputs:
        needed |= {s for s in tape.symbols_of(sp.sympify(e)) if s in self._entry_of}
    for entry in reversed(self.entries):
        if entry.symbol in needed:
            needed |= self.dependencies(entry)
    return [entry for entry in self.entries if entry.symbol in needed]


def _former_closed_form_of(model, lowered, constraints, equations, friction):
    """pipeline.closed_form_of as it was: the parameters' values and the initial state evaluated before
    closed_form refuses loops with extra states or quaternions (the Iltis's)."""
    from mbs.compiler.closed_form_loops import Refused, closed_form
    if constraints is None or friction is not None or lowered.friction_rows:
        return None
    values = pipeline.parameter_values(model)
    x0 = pipeline.initial_state_of(model, None, lowered.tree, values)
    by_name = {s.name: s for s in constraints.parameters()}
    try:
        return closed_form(constraints, equations, {s: values[n] for n, s in by_name.items() if n in values},
                           x0[:lowered.tree.nq])
    except Refused:
        return None


def _former_safe(name: str) -> str:
    """emit_common._safe as it was: identifier's regex substitutions for every temporary's name."""
    ok = (name.isidentifier() and name.isascii() and not name.startswith("__")
          and not (len(name) > 1 and name[0] == "_" and name[1].isupper()))
    bare = name.lstrip("_")
    return (name if ok and emit_common.identifier(bare, capitals=False) == bare
            else emit_common.identifier(name, capitals=False))


def _former_names_in(text: str) -> set:
    return set(ccode_parts._IDENTIFIER.findall(text))


@contextlib.contextmanager
def before_fourth_pass():
    """The code path before issue 12's fourth pass (the front end and the printer)."""
    saved = (emit_common.read_counts, tape.Tape.entries_for, emit_common.replaced, ccode_parts.names_in,
             ccode.names_in, lower.may_kink, pipeline.closed_form_of, emit_common._safe)
    pipeline.closed_form_of, emit_common._safe = _former_closed_form_of, _former_safe
    emit_common.read_counts = _former_read_counts
    tape.Tape.entries_for = _former_entries_for
    emit_common.replaced = fast_arith.replaced
    ccode_parts.names_in = ccode.names_in = _former_names_in
    lower.may_kink = lambda expr: True
    try:
        yield
    finally:
        (emit_common.read_counts, tape.Tape.entries_for, emit_common.replaced, ccode_parts.names_in, ccode.names_in,
         lower.may_kink, pipeline.closed_form_of, emit_common._safe) = saved


def _uncached(cls):
    return lambda self: cls._parameters.func(self)


@contextlib.contextmanager
def previous_derivation():
    """The code path before issue 12's third derivation pass."""
    with before_fourth_pass(), _third_pass_off():
        yield


@contextlib.contextmanager
def _third_pass_off():
    saved = (instances.SharedLaws.convert, fast_arith.sort_key, fast_arith.postprocessed, Equations.parameters,
             Constraints.parameters, gc_pause.ENABLED)
    instances.SharedLaws.convert = lambda self, expr, to_sympy: to_sympy(expr)
    fast_arith.sort_key = fast_arith._shallow_or_none
    fast_arith.postprocessed = lambda node: type(node)._exec_constructor_postprocessors(node)
    Equations.parameters, Constraints.parameters = _uncached(Equations), _uncached(Constraints)
    gc_pause.ENABLED = False
    try:
        yield
    finally:
        (instances.SharedLaws.convert, fast_arith.sort_key, fast_arith.postprocessed, Equations.parameters,
         Constraints.parameters, gc_pause.ENABLED) = saved


@contextlib.contextmanager
def former_derivation():
    """The code path before issue 12's second derivation pass (and its third)."""
    with previous_derivation(), _second_pass_off():
        yield


@contextlib.contextmanager
def _second_pass_off():
    saved = (fast_arith.product, fast_arith.product_of, fast_arith.total, fast_arith.negative,
             emit_common.negative_number, tape.symbols_of, emit_common.symbols_of, emit_common.replaced,
             differentiate._differentiate)
    fast_arith.product = lambda a, b: a * b
    fast_arith.product_of = lambda operands: sp.Mul(*operands)
    fast_arith.total = lambda terms: sp.Add(*terms)
    fast_arith.negative = lambda a: -a
    emit_common.negative_number = _former_negative_number
    tape.symbols_of = emit_common.symbols_of = lambda expr: expr.free_symbols
    emit_common.replaced = lambda expr, rule: expr.xreplace(rule)
    differentiate._differentiate = _former_differentiate
    try:
        yield
    finally:
        (fast_arith.product, fast_arith.product_of, fast_arith.total, fast_arith.negative,
         emit_common.negative_number, tape.symbols_of, emit_common.symbols_of, emit_common.replaced,
         differentiate._differentiate) = saved


def derive(name: str) -> tuple[float, float, str]:
    """(CPU seconds, of them until the equations' C was handed over, C text) of one derivation of model `name`
    into an empty cache."""
    text, path, scene = model_text(name)
    ready = []
    with tempfile.TemporaryDirectory(prefix="mbs-bench-") as cache:
        start = time.process_time()
        generated = mbs.loads(text, path=path, cache_dir=cache).generate(
            scene, equations_ready=lambda _: ready.append(time.process_time()))
        cpu = time.process_time() - start
    return cpu, (ready[0] - start if ready else cpu), generated.c_source + generated.numpy_source


def printer_rounds(name: str, repeat: int) -> None:
    """--printer: the equations' C of model `name` printed `repeat` times with each printer, alternating."""
    text, path, scene = model_text(name)
    captured = []
    original = ccode.generate_c

    def capture(*args, **kwargs):
        captured.append((args, kwargs))
        return original(*args, **kwargs)
    with tempfile.TemporaryDirectory(prefix="mbs-bench-") as cache:
        system = mbs.loads(text, path=path, cache_dir=cache)
        ccode.generate_c = capture
        try:
            pipeline.generate(system.model, system.scene(scene) if scene else None, cold_apart=True)
        finally:
            ccode.generate_c = original
    args, kwargs = captured[0]
    times: dict[str, list] = {"current": [], "fourth": []}
    texts = set()

    tapes = [args[0].tape] + ([kwargs["constraints"].tape] if kwargs.get("constraints") is not None else [])

    def forget():
        """The fourth pass's memory of the last round (each entry's reads and places, the texts' identifiers):
        a derivation prints once."""
        for tape_ in tapes:
            for entry in tape_.entries:
                entry._reads = entry._dep_places = None
        ccode_parts.names_in.cache_clear()

    @gc_pause.paused  # (as in a derivation)
    def rounds():
        for _ in range(repeat):
            for label, switch in (("current", contextlib.nullcontext), ("fourth", before_fourth_pass)):
                forget()
                with switch():
                    start = time.process_time()
                    texts.add(original(*args, **kwargs))
                    times[label].append(time.process_time() - start)
    rounds()
    now, before = statistics.median(times["current"]), statistics.median(times["fourth"])
    print(f"  {name:8s} {now:7.3f}s {before:14.3f}s {before / now:22.2f}x  "
          f"{'the same' if len(texts) == 1 else 'THE TEXTS DIFFER'}", flush=True)


PATHS = {"current": contextlib.nullcontext, "fourth": before_fourth_pass, "previous": previous_derivation,
         "former": former_derivation}
#: What each path is, for the table.
LABELS = {"current": "current", "fourth": "before pass 4", "previous": "before pass 3", "former": "before pass 2"}


def derive_fresh(name: str, path: str) -> tuple[float, float, str]:
    """derive in a process of its own (sympy's caches as a fresh compile finds them) on code path `path` (a key
    of PATHS): (CPU seconds, of them until the equations' C was ready, SHA-256 of the text)."""
    command = [sys.executable, __file__, "--one", name, "--path", path]
    out = subprocess.run(command, check=True, capture_output=True, text=True).stdout.split()
    return float(out[0]), float(out[1]), out[2]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", nargs="+", default=["iltis", "chain40"])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--paths", nargs="+", choices=PATHS, default=list(PATHS),
                    help="the code paths to measure (default: all; the first is the one the others are divided by)")
    ap.add_argument("--printer", action="store_true", help="the equations' C printer alone, in one process")
    ap.add_argument("--one", help=argparse.SUPPRESS)  # the child: one derivation, prints seconds and digest
    ap.add_argument("--path", choices=PATHS, default="current", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.one:
        with PATHS[args.path]():
            cpu, ready, text = derive(args.one)
        print(f"{cpu:.6f} {ready:.6f} {hashlib.sha256(text.encode()).hexdigest()}")
        return
    if args.printer:
        print(f"the equations' C printed (ccode.generate_c, CPU seconds, one process), medians of {args.repeat}, "
              "the current printer and the one before issue 12's fourth pass alternating")
        print(f"  {'model':8s} {'current':>8s} {'before pass 4':>15s} {'before pass 4/current':>23s}  text")
        for name in args.models:
            printer_rounds(name, args.repeat)
        return
    paths = list(dict.fromkeys(args.paths))
    print(f"derivation CPU seconds (parse to C text, each in a fresh process), medians of {args.repeat}, the code "
          f"paths {', '.join(LABELS[p] for p in paths)} interleaved; in brackets: until the equations' C is handed "
          "to the C compiler")
    print(f"  {'model':8s} " + " ".join(f"{LABELS[p]:>22s}" for p in paths)
          + "".join(f" {LABELS[p] + '/' + LABELS[paths[0]]:>28s}" for p in paths[1:]) + "  text")
    for name in args.models:
        runs: dict[str, list] = {path: [] for path in paths}
        for _ in range(args.repeat):
            for path in runs:
                runs[path].append(derive_fresh(name, path))
        total = {p: statistics.median(c for c, _, _ in runs[p]) for p in paths}
        ready = {p: statistics.median(r for _, r, _ in runs[p]) for p in paths}
        same = len({digest for path in runs for _, _, digest in runs[path]}) == 1
        first = paths[0]
        print(f"  {name:8s} " + " ".join(f"{f'{total[p]:.2f}s ({ready[p]:.2f}s)':>22s}" for p in paths)
              + "".join(f" {f'{total[p] / total[first]:.2f}x ({ready[p] / ready[first]:.2f}x)':>28s}"
                        for p in paths[1:])
              + f"  {'the same on every path' if same else 'THE TEXTS DIFFER'}", flush=True)


if __name__ == "__main__":
    main()
