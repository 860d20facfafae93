"""The Iltis bump scenes against a tight reference: what accuracy figure 18 of the founding paper needs, and what
each tolerance of the scene's own integrator costs.

    python bench/bump_accuracy.py [--scenes bump_5 bump_10] [--rtols 1e-4 1e-5 1e-6 1e-7] [--repeat 3] [--no-check]

Figure 18 of the paper shows the vertical motion of the vehicle over the bump at 5 and 10 m/s; with it go the
tyre loads (what lifts off at 10 m/s). Those are the quantities judged here: heave, pitch and the four tyre
loads, on the scene's sample grid (the rows at events left out, as a plot of the samples shows them).

Printed, all measured in this run:

* the reference: the scene with DOPRI5 in C (set explicitly: the scenes' own integrator is adams) at
  rtol = REFERENCE_RTOL (atol a hundredth of it, the scenes' ratio),
  confirmed by scipy's DOP853 (order 8, another method and code) at the same tolerance: their distance is the
  reference's own error and must lie far below the errors judged (unless --no-check);
* per scene and tolerance (the scene's own setting marked `*`), with the scene's own integrator (named in the
  table's heading, from the results' metadata): the whole `System.simulate(scene)` (equilibrium
  included, results with all the scene's outputs; median of --repeat), its real-time factor (simulated / wall),
  right-hand sides, steps, rejected steps, events, and the largest error of each quantity over the samples, in
  its unit and as a fraction of the quantity's range over the run; `ok` when every fraction is below
  FIGURE_ACCURACY;
* the baseline row `former`: DOPRI5 at rtol 1e-7, atol 1e-9, the bump scenes' settings before they moved to adams
  (bench/dopri5_former.py), measured the same way in the same run.

Why FIGURE_ACCURACY = 1e-3 of the range: a printed figure of 8 cm height resolves about 0.2 mm, 2.5e-3 of its
axis; 1e-3 keeps every curve within half a line width of the exact one, and a tyre load within 0.1 % of its swing
(33 kN at 10 m/s: 33 N, against the tyre's own data given to three or four digits, DATASHEET.md).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

import mbs
from mbs.runtime.simulate import output_times

sys.path.insert(0, str(Path(__file__).resolve().parent))
#: the baseline row: the bump scenes' settings before they moved to adams (DOPRI5 at rtol 1e-7, atol 1e-9)
from dopri5_former import DOPRI5_FORMER, described, scene_settings  # noqa: E402

MODEL = Path(__file__).resolve().parent.parent / "library" / "iltis" / "vehicle.mbs"
#: The quantities of figure 18 (vertical motion) and the tyre loads that go with it.
QUANTITIES = ("heave", "pitch", "tyre_fl.radial.load", "tyre_fr.radial.load", "tyre_rl.radial.load",
              "tyre_rr.radial.load")
REFERENCE_RTOL = 1e-10
#: atol = ATOL_RATIO * rtol, as the bump scenes set it (adams: rtol 2e-8, atol 2e-10 and 5e-7, 5e-9)
ATOL_RATIO = 1e-2
#: The largest error a figure-18 quantity may have, as a fraction of its range over the run.
FIGURE_ACCURACY = 1e-3


def sample_rows(res, times: np.ndarray) -> np.ndarray:
    """Indices of the rows at the sample times (a run with events has rows at its events between them)."""
    t = res["time"]
    on = np.flatnonzero(np.isin(t, times))
    _, first = np.unique(t[on], return_index=True)
    return on[first]


def errors(res, ref, times: np.ndarray) -> dict[str, float]:
    """Largest |res - ref| of each quantity over the sample times."""
    mine, theirs = sample_rows(res, times), sample_rows(ref, times)
    if len(mine) != len(times) or len(theirs) != len(times):
        return {q: float("nan") for q in QUANTITIES}
    return {q: float(np.max(np.abs(res[q][mine] - ref[q][theirs]))) for q in QUANTITIES}


def timed(system, scene: str, repeat: int, **settings):
    """(median wall time of the whole simulate, the last results)."""
    walls, res = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        res = system.simulate(scene, **settings)
        walls.append(time.perf_counter() - start)
    return statistics.median(walls), res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="+", default=["bump_5", "bump_10"])
    ap.add_argument("--rtols", nargs="+", type=float, default=[1e-4, 1e-5, 1e-6, 1e-7])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--no-check", action="store_true", help="skip the DOP853 check of the reference (slow)")
    args = ap.parse_args()
    system = mbs.load(MODEL)
    short = {q: q.replace(".radial.load", "").replace("tyre_", "F_") for q in QUANTITIES}
    for scene in args.scenes:
        sc = system.scene(scene)
        system.simulate(scene, t_end=0.01)  # compiled and loaded before anything is timed
        ref_wall, ref = timed(system, scene, 1, integrator="dopri5", rtol=REFERENCE_RTOL,
                              atol=ATOL_RATIO * REFERENCE_RTOL)
        times = output_times(float(ref["time"][0]), sc.t_end, sample=sc.sample)  # the floats simulate samples at
        span = {q: float(np.ptp(ref[q][sample_rows(ref, times)])) for q in QUANTITIES}
        print(f"\n{scene}: {sc.t_end:g} s, samples every {sc.sample:g} s ({len(times)}), scene settings "
              f"{sc.integrator} rtol {sc.rtol:g} atol {sc.atol:g}")
        print(f"  reference dopri5 rtol {REFERENCE_RTOL:g}: {ref.metadata['stats']['nfev']} rhs, {ref_wall:.1f} s; "
              "ranges " + ", ".join(f"{short[q]} {span[q]:.4g}" for q in QUANTITIES))
        if not args.no_check:
            _, check = timed(system, scene, 1, integrator="DOP853", rtol=REFERENCE_RTOL,
                             atol=ATOL_RATIO * REFERENCE_RTOL)
            own = errors(check, ref, times)
            print("  reference against DOP853 at the same tolerance (its own error): "
                  + ", ".join(f"{short[q]} {own[q]:.1e} ({own[q] / span[q]:.0e})" for q in QUANTITIES))
        print(f"  {sc.integrator}, the scene's integrator, over the tolerances (atol = rtol / 100); `former`: "
              f"{described()}, the scene's settings before adams")
        print(f"  {'rtol':>7s} {'wall':>7s} {'RTF':>6s} {'rhs':>6s} {'steps':>5s} {'rej':>4s} {'events':>6s}  "
              + " ".join(f"{short[q]:>15s}" for q in QUANTITIES) + "  (largest error, its fraction of the range)")
        ladder = [(rtol, {"rtol": rtol, "atol": ATOL_RATIO * rtol}) for rtol in sorted(set(args.rtols) | {sc.rtol})]
        for rtol, settings in ladder + [("former", DOPRI5_FORMER)]:
            wall, res = timed(system, scene, args.repeat, **settings)
            err = errors(res, ref, times)
            share = {q: err[q] / span[q] for q in QUANTITIES}
            stats = res.metadata["stats"]
            verdict = "ok" if max(share.values()) < FIGURE_ACCURACY else "too coarse"
            label = f"{rtol:7.0e}" if rtol != "former" else f"{rtol:>7s}"
            print(f"{'*' if rtol == sc.rtol else ' '} {label} {wall * 1e3:5.0f}ms {sc.t_end / wall:6.1f} "
                  f"{stats['nfev']:6d} {stats['nsteps']:5d} {stats['nreject']:4d} {len(res.events):6d}  "
                  + " ".join(f"{err[q]:7.1e} ({share[q]:.0e})" for q in QUANTITIES) + f"  {verdict}"
                  + (f"  ({scene_settings(res)})" if rtol == "former" or rtol == sc.rtol else ""))
    print(f"\n(* the scene's own tolerance; former: {described()}, the bump scenes' before adams; ok: every "
          f"quantity within {FIGURE_ACCURACY:g} of its range, what figure 18 "
          "needs; RTF = simulated / wall time of the whole simulate)")


if __name__ == "__main__":
    main()
