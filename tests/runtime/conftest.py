"""Shared fixtures of the run-time tests: hand-written models in the generated-code shape (fixtures/),
built once per session into a private cache directory."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mbs.runtime import build
from mbs.runtime.backends import CBackend
from mbs.runtime.model import CompiledModel, load_numpy

FIXTURES = Path(__file__).parent / "fixtures"
G = 9.81

PENDULUM_INFO = dict(name="pendulum", q_names=["hinge.phi"], v_names=["hinge.phi_dot"], p_names=["m", "l", "g"],
                     y_names=["angle", "energy"], p_default=[1.0, 1.0, G], x0=[np.radians(30), 0.0],
                     units={"hinge.phi": "rad", "hinge.phi_dot": "rad/s", "energy": "J"})
#: quarter car: [m_wheel, m_body, k_tyre, c_tyre, k_spring, c_damper, road amplitude, road frequency]
QUARTER_CAR_P = [1e-3, 1.0, 1e5, 100.0, 100.0, 1.0, 0.01, 20.0]


@pytest.fixture(scope="session")
def cache_dir(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("mbs-cache")


@pytest.fixture(scope="session")
def builds(cache_dir) -> dict[str, build.BuildResult]:
    """Fresh builds of every C fixture (the session's cache starts empty), by file name."""
    return {path.name: build.build_file(path, cache_dir=cache_dir) for path in sorted(FIXTURES.glob("*.c"))}


def _load(builds, filename, **info) -> CompiledModel:
    return CompiledModel.from_backend(CBackend(build.load(builds[filename])), **info)


@pytest.fixture(scope="session")
def pendulum(builds):
    return _load(builds, "pendulum.c", **PENDULUM_INFO)


@pytest.fixture(scope="session")
def pendulum_numpy():
    return load_numpy(FIXTURES / "pendulum_numpy.py", **PENDULUM_INFO)


@pytest.fixture(scope="session")
def failing(builds):
    """Pendulum failing from t = p[3] on; p[4] selects how (see fixtures/pendulum_failing.c)."""
    return _load(builds, "pendulum_failing.c", name="failing", q_names=["phi"], v_names=["omega"],
                 p_default=[1.0, 1.0, G, 0.5, 0.0], x0=[0.5, 0.0])


@pytest.fixture(scope="session")
def order_problems(builds):
    """Linear, Prothero-Robinson and van der Pol with exact Jacobians; p = [problem, ...]
    (fixtures/order_problems.c)."""
    return _load(builds, "order_problems.c", name="order_problems", q_names=["x0"], v_names=["x1"],
                 p_default=[0.0, 1.0, 10.0], x0=[1.0, 0.0])


@pytest.fixture(scope="session")
def quarter_car(builds):
    return _load(builds, "quarter_car.c", name="quarter_car", q_names=["z_wheel", "z_body"],
                 v_names=["vz_wheel", "vz_body"], p_default=QUARTER_CAR_P, x0=[0.0, 0.0, 0.0, 0.0])
