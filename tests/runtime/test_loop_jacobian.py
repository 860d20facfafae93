"""The exact Jacobian of closed mechanisms (compiler/jacobian_loops.py, runtime/c/loop_jacobian.c): equal to
central differences of the projecting right-hand side, and what lets rodasp take 6 right-hand sides per step
(rodas5p 8) on closed loops (central differences of the loop solver cost it 2 nx + 8)."""

import numpy as np
import pytest

import mbs
from mbs import pipeline
from mbs.compiler import jacobian_loops
from mbs.runtime.simulate import simulate
from mbs.runtime.workspace import Workspace


def _central_differences(f, t, x, h=1e-5):
    n = x.size
    J = np.empty((n, n + 1))
    for j in range(n + 1):
        dt, dx = (h, np.zeros(n)) if j == n else (0.0, h * np.eye(n)[j])
        J[:, j] = (f(t + dt, x + dx) - f(t - dt, x - dx)) / (2 * h)
    return J


def _workspace(path, scene, cache=None):
    """cache: a private cache folder for a test that patches the generator (the derivation cache's key holds the
    model and the options, not MAX_STATES); None: the default one, where other tests' builds of the model are."""
    system = mbs.load(path, cache_dir=None if cache is None else str(cache))
    gen = system.generate(scene, jacobian=True)
    values = pipeline.parameter_values(system.model, pipeline.scene_overrides(gen.scene))
    return system, system._workspace(system.compile(scene, jacobian=True), gen, values)


def _check_against_differences(data, t, bound=1e-8, h=1e-5):
    """At a projected state away from the start: every column, the time column included, to the digits
    central differences have (their truncation and the loop solver's Newton tolerance, ~1e-9 relative)."""
    rng = np.random.default_rng(2)
    x = data.function("project")(t, data.x + 0.05 * rng.standard_normal(data.x.size))
    J = data.function("jacobian")(t, x)
    reference = _central_differences(data.function("rhs"), t, x, h)
    scale = np.abs(reference).max()
    assert np.abs(J - reference).max() <= bound * scale
    # the directions the projection undoes (dependent coordinates) have zero columns: not all columns are zero
    assert 0 < np.count_nonzero(np.abs(J[:, :-1]).max(axis=0) == 0.0) < x.size
    return J


def test_slider_crank_jacobian_equals_central_differences():
    _, data = _workspace("library/examples/slider_crank.mbs", None)
    assert "jacobian" in data.model.functions
    _check_against_differences(data, 0.3)


def test_large_mechanisms_take_the_partials_by_differences(tmp_path, monkeypatch):
    """Beyond MAX_STATES (or with lookup tables) the same assembly runs on central differences of the residuals
    along each column's directions: measured 1.6e-10 relative here against central differences of the projecting
    rhs (3.4e-10 against the generated partials; forward differences per state gave 1.5e-8), no generation
    time."""
    monkeypatch.setattr(jacobian_loops, "MAX_STATES", 0)
    system = mbs.load("library/examples/slider_crank.mbs", cache_dir=str(tmp_path))
    gen = system.generate(None, jacobian=True)
    assert "MBS_LOOP_PARTIALS_BY_DIFFERENCES 1" in gen.c_source and "mbs_loop_partials(" not in gen.c_source
    _, data = _workspace("library/examples/slider_crank.mbs", None, tmp_path)
    _check_against_differences(data, 0.3, bound=1e-8)


@pytest.mark.parametrize("generated", [False, pytest.param(True, marks=pytest.mark.slow)])  # 6 s; 20 s to generate
def test_a_floating_body_with_two_loops_jacobian_equals_central_differences(tmp_path, monkeypatch, generated):
    """A free body's quaternion and translations feeding two independent loop blocks, the Iltis vehicle's shape in
    25 states: its reduced mass matrix T^T M T has small diagonal entries (light links) next to larger couplings
    to the body, so its factors exchange rows at several steps. The solve once applied each exchange just before
    its elimination step although the factors had moved the stored multipliers with the rows: this Jacobian was
    off by 10 times its largest entry (the vehicle's by 13), 1.5e-10 relative now, both with the generated
    partials and with the partials by differences."""
    if not generated:
        monkeypatch.setattr(jacobian_loops, "MAX_STATES", 0)
    system, data = _workspace("tests/runtime/models/floating_four_bars.mbs", None, tmp_path)
    assert ("MBS_LOOP_PARTIALS_BY_DIFFERENCES 1" in system.generate(None, jacobian=True).c_source) != generated
    assert data.model.nq > data.model.nv
    _check_against_differences(data, 0.3)


@pytest.mark.slow  # the vehicle takes about a minute to generate and compile
def test_iltis_vehicle_jacobian_equals_central_differences(tmp_path):
    """The full vehicle on the bump (39 + 34 states, four loop blocks on a floating body: the partials by
    differences). The bound is the truncation of those differences (step 6e-6, mbs_lj_along) on the stiff tyres,
    measured from the reference's own convergence at this state: central differences of the rhs at h = 1e-4,
    1e-5 and 1e-6 differ by 1.5e-4 and 1.45e-6 of the largest entry (h^2), i.e. 5.2e-7 at 6e-6; the Jacobian
    is 5.1e-7 from the reference at h = 1e-6 (at most 1.4e-9 off itself)."""
    system, data = _workspace("library/iltis/vehicle.mbs", "bump_10", tmp_path)
    assert "MBS_LOOP_PARTIALS_BY_DIFFERENCES 1" in system.generate("bump_10", jacobian=True).c_source
    _check_against_differences(data, 0.3, bound=2e-6, h=1e-6)


@pytest.mark.slow  # the quarter car's partial derivatives take half a minute to generate and compile
def test_quarter_car_jacobian_with_quaternions_and_road_equals_central_differences(tmp_path):
    _, data = _workspace("library/iltis/quarter_car.mbs", "bump_5", tmp_path)
    assert data.model.nq > data.model.nv  # a quaternion: the projection's normalisation is differentiated
    _check_against_differences(data, 0.5)  # on the bump: the road drives the time column


@pytest.mark.parametrize("method, stages", [("rodasp", 6), ("rodas5p", 8)])
def test_the_rosenbrock_methods_take_their_stages_in_rhs_per_step_on_the_slider_crank(method, stages):
    """One rhs per stage and none for the Jacobian (the assembled one), and the end state agrees with dopri5."""
    system = mbs.load("library/examples/slider_crank.mbs")
    data, settings = system.start(None, jacobian=True)
    assert "jacobian" in data.model.functions

    def run(integrator, rtol):
        work = Workspace(data.model)
        work.p, work.t, work.x = data.p, data.t, data.x.copy()
        res = simulate(data.model, work, settings["t_end"], integrator=integrator, rtol=rtol, atol=1e-2 * rtol,
                       outputs=False)
        assert res.metadata["status"] == "finished"
        return res

    stiff, reference = run(method, 1e-8), run("dopri5", 1e-12)
    stats = stiff.metadata["stats"]
    assert stats["njev"] > 0 and stats["nfev"] <= stages * stats["nsteps"] + 10  # + the start: f(x0), first step
    end = [stiff[n][-1] - reference[n][-1] for n in data.model.x_names]
    assert np.abs(end).max() < 1e-5
