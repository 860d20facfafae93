"""The Iltis bump scenes' real-time factor over fresh placements of the model library in memory.

    python bench/bump_placements.py [--scenes bump_10] [--placements 7] [--repeat 11] [--huge-pairs]

The same model library, byte for byte, runs the Iltis's right-hand side at 2.05 us a call from one copy of its file
and at 2.45 us from another, in every process, until the file is copied afresh (bench/rhs_placement.py): the CPU's
caches are indexed by physical address, and where the pages of the library's hot code (mbs_loop_terms alone is
about 120 kB) land decides how much of it conflicts.  A whole bump_10 simulate timed in one process (bench/bump_cost.py)
so carries the luck of one placement: 23.7 to 27.3 ms over six fresh copies of one build.  This bench times the
scene over --placements placements: before each round it copies every model library the scene maps from the build
cache afresh into its place (its pages then lie elsewhere), then one child process times --repeat whole
`System.simulate(scene)` calls from a first start (the kept start states let go: assembly and equilibrium in each,
as bench/bump_cost.py) and, interleaved in the same process, the same scene with DOPRI5 at the bump scenes' former
settings (bench/dopri5_former.py: the baseline of issue 12's figures).  Printed: per placement the medians and their
ratio, then over the placements the median, the fastest and the slowest, as real-time factors (simulated time over
CPU time).  Nothing is asserted.

Since runtime/c/huge_text.c the library moves its code and constants onto huge pages when it is loaded (where the
kernel offers transparent huge pages), which takes most of the luck away: `MBS_HUGE_TEXT=0 python
bench/bump_placements.py` (the children inherit it) shows the file's own pages, the baseline of that change.
--huge-pairs measures the two side by side: at each placement one child with the huge pages and one with
MBS_HUGE_TEXT=0 (their order alternating), printed with their ratio, then the medians and the median ratio.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
from pathlib import Path

import mbs
from mbs.runtime import build

ROOT = Path(__file__).resolve().parent.parent
MODEL = ROOT / "library" / "iltis" / "vehicle.mbs"
sys.path.insert(0, str(Path(__file__).resolve().parent))
from dopri5_former import DOPRI5_FORMER  # noqa: E402
from rhs_placement import copy_afresh  # noqa: E402

#: One placement: the scene's medians (ms of CPU) now and at the former settings, interleaved, as "now former".
CHILD = """
import statistics, sys, time
import mbs
model, scene, repeat, former = sys.argv[1], sys.argv[2], int(sys.argv[3]), eval(sys.argv[4])
system = mbs.load(model)
def timed(**settings):
    system.forget_starts()
    t0 = time.process_time()
    system.simulate(scene, **settings)
    return time.process_time() - t0
for _ in range(2):
    timed(); timed(**former)
now, before = [], []
for _ in range(repeat):
    now.append(timed())
    before.append(timed(**former))
print(1e3 * statistics.median(now), 1e3 * statistics.median(before))
"""


def mapped_libraries(system, scene: str) -> list[Path]:
    """The files of the build cache this process maps once the scene has run: the scene's model library."""
    system.simulate(scene)
    cache = str(build.default_cache_dir())
    with open("/proc/self/maps") as maps:
        return sorted({Path(line.split()[-1]) for line in maps if cache in line and line.rstrip().endswith(".so")})


def timed_child(scene: str, repeat: int, huge: bool = True) -> tuple[float, float]:
    """(the scene's median, the former settings' median) in ms of CPU, from one child process."""
    env = dict(os.environ)
    if huge:
        env.pop("MBS_HUGE_TEXT", None)
    else:
        env["MBS_HUGE_TEXT"] = "0"
    out = subprocess.run([sys.executable, "-c", CHILD, str(MODEL), scene, str(repeat), repr(DOPRI5_FORMER)],
                         capture_output=True, text=True, check=True, env=env)
    now, before = map(float, out.stdout.split())
    return now, before


def huge_pairs(system, scene: str, placements: int, repeat: int) -> None:
    """Per placement the scene with the library on huge pages and without, alternating which goes first."""
    t_end = system.scene(scene).t_end
    libraries = mapped_libraries(system, scene)
    pairs = []
    for k in range(placements):
        for path in libraries:
            copy_afresh(path)
        times = {}
        for huge in ((False, True) if k % 2 == 0 else (True, False)):
            times[huge] = timed_child(scene, repeat, huge)[0]
        pairs.append((times[True], times[False]))
        print(f"  {scene} placement {k + 1}: huge pages {times[True]:.1f} ms, MBS_HUGE_TEXT=0 {times[False]:.1f} ms, "
              f"ratio {times[True] / times[False]:.3f}")
    on, off = statistics.median(p[0] for p in pairs), statistics.median(p[1] for p in pairs)
    ratios = [a / b for a, b in pairs]
    print(f"{scene}: huge pages median {on:.1f} ms ({1e3 * t_end / on:.1f}x real time), fastest and slowest placement "
          f"{1e3 * t_end / min(p[0] for p in pairs):.1f}x, {1e3 * t_end / max(p[0] for p in pairs):.1f}x; "
          f"MBS_HUGE_TEXT=0 {off:.1f} ms ({1e3 * t_end / off:.1f}x), {1e3 * t_end / min(p[1] for p in pairs):.1f}x, "
          f"{1e3 * t_end / max(p[1] for p in pairs):.1f}x; median ratio {statistics.median(ratios):.3f} "
          f"({min(ratios):.3f} to {max(ratios):.3f})")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="+", default=["bump_10"])
    ap.add_argument("--placements", type=int, default=7)
    ap.add_argument("--repeat", type=int, default=11)
    ap.add_argument("--huge-pairs", action="store_true", help="huge pages against MBS_HUGE_TEXT=0 per placement")
    args = ap.parse_args(argv)
    system = mbs.load(MODEL)
    if args.huge_pairs:
        print(f"Iltis bump scenes, whole simulate() from a first start, CPU time: medians of {args.repeat} runs in one "
              "process each, the library's code on huge pages and not (MBS_HUGE_TEXT=0) at each of "
              f"{args.placements} placements")
        for scene in args.scenes:
            huge_pairs(system, scene, args.placements, args.repeat)
        return 0
    print(f"Iltis bump scenes, whole simulate() from a first start, CPU time: medians of {args.repeat} runs in one "
          f"process per placement of the model library, {args.placements} placements (fresh copies of the file); "
          f"baseline: dopri5 rtol {DOPRI5_FORMER['rtol']:g} atol {DOPRI5_FORMER['atol']:g} (the scenes' former "
          "settings), interleaved in the same processes")
    for scene in args.scenes:
        t_end = system.scene(scene).t_end
        libraries = mapped_libraries(system, scene)
        rows = []
        for k in range(args.placements):
            for path in libraries:
                copy_afresh(path)
            now, before = timed_child(scene, args.repeat, huge=os.environ.get("MBS_HUGE_TEXT") != "0")
            rows.append((now, before))
            print(f"  {scene} placement {k + 1}: {now:.1f} ms ({1e3 * t_end / now:.1f}x real time), former settings "
                  f"{before:.1f} ms, ratio {now / before:.3f}")
        now = sorted(r[0] for r in rows)
        ratios = [r[0] / r[1] for r in rows]
        median = statistics.median(now)
        print(f"{scene}: {t_end:g} s simulated; over {len(rows)} placements median {median:.1f} ms, real-time factor "
              f"{1e3 * t_end / median:.1f} (fastest {1e3 * t_end / now[0]:.1f}, slowest {1e3 * t_end / now[-1]:.1f}); "
              f"against the former settings {statistics.median(ratios):.3f} (placements {min(ratios):.3f} to "
              f"{max(ratios):.3f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
