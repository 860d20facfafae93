"""IDA on closed loops as the stabilised index-2 DAE (runtime/integrators/ggl.py), checked against the ODE form
(the projected tree state, dopri5 at a tight tolerance) on the slider-crank."""

import numpy as np
import pytest

import mbs
from mbs.runtime.integrators.ggl import GGL
from mbs.runtime.integrators.ida import Ida
from mbs.runtime.simulate import simulate
from mbs.runtime.workspace import Workspace

pytest.importorskip("sksundae")


@pytest.fixture(scope="module")
def slider_crank():
    system = mbs.load("library/examples/slider_crank.mbs")
    return system.start(None)


def _run(data, settings, integrator, rtol):
    work = Workspace(data.model)
    work.p, work.t, work.x = data.p, data.t, data.x.copy()
    res = simulate(data.model, work, settings["t_end"], sample=0.01, integrator=integrator, rtol=rtol,
                   atol=1e-2 * rtol, outputs=False)
    assert res.metadata["status"] == "finished"
    return np.column_stack([res[n] for n in data.model.x_names])


def test_the_dae_keeps_independent_rows_and_starts_consistent(slider_crank):
    data, _ = slider_crank
    ggl = GGL(data, 0.0, data.x)
    report = data.loop_report(0.0, data.x)
    assert ggl.nc == int(report[5]) < data.constraints(0.0, data.x).size  # redundant rows of a planar loop dropped
    res = np.empty(ggl.n)
    ggl.residual(0.0, ggl.y0, ggl.yp0, res)
    assert np.abs(res).max() < 1e-9


def test_ida_stays_on_the_constraints_without_projection(slider_crank):
    data, settings = slider_crank
    solver = Ida(data.rhs, 0.0, data.x.copy(), settings["t_end"], rtol=1e-8, atol=1e-10, workspace=data)
    worst = 0.0
    while solver.status == "running":
        solver.step()
        worst = max(worst, np.abs(data.constraints(solver.t, solver.y)).max())
    assert solver.status == "finished" and solver.y.size == data.model.nx
    assert worst < 1e-8  # positions on g = 0 at every step: the DAE holds them, nothing projects


def test_ida_dae_converges_to_the_ode_form(slider_crank):
    data, settings = slider_crank
    reference = _run(data, settings, "dopri5", 1e-12)
    errors = [np.abs(_run(data, settings, "ida", rtol) - reference).max() for rtol in (1e-5, 1e-7, 1e-9)]
    assert errors[2] < 1e-6
    assert errors[1] < 0.2 * errors[0] and errors[2] < 0.2 * errors[1]
