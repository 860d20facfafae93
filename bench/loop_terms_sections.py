"""Where the instructions of the generated mbs_loop_terms go, by the sections of the derivation (issue 12).

    python bench/loop_terms_sections.py [--model library/iltis/vehicle.mbs] [--scene bump_5] [--calls 200]
                                        [--lines SECTION] [--bodies]

mbs_loop_terms gives the loop solver [M; f; G; gddot0] (compiler/ccode_loop_terms.py); on the Iltis it is most of
the constrained right-hand side.  This prints its instructions per call (callgrind, load-independent) summed over
the section comments the generated C carries ("body 14 (fl.lower_ball): composite inertia", with the bodies'
numbers folded: "body N : composite inertia"), plus the stores of the outputs' zeros and copies, the reads of
x and p and of the parts' carry, and the helpers (mbs_all_finite, lookup tables) under the last comment above them.
--lines SECTION prints the costliest lines of the sections whose name contains SECTION; --bodies keeps each body's
sections apart.

The generated file is compiled on its own with the model units' flags (runtime/build.py FLAGS and
GCC_MODEL_UNIT_FLAGS) and -g, into a program that calls mbs_loop_terms --calls times at the scene's initial state
with its speeds perturbed (the loop solver's functions, defined in runtime/c/loops.c, are stubs: never called).
The total is below what bench/rhs_instructions.py's profile shows for the model's own build (the Iltis's bump_5:
20,900 here, 23,100 there; 28,000 and 30,300 before the body frames moved to the joints): one unit here, split units
there, and only the lines of the generated file here (the math library's sines and cosines not).  Needs gcc and
valgrind.
"""

from __future__ import annotations

import argparse
import collections
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
HARNESS = r"""
#include <stdio.h>
#include <stdlib.h>
int mbs_loop_terms(double t, const double *x, const double *p, double *out, double *work);
#define STUB(name) int name(double t, const double *x, const double *p, double *o, double *w) \
    { (void)t; (void)x; (void)p; (void)o; (void)w; return 0; }
STUB(mbs_loop_rhs) STUB(mbs_loop_rhs_direct) STUB(mbs_loop_multipliers) STUB(mbs_loop_rates)
static double values(FILE *f, double *a, int n) { int k; for (k = 0; k < n; k++) if (fscanf(f, "%lf", a + k) != 1) exit(3); return 0; }
int main(int argc, char **argv)
{
    static double x[1 << 14], p[1 << 14], out[1 << 18], work[1 << 18];
    FILE *fx = fopen(argv[1], "r"), *fp = fopen(argv[2], "r");
    int nx = atoi(argv[3]), np = atoi(argv[4]), n = atoi(argv[5]), k, s = 0;
    values(fx, x, nx);
    values(fp, p, np);
    for (k = 0; k < n; k++) s += mbs_loop_terms(0.01, x, p, out, work);
    printf("%d\n", s);
    return 0;
}
"""


def inputs(model: Path, scene: str, folder: Path) -> tuple[str, int, int]:
    """(the generated C, nx, np), with the state and parameters written to folder/x.txt and folder/p.txt."""
    import mbs
    from mbs import pipeline
    system = mbs.load(model)
    compiled = system.compile(scene)
    gen = system.generate(scene)
    values = pipeline.parameter_values(system.model, pipeline.scene_overrides(system.scene(scene)))
    data = system._workspace(compiled, gen, values)
    x = np.array(data.x, dtype=float)
    x[compiled.nq:compiled.nq + compiled.nv] += np.random.default_rng(1).normal(0.0, 0.5, compiled.nv)
    np.savetxt(folder / "x.txt", x)
    np.savetxt(folder / "p.txt", np.array(data.p, dtype=float))
    return gen.c_source, x.size, data.p.size


def line_costs(dump: Path, source: str) -> collections.Counter:
    """Instructions per line of `source` in a callgrind dump (positions: line; the calls' inclusive lines skipped)."""
    names, cost, current, skip, last = {}, collections.Counter(), None, False, 0
    for line in dump.read_text(errors="replace").splitlines():
        named = re.match(r"(cfi|cfl|fl|fi|fe)=\((\d+)\)(?: (.*))?", line)
        if named:
            if named.group(3):
                names[named.group(2)] = named.group(3)
            if named.group(1) in ("fl", "fi", "fe"):
                current = names.get(named.group(2))
            continue
        if line.startswith("calls="):
            skip = True
            continue
        cost_line = re.match(r"^([+-]?\d+|\*)\s+(\d+)$", line)
        if cost_line:
            pos = cost_line.group(1)
            last = last if pos == "*" else last + int(pos) if pos[0] in "+-" else int(pos)
            if skip:
                skip = False
            elif current and Path(current).name == Path(source).name:
                cost[last] += int(cost_line.group(2))
    return cost


def sections(text: list[str], fold: bool = True) -> list[str]:
    """The section of each line (1-based: entry 0 unused) by the comment above it, bodies' numbers folded unless
    `fold` is false."""
    out, section = ["?"], "?"
    for line in text:
        comment = re.match(r"\s*/\* (.*) \*/$", line)
        if comment:
            section = re.sub(r"\d+", "N", re.sub(r"\(.*?\)", "", comment.group(1))) if fold else comment.group(1)
        if line.startswith("int "):
            section = "(function entries)"
        if re.match(r"\s*out\[\d+\] = (0|out\[\d+\]);", line):
            out.append("(outputs: zeros and copies)")
        elif re.match(r"\s*(carry\[\d+\] = \w+|const double \w+ = carry\[\d+\]);", line):
            out.append("(carry between parts)")
        elif re.match(r"\s*const double \w+ = [xp]\[\d+\];", line):
            out.append("(reads of x and p)")
        else:
            out.append(section)
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default=str(ROOT / "library" / "iltis" / "vehicle.mbs"))
    parser.add_argument("--scene", default="bump_5")
    parser.add_argument("--calls", type=int, default=200)
    parser.add_argument("--top", type=int, default=30, help="sections printed")
    parser.add_argument("--lines", metavar="SECTION", help="the costliest lines of the sections containing this")
    parser.add_argument("--bodies", action="store_true", help="each body's sections apart (numbers not folded)")
    args = parser.parse_args(argv)
    if shutil.which("valgrind") is None or shutil.which("gcc") is None:
        print("needs gcc and valgrind on the PATH")
        return 1
    from mbs.runtime.build import FLAGS, GCC_MODEL_UNIT_FLAGS
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        code, nx, np_ = inputs(Path(args.model), args.scene, folder)
        if "int mbs_loop_terms(" not in code:
            print(f"{args.model} (scene {args.scene}) has no mbs_loop_terms (no closed loops, or G not printed)")
            return 1
        source, harness, program = folder / "model.c", folder / "harness.c", folder / "terms"
        source.write_text(code)
        harness.write_text(HARNESS)
        flags = [f for f in FLAGS if f not in ("-shared", "-fPIC")] + list(GCC_MODEL_UNIT_FLAGS) + ["-g"]
        built = subprocess.run(["gcc", *flags, "-o", str(program), str(harness), str(source), "-lm"],
                               capture_output=True, text=True)   # (the tables the loop solver reads: unused here)
        if built.returncode != 0:
            raise SystemExit(built.stderr[-3000:])
        dump = folder / "callgrind.out"
        subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={dump}",
                        "--toggle-collect=mbs_loop_terms", str(program), str(folder / "x.txt"),
                        str(folder / "p.txt"), str(nx), str(np_), str(args.calls)], check=True, capture_output=True)
        cost = line_costs(dump, str(source))
        text = code.splitlines()
        where = sections(text, fold=not args.bodies)
        total = collections.Counter()
        for n, c in cost.items():
            total[where[n] if n < len(where) else "?"] += c
        print(f"mbs_loop_terms of {Path(args.model).name} ({args.scene}): {sum(total.values()) / args.calls:,.0f} "
              f"instructions a call (callgrind, {args.calls} calls, the file as one unit), by section:")
        for name, c in total.most_common(args.top):
            print(f"  {c / args.calls:8,.0f}  {name}")
        if args.lines:
            rows = sorted(((c, n) for n, c in cost.items() if n < len(where) and args.lines in where[n]),
                          reverse=True)
            print(f"\nthe costliest lines of the sections containing {args.lines!r}:")
            for c, n in rows[:30]:
                print(f"  {c / args.calls:7.1f}  {n:6d}  {text[n - 1].strip()[:140]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
