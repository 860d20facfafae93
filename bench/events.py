"""What events cost: nothing in a model that has none, and how fast a model with many of them runs.

    python bench/events.py [--repeats R]

1. A model without events (the double pendulum example, dopri5 in C, 10 s): ``simulate()`` against the bare
   C sampling loop with no driver around it (``Solver.sample`` of the same compiled model), the median of R
   runs each, the two interleaved.  The ratio bounds what the event machinery costs a model that does not use it: it contains the
   driver's fixed cost (workspace, results table), and of the event machinery only one test per step in C
   (``nev == 0``) and one attribute test in Python.
2. The bouncing ball example to its accumulation point: events per second of wall time.
3. The Iltis quarter car and the full Iltis (library/iltis/vehicle.mbs) over the bump at 10 m/s, each scene with its
   own integrator and tolerances (printed from the results' metadata: dopri5 for the quarter car, adams for the full
   Iltis since its bump scenes moved to it):
   the tyre contact, leaf stop and damper kinks as switches (events) against the smooth form of the same model
   (``switches = false``, the baseline), median of R runs each, the two forms interleaved; wall time and the
   process's CPU time (the steadier figure when other jobs share the cores); the ratio event / smooth is the
   issue's figure ("no slower": <= 1).  The rows at a continuous switch's event are computed once and every row
   of the run projected and its outputs evaluated in one C call (runtime/simulate.py _evaluate_rows).  The event form's
   restarts run inside the C sampling loop (c/ode.c, mbs_ode_restart); ``--python-restarts`` times the Python
   loop's restarts (a new integrator after each event) as a third line for comparison.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np
from timing import interleaved_medians  # bench/timing.py (the scripts run from bench/)

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "library" / "examples"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=21)
    parser.add_argument("--python-restarts", action="store_true", help="also time the restarts in Python")
    args = parser.parse_args(argv)
    import mbs
    from mbs.runtime.simulate import output_times, simulate
    from mbs.runtime.workspace import Workspace

    system = mbs.load(EXAMPLES / "double_pendulum.mbs")
    compiled = system.compile()
    data = system._workspace(compiled, system.generate(), {p.name: p.value for p in system.model.parameters})
    x0, times = data.x.copy(), output_times(0.0, 10.0, sample=0.01)
    module = compiled.backend.module
    rhs = data.function("rhs")

    def bare():
        solver = module.Solver("dopri5", rhs, 0.0, x0, 10.0, 1e-8, 1e-10)
        out = np.empty((times.size, compiled.nx))
        solver.sample(times, out, 0)

    def full():
        fresh = Workspace(compiled)
        fresh.p, fresh.x = data.p, x0
        simulate(compiled, fresh, 10.0, sample=0.01, rtol=1e-8, atol=1e-10)

    base, driver = interleaved_medians((bare, full), args.repeats)
    print(f"double pendulum, 10 s, dopri5 in C, median of {args.repeats}:")
    print(f"  bare C sampling loop (baseline)          {base * 1e3:8.2f} ms")
    print(f"  simulate() of a model without events     {driver * 1e3:8.2f} ms   ratio {driver / base:.2f}")
    ball = mbs.load(EXAMPLES / "bouncing_ball.mbs")
    ball.simulate("drop")  # compile first
    runs = []
    for _ in range(max(3, args.repeats // 4)):
        res = ball.simulate("drop")
        runs.append((res.metadata["wall_time"], len(res.events)))
    wall = statistics.median(w for w, _ in runs)
    print(f"bouncing ball to its accumulation point: {runs[0][1]} events in {wall * 1e3:.1f} ms "
          f"({runs[0][1] / wall:.0f} events/s)")
    iltis = ROOT / "library" / "iltis"
    for label, path, header in (
            ("Iltis quarter car", iltis / "quarter_car.mbs", 'model quarter_car "Iltis quarter car" {'),
            ("full Iltis", iltis / "vehicle.mbs", 'model vehicle "Iltis on four suspensions" {')):
        compare_forms(mbs, label, path, header, max(3, args.repeats // 2), args.python_restarts)
    return 0


def compare_forms(mbs, label: str, path: Path, header: str, repeats: int, python_restarts: bool) -> None:
    """Wall time of the bump at 10 m/s with switches (events) against the smooth form, medians, interleaved."""
    from mbs.runtime import event_loop
    text = path.read_text()
    forms = {name: mbs.loads(text.replace(header, f"{header}\n    switches = {flag}"), path=str(path))
             for name, flag in (("smooth", "false"), ("events", "true"))}
    runs: dict[str, list] = {"smooth": [], "events": [], "python": []}
    cpu: dict[str, list] = {"smooth": [], "events": [], "python": []}
    tables = event_loop.c_restart_tables

    def run(name: str, form: str) -> None:
        started = time.process_time()
        runs[name].append(forms[form].simulate("bump_10"))
        cpu[name].append(time.process_time() - started)

    for name in ("smooth", "events"):
        forms[name].simulate("bump_10")  # compile and warm up
    for _ in range(repeats):
        run("smooth", "smooth")
        run("events", "events")
        if python_restarts:
            event_loop.c_restart_tables = lambda model: None
            try:
                run("python", "events")
            finally:
                event_loop.c_restart_tables = tables
    med = {k: statistics.median(r.metadata["wall_time"] for r in v) for k, v in runs.items() if v}
    med_cpu = {k: statistics.median(v) for k, v in cpu.items() if v}
    smooth, events = runs["smooth"][0], runs["events"][0]

    def counts(res) -> str:
        stats = res.metadata["stats"]
        return f"nfev {stats['nfev']:6d}, rejected {stats['nreject']:4d}"

    settings = smooth.metadata
    print(f"{label}, bump at 10 m/s, {settings['integrator']} rtol {settings['rtol']:g} atol {settings['atol']:g}, "
          f"median of {repeats} (wall; process CPU, steadier on a busy machine):")
    print(f"  smooth form (baseline)        {med['smooth'] * 1e3:8.1f} ms; {med_cpu['smooth'] * 1e3:7.1f} ms   "
          f"{counts(smooth)}")
    print(f"  event form, restarts in C     {med['events'] * 1e3:8.1f} ms; {med_cpu['events'] * 1e3:7.1f} ms   "
          f"{counts(events)}, {len(events.events)} events   ratio {med['events'] / med['smooth']:.2f}; "
          f"{med_cpu['events'] / med_cpu['smooth']:.2f}")
    if "python" in med:
        print(f"  event form, restarts in Python{med['python'] * 1e3:8.1f} ms; {med_cpu['python'] * 1e3:7.1f} ms   "
              f"ratio {med['python'] / med['smooth']:.2f}; {med_cpu['python'] / med_cpu['smooth']:.2f}")


if __name__ == "__main__":
    raise SystemExit(main())
