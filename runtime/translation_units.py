"""Split a generated model into translation units that the C compiler builds in parallel.

A large model (the Iltis: 850 kB of C, seven big straight-line functions) compiles for many seconds as one unit,
on one core. The generated file (compiler/ccode.py) has a fixed layout, which this module reads:

    header comment, #include, #define sizes, static const arrays      -> model.h, shared by every unit
    static helper functions (mbs_all_finite, mbs_lookup, tables ...)  -> copied into the units that call them,
    with the static const arrays right above one that only it reads      (a lookup table's points)
    the contract's functions (int mbs_rhs(...) { ... }, name tables)  -> model_1.c .. model_n.c, by size
    those no integrator calls (COLD_FUNCTIONS, models without loops)  -> cold_1.c .., compiled cheaper

A tree's file written without its cold functions (compiler/ccode.py cold_apart, COLD_APART) has no cold units; the
whole file's cold functions are then split by cold_sources into model.h and cold_1.c .. of a library of their own
(runtime/build.py build_cold), built when one is first called.

model.h ends with the prototype of every contract function, so the units may call each other, and the glue unit
(<Python.h>, model.h, c/mbs_glue.c with the integrators) sees them all. The outputs' part at the end of a file
(after OUTPUTS_MARKER, compiler/ccode.py generate_c_outputs) becomes outputs.c, and the glue unit then declares
mbs_outputs and their number `mbs_ny` without naming them (OUTPUTS_DECLARATIONS): model.h and the model units are
the same text whatever outputs a scene asks for, or none, and so is the glue unit whatever outputs; the build cache
(runtime/build.py) keeps their objects by content, so another output set recompiles outputs.c alone. Static helpers go only where they are
called, so no unit defines a function it does not use (-Wall stays quiet). Each function keeps its place in
the generated file for the compiler's messages (#line). A text not in this layout (a hand-written model) is
built as one unit, as before.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

#: Below this much generated C one unit compiles faster than several (each unit parses the header again).
SPLIT_MIN_CHARS = 96_000
#: A model with closed loops is split from this fraction of it: its glue unit holds the loop solver
#: (runtime/c/loops.c, about 1.7 s of compiler CPU), which a one-unit build compiles again for every set of outputs
#: and never beside the model's code. Split, the loop solver compiles on the other core, and a scene with other
#: outputs compiles outputs.c alone. The Iltis quarter car (95 kB) is then built in parts: its first scene and a
#: second scene with other outputs compile faster, the small slider-crank and four-bar (26 and 29 kB) stay one unit
#: (`python bench/split_threshold.py`).
LOOP_SPLIT_FRACTION = 0.5
#: The size a model unit aims for; the number of units follows from the text alone (never from the machine's
#: cores), so the cache key of a model is the same everywhere.
UNIT_CHARS = 120_000
MAX_MODEL_UNITS = 8
GLUE_UNIT = "glue.c"
OUTPUTS_UNIT = "outputs.c"
#: The units of the cold functions are named cold_1.c ...; runtime/build.py compiles them at a cheaper level.
COLD_PREFIX = "cold_"
#: Functions that no integrator calls in a model without loops (its mbs_rhs is the articulated-body algorithm):
#: the mass matrix and the forces serve linearisation, the equilibrium and the user, the dynamics functions the
#: user. They are most of a long open chain's C (the 40-link pendulum's dense mass matrix). With loops the loop
#: solver calls the mass matrix and the forces at every right-hand side: then they are model units like the rest.
COLD_FUNCTIONS = frozenset({"mbs_mass_matrix_unchecked", "mbs_mass_matrix", "mbs_forces", "mbs_inverse_dynamics",
                            "mbs_bias_forces", "mbs_gravity_forces", "mbs_frame_positions", "mbs_frame_velocities",
                            "mbs_frame_jacobians"})
#: With the one-pass loop terms (compiler/ccode_loop_terms.py) the loop solver's right-hand side calls neither the
#: mass matrix, nor the forces, nor the constraint acceleration (only the loop Jacobian of the implicit integrators,
#: the equilibrium and a singular position do): they are cold there too.
COLD_WITH_LOOP_TERMS = COLD_FUNCTIONS | {"mbs_constraint_acceleration"}
#: The macro of a tree's file written without its cold functions (compiler/ccode.py cold_apart): the glue leaves
#: them out of the function table, and runtime/build.py build_cold makes them a library of their own, from the
#: whole file, when one is first called (cold_sources).
COLD_APART = "MBS_COLD_APART"
#: The glue unit of that library (its function table: runtime/c/mbs_cold_glue.c).
COLD_GLUE_UNIT = "cold_glue.c"
_LOOPS = re.compile(r"^#define MBS_NC ", re.M)
_LOOP_TERMS = re.compile(r"^#define MBS_LOOP_TERMS\b", re.M)
#: The first line of a generated file's outputs part (written by compiler/ccode.py, read here).
OUTPUTS_MARKER = "/* ==== The outputs (MBS_NY, mbs_outputs, mbs_output_name): a part of their own ==== */"

#: What the glue unit of a split file with an outputs part declares of them (outputs.c defines them). Not in model.h:
#: model.h, and so the model units' objects, are then the same text whether the scene has outputs or not, which
#: runtime/build.py prebuild does not know when it compiles them (a scene without outputs threw its objects away).
OUTPUTS_DECLARATIONS = ("/* The outputs, in outputs.c (their number: mbs_ny). */\n#define MBS_OUTPUTS_UNIT 1\n"
                        "extern const int mbs_ny;\n"
                        "int mbs_outputs(double t, const double *x, const double *p, double *y, double *work);\n"
                        "const char *mbs_output_name(int i);\n")

#: The header the glue unit includes when it can (glue_header): the file's head (compiler/ccode.py CEmitter.head: the
#: sizes, the constant tables and the declarations, all known before a function is printed) and the declarations of
#: the functions the glue and the loop solver may call. Unlike model.h it does not list the file's functions, which
#: are known only once printed, so the glue unit can be compiled while they are (runtime/build.py prebuild_head).
GLUE_HEADER = "glue.h"
_CONTRACT = "int {}(double, const double *, const double *, double *, double *);"
_NAMES = "const char *{}(int);"
#: What glue_header declares: the functions of the contract that the glue unit (c/mbs_glue.c, c/loops.c,
#: c/loop_jacobian.c) may call, whether or not the file defines them (it refers to each under the macro that says the
#: file has it). A file that defines a function not here, or one of these otherwise, has no glue header: the glue
#: unit then includes model.h.
GLUE_DECLARATIONS = {
    **{name: _CONTRACT.format(name) for name in (
        "mbs_rhs", "mbs_qdot", "mbs_mass_matrix", "mbs_mass_matrix_unchecked", "mbs_forces", "mbs_outputs",
        "mbs_jacobian", "mbs_inverse_dynamics", "mbs_bias_forces", "mbs_gravity_forces", "mbs_frame_positions",
        "mbs_frame_velocities", "mbs_frame_jacobians", "mbs_events", "mbs_event_actions", "mbs_param_jacobian",
        "mbs_constraints", "mbs_constraint_velocity", "mbs_constraints_with_velocity", "mbs_constraint_acceleration",
        "mbs_constraint_matrix",
        "mbs_loop_terms", "mbs_state_rates", "mbs_loop_partials", "mbs_closed_form", "mbs_closed_form_at",
        "mbs_closed_form_rhs", "mbs_closed_form_project")},
    "mbs_cf_angle_near": "double mbs_cf_angle_near(double, double);",
    "mbs_event_indicator": "int mbs_event_indicator(int, double, const double *, const double *, double *, double *);",
    **{name: _NAMES.format(name) for name in (
        "mbs_state_name", "mbs_parameter_name", "mbs_output_name", "mbs_constraint_name", "mbs_frame_name")},
}
_PROTOTYPE = re.compile(r"^((?:int|double|void|const char \*)\s*)(mbs_\w+)\(([^;{}]*)\);?$")

#: A long function is printed as parts `<name>_part<k>` and a function `<name>` that calls them (written by
#: compiler/ccode_parts.py, read here): the parts of a cold function are cold too.
PART_SUFFIX = "_part"
_PART_NAME = re.compile(rf"^(mbs_\w+?){PART_SUFFIX}\d+$")
_DEFINITION = re.compile(r"^(?:int|double|void|const char \*)\s*(mbs_\w+)\(([^;{}]*)\)$")
_STATIC_FUNCTION = re.compile(r"^static (?:inline |MBS_TRIG_INLINE )?(?:int|double|void)\s+(mbs_\w+)\(([^;{}]*)\)$")
#: A static const array on one line (compiler/ccode.py _array): a lookup table's points.
_STATIC_ARRAY = re.compile(r"^static const (?:double|int) (mbs_\w+)\[\d+\] = \{[^;]*\};$")
_STATIC_ARRAY_LINE = re.compile(_STATIC_ARRAY.pattern, re.M)
#: A name of the generated code, whole (what a helper's name must be to be called: as \\bname\\b).
_NAME = re.compile(r"\bmbs_\w+")


@dataclass(frozen=True)
class Block:
    """A top-level function of the generated file: its name, text (leading comment to closing brace), the
    line of the file where that text starts, and its prototype."""

    name: str
    text: str
    line: int
    prototype: str


@dataclass(frozen=True)
class Layout:
    """The generated file read as shared header, static helpers and contract functions."""

    header: str
    helpers: tuple[Block, ...]
    functions: tuple[Block, ...]
    outputs: str | None = None   # the outputs' part after OUTPUTS_MARKER (None: the file has none)
    outputs_line: int = 0        # the line of the file where it starts


def read_layout(code: str) -> Layout | None:
    """The layout of a generated file; None when the text is not laid out as compiler/ccode.py writes it."""
    code, marker, outputs = code.partition("\n" + OUTPUTS_MARKER + "\n")
    lines = code.split("\n")
    header: list[str] = []
    helpers: list[Block] = []
    functions: list[Block] = []
    pending: list[str] = []  # lines since the last function: header text, then maybe the next one's comment
    i = 0
    while i < len(lines):
        line = lines[i]
        match = _DEFINITION.match(line) or _STATIC_FUNCTION.match(line)
        if match is None:
            pending.append(line)
            i += 1
            continue
        end = _closing_brace(lines, i + 1)
        if end is None:
            return None
        comment = _trailing_comment(pending)
        if line.startswith("static") and not functions and not comment:
            comment = _own_arrays(pending, lines[i + 1:end + 1])
        rest = pending[:len(pending) - comment]
        if functions:  # between contract functions only macros may stand: they go to the shared header
            if any(text.strip() and not text.startswith("#define ") for text in rest):
                return None  # something else between the contract functions: not the layout we know
        header += rest
        first = i - comment
        block = Block(match.group(1), "\n".join(lines[first:end + 1]), first + 1, f"{line};")
        if line.startswith("static"):
            if functions:
                return None  # a helper after the contract functions: not the layout we know
            helpers.append(block)
        else:
            functions.append(block)
        pending = []
        i = end + 1
    if not functions or any(text.strip() for text in pending):
        return None
    return Layout("\n".join(header), tuple(helpers), tuple(functions), outputs if marker else None,
                  len(lines) + 1)


def _trailing_comment(lines: list[str]) -> int:
    """How many of the last lines form the block comment right above a function (0: none)."""
    if not lines or not lines[-1].rstrip().endswith("*/"):
        return 0
    for k in range(len(lines) - 1, -1, -1):
        if lines[k].startswith("/*"):
            return len(lines) - k
        if not lines[k].startswith(" *"):
            return 0
    return 0


def _own_arrays(lines: list[str], body: list[str]) -> int:
    """How many of the last lines are the static const arrays that the helper `body` reads (one a line,
    compiler/ccode.py _table_text), with the block comment above them: they go with the helper into the units that
    call it, not into the shared header (the Iltis's road tables were 270 kB of every unit's header). 0: none."""
    text = "\n".join(body)
    k = len(lines)
    while k > 0:
        match = _STATIC_ARRAY.match(lines[k - 1])
        if match is None or not re.search(rf"\b{match.group(1)}\b", text):
            break
        k -= 1
    if k == len(lines):
        return 0
    return len(lines) - k + _trailing_comment(lines[:k])


def code_chars(text: str) -> int:
    """The characters of a unit's text that are code, not a table's numbers (what its compile time grows with)."""
    return len(text) - sum(len(m.group(0)) for m in _STATIC_ARRAY_LINE.finditer(text))


def _closing_brace(lines: list[str], i: int) -> int | None:
    """The line of the function's closing brace: its body opens with '{' on line i and ends at the first line
    that is exactly '}' (the generator indents everything inside a function)."""
    if i >= len(lines) or lines[i] != "{":
        return None
    for k in range(i + 1, len(lines)):
        if lines[k] == "}":
            return k
    return None


def split_sources(code: str, filename: str) -> dict[str, str] | None:
    """{file name: text} of model.h and model_1.c .. model_n.c (without the glue unit); None: build one unit."""
    if len(code) < split_min_chars(code):
        return None
    layout = read_layout(code)
    if layout is None:
        return None
    marker, outputs = layout.outputs is not None, layout.outputs
    where = line_name(filename)
    prototypes = "\n".join(b.prototype for b in layout.functions)
    files = {"model.h": (f"/* The shared part of {filename}, split into units by mbs.runtime.translation_units: do not edit */\n"
                         f"#line 1 \"{where}\"\n{layout.header}\n"
                         "/* The model's functions, each defined in one of the units model_<k>.c. */\n"
                         f"{prototypes}\n")}
    glue = glue_header(file_head(code), filename, tuple(b.prototype[:-1] for b in layout.functions
                                                       if part_of(b.name) == b.name))
    if glue is not None:
        files[GLUE_HEADER] = glue
    cold = cold_functions(layout.header)
    hot = tuple(b for b in layout.functions if part_of(b.name) not in cold)
    colder = tuple(b for b in layout.functions if part_of(b.name) in cold)
    for prefix, functions in (("model_", hot), (COLD_PREFIX, colder)):
        files.update(_units_of(functions, prefix, layout.helpers, filename))
    if marker:
        texts = [f"/* The outputs of {filename} (mbs.runtime.translation_units): do not edit */", '#include "model.h"']
        for helper in _helpers_for(outputs, layout.helpers):
            texts += [f"#line {helper.line} \"{where}\"", helper.text]
        texts += [f"#line {layout.outputs_line} \"{where}\"", OUTPUTS_MARKER, outputs,
                  "const int mbs_ny = MBS_NY;"]
        files[OUTPUTS_UNIT] = "\n".join(texts) + "\n"
    return files


def file_head(code: str) -> str:
    """The text of a generated file before its first function (static or not): what compiler/ccode.py
    CEmitter.head wrote (the same text, whether read off the whole file or taken before its functions existed)."""
    lines = code.split("\n")
    for k, line in enumerate(lines):
        if _DEFINITION.match(line) or _STATIC_FUNCTION.match(line):
            return "\n".join(lines[:k])
    return code


def _declaration(line: str) -> tuple[str, str] | None:
    """(name, its declaration without parameter names, as GLUE_DECLARATIONS writes it) of a function's definition
    or prototype line; None for any other line."""
    match = _PROTOTYPE.match(line)
    if match is None:
        return None
    params = [re.sub(r"\b\w+\s*$", "", param).strip() if param.strip() != "void" else "void"
              for param in match.group(3).split(",")]
    return match.group(2), f"{match.group(1)}{match.group(2)}({', '.join(params)});"


def glue_header(head: str, filename: str, functions: tuple[str, ...] = ()) -> str | None:
    """The text of GLUE_HEADER for a file whose head (file_head) is `head` and whose function definition lines
    (without parts) are `functions` (none: not yet known, the file is being printed), or None when a declaration of
    GLUE_DECLARATIONS would not be the file's own (a function defined or declared there otherwise) or the file
    defines a function that is not declared there (the glue unit then includes model.h)."""
    for line in head.split("\n"):  # what the head declares itself must agree with GLUE_DECLARATIONS
        found = _declaration(line)
        if found is not None and GLUE_DECLARATIONS.get(found[0], found[1]) != found[1]:
            return None
    for line in functions:  # and so must every function of the file
        found = _declaration(line)
        if found is None or GLUE_DECLARATIONS.get(found[0]) != found[1]:
            return None
    return (f"/* The head of {filename} and the functions the glue unit may call "
            "(mbs.runtime.translation_units): do not edit */\n"
            f"#line 1 \"{line_name(filename)}\"\n{head}\n"
            "/* The model's functions that the glue and the loop solver may call (each under the macro that says the "
            "model has it). */\n" + "\n".join(GLUE_DECLARATIONS.values()) + "\n")


def cold_sources(code: str, filename: str) -> dict[str, str] | None:
    """{file name: text} of the library of a tree's cold functions (COLD_FUNCTIONS) in the whole generated file
    `code`: model.h (the file's shared header and the cold functions' prototypes) and cold_1.c .. (without its glue
    unit); None: the text is not in the generated layout, or the model has loops or no cold function. Whatever
    the file's size: the library is built apart from the model's (runtime/build.py build_cold)."""
    layout = read_layout(code)
    if layout is None or has_loops(layout.header):
        return None
    cold = tuple(b for b in layout.functions if part_of(b.name) in COLD_FUNCTIONS)
    if not cold:
        return None
    where = line_name(filename)
    prototypes = "\n".join(b.prototype for b in cold)
    files = {"model.h": (f"/* The shared part of {filename} and its cold functions' prototypes, for their library "
                         "(mbs.runtime.translation_units): do not edit */\n"
                         f"#line 1 \"{where}\"\n{layout.header}\n"
                         "/* The functions no integrator calls, each defined in one of the units cold_<k>.c. */\n"
                         f"{prototypes}\n")}
    files.update(_units_of(cold, COLD_PREFIX, layout.helpers, filename))
    return files


def _units_of(functions: tuple[Block, ...], prefix: str, helpers: tuple[Block, ...], filename: str) -> dict[str, str]:
    """{<prefix><k>.c: text} of the functions in balanced groups, each unit with the static helpers it calls."""
    where = line_name(filename)
    files = {}
    for k, group in enumerate(_balanced(functions) if functions else [], start=1):
        texts = [f"/* Unit {k} of {filename} (mbs.runtime.translation_units): do not edit */", '#include "model.h"']
        body = "\n".join(b.text for b in group)
        for helper in _helpers_for(body, helpers):
            texts += [f"#line {helper.line} \"{where}\"", helper.text]
        for block in group:
            texts += [f"#line {block.line} \"{where}\"", block.text]
        files[f"{prefix}{k}.c"] = "\n".join(texts) + "\n"
    return files


def part_of(function: str) -> str:
    """The function a part belongs to (`mbs_forces_part2` -> `mbs_forces`); any other name unchanged."""
    m = _PART_NAME.match(function)
    return m.group(1) if m else function


def split_min_chars(code: str) -> float:
    """How long a generated file must be to be split into units: SPLIT_MIN_CHARS, for a model with loops
    LOOP_SPLIT_FRACTION of it."""
    return SPLIT_MIN_CHARS * (LOOP_SPLIT_FRACTION if has_loops(code) else 1.0)


def has_loops(header: str) -> bool:
    """Whether the shared header of a generated file is a model with closed loops (MBS_NC)."""
    return _LOOPS.search(header) is not None


def cold_functions(header: str) -> frozenset[str]:
    """The functions of a generated file (by its shared header) that no right-hand side calls."""
    if not has_loops(header):
        return COLD_FUNCTIONS
    return COLD_WITH_LOOP_TERMS if _LOOP_TERMS.search(header) else frozenset()


def _balanced(functions: tuple[Block, ...]) -> list[list[Block]]:
    """The functions in groups of about UNIT_CHARS (largest first onto the lightest group), in file order."""
    total = sum(len(b.text) for b in functions)
    n = max(1, min(MAX_MODEL_UNITS, len(functions), round(total / UNIT_CHARS)))
    loads = [0] * n
    member: dict[str, int] = {}
    for block in sorted(functions, key=lambda b: -len(b.text)):
        k = loads.index(min(loads))
        member[block.name] = k
        loads[k] += len(block.text)
    groups: list[list[Block]] = [[] for _ in range(n)]
    for block in functions:
        groups[member[block.name]].append(block)
    return [g for g in groups if g]


def _helpers_for(body: str, helpers: tuple[Block, ...]) -> list[Block]:
    """The static helpers `body` calls, with those they call in turn, in file order. (Each text is read once for
    the names it holds: a search of the whole text for each helper's name took the Iltis 0.5 s of CPU, between
    its derivation's end and its build's first compiler process.)"""
    by_name = {h.name: h for h in helpers}
    wanted: set[str] = set()
    texts = [body]
    while texts:
        for name in set(_NAME.findall(texts.pop())) & by_name.keys() - wanted:
            wanted.add(name)
            texts.append(by_name[name].text)
    return [h for h in helpers if h.name in wanted]


def line_name(filename: str) -> str:
    """The file name as the string of a #line directive."""
    return filename.replace("\\", "\\\\").replace('"', '\\"')
