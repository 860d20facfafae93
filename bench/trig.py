"""What the inline sin and cos of the generated C (compiler/ccode_trig.py) cost against the C library's, per call and
in a whole simulate of the Iltis bump, and where their coefficients come from.

    python bench/trig.py [--scene bump_10] [--repeat 7] [--no-simulate] [--accuracy] [--coefficients]

1. Per call, over 100,000 arguments of a range (small: |x| < 0.5, a suspension's angles; large: [-100, 100], a
   wheel's spin): the instructions of a sin, a cos and the sin-cos pair of one argument (callgrind, the loop's
   share included), the helpers against the C library's sin, cos and the sincos GCC fuses them into
   (-DMBS_TRIG_FORMER=1, the same source), and the time per call (medians of interleaved rounds, this process's CPU;
   the calls of a loop are independent: throughput, not latency).
2. The whole System.simulate(scene) from a first start: its instructions (callgrind, one run after two uncounted
   ones, like bench/bump_cost.py --instructions) and CPU-time medians of --repeat runs interleaved, current build
   against the same model built with -DMBS_TRIG_FORMER=1, and whether the results agree to round-off.
   The results differ by round-off, which moves the step sequence of the adaptive integrator: --accuracy measures
   both builds against a tight reference (bench/bump_accuracy.py's: DOPRI5 at rtol 1e-10, the figure-18
   quantities heave, pitch and the tyre loads), at the scene's tolerance and two others.
3. --coefficients: the minimax polynomials (a Remez exchange in mpmath, relative error of sin and cos weighted)
   and the three parts of pi/2, with the reduction's hardest argument below 1e5, as compiler/ccode_trig.py has them.
"""

from __future__ import annotations

import argparse
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from mbs.compiler.ccode_trig import INLINE_DEFINITION, TRIG_HELPERS  # noqa: E402
from mbs.runtime import build  # noqa: E402

MODEL = Path(__file__).resolve().parent.parent / "library" / "iltis" / "vehicle.mbs"
FORMER = ("-DMBS_TRIG_FORMER=1",)
N = 100_000
RANGES = {"small |x| < 0.5": 0.5, "large |x| < 100": 100.0}

#: Loops over an array, one a function kind; `sink` keeps the results alive; timed in C (CPU clock).
LOOPS = r"""
#include <time.h>
double sink;
void loop_sin(const double *x, long n) { double s = 0; for (long i = 0; i < n; i++) s += mbs_sin(x[i]); sink = s; }
void loop_cos(const double *x, long n) { double s = 0; for (long i = 0; i < n; i++) s += mbs_cos(x[i]); sink = s; }
void loop_pair(const double *x, long n)
{
    double s = 0;
    for (long i = 0; i < n; i++) { const double v = x[i]; s += mbs_sin(v) * mbs_cos(v); }
    sink = s;
}
double seconds(void (*loop)(const double *, long), const double *x, long n)
{
    struct timespec a, b;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &a);
    loop(x, n);
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &b);
    return (b.tv_sec - a.tv_sec) + 1e-9 * (b.tv_nsec - a.tv_nsec);
}
"""
KINDS = ("sin", "cos", "pair")

#: The program callgrind counts: the loops over n arguments uniform in [-bound, bound] (argv bound, n).
MAIN = r"""
#include <stdlib.h>
int main(int argc, char **argv)
{
    const double bound = atof(argv[1]);
    const long n = atol(argv[2]);
    double *x = malloc(n * sizeof *x);
    unsigned long long state = 88172645463325252ULL;
    for (long i = 0; i < n; i++) {  /* xorshift64 */
        state ^= state << 13; state ^= state >> 7; state ^= state << 17;
        x[i] = bound * (2.0 * (double)(state >> 11) / 9007199254740992.0 - 1.0);
    }
    loop_sin(x, n);
    loop_cos(x, n);
    loop_pair(x, n);
    free(x);
    return 0;
}
"""


#: The callgrind child of a whole simulate: argv scene, "former" or "current"; two runs uncounted, one counted.
SIMULATE_CHILD = """
import functools, os, subprocess, sys
sys.path.insert(0, sys.argv[3])
import mbs
from bump_cost import former_model, using
system = mbs.load(sys.argv[4])
scene = sys.argv[1]
model = former_model(system, scene, ("-DMBS_TRIG_FORMER=1",)) if sys.argv[2] == "former" else None
def run():
    system.forget_starts()
    with using(system, scene, model):
        system.simulate(scene)
run(); run()
subprocess.run(["callgrind_control", "-i", "on", str(os.getpid())], check=True, capture_output=True)
functools.reduce(lambda _, __: run(), range(1), None)
"""


def loops_library(workdir: Path, flags: tuple[str, ...], program: bool = False) -> Path:
    """The loops over the helpers compiled with the model's flags and `flags`: a library, or with program a program
    (MAIN) for callgrind."""
    order = ("mbs_sin_poly", "mbs_cos_poly", "mbs_circular", "mbs_sin", "mbs_cos")
    source = workdir / "loops.c"
    source.write_text("\n".join(["#define _POSIX_C_SOURCE 199309L  /* clock_gettime */", "#include <math.h>",
                                 *INLINE_DEFINITION,
                                 *("\n".join(TRIG_HELPERS[k]) for k in order), LOOPS,
                                 MAIN if program else ""]))
    cc = tuple(build.compiler_command())
    flags = tuple(f for f in build.base_flags(cc) if not program or f not in ("-shared", "-fPIC")) + flags
    target = workdir / f"loops{len(flags)}{'' if program else '.so'}"
    subprocess.run([*cc, *flags, "-o", str(target), str(source), "-lm"], check=True)
    return target


def call_instructions(program: Path, bound: float, workdir: Path) -> dict[str, float]:
    """Instructions per call of each loop (inclusive: the C library's functions they call counted in)."""
    out = workdir / "callgrind.calls"
    done = subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", str(program), str(bound),
                           str(N)], capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"valgrind run failed:\n{done.stderr[-2000:]}")
    text = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--threshold=100", str(out)],
                          capture_output=True, text=True).stdout
    counts = {}
    for kind in KINDS:
        found = re.search(rf"^\s*([\d,]+)\s.*:loop_{kind}\b", text, re.M)
        counts[kind] = int(found.group(1).replace(",", "")) / N if found else float("nan")
    return counts


def call_seconds(library: Path, bound: float) -> dict[str, float]:
    """CPU seconds per call of each loop, one pass over the arguments."""
    import ctypes
    lib = ctypes.CDLL(str(library))
    lib.seconds.restype = ctypes.c_double
    lib.seconds.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_long]
    x = np.random.default_rng(1).uniform(-bound, bound, N)
    return {kind: lib.seconds(ctypes.cast(getattr(lib, "loop_" + kind), ctypes.c_void_p),
                              x.ctypes.data_as(ctypes.c_void_p), N) / N for kind in KINDS}


def per_call(rounds: int) -> None:
    with tempfile.TemporaryDirectory(prefix="mbs-bench-trig-") as tmp:
        workdir = Path(tmp)
        libraries = {"inline": loops_library(workdir, ()), "C library": loops_library(workdir, FORMER)}
        programs = {"inline": loops_library(workdir, (), True), "C library": loops_library(workdir, FORMER, True)}
        print(f"per call over {N:,} arguments (the loop's share included; C library: -DMBS_TRIG_FORMER=1, GCC's "
              f"sincos for the pair)")
        for label, bound in RANGES.items():
            counts = {name: call_instructions(program, bound, workdir) for name, program in programs.items()}
            times = {name: {kind: [] for kind in KINDS} for name in libraries}
            for _ in range(rounds):  # interleaved
                for name, lib in libraries.items():
                    for kind, seconds in call_seconds(lib, bound).items():
                        times[name][kind].append(seconds)
            for kind in KINDS:
                a, b = counts["inline"][kind], counts["C library"][kind]
                ta = statistics.median(times["inline"][kind]) * 1e9
                tb = statistics.median(times["C library"][kind]) * 1e9
                print(f"  {label:17s} {kind:4s}: {a:6.1f} instructions, C library {b:6.1f} (ratio {a / b:.2f}); "
                      f"{ta:5.1f} ns, C library {tb:5.1f} ns (ratio {ta / tb:.2f}, medians of {rounds})")


def simulate_instructions(scene: str, how: str) -> int:
    with tempfile.TemporaryDirectory(prefix="mbs-bench-trig-") as tmp:
        out = Path(tmp) / "callgrind.simulate"
        done = subprocess.run(["valgrind", "--tool=callgrind", "--instr-atstart=no", "--collect-atstart=no",
                               "--toggle-collect=functools_reduce", f"--callgrind-out-file={out}", sys.executable,
                               "-c", SIMULATE_CHILD, scene, how, str(Path(__file__).parent), str(MODEL)],
                              capture_output=True, text=True)
        found = re.search(r"Collected\s*:\s*(\d+)", done.stderr)
        if done.returncode != 0 or not found:
            raise SystemExit(f"valgrind run failed:\n{done.stderr[-2000:]}")
        return int(found.group(1))


def whole_simulate(scene: str, repeat: int) -> None:
    import mbs
    from bump_cost import former_model, using
    system = mbs.load(MODEL)
    former = former_model(system, scene, FORMER)
    counts = {how: simulate_instructions(scene, how) for how in ("current", "former")}
    print(f"whole simulate of {scene} from a first start, instructions (callgrind): inline {counts['current']:,}, "
          f"C library {counts['former']:,} (ratio {counts['current'] / counts['former']:.3f})")
    times = {"current": [], "former": []}
    results = {}
    for _ in range(repeat):
        for how, model in (("current", None), ("former", former)):
            system.forget_starts()
            with using(system, scene, model):
                start = time.process_time()
                results[how] = system.simulate(scene)
                times[how].append(time.process_time() - start)
    a, b = statistics.median(times["current"]), statistics.median(times["former"])
    print(f"  CPU time, medians of {repeat} interleaved: inline {a * 1e3:.1f} ms, C library {b * 1e3:.1f} ms "
          f"(ratio {a / b:.3f})")
    cur, old = results["current"], results["former"]
    scale = np.abs(old.data).max(axis=0)
    real = scale > 1e-6  # (columns zero but for round-off, a symmetric car's roll moments, differ wholly)
    stats = [r.metadata["stats"] for r in (cur, old)]
    print(f"  results: {cur.data.shape[0]} and {old.data.shape[0]} rows, {len(cur.events)} and {len(old.events)} "
          f"events, steps {stats[0]['nsteps']} and {stats[1]['nsteps']}, rhs {stats[0]['nfev']} and {stats[1]['nfev']}"
          + (f"; largest difference {np.max(np.abs(cur.data - old.data)[:, real] / scale[real]):.1e} of a column's "
             f"largest value (columns above 1e-6)" if cur.data.shape == old.data.shape else ""))


def accuracy(scene: str) -> None:
    """Both builds' errors against a tight reference, at the scene's tolerance and two others."""
    import mbs
    from bump_accuracy import ATOL_RATIO, QUANTITIES, REFERENCE_RTOL, errors, sample_rows
    from bump_cost import former_model, using
    from mbs.runtime.simulate import output_times
    system = mbs.load(MODEL)
    former = former_model(system, scene, FORMER)
    sc = system.scene(scene)
    ref = system.simulate(scene, integrator="dopri5", rtol=REFERENCE_RTOL, atol=ATOL_RATIO * REFERENCE_RTOL)
    times = output_times(float(ref["time"][0]), sc.t_end, sample=sc.sample)
    span = {q: float(np.ptp(ref[q][sample_rows(ref, times)])) for q in QUANTITIES}
    short = {q: q.replace(".radial.load", "").replace("tyre_", "F_") for q in QUANTITIES}
    print(f"{scene} ({sc.integrator}) against dopri5 at rtol {REFERENCE_RTOL:g}: largest error of each quantity, "
          "as a fraction of its range")
    print(f"  {'rtol':>7s} {'build':>9s} {'steps':>5s} {'rhs':>5s}  " + " ".join(f"{short[q]:>7s}" for q in QUANTITIES)
          + "    worst")
    for rtol in sorted({sc.rtol, 1e-6, 1e-8}):
        for label, model in (("inline", None), ("C library", former)):
            system.forget_starts()
            with using(system, scene, model):
                res = system.simulate(scene, rtol=rtol, atol=ATOL_RATIO * rtol)
            err = errors(res, ref, times)
            share = [err[q] / span[q] for q in QUANTITIES]
            stats = res.metadata["stats"]
            print(f"{'*' if rtol == sc.rtol else ' '} {rtol:7.0e} {label:>9s} {stats['nsteps']:5d} {stats['nfev']:5d}  "
                  + " ".join(f"{x:7.1e}" for x in share) + f"  {max(share):7.1e}")
    print("  (* the scene's own tolerance)")


def remez(f, weight, n: int, a, b, iterations: int = 30):
    """Coefficients c0..c(n-1) of the polynomial p(z) minimising max |weight(z) (p(z) - f(z))| on [a, b] (Remez
    exchange on a grid of 2,000 points), and that maximum."""
    import mpmath as mp
    reference = [(a + b) / 2 - (b - a) / 2 * mp.cos(mp.pi * k / n) for k in range(n + 1)]
    grid = [a + (b - a) * k / 2000 for k in range(2001)]
    for _ in range(iterations):
        matrix = mp.matrix([[weight(z) * z**j for j in range(n)] + [(-1) ** i] for i, z in enumerate(reference)])
        solution = mp.lu_solve(matrix, mp.matrix([weight(z) * f(z) for z in reference]))
        c = [solution[j] for j in range(n)]
        values = [weight(z) * (mp.polyval(c[::-1], z) - f(z)) for z in grid]
        peaks = [0] + [k for k in range(1, 2000) if (values[k] - values[k - 1]) * (values[k + 1] - values[k]) <= 0]
        alternating: list = []
        for k in peaks + [2000]:
            if alternating and mp.sign(values[alternating[-1]]) == mp.sign(values[k]):
                if abs(values[k]) > abs(values[alternating[-1]]):
                    alternating[-1] = k
            else:
                alternating.append(k)
        while len(alternating) > n + 1:
            alternating.pop(0 if abs(values[alternating[0]]) < abs(values[alternating[-1]]) else -1)
        reference = [grid[k] for k in alternating]
    return c, max(abs(v) for v in values)


def coefficients() -> None:
    import mpmath as mp
    mp.mp.dps = 60
    top = (mp.pi / 4 + mp.mpf("1e-6")) ** 2  # a little beyond pi/4: n rounded from x 2/pi may leave |r| above it
    sin_part = lambda z: (mp.sin(mp.sqrt(z)) - mp.sqrt(z)) / mp.sqrt(z) ** 3 if z else -mp.mpf(1) / 6  # noqa: E731
    cos_part = lambda z: (mp.cos(mp.sqrt(z)) - 1 + z / 2) / z**2 if z else mp.mpf(1) / 24  # noqa: E731
    for name, f, weight in (("S (sin r = r + r z S(z))", sin_part, lambda z: z),
                            ("C (cos r = 1 - z/2 + z^2 C(z))", cos_part, lambda z: z * z)):
        c, worst = remez(f, weight, 6, mp.mpf(0), top)
        print(f"{name}: relative error 2^{float(mp.log(worst, 2)):.1f}")
        print("    " + ", ".join(float(k).hex() for k in c))
    mp.mp.prec = 400
    half_pi = mp.pi / 2
    p1 = mp.floor(half_pi * 2**36) / 2**36
    p2 = mp.nint((half_pi - p1) * 2**73) / 2**73
    p3 = mp.mpf(float(half_pi - p1 - p2))
    print(f"pi/2 = {float(p1).hex()} + {float(p2).hex()} + {float(p3).hex()} "
          f"(to 2^{float(mp.log(abs(half_pi - p1 - p2 - p3), 2)):.1f})")
    distance, n = min((abs(mp.mpf(float(k * half_pi)) - k * half_pi), k) for k in range(1, 63663))
    print(f"nearest double to a multiple of pi/2 below 1e5: n = {n}, |x - n pi/2| = 2^{float(mp.log(distance, 2)):.1f}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="bump_10")
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--no-simulate", action="store_true", help="per call only")
    ap.add_argument("--accuracy", action="store_true", help="both builds against a tight reference, and stop")
    ap.add_argument("--coefficients", action="store_true", help="derive the coefficients and stop")
    args = ap.parse_args(argv)
    if args.coefficients:
        coefficients()
        return 0
    if args.accuracy:
        accuracy(args.scene)
        return 0
    per_call(args.repeat)
    if not args.no_simulate:
        whole_simulate(args.scene, args.repeat)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
