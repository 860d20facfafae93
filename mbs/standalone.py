"""`mbs compile`: the generated C as a standalone library for other tools (no Python inside).

Writes <model>.c, <model>.h (sizes and prototypes) and lib<model>.so, each atomically. The header is
derived from the generated source, so it cannot disagree with it.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import tempfile
from pathlib import Path

from mbs.atomic import write_bytes_atomic, write_text_atomic
from mbs.language.diagnostics import Diagnostic, MbsError
from mbs.runtime.build import C_DIR, compiler_command

from .pipeline import Generated

_PROTOTYPE = re.compile(r"^((?:int|const char \*)\s*mbs_\w+\(.*\))\s*$")
FLAGS = ["-O2", "-fPIC", "-shared", "-std=c99", "-Wall", "-Wextra"]


def standalone_source(gen: Generated) -> str:
    """The generated C; with closed loops the run-time loop solver (runtime/c/loops.c) appended, which defines
    the mbs_loop_rhs that mbs_rhs calls, mbs_project, mbs_loop_multipliers, ..."""
    if gen.constraints is None:
        return gen.c_source
    return gen.c_source + "\n/* ---- the loop solver, runtime/c/loops.c ---- */\n" + (C_DIR / "loops.c").read_text()


def header_text(gen: Generated) -> str:
    name = gen.model.name
    guard = re.sub(r"\W", "_", name).upper() + "_MBS_H"
    lines = [f"/* Interface of the generated equations of motion of \"{name}\" (see {name}.c). */",
             f"#ifndef {guard}", f"#define {guard}", ""]
    source = standalone_source(gen).splitlines()
    lines += [line for line in source if re.match(r"#define MBS_N[A-Z]+ ", line)]
    lines.append("")
    for i, line in enumerate(source):
        match = _PROTOTYPE.match(line)
        if match and i + 1 < len(source) and source[i + 1].strip() == "{":
            lines.append(match.group(1) + ";")
    lines += ["", f"#endif /* {guard} */", ""]
    return "\n".join(lines)


def write_standalone(gen: Generated, directory: Path) -> list[Path]:
    directory.mkdir(parents=True, exist_ok=True)
    stem = re.sub(r"\W", "_", gen.model.name)
    c_path, h_path, so_path = directory / f"{stem}.c", directory / f"{stem}.h", directory / f"lib{stem}.so"
    write_text_atomic(c_path, standalone_source(gen))
    write_text_atomic(h_path, header_text(gen))
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / so_path.name
        # absolute paths: a name the user gave that starts with '-' must never reach the compiler as an option
        cmd = [*compiler_command(), *FLAGS, str(c_path.resolve()), "-o", str(out.resolve()), "-lm"]
        try:
            proc = subprocess.run(cmd, capture_output=True, text=True)
        except OSError as exc:
            raise MbsError([Diagnostic("error", f"no C compiler to build {so_path} ({cmd[0]}: {exc.strerror}); "
                                                f"{c_path} and {h_path} are written: build them with your own "
                                                "compiler, or install one (e.g. gcc)", None)]) from None
        if proc.returncode != 0:
            raise MbsError([Diagnostic("error", f"the C compiler failed on {c_path}:\n{proc.stderr}", None)])
        write_bytes_atomic(so_path, out.read_bytes(), executable=True)
    return [c_path, h_path, so_path]


__all__ = ["header_text", "write_standalone", "shutil"]
