"""Parameter variation on Dask: the pendulum's period against the closed form, failures as rows, a compiled model
shipped once (no variant recompiles), the same numbers as single runs."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mbs
from mbs.studies import sweep
from mbs.studies.package import ModelPackage

pytest.importorskip("distributed")
G = 9.81
THETA0 = math.radians(30)
I_BOB = 1e-6  # the bob's own inertia about its centre (library/examples/pendulum.mbs)


def closed_form_period(l: float, m: float = 1.0) -> float:
    """The compound pendulum from rest at THETA0: T = 4 sqrt(I_O / (m g l)) K(sin^2(THETA0 / 2)), K the complete
    elliptic integral of the first kind (parameter m = k^2), I_O = m l^2 + I_BOB about the pivot."""
    from scipy.special import ellipk
    return 4.0 * math.sqrt((m * l * l + I_BOB) / (m * G * l)) * ellipk(math.sin(THETA0 / 2) ** 2)


@pytest.fixture(scope="module")
def pendulum():
    return mbs.load("library/examples/pendulum.mbs")


def test_pendulum_periods_over_length_agree_with_the_elliptic_integral(pendulum, dask_client):
    lengths = [0.25, 0.5, 1.0, 2.0, 4.0]
    table = sweep(pendulum, "swing", {"l": lengths}, metrics=["period(hinge.phi)", "peak(hinge.phi)"],
                  sample=1e-3, client=dask_client)
    assert not table.failed
    assert list(table["l"]) == lengths
    expected = [closed_form_period(l) for l in lengths]
    # rtol 1e-8 and crossing times interpolated where phi is nearly linear: far below 1e-6
    np.testing.assert_allclose(table["period(hinge.phi)"], expected, rtol=1e-6)
    np.testing.assert_allclose(table["peak(hinge.phi)"], THETA0, rtol=1e-9)
    assert table.metadata["units"]["period(hinge.phi)"] == "s"


def test_a_failed_variant_is_a_row_with_its_message(pendulum, dask_client):
    # a negative mass: refused when the variant's parameters are bound, before it runs
    table = sweep(pendulum, "swing", {"m": [1.0, -I_BOB]}, metrics=["final(hinge.phi)"], client=dask_client)
    ok, bad = table.rows
    assert ok.status == "finished" and math.isfinite(ok.metrics["final(hinge.phi)"])
    assert bad.status == "failed" and "the mass of 'bob' must not be negative" in bad.message
    assert math.isnan(bad.metrics["final(hinge.phi)"])


def test_sweep_rows_equal_single_runs_over_damping_and_speed(dask_client):
    """Two parameters on a grid (the two-mass quarter car's damper and speed): each row has the numbers of a
    separate `simulate` with the same parameters, so the shipped binary and the run-time parameters are right."""
    system = mbs.load("library/examples/two_mass_quarter_car.mbs")
    damping, speeds = [1500.0, 3000.0], [10 / 3.6, 20 / 3.6]
    metrics = ["peak(body_z) - min(body_z)", "rms(wheel_load - final(wheel_load))"]
    table = sweep(system, "bump", {"d_susp": damping, "v": speeds}, metrics=metrics, client=dask_client)
    assert [(r.values["d_susp"], r.values["v"]) for r in table.rows] == [(d, v) for d in damping for v in speeds]
    for row in table.rows:
        res = system.simulate("bump", params=row.values)
        z, load = res["body_z"], res["wheel_load"]
        assert row.metrics[metrics[0]] == pytest.approx(z.max() - z.min(), rel=1e-12)
        assert row.metrics[metrics[1]] == pytest.approx(np.sqrt(np.mean((load - load[-1]) ** 2)), rel=1e-12)
    travel = table[metrics[0]]
    assert travel[0] > travel[2] and travel[1] > travel[3]  # more damping, less body travel over the bump


def test_the_package_runs_without_a_compiler(pendulum, tmp_path, monkeypatch):
    """What a worker gets is the built binary: loading it in an empty cache with no C compiler works."""
    package = ModelPackage.of(pendulum, "swing")
    monkeypatch.setenv("MBS_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("CC", "/nonexistent/cc")
    model = package.load()
    mine = pendulum.compile("swing")
    x = np.array([0.3, -0.2])
    from mbs.runtime.workspace import Workspace
    np.testing.assert_array_equal(Workspace(model).rhs(0.0, x), Workspace(mine).rhs(0.0, x))
    assert model.y_names == mine.y_names and model.units == mine.units


@pytest.mark.slow
def test_iltis_quarter_car_over_strut_damping_and_speed(dask_client):
    """The Iltis quarter car over the benchmark bump: strut damping (a scale of the data sheet's characteristic)
    times speed on a grid, one compile; rows equal single runs; the parameter reaches the strut."""
    system = mbs.load("library/iltis/quarter_car.mbs")
    grid = {"fl.damping": [0.5, 1.0, 2.0], "v": [5.0, 10.0]}
    metrics = ["range(heave)", "peak(tyre.radial.load)"]
    table = sweep(system, "bump_5", grid, metrics=metrics, client=dask_client)
    assert not table.failed
    for row in table.rows[::5]:
        res = system.simulate("bump_5", params=row.values)
        assert row.metrics["range(heave)"] == pytest.approx(np.ptp(res["heave"]), rel=1e-12)
    load = table["peak(tyre.radial.load)"].reshape(3, 2)
    assert np.all(load[:, 1] > load[:, 0])  # a faster bump, a harder hit, at every damping
    assert len(set(np.round(load[:, 1], 3))) == 3  # the damping scale reaches the strut


def test_numpy_back_end_package_runs_on_the_workers(dask_client):
    """Without a C compiler the package carries the generated NumPy module: the same periods as the C model."""
    lengths = [0.5, 2.0]
    rows = {}
    for backend in ("numpy", "c"):
        system = mbs.load("library/examples/pendulum.mbs", backend=backend)
        table = sweep(system, "swing", {"l": lengths}, metrics=["period(hinge.phi)"], t_end=3.0, integrator="DOP853",
                      client=dask_client)
        assert not table.failed, table.failed[0].message
        rows[backend] = table["period(hinge.phi)"]
    np.testing.assert_allclose(rows["numpy"], rows["c"], rtol=1e-6)


def test_a_worker_without_the_cpu_features_of_the_binary_builds_its_own(pendulum, tmp_path, monkeypatch):
    """A package built with AVX2 (runtime/build.py cpu_flags) goes to a worker whose CPU lacks it: the worker
    compiles the source instead of loading a binary it cannot run; with the feature it loads the binary."""
    import dataclasses

    from mbs.runtime import build
    from mbs.studies import package as package_module
    package = dataclasses.replace(ModelPackage.of(pendulum, "swing"), cpu=("avx2",))
    monkeypatch.setenv("MBS_CACHE_DIR", str(tmp_path))
    built = []
    real_load_c = package_module.load_c
    monkeypatch.setattr(package_module, "load_c", lambda **kw: built.append(1) or real_load_c(**kw))
    monkeypatch.setattr(build, "_cpu_features", lambda: frozenset({"avx2", "sse2"}))
    package.load()
    assert built == []
    monkeypatch.setattr(build, "_cpu_features", lambda: frozenset({"sse2"}))
    model = package.load()
    assert built == [1]
    x = np.array([0.3, -0.2])
    from mbs.runtime.workspace import Workspace
    np.testing.assert_array_equal(Workspace(model).rhs(0.0, x), Workspace(pendulum.compile("swing")).rhs(0.0, x))
