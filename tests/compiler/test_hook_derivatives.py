"""The derivatives of user hooks in the generated Jacobians (compiler/hooks.py): the hook's own derivative when
its implementation has one (C `NAME_derivative`, a Python callable's `.derivative`), else central differences
of the hook. Checked against the same law written as a plain expression in the model (hook_friction.mbs,
`plain = 1`), whose Jacobians sympy differentiates exactly, at states across stick and slip."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import mbs
from mbs.runtime.build import have_c_compiler
from mbs.runtime.hook_implementations import implementation

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "library" / "examples" / "hook_friction.mbs"
HOOKS = ROOT / "tests" / "runtime" / "hooks"
C_LAW = str(ROOT / "library" / "examples" / "hooks" / "friction_law.c")
STATES = ([0.01, 0.1], [0.02, 0.17], [-0.03, 0.5], [0.0, 0.2])  # slip speeds 0.1, 0.03, -0.3, 0 m/s
needs_c = pytest.mark.skipif(not have_c_compiler(), reason="no C compiler")


def jacobians(impl, plain: int = 0, backend: str = "c"):
    """(d xdot/d x, d xdot/d p) at STATES of hook_friction.mbs with the friction law `impl`."""
    system = mbs.load(EXAMPLE, backend=backend)
    data, _ = system.start("cycles", params={"plain": plain}, jacobian=True, parameter_jacobian=True,
                           hooks={"friction_law": impl})
    assert {"jacobian", "param_jacobian"} <= set(data.model.functions)
    x = [np.array(s) for s in STATES]
    return (np.array([data.function("jacobian")(0.0, s) for s in x]),
            np.array([data.function("param_jacobian")(0.0, s) for s in x]))


def relative(a, b) -> float:
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


@pytest.fixture(scope="module")
def plain():
    return jacobians(C_LAW, plain=1, backend="c" if have_c_compiler() else "numpy")


def python(path: Path, function: str = "friction_law") -> object:
    return implementation("friction_law", f"{path}:{function}")


@needs_c
@pytest.mark.parametrize("impl", [C_LAW, str(ROOT / "library" / "examples" / "hooks" / "friction_law.py")],
                         ids=["c", "python"])
def test_a_hook_without_derivative_is_differenced_centrally(plain, impl):
    J, P = jacobians(impl if impl.endswith(".c") else python(Path(impl)))
    # a central difference is off by h^2/6 times the ratio of the third to the first derivative; with
    # h = cbrt(eps) * max(|w|, 1 m/s) = 6.06e-6 m/s and f ~ tanh(w / 0.01 m/s) that ratio is 2 / (0.01 m/s)^2
    # at w = 0: 1.22e-7 relative
    assert relative(J, plain[0]) < 1.3e-7 and relative(P, plain[1]) < 1.3e-7
    assert relative(J, plain[0]) > 1e-12  # differences, not the exact derivative


@needs_c
@pytest.mark.parametrize("impl", ["c", "python"])
def test_the_hooks_own_derivative_is_used_exactly(plain, impl):
    law = str(HOOKS / "friction_law_derivative.c") if impl == "c" else python(HOOKS / "friction_law_derivative.py")
    J, P = jacobians(law)
    assert relative(J, plain[0]) < 1e-14 and relative(P, plain[1]) < 1e-13


@needs_c
def test_a_wrong_derivative_shows_it_is_the_one_used(plain):
    J, _ = jacobians(python(HOOKS / "friction_law_derivative.py", "wrong_law"))
    assert relative(J, plain[0]) > 0.1


def test_the_numpy_back_end_differentiates_a_python_hook_the_same_way(plain):
    J, P = jacobians(python(ROOT / "library" / "examples" / "hooks" / "friction_law.py"), backend="numpy")
    assert relative(J, plain[0]) < 1.3e-7 and relative(P, plain[1]) < 1.3e-7
    J, P = jacobians(python(HOOKS / "friction_law_derivative.py"), backend="numpy")
    assert relative(J, plain[0]) < 1e-14 and relative(P, plain[1]) < 1e-13


@needs_c
def test_a_derivative_of_the_wrong_shape_stops_the_run_naming_the_hook():
    law = python(HOOKS / "friction_law_derivative.py").load()

    def hook(*args):
        return law(*args)
    hook.derivative = lambda *args: [1.0, 2.0, 3.0]  # four arguments: four values
    res = mbs.load(EXAMPLE).simulate("cycles", integrator="rodasp", hooks={"friction_law": hook})
    assert not res.success
    assert "hook 'friction_law' failed" in res.message
    assert "its derivative: ValueError: the derivative returned 3 values; 1 result(s) x 4 argument(s)" in res.message



@needs_c
def test_a_c_derivative_that_fails_stops_the_run_naming_the_hook():
    res = mbs.load(EXAMPLE).simulate("cycles", integrator="rodasp",
                                     hooks={"friction_law": str(HOOKS / "failing_derivative.c")})
    assert not res.success
    assert "hook 'friction_law' failed at t = 0 s (w = 0.2 m/s, n = 9.81 N, mu_s = 0.6, mu_k = 0.4): its derivative " \
           "returned status 3" in res.message
