"""One model, one workspace per run: runs in threads agree with sequential runs and overlap in C."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np

from mbs.runtime.simulate import simulate
from mbs.runtime.workspace import Workspace


def run(model, length):
    data = Workspace(model)
    data.set_param("l", length)
    return simulate(model, data, 5.0, sample=0.01, rtol=1e-9, atol=1e-11)


def test_threads_with_one_workspace_each_match_sequential_runs(pendulum):
    lengths = [0.5, 1.0, 1.5, 2.0]
    sequential = [run(pendulum, l) for l in lengths]
    with ThreadPoolExecutor(max_workers=4) as pool:
        parallel = list(pool.map(lambda l: run(pendulum, l), lengths))
    for a, b in zip(sequential, parallel):
        np.testing.assert_array_equal(a.data, b.data)
    # different parameters really gave different runs
    assert not np.allclose(sequential[0]["hinge.phi"], sequential[-1]["hinge.phi"])


def test_workspaces_do_not_share_state(pendulum):
    a, b = Workspace(pendulum), Workspace(pendulum)
    a.set_param("g", 1.0)
    a.x = [1.0, 0.0]
    assert b.p[2] == 9.81 and b.x[0] == pendulum.x0[0]
    assert a.rhs(0.0, [1.0, 0.0])[1] != b.rhs(0.0, [1.0, 0.0])[1]
    simulate(pendulum, a, 1.0)
    assert a.t == 1.0 and b.t == 0.0
    a.reset()
    assert a.t == 0.0 and a.p[2] == 9.81 and a.x[0] == pendulum.x0[0]


def test_numpy_back_end_simulates_like_c(pendulum, pendulum_numpy):
    c = simulate(pendulum, Workspace(pendulum), 2.0, sample=0.1, integrator="RK45", rtol=1e-9, atol=1e-12)
    py = simulate(pendulum_numpy, Workspace(pendulum_numpy), 2.0, sample=0.1, integrator="RK45", rtol=1e-9,
                  atol=1e-12)
    np.testing.assert_allclose(c.data, py.data, rtol=0, atol=1e-13)
    assert py.metadata["backend"] == "numpy" and c.metadata["backend"] == "c"
