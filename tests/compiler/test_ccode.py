"""The C printer and the emitter: golden expressions, the file contract, status codes, determinism, size."""

import hashlib
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).parents[2] / "bench"))
import treekit  # noqa: E402
from chain import chain  # noqa: E402

from mbs.compiler.ccode import CEmitter, CodegenError, CPrinter, generate_c  # noqa: E402
from mbs.compiler.equations import derive_equations  # noqa: E402
from mbs.compiler.kinematics import Kinematics  # noqa: E402
from mbs.compiler.tree import JointSpec, Tree, TreeBody, t  # noqa: E402

a, b, c = sp.symbols("a b c")
PRINTER = CPrinter({a: "a", b: "b", c: "c_1", t: "t"})


@pytest.mark.parametrize("expr, text", [
    (a + b, "a + b"),
    (a - b * c, "a - b*c_1"),
    (-a - b, "-a - b"),
    (a * (b + c), "a*(b + c_1)"),
    (-a * b, "-a*b"),
    (a / b, "a/b"),
    (a / (b * c), "a/(b*c_1)"),
    (2 * a / (b + c), "2*a/(b + c_1)"),
    (a**2, "a*a"),
    (a**3, "a*a*a"),
    ((a + b)**2, "pow(a + b, 2)"),
    (1 / a, "1.0/a"),
    (1 / a**2, "1.0/(a*a)"),
    (sp.sqrt(a), "sqrt(a)"),
    (1 / sp.sqrt(a), "1.0/sqrt(a)"),
    (a**sp.Rational(3, 2), "pow(a, 1.5)"),
    (sp.Rational(1, 3) * a, "0.3333333333333333*a"),
    (sp.Float(0.1) + a, "0.1 + a"),
    (a - sp.pi, "a - 3.141592653589793"),
    (sp.sin(a) * sp.cos(t), "mbs_cos(t)*mbs_sin(a)"),  # compiler/ccode_trig.py
    (sp.Abs(a - b), "fabs(a - b)"),
    (sp.atan2(a, b), "atan2(a, b)"),
    (sp.Max(a, b, c), "fmax(fmax(a, b), c_1)"),
    (sp.Piecewise((a, b > 0), (c, True)), "(b > 0 ? a : c_1)"),
    (a - b * (-c), "a + b*c_1"),
])
def test_printer(expr, text):
    assert PRINTER.doprint(expr) == text


def test_printer_rejects_what_c_cannot_say():
    with pytest.raises(CodegenError, match="besselj"):
        PRINTER.doprint(sp.besselj(0, a))
    with pytest.raises(CodegenError, match="neither"):
        PRINTER.doprint(sp.Symbol("unknown") + a)


def _pendulum(mass=None):
    m, l, g = sp.symbols("m l g")
    arm = TreeBody("arm", -1, JointSpec("revolute", ((0, 1, 0),)), (sp.eye(3), (0, 0, 0)),
                   (sp.eye(3), (0, 0, 0)), m if mass is None else mass, (0, 0, -l), sp.zeros(3))
    return derive_equations(Kinematics(Tree((arm,), (0, 0, -g)))), [g, l, m]


def test_contract_and_parameter_order():
    eqs, params = _pendulum()
    source = generate_c(eqs, [params[2], params[0], params[1]], "pendulum")
    for line in ("#define MBS_NQ 1", "#define MBS_NV 1", "#define MBS_NX (MBS_NQ+MBS_NV)", "#define MBS_NP 3",
                 "#define MBS_NWORK 1",
                 "int mbs_rhs(double t, const double *x, const double *p, double *xdot, double *work)",
                 "int mbs_mass_matrix(double t, const double *x, const double *p, double *M, double *work)",
                 "int mbs_forces(double t, const double *x, const double *p, double *f, double *work)",
                 "int mbs_qdot(double t, const double *x, const double *p, double *qdot, double *work)",
                 "const double m = p[0];   /* m */", "const double g = p[1];   /* g */",
                 "const double arm_phi = x[0];"):
        assert line in source, line
    assert source.startswith('/* Equations of motion of the model "pendulum".')
    with pytest.raises(CodegenError, match="missing.*l"):
        generate_c(eqs, [params[0], params[2]])


def test_status_codes(tmp_path):
    eqs, params = _pendulum()
    model = treekit.CModel(generate_c(eqs, params), tmp_path)
    p = [9.81, 0.5, 2.0]
    assert model.call("mbs_rhs", 0.0, [0.3, 0.0], p, 2)[0] == 0
    # A massless pendulum has a zero articulated inertia and a zero mass matrix.
    assert model.call("mbs_rhs", 0.0, [0.3, 0.0], [9.81, 0.5, 0.0], 2)[0] == 1
    assert model.call("mbs_mass_matrix", 0.0, [0.3, 0.0], [9.81, 0.5, 0.0], 1)[0] == 1
    assert model.call("mbs_mass_matrix", 0.0, [0.3, 0.0], [9.81, 0.5, -2.0], 1)[0] == 1
    # Not-a-number in the state or the parameters (M = m l^2 does not depend on the state).
    for fn, n in (("mbs_rhs", 2), ("mbs_forces", 1)):
        assert model.call(fn, 0.0, [np.nan, 0.0], p, n)[0] == 2
    assert model.call("mbs_mass_matrix", 0.0, [np.nan, 0.0], p, 1)[0] == 0
    for fn, n in (("mbs_rhs", 2), ("mbs_forces", 1), ("mbs_mass_matrix", 1)):
        assert model.call(fn, 0.0, [0.3, 0.0], [9.81, np.nan, 2.0], n)[0] == 2
    names = [model.lib.mbs_state_name(i) for i in range(3)]
    assert names == [b"arm.phi", b"arm.der(phi)", None]


def test_structurally_singular_tree_is_rejected_at_derivation():
    with pytest.raises(ZeroDivisionError, match="singular"):
        _pendulum(mass=0)


def test_pivot_checked_before_division():
    eqs, params = _pendulum()
    rhs = generate_c(eqs, params).split("int mbs_rhs")[1]
    assert rhs.index("MBS_PIVOT(") < rhs.index("1.0/")


def _chain_source(n):
    eqs = derive_equations(Kinematics(chain(n, symbolic=True)))
    return generate_c(eqs, eqs.parameters(), f"chain{n}")


def test_text_is_deterministic_across_processes():
    source = _chain_source(4)
    script = ("import sys; sys.path.insert(0, 'bench'); from chain import chain; import hashlib;"
              "from mbs.compiler.equations import derive_equations; from mbs.compiler.kinematics import Kinematics;"
              "from mbs.compiler.ccode import generate_c;"
              "e = derive_equations(Kinematics(chain(4, symbolic=True)));"
              "print(hashlib.sha256(generate_c(e, e.parameters(), 'chain4').encode()).hexdigest())")
    other = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True,
                           cwd=Path(__file__).parents[2], env={"PYTHONHASHSEED": "123", "PATH": ""})
    assert other.stdout.strip() == hashlib.sha256(source.encode()).hexdigest()
    assert source == _chain_source(4)


def test_ten_link_chain_compiles_cleanly_and_stays_small(tmp_path):
    # Regression bound on the size: about 90 KiB at the time of writing (symbolic masses and lengths).
    source = _chain_source(10)
    assert len(source.encode()) < 100 * 1024
    model = treekit.CModel(source, tmp_path)
    assert model.warnings == ""
    assert model.sizes["MBS_NQ"] == 10 and model.sizes["MBS_NP"] == 21
    x = np.linspace(-1, 1, 20)
    p = [9.81] + [1.0] * 20
    out = model.evaluate(0.0, x, p)
    np.testing.assert_allclose(np.linalg.solve(out["M"], out["f"]), out["vdot"], rtol=1e-10, atol=1e-10)


def test_emitter_refuses_equations_without_forward_dynamics():
    m = sp.Symbol("m")
    arm = TreeBody("arm", -1, JointSpec("prismatic", ((1, 0, 0),)), (sp.eye(3), (0, 0, 0)),
                   (sp.eye(3), (0, 0, 0)), m, (0, 0, 0), sp.zeros(3))
    eqs = derive_equations(Kinematics(Tree((arm,), (0, 0, -1))), forward_dynamics=False)
    with pytest.raises(CodegenError, match="forward dynamics"):
        CEmitter(eqs, [m])
