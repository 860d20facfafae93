"""Model functions at many rows (runtime/rows.py): the C back end's one call (Function.rows) gives what calling the
function row by row gives, with the run-time values of each row in force, and stops at the first failing row."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import mbs
from mbs.runtime.rows import evaluate_rows, project_and_evaluate_rows, project_rows
from mbs.runtime.simulate import simulate

SLIDER_CRANK = Path(__file__).resolve().parents[2] / "library" / "examples" / "slider_crank.mbs"
SPRING = '''
model spring {
    param k = 100 N/m
    rigid mass {
        body {
            mass = 1 kg
            inertia = diag(1, 1, 1) kg*m^2
        }
    }
    interact slide {
        connect inertial -> mass
        joint prismatic(axis = x) {
            init s = 0.5 m
        }
        force f = joint(s = -k * slide.s)
    }
    output push = k * slide.s
}
'''


def run(system):
    res = system.simulate(t_end=0.5, sample=0.01)
    compiled = system.compile()
    data = system._workspace(compiled, system.generate(), {p.name: p.value for p in system.model.parameters})
    return data, res.t, res.data[:, 1:1 + compiled.nx]


@pytest.fixture(scope="module")
def crank():
    return run(mbs.load(SLIDER_CRANK))


@pytest.fixture(scope="module")
def spring():
    return run(mbs.loads(SPRING))


def one_by_one(data, name, ps, ts, xs, which):
    """The reference: the bound function called per row, p set by hand."""
    f, saved, rows = data.function(name), data.p.copy(), []
    for t, x, k in zip(ts, xs, which):
        data.p[:] = ps[k]
        rows.append(f(float(t), x))
    data.p[:] = saved
    return np.array(rows)


@pytest.mark.parametrize("case, name, parameter", [("crank", "project", "L"), ("spring", "outputs", "k")])
def test_one_call_gives_the_rows_of_single_calls_with_each_rows_values(request, case, name, parameter):
    data, ts, xs = request.getfixturevalue(case)
    longer = data.p.copy()
    longer[data.model.parameter_index(parameter)] *= 1.1  # another rod (other constraints), another spring
    ps, which = [data.p.copy(), longer], (np.arange(len(ts)) // 7) % 2
    xs = xs + 1e-6 * np.sin(np.arange(xs.size)).reshape(xs.shape)  # off the constraints: the projection works
    before = data.p.copy()
    out = np.empty((len(ts), len(one_by_one(data, name, ps, ts[:1], xs[:1], which[:1])[0])))
    assert hasattr(data.function(name), "rows")  # the C back end
    assert evaluate_rows(data, name, ps, ts, xs, which, out) == (len(ts), None)
    np.testing.assert_array_equal(out, one_by_one(data, name, ps, ts, xs, which))
    np.testing.assert_array_equal(data.p, before)  # the workspace's values restored


def test_a_failing_row_stops_the_call_there_with_its_error(crank):
    data, ts, xs = crank
    xs = xs.copy()
    xs[5, 0] = np.nan  # a state the projection cannot close
    out = np.empty_like(xs)
    done, error = evaluate_rows(data, "project", [data.p], ts, xs, np.zeros(len(ts), dtype=np.intp), out)
    assert done == 5 and error is not None
    np.testing.assert_array_equal(out[:5], one_by_one(data, "project", [data.p], ts[:5], xs[:5], [0] * 5))


#: The slider crank with outputs that read the loop solve's accelerations (mbs_loop_rates in its mbs_outputs).
CRANK_ACCELERATION = SLIDER_CRANK.read_text().rstrip()[:-1] + '''
    interact slider_motion {
        connect inertial -> slider
        sensor acceleration = acceleration(in = inertial)
    }
    output slider_acc = slider_motion.acceleration.x
    output crank_rate = der(main_bearing.phi)
}
'''


@pytest.fixture(scope="module")
def crank_outputs():
    return run(mbs.loads(CRANK_ACCELERATION))


@pytest.fixture(scope="module")
def crank_outputs_numeric():
    """The crank with the numeric loop solver alone: its rows go through c/loops.c mbs_loop_project_row (a closed
    form projects them itself), which starts each row's Newton steps from the factors of G the row before it left."""
    system = mbs.loads(CRANK_ACCELERATION)
    compiled, gen = system.compile(closed_form=False), system.generate(closed_form=False)
    values = {p.name: p.value for p in system.model.parameters}
    res = simulate(compiled, system._workspace(compiled, gen, values), 0.5, sample=0.01)
    return system._workspace(compiled, gen, values), res.t, res.data[:, 1:1 + compiled.nx]


def one_pass_with_two_lengths(data, ts, xs):
    """The outputs' one pass in C over the rows xs moved off the constraints (so the projection works), the loop's
    length L switching between two values every 7 rows: (ps, which, the moved xs, projected, outputs)."""
    longer = data.p.copy()
    longer[data.model.parameter_index("L")] *= 1.1
    ps, which = [data.p.copy(), longer], (np.arange(len(ts)) // 7) % 2
    xs = xs + 1e-6 * np.sin(np.arange(xs.size)).reshape(xs.shape)
    projected, ys = np.empty_like(xs), np.empty((len(ts), data.model.ny))
    assert data.function("outputs").rows(np.ascontiguousarray(ts), xs, ys, np.array(ps), which.astype(np.intp),
                                         projected) == len(ts)
    return ps, which, xs, projected, ys


@pytest.mark.parametrize("case", ["crank_outputs", "crank_outputs_numeric"])
def test_one_pass_projects_each_row_and_gives_its_outputs_there(request, case):
    """Function.rows with `projected`: each row's projection, and the outputs at it from the loop solve that starts
    from the projection's factors (not projecting again), against project then outputs called row by row.  The
    two differ only by the round-off of a second projection of a projected state.  With the numeric loop solver
    (crank_outputs_numeric) each row's Newton steps start from the factors of G the row before it left, where
    project evaluates and factors G afresh: the same positions (the independent ones stay in both) to the Newton
    tolerance, the same velocities and outputs to round-off, rows after a change of the loop's length included."""
    data, ts, xs = request.getfixturevalue(case)
    ps, which, xs, projected, ys = one_pass_with_two_lengths(data, ts, xs)
    assert project_and_evaluate_rows(data, "outputs", ps, ts, xs, which, projected, ys) == (len(ts), None, None)
    reference = one_by_one(data, "project", ps, ts, xs, which)
    np.testing.assert_allclose(projected, reference, rtol=1e-12, atol=1e-14)
    outputs = one_by_one(data, "outputs", ps, ts, reference, which)
    np.testing.assert_allclose(ys, outputs, rtol=1e-9, atol=1e-9 * np.abs(outputs).max())
    assert np.ptp(ys[:, 0]) > 1.0  # the slider's acceleration varies over the run: the comparison means something


#: The slider crank with outputs of positions alone: its mbs_outputs solves no loops (no mbs_loop_rates), so each row
#: of the one pass starts its Newton steps from the factors of G the projection of the row before it left.
CRANK_POSITIONS = SLIDER_CRANK.read_text().rstrip()[:-1] + '''
    output slider_x = guide.s
    output rod_angle = crank_pin.phi
}
'''


@pytest.fixture(scope="module")
def crank_positions_numeric():
    system = mbs.loads(CRANK_POSITIONS)
    compiled, gen = system.compile(closed_form=False), system.generate(closed_form=False)
    values = {p.name: p.value for p in system.model.parameters}
    res = simulate(compiled, system._workspace(compiled, gen, values), 0.5, sample=0.01)
    return system._workspace(compiled, gen, values), res.t, res.data[:, 1:1 + compiled.nx]


def test_one_pass_of_outputs_without_loop_solve_projects_each_row_as_project_does(crank_positions_numeric):
    """Outputs that read no accelerations: each row's projection starts from the factors the projection of the row
    before it left (c/loops.c mbs_loop_row_factors_hold), where project evaluates and factors G afresh; the same
    projection to round-off (the positions to the Newton tolerance), rows after a change of the loop's length
    included, and the outputs there."""
    data, ts, xs = crank_positions_numeric
    ps, which, xs, projected, ys = one_pass_with_two_lengths(data, ts, xs)
    reference = one_by_one(data, "project", ps, ts, xs, which)
    np.testing.assert_allclose(projected, reference, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(ys, one_by_one(data, "outputs", ps, ts, reference, which), rtol=1e-12, atol=1e-14)
    assert np.ptp(ys[:, 0]) > 0.1  # the slider moves over the run: the comparison means something


def test_the_rows_projection_gives_project_row_by_row(crank_positions_numeric):
    """The rows of a run without outputs (rows.project_rows: `project_row`, c/loops.c mbs_loop_project_row): each
    row's Newton steps start from the factors the row before it left; the same projection as project afresh to
    round-off, rows after a change of the loop's length included, and a row that cannot be closed stops them."""
    data, ts, xs = crank_positions_numeric
    assert "project_row" in data.model.functions
    longer = data.p.copy()
    longer[data.model.parameter_index("L")] *= 1.1
    ps, which = [data.p.copy(), longer], (np.arange(len(ts)) // 7) % 2
    xs = xs + 1e-6 * np.sin(np.arange(xs.size)).reshape(xs.shape)
    projected = np.empty_like(xs)
    assert project_rows(data, ps, ts, xs, which, projected) == (len(ts), None)
    reference = one_by_one(data, "project", ps, ts, xs, which)
    np.testing.assert_allclose(projected, reference, rtol=1e-12, atol=1e-14)
    assert not np.array_equal(projected, xs)  # the rows were off the constraints
    xs[5, 0] = np.nan
    done, error = project_rows(data, ps, ts, xs, which, projected)
    assert done == 5 and error is not None


def test_one_pass_names_the_stage_that_failed(crank_outputs):
    data, ts, xs = crank_outputs
    xs = xs.copy()
    xs[5, 0] = np.nan  # a state the projection cannot close
    projected, ys = np.empty_like(xs), np.empty((len(ts), data.model.ny))
    done, error, stage = project_and_evaluate_rows(data, "outputs", [data.p], ts, xs, np.zeros(len(ts), dtype=np.intp),
                                                   projected, ys)
    assert (done, stage) == (5, "project") and error is not None
    reference = one_by_one(data, "project", [data.p], ts[:5], xs[:5], [0] * 5)
    np.testing.assert_allclose(projected[:5], reference, rtol=1e-12, atol=1e-14)
