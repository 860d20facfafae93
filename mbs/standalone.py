"""`mbs compile`: the generated C as a standalone library for other tools (no Python inside).

Writes <model>.c, <model>.h (sizes and prototypes) and lib<model>.so, each atomically. The header is
derived from the generated source, so it cannot disagree with it.

User hooks stay in their own files: <model>.c calls them, lib<model>.so is built from <model>.c and the C files
given for them (`mbs compile --hook NAME=file.c`), and the header declares each hook's C function with its
arguments and results in their units, for a program that links <model>.c with its own implementation. A
Python hook cannot go into a library without Python: that is refused.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import tempfile
from pathlib import Path

from mbs.base.atomic import write_bytes_atomic, write_text_atomic
from mbs.language.diagnostics import Diagnostic, MbsError
from mbs.runtime.build import C_DIR, compiler_command

from .pipeline import Generated

FLAGS = ["-O2", "-fPIC", "-shared", "-std=c99", "-Wall", "-Wextra"]


def standalone_source(gen: Generated) -> str:
    """The whole generated C (the cold functions included: Generated.whole_source); with closed loops the run-time
    loop solver (runtime/c/loops.c) appended, which defines the mbs_loop_rhs that mbs_rhs calls, mbs_project,
    mbs_loop_multipliers, ..."""
    if gen.layout.constraint_rows is None:
        return gen.whole_source
    source = gen.whole_source + "\n/* ---- the loop solver, runtime/c/loops.c ---- */\n" + (C_DIR / "loops.c").read_text()
    if "#define MBS_LOOP_JACOBIAN " in gen.c_source:  # its exact Jacobian, when the scene's integrator asked for it
        source += "\n/* ---- runtime/c/loop_jacobian.c ---- */\n" + _with_includes_inlined("loop_jacobian.c")
    return source


def _with_includes_inlined(name: str) -> str:
    """The run-time C file `name` with its `#include "x.c"` lines replaced by those files (runtime/c/dense_lu.c in
    loop_jacobian.c): the standalone source is one file, compiled where runtime/c is not."""
    return re.sub(r'^#include "(\w+\.c)".*$', lambda m: (C_DIR / m.group(1)).read_text(),
                  (C_DIR / name).read_text(), flags=re.MULTILINE)


#: A top-level declaration or definition of an mbs_ function or datum that is not static yet.
_EXTERN = re.compile(r"^(?!static\b)(?:const\s+)?(?:int|double|void|char)\b[\s*]*mbs_\w+\b")
_DEFINITION = re.compile(r"^static ((?:const\s+)?(?:int|double|void|char)[\s*]*)(mbs_\w+)\((.*)\)\s*$")


def prefix_of(gen: Generated) -> str:
    """The model's C prefix: 'pendulum' for pendulum_rhs and PENDULUM_NQ (a C identifier)."""
    stem = re.sub(r"\W", "_", gen.model.name)
    return stem if re.match(r"[A-Za-z_]", stem) else f"m_{stem}"


def _internal(source: str) -> tuple[str, list[tuple[str, str, str]]]:
    """The source with every mbs_ symbol static (internal to its object file, so two models link into one
    program), and the functions that were public: [(return type, name, parameters)]."""
    lines, public = [], []
    text = source.splitlines()
    for i, line in enumerate(text):
        if _EXTERN.match(line):
            line = "static " + line
            match = _DEFINITION.match(line)
            if match and i + 1 < len(text) and text[i + 1].strip() == "{":
                public.append((match.group(1).strip(), match.group(2), match.group(3)))
        lines.append(line)
    return "\n".join(lines) + "\n", public


def _call_arguments(parameters: str) -> str:
    """'double t, const double *x' -> 't, x'; 'void' or '' -> ''."""
    names = [re.findall(r"\w+", part)[-1] for part in parameters.split(",") if part.strip() not in ("", "void")]
    return ", ".join(names)


def _array(values) -> str:
    values = [float(v) for v in values] or [0.0]  # C has no empty arrays; the size macro says 0
    return ", ".join(repr(v) for v in values)


def standalone_c(gen: Generated) -> str:
    """The standalone C file: the generated code with its mbs_ symbols static, public wrappers with the
    model's prefix (pendulum_rhs calls mbs_rhs), and accessors of the default parameters and initial state."""
    from . import pipeline
    body, public = _internal(standalone_source(gen))
    prefix = prefix_of(gen)
    values = pipeline.parameter_values(gen.model, pipeline.scene_overrides(gen.scene))
    p_default = pipeline.parameter_vector(gen.p_names, values)
    x0 = pipeline.initial_state(gen, values)
    out = [body, f"/* ---- the public interface of {gen.model.name} (prefix {prefix}_, declared in {prefix}.h) ---- */",
           f'#include "{prefix}.h"', ""]
    for kind, name, parameters in public:
        ret = "" if kind == "void" else "return "
        out += [f"{kind} {prefix}_{name[4:]}({parameters})".replace("* ", "*"),
                f"{{\n    {ret}{name}({_call_arguments(parameters)});\n}}", ""]
    out += [f"const double *{prefix}_default_parameters(void)",
            f"{{\n    static const double p[] = {{{_array(p_default)}}};  /* {', '.join(gen.p_names)} */\n"
            "    return p;\n}", "",
            f"const double *{prefix}_initial_state(void)",
            f"{{\n    static const double x0[] = {{{_array(x0)}}};\n    return x0;\n}}", ""]
    return "\n".join(out)


def hook_declarations(gen: Generated, binding=None) -> list[str]:
    """The header's section on the model's user hooks: each one's C function, documented (empty without hooks)."""
    specs = gen.model.hooks
    if not specs:
        return []
    given = dict(binding.c_files) if binding is not None else {}
    lines = ["/* User hooks: functions this model calls and the user supplies, each", " *",
             " *     int NAME(const double *arg, double *res);", " *",
             " * with the arguments and results in the units below; return 0 on success (another status, or a",
             " * non-finite result, makes the model function fail with status 2). Optionally",
             " *     int NAME_derivative(const double *arg, double *jac);   jac[i * nargs + j] = d res[i] / d arg[j]",
             " * for the generated Jacobians (else they take central differences of the hook). */"]
    for spec in specs:
        args = ", ".join(f"arg[{i}] = {s.name} [{s.unit}]" for i, s in enumerate(spec.args)) or "none"
        results = ", ".join(f"res[{i}] = {s.name} [{s.unit}]" for i, s in enumerate(spec.results))
        source = f"; linked from {Path(given[spec.name][0]).name}" if spec.name in given else ""
        lines += [f"/* {spec.signature()}" + (f": {spec.description}" if spec.description else "") + source,
                  f" * {args}; {results} */", f"int {spec.name}(const double *arg, double *res);"]
    return lines + [""]


def header_text(gen: Generated, binding=None) -> str:
    """Sizes (PENDULUM_NQ ...) and prototypes (pendulum_rhs ...), from the generated source itself."""
    name, prefix = gen.model.name, prefix_of(gen)
    macro = prefix.upper()
    guard = f"{macro}_MBS_H"
    lines = [f"/* Interface of the generated equations of motion of \"{name}\" (see {prefix}.c). Every function",
             " * returns 0 or a status (1 singular mass matrix, 2 non-finite value, 3 loops not closed); work is",
             f" * {macro}_NWORK doubles the caller provides. */",
             f"#ifndef {guard}", f"#define {guard}", ""]
    source = standalone_source(gen).splitlines()
    for line in source:
        if re.match(r"#define MBS_N[A-Z]+ ", line):
            lines.append(line.replace("MBS_", f"{macro}_"))
    lines.append("")
    for kind, fn, parameters in _internal(standalone_source(gen))[1]:
        lines.append(f"{kind} {prefix}_{fn[4:]}({parameters});".replace("* ", "*"))
    lines += [""] + hook_declarations(gen, binding)
    lines += [f"/* defaults: {macro}_NP parameters ({', '.join(gen.p_names)}), {macro}_NX initial state */",
              f"const double *{prefix}_default_parameters(void);", f"const double *{prefix}_initial_state(void);",
              "", f"#endif /* {guard} */", ""]
    return "\n".join(lines)


def write_standalone(gen: Generated, directory: Path, hooks=None) -> list[Path]:
    """Write <model>.c, <model>.h and lib<model>.so; hooks: the implementations of the model's user hooks
    ({name: 'file.c'} or a runtime.hooks.HookBinding), compiled into the library."""
    from mbs.runtime.hooks import HookBinding, bind, require_c
    binding = hooks if isinstance(hooks, HookBinding) else bind(gen.model.hooks, hooks, gen.model.name)
    require_c(binding, "a standalone library (mbs compile) runs without Python")
    directory.mkdir(parents=True, exist_ok=True)
    stem = prefix_of(gen)
    c_path, h_path, so_path = directory / f"{stem}.c", directory / f"{stem}.h", directory / f"lib{stem}.so"
    write_text_atomic(c_path, standalone_c(gen))
    write_text_atomic(h_path, header_text(gen, binding))
    hook_files = binding.c_paths() if binding is not None else []
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / so_path.name
        # absolute paths: a name the user gave that starts with '-' must never reach the compiler as an option
        cmd = [*compiler_command(), *FLAGS, str(c_path.resolve()), *(str(Path(p).resolve()) for p in hook_files),
               "-o", str(out.resolve()), "-lm"]
        try:
            proc = subprocess.run(cmd, capture_output=True, text=True)
        except OSError as exc:
            raise MbsError([Diagnostic("error", f"no C compiler to build {so_path} ({cmd[0]}: {exc.strerror}); "
                                                f"{c_path} and {h_path} are written: build them with your own "
                                                "compiler, or install one (e.g. gcc)", None)]) from None
        if proc.returncode != 0:
            on = ", ".join(map(str, [c_path, *hook_files]))
            raise MbsError([Diagnostic("error", f"the C compiler failed on {on}:\n{proc.stderr}", None)])
        write_bytes_atomic(so_path, out.read_bytes(), executable=True)
    return [c_path, h_path, so_path]


__all__ = ["header_text", "standalone_c", "write_standalone", "prefix_of", "shutil"]
