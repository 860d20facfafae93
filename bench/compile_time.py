"""A model's fresh compile (text to loaded library, empty caches) with the current settings against the former ones,
and what the settings cost the compiled model at run time.

    python bench/compile_time.py [--models iltis chain40 fourbar40] [--repeat 3] [--units]
                                 [--baseline former|eager|overlap|flags] [--empty] [--timeline]

Per model, all measured in this run, the two settings' runs interleaved (medians of --repeat; the machine is shared
and noisy, so CPU seconds are printed beside wall seconds):

* compile: ``mbs.load(text).compile(scene)`` into an empty cache: parse, derive, emit C, the C compiler (the
  equations' units start while the outputs are derived, runtime/build.py prebuild), load. The cache holds only the
  runtime object every model shares (runtime/build.py RUNTIME_UNIT: the Python bindings and the integrators,
  compiled once per compiler and flags), as after a user's first model; its own compile is printed apart. The baseline is the
  same with the former settings: the former C printer (every function of the file printed its temporaries anew,
  and sympy's could_extract_minus_sign, which builds -term for every term of a sum), the former derivation helpers
  (compiler/tape.py: -expr built for every new temporary to look its negative up, where now a cheap sign key says
  whether any entry could be it; compiler/differentiate.py: the constraint Jacobian's partial derivatives by
  sympy's diff, a Derivative around every node, where now sympy_diff applies sympy's rules to sums, products and
  powers itself; every entry's and printed expression's free symbols computed anew) and the former flags (the
  outputs' unit and the functions no integrator calls, an open tree's mass matrix and forces, at the model units'
  level; runtime/build.py OUTPUTS_UNIT_FLAGS, COLD_UNIT_FLAGS) and a tree's NumPy module printed with every
  derivation (now only when the NumPy back end asks for it). Printed: wall time, and of it the derivation (to the generated C)
  and the C build after it; the CPU time of this process (the derivation) and of the compiler processes, and of
  theirs what the processes that ended before the derivation did (the compiler's work taken off the build after
  it: a figure the load of a shared machine moves less than the wall times);
* same text: the generated C of both settings is compared (the settings must not change it);
* run time, 15 interleaved rounds inside C (`backend.time_call`, no Python; the fastest round of each): the
  right-hand side the integrators call, the outputs and the mass matrix at the start state (the model units, and
  with them the right-hand side of a model without loops, are the same objects with both settings), and a whole `simulate` of the scene (the vehicle: bump_5; the chains:
  1 s), each against the former build;
* --units: each translation unit compiled alone, one at a time, with the current and the former flags: its
  size and the compiler's CPU seconds.
* --baseline eager: the baseline is the current settings with a tree's cold functions (its mass matrix and forces,
  which no integrator calls) derived and compiled with the rest, as before (mbs/system.py COLD_APART), and the
  split build's prebuild as before (eager_cold): the change "cold functions on demand" alone. The default baseline, "former", has them so too. Printed besides: the first
  call of the mass matrix after the fresh compile (the whole file derived, the cold functions' library built:
  runtime/backends.py ColdLibrary), the same in a new process's view (a new System on the same cache: nothing
  derived nor compiled again), and whether the right-hand side and the mass matrix of both builds are the same to
  the bit at random states.
* --baseline overlap: the baseline is the current settings with the C compiler started as before the early starts
  (runtime/build.py Prebuilds: the runtime unit as the derivation starts, the glue unit from the file's head before
  the functions are printed; before, both with the equations' units), the split's former helper search and the
  former order of the units (bench/compile_time.py former_overlap). The default baseline has them so too.
* --baseline flags: the baseline is the current settings with the model units' former flags (bench/unit_flags.py
  FORMER_MODEL_UNIT_FLAGS: before the post-reload CSE's memory and the second scheduling were cut); the default
  baseline has them so too.
* --empty: the cache is empty, without the runtime object (a user's very first compile), for both settings.
* --timeline: when each compiler process of each setting's last compile ran against the derivation's phases
  (mbs/pipeline.py _Phases), in seconds from the compile's start.

Issue 12's targets: a fresh compile of the Iltis under 5 s, of the 40-link chain under 10 s.
"""

from __future__ import annotations

import argparse
import atexit
import contextlib
import resource
import shutil
import statistics
import subprocess
import sys
import sysconfig
import tempfile
import time
from pathlib import Path

import numpy as np

import mbs
from mbs import system as system_module
from mbs.compiler import differentiate, emit_common
from mbs.compiler import tape as tape_module
from mbs.runtime import build
from mbs.runtime import cache as build_cache
from mbs.runtime import translation_units

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "bench"))
sys.path.insert(0, str(ROOT / "tests" / "runtime"))
from chain import chain_text  # noqa: E402
from fourbar_chain import fourbar_chain  # noqa: E402
from unit_flags import FORMER_MODEL_UNIT_FLAGS, model_flags_set  # noqa: E402

TARGETS = {"iltis": 5.0, "chain40": 10.0}
#: The flags of the outputs' unit before this bench's change (the model units' level).
FORMER_OUTPUTS_FLAGS: tuple[str, ...] = ()
#: The flags of the cold units before (runtime/translation_units.py COLD_FUNCTIONS: they were model units).
FORMER_COLD_FLAGS: tuple[str, ...] = ()


def model_text(name: str) -> tuple[str, str, str | None, float | None]:
    """(model text, its path for messages, the scene to compile, t_end of the simulate run or None: the scene's)."""
    if name == "iltis":
        path = ROOT / "library" / "iltis" / "vehicle.mbs"
        return path.read_text(), str(path), "bump_5", None
    if name == "pendulum":  # a small model, built as one unit
        path = ROOT / "library" / "examples" / "pendulum.mbs"
        return path.read_text(), str(path), "swing", None
    if name.startswith("fourbar"):
        return fourbar_chain(int(name.removeprefix("fourbar"))), "<fourbar>", None, 1.0
    return chain_text(int(name.removeprefix("chain"))), "<chain>", None, 1.0


# ---- the former settings ------------------------------------------------------------------------------------------

def _former_doprint(self, expr) -> str:
    return self._print(emit_common.sp.sympify(expr))[0]


def _former_print_add(self, expr):
    terms = list(expr.args)
    terms.sort(key=lambda e: e.could_extract_minus_sign())
    out = self._paren(terms[0], emit_common.PREC_ADD)
    for term in terms[1:]:
        if term.could_extract_minus_sign():
            out += " - " + self._paren(-term, emit_common.PREC_MUL)
        else:
            out += " + " + self._paren(term, emit_common.PREC_MUL)
    return out, emit_common.PREC_ADD


def _former_temp(self, expr, name: str):
    """Tape.temp as it was: -expr built for every expression not on the tape (a sum's terms re-sorted)."""
    expr = emit_common.sp.sympify(expr)
    if tape_module.is_trivial(expr):
        return expr
    hit = self._by_expr.get(expr)
    if hit is not None:
        return hit
    hit = self._by_expr.get(-expr)
    return -hit if hit is not None else self._add(expr, name)


def _former_symbols_read(entry):
    symbols = entry.expr.free_symbols
    return frozenset(symbols | entry.guard.free_symbols if entry.guard is not None else symbols)


#: The former derivation printed a tree's NumPy module with its C (now printed only for the NumPy back end).
_EAGER_NUMPY = [False]


@contextlib.contextmanager
def eager_cold():
    """As before the cold functions were built on demand: a tree's cold functions derived and compiled with the
    rest (mbs/system.py COLD_APART False), the outputs' declarations in model.h (so that prebuild's model units
    were compiled again for a scene without outputs) and build waiting for prebuild's queue of jobs, compiled one
    after another."""
    split, cancelled = translation_units.split_sources, build._cancelled

    def split_as_before(code, filename):
        files = split(code, filename)
        if files is not None and translation_units.OUTPUTS_UNIT in files:
            files["model.h"] += translation_units.OUTPUTS_DECLARATIONS
        return files

    system_module.COLD_APART = False
    translation_units.split_sources, build._cancelled = split_as_before, (lambda key: False)
    try:
        yield
    finally:
        system_module.COLD_APART = True
        translation_units.split_sources, build._cancelled = split, cancelled


def _former_helpers_for(body, helpers):
    """translation_units._helpers_for as it was: the whole text searched for each helper's name."""
    wanted: set[str] = set()
    text, changed = body, True
    while changed:
        changed = False
        for h in helpers:
            if h.name not in wanted and __import__("re").search(rf"\b{h.name}\b", text):
                wanted.add(h.name)
                text += "\n" + h.text
                changed = True
    return [h for h in helpers if h.name in wanted]


@contextlib.contextmanager
def former_overlap():
    """As before the early starts: the runtime unit (with an empty cache, --empty) not started as the derivation
    starts (runtime/build.py Prebuilds.derivation_started) and the glue unit not from the file's head before the
    functions are printed (Prebuilds.head_written), both with the equations' units, whose glue unit declared the
    outputs whether the scene had any (a scene without them compiled it again); the split's former search for the
    helpers a unit calls (translation_units._helpers_for: 0.5 s of the Iltis's CPU before the first unit); and the
    units compiled at -Og weighed as the others (runtime/build.py OG_WEIGHT), so the outputs' unit started first."""
    started, head, equations = (build.Prebuilds.derivation_started, build.Prebuilds.head_written,
                                build.Prebuilds.__call__)
    helpers_for = translation_units._helpers_for
    build.Prebuilds.derivation_started = lambda self: 0
    build.Prebuilds.head_written = lambda self, text, entries: 0
    build.Prebuilds.__call__ = lambda self, code: build.prebuild(code, cache_dir=self.cache_dir)  # (outputs or not)
    translation_units._helpers_for = _former_helpers_for
    weight, build.OG_WEIGHT = build.OG_WEIGHT, 1.0
    try:
        yield
    finally:
        build.Prebuilds.derivation_started, build.Prebuilds.head_written = started, head
        build.Prebuilds.__call__ = equations
        translation_units._helpers_for = helpers_for
        build.OG_WEIGHT = weight


@contextlib.contextmanager
def former_settings(baseline: str = "former"):
    """The printer, the derivation's helpers and the build flags as they were before, the cold functions
    compiled with the rest and the compiler's former start: the baseline ("eager": the cold functions alone;
    "overlap": the former start alone)."""
    if baseline in ("eager", "overlap"):
        with eager_cold() if baseline == "eager" else former_overlap():
            yield
        return
    if baseline == "flags":
        with model_flags_set(FORMER_MODEL_UNIT_FLAGS):
            yield
        return
    _EAGER_NUMPY[0] = True
    printer, tape = emit_common.ExprPrinter, tape_module.Tape
    saved = (printer.doprint, printer._print_Add, printer.free_symbols, tape.temp, tape.__dict__["symbols_read"],
             differentiate.sympy_diff, build.OUTPUTS_UNIT_FLAGS, build.COLD_UNIT_FLAGS)
    printer.doprint, printer._print_Add = _former_doprint, _former_print_add
    printer.free_symbols = lambda self, expr: expr.free_symbols
    tape.temp, tape.symbols_read = _former_temp, staticmethod(_former_symbols_read)
    differentiate.sympy_diff = lambda expr, a, memo: emit_common.sp.diff(expr, a)
    build.OUTPUTS_UNIT_FLAGS, build.COLD_UNIT_FLAGS = FORMER_OUTPUTS_FLAGS, FORMER_COLD_FLAGS
    try:
        with eager_cold(), former_overlap(), model_flags_set(FORMER_MODEL_UNIT_FLAGS):
            yield
    finally:
        _EAGER_NUMPY[0] = False
        (printer.doprint, printer._print_Add, printer.free_symbols, tape.temp, tape.symbols_read,
         differentiate.sympy_diff, build.OUTPUTS_UNIT_FLAGS, build.COLD_UNIT_FLAGS) = saved


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


_RUNTIME_CACHE: list[Path] = []


def seed_runtime(cache: str | Path) -> None:
    """Copy the runtime object every model shares (and its record) into the empty cache `cache`, made once per run."""
    if not _RUNTIME_CACHE:
        _RUNTIME_CACHE.append(Path(tempfile.mkdtemp(prefix="mbs-bench-runtime-")))
        atexit.register(shutil.rmtree, _RUNTIME_CACHE[0], True)
        build.runtime_object(cache_dir=_RUNTIME_CACHE[0])
    for path in _RUNTIME_CACHE[0].glob(build_cache.OBJECT_PREFIX + "*"):
        shutil.copy2(path, cache)


def runtime_cpu() -> float:
    """The compiler's CPU seconds for the runtime object alone (once per compiler and flags, not per model)."""
    with tempfile.TemporaryDirectory(prefix="mbs-bench-") as cache:
        cpu = _children_cpu()
        build.runtime_object(cache_dir=cache)
        return _children_cpu() - cpu


class Timeline:
    """When each compiler process of a compile ran and when each phase of the derivation ended (the pipeline's
    phase clock, mbs/pipeline.py _Phases, read off its log records), in seconds from the compile's start:
    --timeline prints it."""

    def __init__(self):
        self.start = time.perf_counter()
        self.events: list[tuple[float, float, str]] = []   # (start, end, what) of the compiler processes
        self.phases: list[tuple[float, str]] = []           # (end, phase) of the derivation
        self.lock = __import__("threading").Lock()

    @contextlib.contextmanager
    def recording(self):
        import logging
        run, log = build._run, logging.getLogger("mbs.pipeline")
        timeline = self

        def timed_run(command, cwd, filename):
            began = time.perf_counter()
            try:
                return run(command, cwd, filename)
            finally:
                what = command[command.index("-c") + 1] if "-c" in command else "link"
                with timeline.lock:
                    timeline.events.append((began - timeline.start, time.perf_counter() - timeline.start, what))

        class Phases(logging.Handler):
            def emit(self, record):
                message = record.getMessage()
                if ": " in message and " in " in message:
                    timeline.phases.append((record.created - time.time() + time.perf_counter() - timeline.start,
                                            message.split(": ", 1)[1].rsplit(" in ", 1)[0]))

        handler, level = Phases(level=logging.INFO), log.level
        build._run = timed_run
        log.addHandler(handler)
        log.setLevel(logging.INFO)
        try:
            yield self
        finally:
            build._run = run
            log.removeHandler(handler)
            log.setLevel(level)

    def lines(self, total: float) -> list[str]:
        """The phases and the compiler processes, one a line, with a bar over the compile's wall time."""
        width, out = 60, []
        scale = width / max(total, 1e-9)
        for end, phase in self.phases:
            out.append(f"    {end:6.2f} s  derivation: {phase}")
        for began, ended, what in sorted(self.events):
            bar = " " * int(began * scale) + "#" * max(1, int((ended - began) * scale))
            out.append(f"    {began:6.2f} - {ended:5.2f} s  {what:12s} |{bar:{width}s}|")
        out.append(f"    {total:6.2f} s  loaded")
        return out


def fresh_compile(name: str, cache: str, *, empty: bool = False, timeline: bool = False) -> dict:
    """Seconds of a fresh compile of model `name` into the folder `cache`, empty but for the runtime object
    (seed_runtime; `empty`: not even that), split at the derivation's end; `timeline`: with its Timeline."""
    if not empty:
        seed_runtime(cache)
    text, path, scene, _ = model_text(name)
    marks = {}
    clock = Timeline()
    recording = clock.recording() if timeline else contextlib.nullcontext()
    recording.__enter__()
    start, cpu, cc_cpu = time.perf_counter(), time.process_time(), _children_cpu()
    system = mbs.loads(text, path=path, cache_dir=cache)
    generate = system.generate

    def timed_generate(*a, **k):
        result = generate(*a, **k)
        if _EAGER_NUMPY[0]:
            result.numpy_source  # noqa: B018 (printed here, as the former derivation did with every compile)
        marks.setdefault("derived", time.perf_counter())
        marks.setdefault("derived cpu", time.process_time())
        marks.setdefault("derived cc cpu", _children_cpu())
        return result

    system.generate = timed_generate
    try:
        compiled = system.compile(scene)
    finally:
        recording.__exit__(None, None, None)
    end = time.perf_counter()
    system.generate = generate
    return {"total": end - start, "derive": marks["derived"] - start, "cc": end - marks["derived"],
            "derive cpu": marks["derived cpu"] - cpu, "cc cpu": _children_cpu() - cc_cpu,
            "cc cpu during": marks["derived cc cpu"] - cc_cpu,
            "timeline": clock.lines(end - clock.start) if timeline else None,
            "system": system, "compiled": compiled, "code": system.generate(scene).c_source}


def compare_compiles(name: str, repeat: int, baseline: str = "former", empty: bool = False,
                     timeline: bool = False) -> tuple[dict, dict]:
    """{setting: [runs]} of fresh compiles with the current and the former settings (`baseline`), interleaved;
    `empty`, `timeline`: as for fresh_compile."""
    runs: dict[str, list] = {"current": [], "former": []}
    for _ in range(repeat):
        for setting in runs:
            with tempfile.TemporaryDirectory(prefix="mbs-bench-") as cache:
                with (former_settings(baseline) if setting == "former" else contextlib.nullcontext()):
                    run = {**fresh_compile(name, cache, empty=empty, timeline=timeline), "cache": cache}
                    runs[setting].append({**run, **first_cold_call(run, name)})
    return runs["current"], runs["former"]


def same_but_cold(code: str, whole: str) -> bool:
    """Whether `code` is the text `whole` without its cold functions (or the same text): every function of it is
    the whole file's, and those it lacks are cold (runtime/translation_units.py COLD_FUNCTIONS)."""
    if code == whole:
        return True
    mine, theirs = translation_units.read_layout(code), translation_units.read_layout(whole)
    if mine is None or theirs is None or mine.outputs != theirs.outputs:
        return False
    blocks = {b.name: b.text for b in theirs.functions}
    missing = set(blocks) - {b.name for b in mine.functions}
    return (all(blocks.get(b.name) == b.text for b in mine.functions)
            and all(translation_units.part_of(n) in translation_units.COLD_FUNCTIONS for n in missing))


def first_cold_call(run: dict, name: str, rounds: int = 5) -> dict:
    """After a fresh compile (a run of fresh_compile, its cache still there): seconds of the first mass matrix call
    (the whole file derived and the cold functions' library built, or nothing to do when they were compiled with the
    rest), of the same from a new System on the same cache (the warm second call: both found in the caches), and
    whether the right-hand side and the mass matrix are those of `other` to the bit at random states."""
    compiled = run["compiled"]
    data = compiled_workspace(compiled)
    x = data.x.copy()
    start, cc_cpu = time.perf_counter(), _children_cpu()
    data.function("mass_matrix")(0.0, x)
    first, first_cc = time.perf_counter() - start, _children_cpu() - cc_cpu
    text, path, scene, _ = model_text(name)
    start = time.perf_counter()
    again = mbs.loads(text, path=path, cache_dir=run["cache"])
    compiled_again = again.compile(scene)
    compiled_workspace(compiled_again).function("mass_matrix")(0.0, x)
    warm = time.perf_counter() - start
    rng = np.random.default_rng(12)
    states = [x + 0.1 * rng.standard_normal(x.size) for _ in range(rounds)]
    values = {fn: [data.function(fn)(0.0, s) for s in states] for fn in ("rhs", "mass_matrix")}
    return {"first": first, "first cc cpu": first_cc, "warm": warm, "values": values}


def same_bits(a: dict, b: dict) -> dict[str, bool]:
    """{function: whether both runs' values at the same states are equal to the bit}."""
    return {fn: all(np.array_equal(x, y) for x, y in zip(a["values"][fn], b["values"][fn])) for fn in a["values"]}


def median(runs: list[dict], key: str) -> float:
    return statistics.median(r[key] for r in runs)


# ---- run time -------------------------------------------------------------------------------------------------------

def call_times(current, former, rounds: int) -> dict:
    """{function: (current, former, ratio) seconds per call inside C}: the fastest of interleaved rounds (on a
    loaded machine a round that was preempted is slow, never fast), and the ratio of the two."""
    out = {}
    for fn in ("rhs", "outputs", "mass_matrix"):
        rows = []
        for _ in range(rounds):
            row = []
            for compiled in (current, former):
                data = compiled_workspace(compiled)
                if fn not in data.model.backend.functions:
                    break
                f = data.function(fn)
                row.append(compiled.backend.time_call(f, data.x, 200, 0.0))
            if len(row) == 2:
                rows.append(row)
        if rows:
            a, b = min(r[0] for r in rows), min(r[1] for r in rows)
            out[fn] = (a, b, a / b)
    return out


def compiled_workspace(compiled):
    from mbs.runtime.workspace import Workspace
    return Workspace(compiled)


def simulate_times(current_run: dict, former_run: dict, name: str, rounds: int,
                   baseline: str = "former") -> tuple[float, float, float]:
    """Median seconds of a whole simulate with each build (interleaved): the vehicle's bump_5, a chain's 1 s. The
    baseline's System runs in its settings (a System compiles again when mbs/system.py COLD_APART changed)."""
    _, _, scene, t_end = model_text(name)
    walls: list[list[float]] = [[], []]
    for _ in range(rounds):
        for k, run in enumerate((current_run, former_run)):
            system = run["system"]
            with former_settings(baseline) if k else contextlib.nullcontext():
                start = time.perf_counter()
                system.simulate(scene, t_end=t_end) if t_end is not None else system.simulate(scene)
                walls[k].append(time.perf_counter() - start)
    ratios = [a / b for a, b in zip(*walls)]
    return statistics.median(walls[0]), statistics.median(walls[1]), statistics.median(ratios)


# ---- each unit alone ---------------------------------------------------------------------------------------------

def unit_cpu(code: str, former: bool) -> dict[str, tuple[int, float]]:
    """{unit: (characters, compiler CPU seconds)}, each unit compiled alone with the current or the former flags
    (not the runtime unit, which every model shares: runtime_cpu)."""
    cc = tuple(build.compiler_command())
    files = build._build_files(code, "model.c")
    outputs_flags = FORMER_OUTPUTS_FLAGS if former else build.OUTPUTS_UNIT_FLAGS
    model_flags = build.model_unit_flags(cc)
    saved, build.COLD_UNIT_FLAGS = build.COLD_UNIT_FLAGS, FORMER_COLD_FLAGS if former else build.COLD_UNIT_FLAGS
    includes = (f"-I{build.C_DIR}", f"-I{sysconfig.get_paths()['include']}", f"-I{np.get_include()}")
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, text in files.items():
            Path(tmp, name).write_text(text, encoding="utf-8")
        for name in files:
            if not name.endswith(".c") or name == build.RUNTIME_UNIT:
                continue
            command = (*cc, *build._compile_flags(build.base_flags(cc)), *build.unit_flags(name, model_flags, outputs_flags),
                       *includes, "-c", name, "-o", name[:-2] + ".o")
            cpu = _children_cpu()
            subprocess.run(command, cwd=tmp, check=True, capture_output=True)
            out[name] = (len(files[name]), _children_cpu() - cpu)
    build.COLD_UNIT_FLAGS = saved
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", nargs="+", default=["iltis", "chain40", "fourbar40"])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--units", action="store_true", help="also each unit compiled alone, current and former flags")
    ap.add_argument("--baseline", choices=("former", "eager", "overlap", "flags"), default="former",
                    help="former: every former setting (the default); eager: the current settings with a tree's cold "
                         "functions compiled with the rest; overlap: the current settings with the compiler started as "
                         "before the early starts (bench/compile_time.py former_overlap); flags: the current settings "
                         "with the model units' former flags (bench/unit_flags.py FORMER_MODEL_UNIT_FLAGS)")
    ap.add_argument("--empty", action="store_true",
                    help="compile into a cache without the runtime object every model shares (a user's very first "
                         "compile: the runtime unit is compiled too)")
    ap.add_argument("--timeline", action="store_true",
                    help="print when each compiler process ran against the derivation's phases (each setting's "
                         "last run)")
    args = ap.parse_args()
    same = "(those of the model units)"
    print(f"{build.build_jobs()} compiler jobs; the former settings: the former printer, the outputs' unit and the "
          f"cold functions at {' '.join(FORMER_OUTPUTS_FLAGS) or same}; the current: the outputs' unit at "
          f"{' '.join(build.OUTPUTS_UNIT_FLAGS) or same}, the cold functions' units at "
          f"{' '.join(build.COLD_UNIT_FLAGS) or same}")
    print(f"the runtime object every model shares (the Python bindings, the integrators; in every fresh compile's "
          f"cache): compiler cpu {runtime_cpu():.2f} s, once per compiler and flags")
    if args.baseline == "overlap":
        print("baseline: the current settings with the C compiler started as before (the runtime unit with the "
              "equations' units; bench/compile_time.py former_overlap)")
    if args.baseline == "flags":
        print(f"baseline: the current settings with the model units' former flags "
              f"({' '.join(FORMER_MODEL_UNIT_FLAGS)}; now {' '.join(build.GCC_MODEL_UNIT_FLAGS)}: runtime/build.py "
              "GCC_MODEL_UNIT_FLAGS, for GCC)")
    if args.baseline == "eager":
        print("baseline: the current settings with a tree's cold functions (mass matrix, forces) derived and compiled "
              "with the rest (mbs/system.py COLD_APART False) and prebuild as before (bench/compile_time.py eager_cold)")
    for name in args.models:
        current, former = compare_compiles(name, args.repeat, args.baseline, args.empty, args.timeline)
        same = all(same_but_cold(r["code"], former[0]["code"]) for r in current + former)
        print(f"\n{name}: generated C {len(current[0]['code']) / 1024:.0f} KiB, the baseline's "
              f"{len(former[0]['code']) / 1024:.0f} KiB ({'the same text but the cold functions' if same else 'THE TEXTS DIFFER'}); "
              f"medians of {args.repeat}")
        print(f"  {'':8s} {'compile':>8s} {'derive':>8s} {'C after':>8s} {'derive cpu':>10s} {'cc cpu':>8s} "
              f"{'of it during the derivation':>28s}")
        for label, runs in (("current", current), (args.baseline, former)):
            print(f"  {label:8s} {median(runs, 'total'):7.1f}s {median(runs, 'derive'):7.1f}s "
                  f"{median(runs, 'cc'):7.1f}s {median(runs, 'derive cpu'):9.1f}s {median(runs, 'cc cpu'):7.1f}s "
                  f"{median(runs, 'cc cpu during'):27.1f}s")
        if args.timeline:
            for label, runs in (("current", current), (args.baseline, former)):
                print(f"  timeline of the {label} settings' last compile (seconds from its start):")
                print("\n".join(runs[-1]["timeline"]))
        ratio = lambda key: median(former, key) / median(current, key)  # noqa: E731
        target = TARGETS.get(name)
        print(f"  {args.baseline} / current: compile {ratio('total'):.2f} x, derivation {ratio('derive'):.2f} x (cpu "
              f"{ratio('derive cpu'):.2f} x), C compiler cpu {ratio('cc cpu'):.2f} x"
              + (f"; target: compile under {target:g} s (now {median(current, 'total'):.1f} s)" if target else ""))
        print(f"  first mass matrix call after the fresh compile: {median(current, 'first'):.2f} s (compiler cpu "
              f"{median(current, 'first cc cpu'):.1f} s) against the baseline's {median(former, 'first'):.3f} s; "
              f"compile and first call from a new System on the same cache: {median(current, 'warm'):.3f} s against "
              f"{median(former, 'warm'):.3f} s")
        bits = {fn: all(same_bits(a, b)[fn] for a in current for b in former) for fn in ("rhs", "mass_matrix")}
        print("  the same to the bit as the baseline's build at random states: "
              + ", ".join(f"{fn} {'yes' if ok else 'NO'}" for fn, ok in bits.items()))
        times = call_times(current[-1]["compiled"], former[-1]["compiled"], 15)
        for fn, (a, b, r) in times.items():
            print(f"  {fn} per call in C: {a * 1e6:.2f} us against the former build's {b * 1e6:.2f} us: {r:.2f} x")
        a, b, r = simulate_times(current[-1], former[-1], name, args.repeat, args.baseline)
        print(f"  simulate: {a * 1e3:.0f} ms against the former build's {b * 1e3:.0f} ms: {r:.2f} x")
        if args.units:
            now = unit_cpu(current[0]["code"], False)
            with model_flags_set(FORMER_MODEL_UNIT_FLAGS if args.baseline in ("former", "flags") else None):
                before = unit_cpu(former[0]["code"], args.baseline == "former")
            print(f"  {'unit':12s} {'KiB':>6s} {'cpu':>7s} {'former':>7s}")
            for unit in {**before, **now}:
                size, cpu = now.get(unit, before[unit])
                print(f"  {unit:12s} {size / 1024:6.0f} " + (f"{cpu:6.2f}s" if unit in now else f"{'-':>7s}")
                      + (f" {before[unit][1]:6.2f}s" if unit in before else f" {'-':>7s}"))
            print(f"  {'total':12s} {'':6s} {sum(c for _, c in now.values()):6.2f}s "
                  f"{sum(c for _, c in before.values()):6.2f}s")


if __name__ == "__main__":
    main()
