"""The Iltis full vehicle: compile time, the constrained right-hand side against an open chain of the same size,
the static equilibrium, and each bump scene's wall time and real-time factor with its breakdown.

    python bench/iltis.py [--repeat 5] [--scenes bump_5 bump_10] [--rk45] [--no-one-unit] [--only-cli]

Printed, all measured in this run (medians of --repeat; the machine is shared and noisy):

* compile: text to loaded library with a fresh build cache (holding only the runtime object every model shares,
  bench/compile_time.py seed_runtime: parse, derive, emit C, C compiler, load), and of it
  the derivation (to generated C) and the rest of the C build (split into units compiled in parallel,
  runtime/translation_units.py; the equations' units start while the outputs are derived, runtime/build.py
  prebuild), against the same with the former settings (bench/compile_time.py: the former C printer and the
  outputs' unit compiled at the model units' level) and against the same C built as one unit (how every model
  was built before the split) as baselines;
* the command line, `mbs -q simulate vehicle.mbs --scene S` in a subprocess (medians of --repeat interleaved
  rounds, wall and CPU time): warm (the build, the derivation and the validated model cached: a user's second
  call; target under 1 s) against cold (the build cached, the derivation and the model not: every call before the
  derivation cache), as a ratio, and the model file read again (the warm call before the model cache,
  mbs/model_cache.py); Python's bytecode cached, as in an installed package; with --only-cli nothing else after
  the compile;
* other outputs: text to loaded library of a scene that asks for other outputs than S (--other, default settle)
  when S was derived and compiled before (the equations and their code taken from the derivation cache, the
  model lowered, the equations of motion derived again but not printed, since the outputs share their
  temporaries (mbs/pipeline.py generate_outputs), the outputs derived on the lowering; only outputs.c compiled,
  the other objects from the build cache), against the same scene's fresh compile (whole
  derivation, every unit) in this run; with --only-other nothing else after the first compile;
* rhs per call inside C (no Python, `backend.time_call`) at the scene's equilibrium state: the right-hand side
  the integrators call (`rhs`: the state projected onto the loop-closure constraints, then the constrained
  accelerations), the same without the projection (`loop_rhs`), and the articulated-body right-hand side of an
  open chain with the same number of joint velocities (bench/chain.py's spatial pendulum, compiled here);
  the ratios are medians of per-round ratios, the rounds interleaved;
* the end of an accepted DOPRI5 step inside C: `loop_accept` (the step's last stage, then the projection from the
  factors of G that stage left) against `loop_rhs` plus `project` (the projection with G evaluated and factored
  afresh, as every accepted step did before) as the baseline, the ratio the median of per-round ratios;
* equilibrium: `static_equilibrium` from the scene's assembled start (Newton on the reduced equations), against
  kinetic damping alone (the former method) as the baseline, and how far the two results lie apart;
* per scene: the whole `System.simulate(scene)` (equilibrium included, results with all outputs), its
  real-time factor (simulated / wall time), and the breakdown: equilibrium, integration (with the projections
  and the assembled start; outputs=False) and outputs (the rest), with the scene's own integrator in C at its own
  tolerances (adams since the bump scenes moved to it; printed from the results' metadata);
  and the tree-speed bound: the run's rhs count times the open chain's rhs (the wall time if the closed-loop rhs
  were as cheap as an open tree and nothing else cost anything) as a real-time factor, and the factor with the
  rhs at tree speed and the other parts as measured (the rhs estimated as rhs count x `loop_rhs` at the
  equilibrium, a lower bound: bench/bump_cost.py times the parts inside the run);
  with --rk45 also scipy's RK45 on the same compiled model, as a ratio;
* per scene, both forms of the model's kinks (unless --no-switches): the smooth form (`switches = false`: the
  tyre contact, leaf stop and damper kinks as min/max inside the rhs, which the step size control meets as
  rejections) and the event form (`switches = true`: each kink a located event, the integrator restarted there),
  the whole `simulate` each (the scene's own integrator), with steps, rejections and rhs calls; the ratio is
  event / smooth wall time.
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import mbs
from mbs.runtime import cache as store
from mbs.runtime import equilibrium
from mbs.runtime.build import build_jobs
from mbs.runtime.equilibrium import static_equilibrium
from mbs.runtime.workspace import Workspace

sys.path.insert(0, str(Path(__file__).parent))
from chain import chain_text  # noqa: E402
from dopri5_former import scene_settings  # noqa: E402
from compile_time import former_settings, fresh_compile, seed_runtime  # noqa: E402

MODEL = Path(__file__).resolve().parent.parent / "library" / "iltis" / "vehicle.mbs"
#: Issue 12's targets: the constrained rhs against the open chain, and each bump scene's real-time factor.
TARGET_RHS_RATIO = 3.0
TARGET_RTF = 100.0
#: and the warm command line run of a scene, in seconds
TARGET_WARM_CLI = 1.0


def median_time(fn, repeat: int):
    times, result = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def rhs_costs(system, scene, x, open_compiled, rounds: int):
    """Seconds per call inside C of rhs, loop_rhs and the open chain's rhs; the ratios to the open chain."""
    compiled = system.compile(scene)
    data = system._workspace(compiled, system.generate(scene), _values(system, scene))
    open_data = Workspace(open_compiled)
    backend = compiled.backend
    f_rhs, f_direct = data.function("rhs"), data.function("loop_rhs")
    f_open = open_data.function("rhs")
    x_open = open_compiled.x0
    f_accept, f_project = data.function("loop_accept"), data.function("project")
    calls = 2000
    rows = []
    for _ in range(rounds):
        a = backend.time_call(f_rhs, x, calls, 0.0)
        b = backend.time_call(f_direct, x, calls, 0.0)
        c = open_compiled.backend.time_call(f_open, x_open, 20 * calls, 0.0)
        d = backend.time_call(f_accept, x, calls, 0.0)
        e = backend.time_call(f_project, x, calls, 0.0)
        rows.append((a, b, c, d, e))
    med = statistics.median
    return (med(r[0] for r in rows), med(r[1] for r in rows), med(r[2] for r in rows),
            med(r[0] / r[2] for r in rows), med(r[1] / r[2] for r in rows),
            med(r[3] for r in rows), med(r[1] + r[4] for r in rows), med((r[1] + r[4]) / r[3] for r in rows))


def _values(system, scene):
    from mbs import pipeline
    return pipeline.parameter_values(system.model, pipeline.scene_overrides(system.scene(scene)))


def same_code(a: str, b: str) -> bool:
    """Whether two generated files are the same code: the header's ' * From <path>' line names the model file as
    it was given (compile_time.py loads the text with its absolute path, this bench the file), so it is left out."""
    def code(text: str) -> list[str]:
        return [line for line in text.split("\n") if not line.startswith(" * From ")]
    return code(a) == code(b)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--scenes", nargs="+", default=["bump_5", "bump_10"])
    ap.add_argument("--rk45", action="store_true", help="also run scipy's RK45 as a baseline")
    ap.add_argument("--no-switches", action="store_true", help="leave out the smooth / event form comparison")
    ap.add_argument("--other", default="settle", help="a scene with other outputs than the first of --scenes")
    ap.add_argument("--no-one-unit", action="store_true", help="skip the one-unit C build (the slow baseline)")
    ap.add_argument("--only-cli", action="store_true", help="after the compile only the command line's times")
    ap.add_argument("--only-other", action="store_true", help="after the compile only the other outputs' times")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as cache:
        seed_runtime(cache)
        start = time.perf_counter()
        system = mbs.load(MODEL, cache_dir=cache)
        marks = {}
        generate = system.generate

        def timed_generate(*a, **k):  # the derivation's end inside compile (the C compiler starts before it)
            result = generate(*a, **k)
            marks.setdefault("derived", time.perf_counter())
            return result

        system.generate = timed_generate
        compiled = system.compile(args.scenes[0])
        built = time.perf_counter()
        derived = marks["derived"]
        system.generate = generate
        compile_time = built - start
        gen = system.generate(args.scenes[0])
        open_system = mbs.loads(chain_text(compiled.nv), cache_dir=cache)
        open_compiled = open_system.compile()
        data = system._workspace(compiled, gen, _values(system, args.scenes[0]))
        x_start = data.x.copy()
        report = data.loop_report(0.0, x_start)
        print(f"model {MODEL.name}: compile {compile_time:.1f} s (text to loaded library, fresh cache: derivation "
              f"{derived - start:.1f} s, then C build {built - derived:.1f} s with {build_jobs()} jobs); generated C "
              f"{len(gen.c_source) / 1024:.0f} KiB")
        if args.only_other:
            print_other_outputs(cache, args.other, args.scenes[0])
            return
        with tempfile.TemporaryDirectory() as empty, former_settings():
            before = fresh_compile("iltis", empty)
        print(f"  baseline: the former settings (compile_time.py: the former C printer, the outputs' unit at the model "
              f"units' level) {before['total']:.1f} s (derivation {before['derive']:.1f} s, then C build "
              f"{before['cc']:.1f} s): {before['total'] / compile_time:.2f} x this compile; the same C: "
              f"{'yes' if same_code(before['code'], gen.c_source) else 'NO'}")
        if not args.no_one_unit:
            one = one_unit_build(gen.c_source)
            former = derived - start + one
            print(f"  baseline: the same C built as one unit after the derivation (the former way) {one:.1f} s, "
                  f"compile {former:.1f} s: {former / compile_time:.1f} x the split, overlapped compile")
        if not args.only_cli:
            print_other_outputs(cache, args.other, args.scenes[0])
        cli = cli_times(cache, args.scenes[0], args.repeat)
        (warm, warm_cpu), (read, read_cpu), (cold, cold_cpu) = cli["warm"], cli["model read"], cli["cold"]
        print(f"command line `mbs simulate {MODEL.name} --scene {args.scenes[0]}`: warm {warm:.2f} s (CPU {warm_cpu:.2f}"
              f" s; target < {TARGET_WARM_CLI:g} s), cold (model and derivation not cached, baseline) {cold:.2f} s "
              f"(CPU {cold_cpu:.2f} s): {cold / warm:.1f} x")
        print(f"  the model file read again (derivation cached: the warm call before the model cache) {read:.2f} s "
              f"(CPU {read_cpu:.2f} s): {read / warm:.2f} x warm")
        if args.only_cli:
            return
        print(f"  nq = {compiled.nq}, nv = {compiled.nv}, constraint rows = {len(gen.constraints.names)}, "
              f"rank {int(report[5])}, degrees of freedom {int(report[6])}")

        eq_time, eq = median_time(lambda: static_equilibrium(compiled, fresh_workspace(system, args.scenes[0]),
                                                             x_start), args.repeat)
        damped_time, damped = median_time(lambda: kinetic_damping(compiled, fresh_workspace(system, args.scenes[0]),
                                                                   x_start), 1)
        shift = np.abs(eq.x - damped.x)[:compiled.nq]
        print(f"\nstatic equilibrium ({args.scenes[0]}): Newton {eq_time * 1e3:.1f} ms, kinetic damping (the former "
              f"method) {damped_time * 1e3:.0f} ms: {damped_time / eq_time:.0f} x; max |vdot| left {eq.residual:.1e} "
              f"against {damped.residual:.1e}; largest difference {shift.max():.1e} in "
              f"{compiled.x_names[int(shift.argmax())]} (a direction without stiffness where the damping drifts)")

        rhs, direct, open_rhs, ratio, ratio_direct, step_end, fresh_end, step_ratio = \
            rhs_costs(system, args.scenes[0], eq.x, open_compiled, args.repeat)
        print(f"\nrhs per call inside C at the equilibrium (medians of {args.repeat} interleaved rounds):")
        print(f"  constrained rhs (projected)  {rhs * 1e6:8.2f} us  {ratio:5.1f} x the open chain")
        print(f"  constrained rhs (no projection) {direct * 1e6:5.2f} us  {ratio_direct:5.1f} x the open chain "
              f"(the rhs without the projection; target <= {TARGET_RHS_RATIO:g} x)")
        print(f"  open chain of {compiled.nv} links     {open_rhs * 1e6:8.2f} us")
        print(f"  a step's end (last stage and projection) {step_end * 1e6:6.2f} us  (loop_accept: the projection from "
              f"the factors of the last stage) against loop_rhs + project (a fresh projection, the baseline) "
              f"{fresh_end * 1e6:.2f} us: {step_ratio:.2f} x")

        print(f"\n{'scene':8s} {'t_end':>5s} {'wall':>8s} {'RTF':>6s} {'equil.':>8s} {'integr.':>8s} "
              f"{'outputs':>8s} {'steps':>6s} {'rhs':>6s}" + (f" {'RK45':>8s} {'RK45/ours':>9s}" if args.rk45 else ""))
        for scene in args.scenes:
            t_end = system.scene(scene).t_end
            system.compile(scene)
            # each a first start (its equilibrium solved, not the state a run before kept: System.forget_starts)
            wall, res = median_time(lambda: (system.forget_starts(), system.simulate(scene))[1], args.repeat)
            sc_data = fresh_workspace(system, scene)
            eq_wall, eq_scene = median_time(lambda: static_equilibrium(system.compile(scene), sc_data, sc_data.x),
                                            args.repeat)
            integ, res_plain = median_time(lambda: system.simulate(scene, x0=eq_scene.x, outputs=False), args.repeat)
            outputs = max(0.0, wall - eq_wall - integ)
            stats = res.metadata["stats"]
            line = (f"{scene:8s} {t_end:5.2f} {wall * 1e3:6.0f}ms {t_end / wall:6.1f} {eq_wall * 1e3:6.0f}ms "
                    f"{integ * 1e3:6.0f}ms {outputs * 1e3:6.0f}ms {stats.get('nsteps', 0):6d} {stats.get('nfev', 0):6d}")
            if args.rk45:
                base, _ = median_time(lambda: system.simulate(scene, integrator="RK45"), max(1, args.repeat // 2))
                line += f" {base * 1e3:6.0f}ms {base / wall:9.1f}"
            print(line + f"  {scene_settings(res)}" + ("" if res.success else f"  ({res.message})"))
            bound = stats.get("nfev", 0) * open_rhs  # the rhs as cheap as the open tree, nothing else costing
            print(f"{'':8s} tree-speed bound: {stats.get('nfev', 0)} rhs x {open_rhs * 1e6:.2f} us (open chain) = "
                  f"{bound * 1e3:.0f} ms, real-time factor {t_end / bound:.0f}; with the rest as measured "
                  f"{t_end / (wall - min(stats.get('nfev', 0) * direct, integ) + bound):.1f} (bench/bump_cost.py "
                  f"splits the parts)")
        print(f"(RTF = simulated / wall time, from the start of simulate to the results with every output, each "
              f"scene with its own integrator and tolerances, named at the end of its line; target >= {TARGET_RTF:g})")
        if not args.no_switches:
            compare_forms(cache, args.scenes, args.repeat)


def compare_forms(cache: str, scenes, repeat: int) -> None:
    """Each scene's whole simulate() with the kinks smooth (switches = false) and as events (switches = true),
    medians of interleaved runs, with the step counts of each form."""
    text = MODEL.read_text()
    header = re.search(r"^model [^\n]*\{[^\n]*\n", text, re.M)
    forms = {flag: mbs.loads(text[:header.end()] + f"    switches = {flag}\n" + text[header.end():], path=str(MODEL),
                             cache_dir=cache) for flag in ("false", "true")}
    print(f"\nkinks smooth (switches = false) or as events (switches = true), whole simulate(), medians of {repeat}:")
    print(f"{'scene':8s} {'form':>7s} {'wall':>8s} {'RTF':>6s} {'steps':>6s} {'reject':>6s} {'rhs':>6s} {'events':>6s}"
          f" {'events/smooth':>13s}")
    for scene in scenes:
        t_end = forms["false"].scene(scene).t_end
        walls: dict[str, list] = {"false": [], "true": []}
        last = {}
        for flag in forms:
            forms[flag].simulate(scene)  # compile and warm up
        for _ in range(repeat):
            for flag, system in forms.items():
                system.forget_starts()  # a first start (its equilibrium solved)
                start = time.perf_counter()
                last[flag] = system.simulate(scene)
                walls[flag].append(time.perf_counter() - start)
        wall = {flag: statistics.median(w) for flag, w in walls.items()}
        for flag, name in (("false", "smooth"), ("true", "events")):
            stats, res = last[flag].metadata["stats"], last[flag]
            print(f"{scene:8s} {name:>7s} {wall[flag] * 1e3:6.0f}ms {t_end / wall[flag]:6.1f} {stats.get('nsteps', 0):6d} "
                  f"{stats.get('nreject', 0):6d} {stats.get('nfev', 0):6d} {len(res.events):6d}"
                  + (f" {wall['true'] / wall['false']:13.2f}" if flag == "true" else f" {'':13s}")
                  + f"  {scene_settings(res)}")


def one_unit_build(code: str) -> float:
    """Seconds to build `code` as one translation unit into an empty cache (the split switched off)."""
    from mbs.runtime import build, translation_units
    saved = translation_units.SPLIT_MIN_CHARS
    translation_units.SPLIT_MIN_CHARS = 1 << 62
    try:
        with tempfile.TemporaryDirectory() as empty:
            seed_runtime(empty)
            start = time.perf_counter()
            build.build(code, filename="vehicle.c", cache_dir=empty)
            return time.perf_counter() - start
    finally:
        translation_units.SPLIT_MIN_CHARS = saved


def print_other_outputs(cache: str, scene: str, before: str) -> None:
    other, other_fresh = other_outputs_times(cache, scene)
    print(f"other outputs (scene {scene} after {before}): {other:.1f} s to the loaded library, "
          f"against its fresh compile {other_fresh:.1f} s (baseline): {other_fresh / other:.1f} x")


def other_outputs_times(cache: str, scene: str) -> tuple[float, float]:
    """Seconds from text to loaded library of `scene` (its outputs differ from the scene compiled before in
    `cache`): with that cache, and with an empty one (the fresh compile, the baseline)."""
    times = []
    for folder in (cache, None):
        with tempfile.TemporaryDirectory() as empty:
            start = time.perf_counter()
            mbs.load(MODEL, cache_dir=folder or empty).compile(scene)
            times.append(time.perf_counter() - start)
    return times[0], times[1]


def cli_times(cache: str, scene: str, repeat: int) -> dict[str, tuple[float, float]]:
    """Median (wall, CPU) seconds of the command line run of a scene, in interleaved rounds: 'warm' (every cache
    warm: a user's second call), 'model read' (the model cache emptied before each run: the file parsed and
    validated again, the derivation cached; the warm call before the model cache) and 'cold' (the model and the
    derivation caches emptied, the build cache warm: every call before the derivation cache; every other round)."""
    # as installed: Python's bytecode cached (an environment that forbids writing it compiles every module anew)
    env = {**{k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}, "MBS_CACHE_DIR": cache}
    command = [sys.executable, "-m", "mbs", "-q", "simulate", str(MODEL), "--scene", scene]

    def run(*emptied: str) -> tuple[float, float]:
        for prefix in emptied:
            for entry in Path(cache).glob(f"{prefix}*"):
                entry.unlink()
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.perf_counter()
        subprocess.run(command, env=env, check=True, capture_output=True)
        wall = time.perf_counter() - start
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)

    run()  # the cache as a user's second call finds it
    runs: dict[str, list] = {"warm": [], "model read": [], "cold": []}
    for i in range(repeat):
        runs["warm"].append(run())
        runs["model read"].append(run(store.CHECKED_PREFIX))
        if i % 2 == 0:
            runs["cold"].append(run(store.CHECKED_PREFIX, store.DERIVED_PREFIX))
        run()  # every cache warm again for the next round
    return {kind: (statistics.median(w for w, _ in times), statistics.median(c for _, c in times))
            for kind, times in runs.items()}


def kinetic_damping(compiled, data, x0):
    """The equilibrium by kinetic damping alone (Newton switched off): the former method, as the baseline."""
    saved = equilibrium.newton_equilibrium
    equilibrium.newton_equilibrium = lambda *args: None
    try:
        return equilibrium.static_equilibrium(compiled, data, x0)
    finally:
        equilibrium.newton_equilibrium = saved


def fresh_workspace(system, scene):
    """A fresh workspace at the scene's assembled start."""
    return system._workspace(system.compile(scene), system.generate(scene), _values(system, scene))


if __name__ == "__main__":
    main()
