"""The residuals of the loop constraints and their rate from one generated function (compiler/ccode_loops.py
mbs_constraints_with_velocity, [g; G v + g_t]), which the projections of an accepted step and of a row evaluate at the
positions they end with (runtime/c/loops.c mbs_loop_residuals): the same values as mbs_constraints and
mbs_constraint_velocity apart, to round-off, on a four-bar whose crank is driven by a prescribed motion (g_t not zero)
at states off the constraints."""

from __future__ import annotations

import ctypes

import numpy as np
import pytest
import sympy as sp

from mbs.runtime import build
from test_loops import FB, Mechanism, at, bar, four_bar_state
from mbs.compiler.constraints import CutJoint
from mbs.compiler.tree import JointSpec

pytestmark = pytest.mark.skipif(not build.have_c_compiler(), reason="needs a C compiler")

PLANE = ((0, -1, 0),)


@pytest.fixture(scope="module")
def driven_four_bar(cache_dir):
    a, b, c, d = FB.values()
    tt = sp.Symbol("t")
    theta_t = 0.5 + 2 * tt + sp.Rational(3, 10) * sp.sin(3 * tt)
    bodies = (bar("crank", -1, at(0), a, 1.0, prescribed=(theta_t,)), bar("coupler", 0, at(a), b, 0.8),
              bar("rocker", -1, at(d), c, 1.2))
    return Mechanism("driven_four_bar_rates", bodies,
                     [CutJoint("pin", JointSpec("revolute", PLANE), 1, at(b), 2, at(c))], cache_dir)


def constraints_with_velocity(model):
    """The generated function, called from its library (it is the loop solver's, not in the function table)."""
    module = model.backend.module
    function = ctypes.CDLL(module.__file__).mbs_constraints_with_velocity
    function.restype = ctypes.c_int
    pointer = ctypes.POINTER(ctypes.c_double)
    function.argtypes = [ctypes.c_double, pointer, pointer, pointer, pointer]
    work = np.zeros(module.NWORK)

    def call(t, x, p, nc):
        x, p, out = np.ascontiguousarray(x, dtype=float), np.ascontiguousarray(p, dtype=float), np.empty(2 * nc)
        status = function(t, *(a.ctypes.data_as(pointer) for a in (x, p, out, work)))
        return status, out
    return call


def test_residuals_and_their_rate_from_one_pass_are_those_of_the_two_functions(driven_four_bar):
    mech = driven_four_bar
    data = mech.workspace([*four_bar_state(0.5, 0.0, **FB)[1:3], 0.0, 0.0], fixed=[])
    nc = len(mech.constraints.names)
    call = constraints_with_velocity(mech.model)
    rng = np.random.default_rng(7)
    for t in (0.0, 0.37, 1.9):
        x = np.array(data.x) + rng.normal(scale=1e-3, size=len(data.x))  # off the constraints, moving
        status, out = call(t, x, data.p, nc)
        assert status == 0
        g, gdot = data.constraints(t, x), data.constraint_velocity(t, x)
        resting = x.copy()
        resting[data.model.nq:] = 0.0
        assert np.max(np.abs(g)) > 1e-5 and np.max(np.abs(gdot)) > 1e-5  # something to compare
        assert np.max(np.abs(data.constraint_velocity(t, resting))) > 0.1  # g_t: the prescribed crank's
        np.testing.assert_allclose(out[:nc], g, rtol=1e-14, atol=1e-16)
        np.testing.assert_allclose(out[nc:], gdot, rtol=1e-14, atol=1e-15)
