"""The C emitter's outputs, lookup tables and printing of every expression kind the language produces: golden
texts, warning-free compilation, values against hand-written formulas and mbs.language.expr.interpolate."""

import ctypes
import dataclasses
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

sys.path.insert(0, str(Path(__file__).parent))
import treekit  # noqa: E402

from mbs.compiler.ccode import CodegenError, CPrinter, generate_c  # noqa: E402
from mbs.compiler.equations import derive_equations  # noqa: E402
from mbs.compiler.kinematics import Kinematics  # noqa: E402
from mbs.compiler.lower import lower  # noqa: E402
from mbs.compiler.symbolic import parameter_symbol  # noqa: E402
from mbs.pipeline import run_parameters  # noqa: E402
from mbs.compiler.tree import JointSpec, Tree, TreeBody, t  # noqa: E402
from mbs.language import expr as X  # noqa: E402
from mbs.language.frontend import load, load_text  # noqa: E402
from mbs.runtime.model import load_c  # noqa: E402
from mbs.runtime.workspace import Workspace  # noqa: E402

EXAMPLES = Path(__file__).parents[2] / "library" / "examples"
a, b, c = sp.symbols("a b c")
PRINTER = CPrinter({a: "a", b: "b", c: "c_1", t: "t"}, 1)
table0 = sp.Function("mbs_table_0")


@pytest.mark.parametrize("expr, text", [
    (sp.sign(a - b), "mbs_sign(a - b)"),
    (sp.Piecewise((a, b > 0), (sp.Piecewise((b, c < 1), (c, True)), True)), "(b > 0 ? a : (c_1 < 1 ? b : c_1))"),
    (sp.Piecewise((1, a > 0), (0, True)), "(a > 0 ? 1.0 : 0.0)"),   # never an int-valued C expression
    (sp.Mul(sp.Piecewise((1, a > 0), (2, True)), sp.Pow(sp.Piecewise((3, b > 0), (4, True)), -1, evaluate=False),
            evaluate=False), "(a > 0 ? 1.0 : 2.0)/(b > 0 ? 3.0 : 4.0)"),  # (int)/(int) would truncate
    (sp.Piecewise((a, a > 0), (b, b > 0)), "(a > 0 ? a : (b > 0 ? b : NAN))"),
    (sp.Piecewise((a, sp.And(a > 0, b < 1)), (c, True)), "((a > 0) && (b < 1) ? a : c_1)"),
    (sp.Piecewise((a, sp.Or(a > 0, b < 1)), (c, True)), "((a > 0) || (b < 1) ? a : c_1)"),
    (sp.Piecewise((a, sp.Eq(a, b)), (c, sp.Ne(b, 2))), "(a == b ? a : (b != 2 ? c_1 : NAN))"),
    (sp.Not(a), "!(a)"),
    (sp.Min(a, 0), "fmin(0.0, a)"),
    (sp.Max(a, b, 1), "fmax(fmax(1.0, a), b)"),
    (sp.atan2(a, b) + sp.asin(a) + sp.acos(b), "acos(b) + asin(a) + atan2(a, b)"),
    (sp.sinh(a) * sp.cosh(b) / sp.tanh(c), "cosh(b)*sinh(a)/tanh(c_1)"),
    (sp.exp(a) + sp.log(b), "exp(a) + log(b)"),
    (a**-3, "1.0/(a*a*a)"),
    (a**sp.Rational(1, 3), "pow(a, 0.3333333333333333)"),
    (a**5, "pow(a, 5)"),
    ((a + b)**-2, "1.0/pow(a + b, 2)"),
    ((a + b)**3, "mbs_pow3(a + b)"),                              # the C library's pow(x, 3) is a call
    ((a + b)**-4, "1.0/mbs_pow4(a + b)"),
    (a**4, "mbs_pow4(a)"),
    (2**a, "pow(2, a)"),
    (sp.Integer(2**40) * a, "1099511627776.0*a"),                 # beyond a C int
    (a - sp.Integer(2**40), "a - 1099511627776.0"),
    (sp.Float(1e-30) * a, "1e-30*a"),
    (sp.Float("0.1", 30) * a, "0.1*a"),
    (table0(a) + 1, "1 + mbs_table_0(a)"),
])
def test_printer(expr, text):
    assert PRINTER.doprint(expr) == text


def test_printer_refuses_what_has_no_value():
    for bad in (sp.nan, sp.zoo, sp.oo * a):
        with pytest.raises(CodegenError, match="non-finite"):
            PRINTER.doprint(bad + b)
    with pytest.raises(CodegenError, match="table 1.*only 1"):
        PRINTER.doprint(sp.Function("mbs_table_1")(a))
    with pytest.raises(CodegenError, match="mbs_table"):
        CPrinter({a: "a"}).doprint(table0(a))


# ---- small models built directly on a tree ---------------------------------------------------------------------

def _slider(mass=None):
    """A mass m on a prismatic joint along x under gravity g along -x: vdot = -g."""
    m, g = sp.symbols("m g")
    body = TreeBody("slider", -1, JointSpec("prismatic", ((1, 0, 0),)), (sp.eye(3), (0, 0, 0)),
                    (sp.eye(3), (0, 0, 0)), m if mass is None else mass, (0, 0, 0), sp.eye(3))
    eqs = derive_equations(Kinematics(Tree((body,), (-g, 0, 0))))
    return eqs, [m, g]


def _c_outputs(source: str, directory: Path, ny: int):
    """f(t, x, p) -> (status, y) of a generated file's mbs_outputs, compiled with -Wall -Wextra -Werror."""
    model = treekit.CModel(source, directory)
    dp = ctypes.POINTER(ctypes.c_double)
    model.lib.mbs_outputs.argtypes = [ctypes.c_double, dp, dp, dp, dp]
    model.lib.mbs_outputs.restype = ctypes.c_int
    model.lib.mbs_output_name.argtypes = [ctypes.c_int]
    model.lib.mbs_output_name.restype = ctypes.c_char_p

    def call(t_value, x, p):
        return model.call("mbs_outputs", t_value, x, p, ny)
    call.model = model
    return call


def test_outputs_contract_and_names(tmp_path):
    eqs, params = _slider()
    x_sym, v_sym = eqs.tree.q_symbols[0], eqs.tree.v_symbols[0]
    outputs = (("pos", x_sym), ("kinetic", params[0] * v_sym**2 / 2), ("time", t))
    source = generate_c(eqs, params, "slider", outputs=outputs)
    for line in ("#define MBS_NY 3   /* outputs */",
                 "int mbs_outputs(double t, const double *x, const double *p, double *y, double *work)",
                 "const char *mbs_output_name(int i)"):
        assert line in source, line
    call = _c_outputs(source, tmp_path, 3)
    status, y = call(1.5, [0.25, -2.0], [3.0, 9.81])
    assert status == 0
    np.testing.assert_array_equal(y, [0.25, 6.0, 1.5])
    assert [call.model.lib.mbs_output_name(i) for i in (0, 1, 2, 3, -1)] == [b"pos", b"kinetic", b"time", None, None]
    # mbs_outputs reads only what the outputs need: no mass-matrix or ABA temporaries.
    body = source.split("int mbs_outputs")[1].split("\n}\n")[0]
    assert "MBS_PIVOT" not in body and "iD" not in body


def test_without_outputs_the_file_is_the_old_one():
    eqs, params = _slider()
    old_call = generate_c(eqs, params, "slider")
    assert old_call == generate_c(eqs, params, "slider", outputs=(), tables=())
    for absent in ("MBS_NY", "mbs_outputs", "mbs_output_name", "mbs_lookup", "mbs_table", "mbs_sign"):
        assert absent not in old_call, absent


def test_output_parameters_must_be_listed():
    eqs, params = _slider()
    k = sp.Symbol("k")
    with pytest.raises(CodegenError, match="missing.*: k"):
        generate_c(eqs, params, outputs=[("spring", k * eqs.tree.q_symbols[0])])
    with pytest.raises(CodegenError, match="table 0"):
        generate_c(eqs, params, outputs=[("y", table0(t))])


def test_names_that_are_c_macros_or_own_names_compile(tmp_path):
    """Parameters named like macros of <Python.h> and the C library, or like the generated code's own names."""
    eqs, _ = _slider(mass=sp.Symbol("errno"))
    hostile = [sp.Symbol(n) for n in ("EOF", "NAN", "stdin", "mbs_rhs", "y", "M", "int", "lambda")]
    params = [sp.Symbol("errno"), sp.Symbol("g"), *hostile]
    source = generate_c(eqs, params, "hostile",
                        outputs=[("sum", sum(hostile, sp.Integer(0))), ("weird \"name\" \\ ??/", hostile[0])])
    call = _c_outputs(source, tmp_path, 2)
    p = [2.0, 9.81, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0]
    status, y = call(0.0, [0.0, 0.0], p)
    assert status == 0 and list(y) == [36.0, 1.0]
    assert call.model.lib.mbs_output_name(1) == b'weird "name" \\ ??/'
    status, xdot = call.model.call("mbs_rhs", 0.0, [0.0, 0.0], p, 2)
    assert status == 0 and list(xdot) == [0.0, -9.81]


# ---- lookup tables --------------------------------------------------------------------------------------------

TABLES = [
    X.Table(X.TIME, (0.0, 1.0), (2.0, -3.0), "linear"),
    X.Table(X.TIME, (-1.0, 0.0, 0.5, 2.0, 2.5), (1.0, 1.0, -0.5, 4.0, 3.9), "linear"),
    X.Table(X.TIME, (0.0, 1.0), (2.0, -3.0), "smooth"),
    X.Table(X.TIME, (-1.0, 0.0, 0.5, 2.0, 2.5, 4.0), (1.0, 1.0, -0.5, 4.0, 3.9, 1e3), "smooth"),  # flat, extrema
    X.Table(X.TIME, tuple(np.cumsum(np.linspace(0.1, 1.0, 40)) - 3.0), tuple(np.sin(np.arange(40.0))), "smooth"),
    # evenly spaced as a road profile's (k * 0.05: the knots' spacing varies in the last bits), and nearly so
    X.Table(X.TIME, tuple(float(k * 0.05) for k in range(401)), tuple(np.sin(np.arange(401.0))), "linear"),
    X.Table(X.TIME, tuple(np.arange(64.0) + 0.4 * np.sin(np.arange(64.0))), tuple(np.cos(np.arange(64.0))), "smooth"),
]


def _table_points(xs):
    xs = np.asarray(xs)
    mids = (xs[:-1] + xs[1:]) / 2
    inner = np.concatenate([xs[:-1] + 0.1 * np.diff(xs), xs[1:] - 1e-9 * np.diff(xs)])
    return np.concatenate([xs, mids, inner, [xs[0] - 1.0, xs[-1] + 1.0, -1e300, 1e300]])


def test_tables_in_c_equal_the_reference_interpolation(tmp_path):
    eqs, params = _slider()
    outputs = [(f"table{k}", sp.Function(f"mbs_table_{k}")(t)) for k in range(len(TABLES))]
    source = generate_c(eqs, params, "tables", outputs=outputs, tables=TABLES)
    assert source.count("static double mbs_table_") == len(TABLES)
    assert source.count("_m[") == sum(table.method == "smooth" for table in TABLES)  # slopes only for those
    call = _c_outputs(source, tmp_path, len(TABLES))
    for k, table in enumerate(TABLES):
        scale = max(abs(v) for v in table.ys)
        for x in _table_points(table.xs):
            status, y = call(float(x), [0.0, 0.0], [1.0, 1.0])
            assert status == 0
            assert y[k] == pytest.approx(X.interpolate(float(x), table.xs, table.ys, table.method),
                                         rel=1e-12, abs=1e-12 * scale), (k, x)
    assert call(math.nan, [0.0, 0.0], [1.0, 1.0])[0] == 2  # NaN in, NaN out: not finite


def _binary_search_lookup(x, xs, ys):
    """The linear lookup of the C helper with the interval found by bisection over all knots, in doubles."""
    if x <= xs[0]:
        return ys[0]
    if x >= xs[-1]:
        return ys[-1]
    lo = int(np.searchsorted(xs, x, side="right")) - 1
    s = (x - xs[lo]) / (xs[lo + 1] - xs[lo])
    return ys[lo] + s * (ys[lo + 1] - ys[lo])


def test_the_lookup_s_start_from_even_spacing_ends_on_the_binary_search_s_interval(tmp_path):
    """mbs_lookup starts its search next to the interval evenly spaced knots would put x in: on a road-like table
    (4001 knots k * 0.05) and an uneven one, at the knots, next to them by a double either side and in between, its
    values are those of the interval a bisection over all knots finds, to the bit."""
    road = X.Table(X.TIME, tuple(float(k * 0.05) for k in range(4001)), tuple(np.sin(np.arange(4001.0))), "linear")
    uneven = TABLES[1]
    eqs, params = _slider()
    outputs = [(f"table{k}", sp.Function(f"mbs_table_{k}")(t)) for k in range(2)]
    call = _c_outputs(generate_c(eqs, params, "lookups", outputs=outputs, tables=[road, uneven]), tmp_path, 2)
    for k, table in enumerate((road, uneven)):
        xs = np.asarray(table.xs)
        points = np.concatenate([xs, np.nextafter(xs, -np.inf), np.nextafter(xs, np.inf), _table_points(xs),
                                 np.random.default_rng(3).uniform(xs[0], xs[-1], 500)])
        for x in points:
            status, y = call(float(x), [0.0, 0.0], [1.0, 1.0])
            assert status == 0 and y[k] == _binary_search_lookup(float(x), table.xs, table.ys), (k, x)


def test_table_registry_is_accepted_and_bad_tables_refused():
    eqs, params = _slider()
    from mbs.compiler.symbolic import TableRegistry
    registry = TableRegistry()
    fn = registry.function(TABLES[1])
    assert "mbs_table_0(t)" in generate_c(eqs, params, outputs=[("y", fn(t))], tables=registry)
    for bad in (X.Table(X.TIME, (0.0, 0.0), (1.0, 2.0), "linear"), X.Table(X.TIME, (0.0, 1.0), (1.0, math.inf),
                                                                              "linear")):
        with pytest.raises(CodegenError, match="table 0"):
            generate_c(eqs, params, outputs=[("y", table0(t))], tables=[bad])


# ---- whole models ---------------------------------------------------------------------------------------------

def _quarter_car():
    """The quarter car with its run-time parameters: the model's, then the branch flags of the road's and the tyre's
    switches (the bump's ends, the contact's max) and the frozen flag, which the tests leave 0: every comparison as
    written, the formulas by hand below."""
    model = load(EXAMPLES / "two_mass_quarter_car.mbs")
    lowered = lower(model, model.scene("bump"))
    return model, lowered, derive_equations(lowered.kinematics), run_parameters(model, lowered)


def _quarter_car_outputs_by_hand(t_value, x, p):
    P = dict(zip(["m_body", "m_wheel", "k_susp", "d_susp", "k_tyre", "l0_susp", "r0", "v", "h", "L"], p))
    s_body, s_wheel = x[0], x[1]
    d = P["v"] * t_value - 1.0
    road = P["h"] / 2 * (1 - math.cos(2 * math.pi * d / P["L"])) if 0 <= d <= P["L"] else 0.0
    return [s_body, abs(s_wheel + 0.1), P["k_tyre"] * (P["r0"] + road - (s_body + s_wheel))]


def test_quarter_car_outputs_equal_the_formulas(tmp_path):
    model, lowered, eqs, params = _quarter_car()
    assert [p.name for p in params] == ["m_body", "m_wheel", "k_susp", "d_susp", "k_tyre", "l0_susp", "r0", "v",
                                        "h", "L", "switch.1", "switch.2", "switch.3", "switch.frozen"]
    source = generate_c(eqs, params, model.name, outputs=lowered.outputs, tables=lowered.tables)
    call = _c_outputs(source, tmp_path, 3)
    compiled = load_c(code=source, cache_dir=tmp_path / "cache", y_names=[n for n, _ in lowered.outputs])
    data = Workspace(compiled)
    rng = np.random.default_rng(7)
    p = np.array([p.value for p in model.parameters] + [0.0] * 4)
    data.p = p
    for t_value in (0.0, 0.2, 0.5, 0.9, 1.3):  # before, on and after the bump (v = 2.78 m/s, L = 2 m)
        x = np.concatenate([rng.uniform(-0.5, 1.0, 2), rng.normal(size=2)])
        status, y = call(t_value, x, p)
        assert status == 0
        np.testing.assert_allclose(y, _quarter_car_outputs_by_hand(t_value, x, p), rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(data.outputs(t_value, x), y)
    assert compiled.ny == 3 and "outputs" in compiled.functions


#: A model whose force laws and outputs use every function and operator of the language and four tables.
EVERY_TEXT = """
model every "every function of the language" {
    param m = 2 kg
    param k = 100 N/m
    param d = 0.5 N*s/m
    param a = 0.3
    param e = 1.25
    param EI = 0.7 "an all-capital name"
    gravity = (0, 0, -9.81) m/s^2
    func u(x) = x / 1 m

    rigid bob {
        body {
            mass = m
            inertia = diag(0.1, 0.1, 0.1) kg*m^2
        }
    }
    rigid arm {
        body {
            mass = m / 2
            com = (0, 0, -0.4) m
            inertia = diag(0.02, 0.03, 0.04) kg*m^2
        }
        frame tip at (0.1, 0, -0.5) m
    }

    interact probe {
        connect inertial -> arm.tip
        sensor where = position()
    }

    interact slide {
        connect inertial -> bob
        joint prismatic(axis = z) {
            init s = 0.3 m
        }
        force spring = line(f = k * (l - 1 m) * (1 + 0.1 * tanh(u(l)))
                                + d * v * lookup(u(v) * 1 s, [[-2, 0.5], [0, 1], [1, 1.5], [3, 4]], "smooth"))
        force drive = joint(s = -d * der(s) * abs(sign(der(s)))
                                + lookup(t, [[0 s, 0 N], [1 s, 2 N], [2 s, 1.5 N], [5 s, 0 N]], "linear"))
    }

    interact swing {
        connect bob -> arm
        joint revolute(axis = y) {
            init phi = 0.4
        }
        force friction = joint(phi = if(der(phi) > 0 and not (phi < -1), -0.1 * der(phi) * 1 s,
                                        if(phi > 2 or phi < -2, -cosh(phi) + sinh(phi / 3), -0.05 * der(phi) * 1 s))
                                     * 1 N*m)
    }

    output o_max = max(swing.phi, u(slide.s))
    output o_min = min(swing.phi, 0.2)
    output o_trig = sin(swing.phi) + cos(u(slide.s)) + tan(0.1 * swing.phi) + atan(swing.phi) \\
                    + atan2(u(probe.where.x), u(probe.where.z))
    output o_inv = asin(0.5 * tanh(swing.phi)) + acos(0.3 * tanh(u(slide.s)))
    output o_hyp = sinh(0.2 * swing.phi) * cosh(0.1 * u(slide.s)) + tanh(der(swing.phi) * 1 s)
    output o_exp = exp(0.1 * swing.phi) * log(2 + sin(u(slide.s))) + sqrt(1 + swing.phi^2)
    output o_pow = swing.phi^3 + swing.phi^4 - u(slide.s)^-2 + (1 + u(slide.s)^2)^1.5 \\
                   + (2 + cos(swing.phi))^(1/3) + e^swing.phi
    output o_sign = sign(swing.phi - 0.1) + abs(u(slide.s) - 0.2) * EI
    output o_cmp = if(swing.phi == 0.5, 1, if(swing.phi != 0.25, 2, 3)) \\
                   + if(u(slide.s) >= 0.3 or u(slide.s) <= -0.3, 4, 5)
    output o_smooth = smoothstep(swing.phi, -0.5, 0.5)
    output o_table = lookup(swing.phi, [[-1, 1], [-0.5, 0.2], [0, 0], [0.5, 0.3], [1, 2]], "smooth") \\
                     + lookup(u(slide.s), [[-1, 1], [1, 3]])
    output o_big = 1e20 * a + 3e-30 * e + 4294967296 * a
}
"""


def test_header_names_the_model_and_the_options():
    model, lowered, eqs, params = _quarter_car()
    source = generate_c(eqs, params, model.name, outputs=lowered.outputs, tables=lowered.tables,
                        origin="two_mass_quarter_car.mbs, scene bump", inline_max_chars=20)
    header = source.split(" */")[0]
    for text in ('Equations of motion of the model "two_mass_quarter_car".',
                 "From two_mass_quarter_car.mbs, scene bump.", "Generated by Baukasten ", "(mbs.compiler.ccode)",
                 "in place up to 20 characters", "3 output(s), 0 lookup table(s)", "y[2]  wheel_load",
                 "p[9]  L", "x[3]  wheel_guide.der(s)"):
        assert text in header, text


def test_hostile_origin_cannot_end_the_comment(tmp_path):
    eqs, params = _slider()
    source = generate_c(eqs, params, "slider", origin="a */ int oops; /* \n #error no ??/")
    assert "int oops" not in source.split("*/")[1]
    treekit.CModel(source, tmp_path)  # compiles with -Werror (a trigraph would warn)


def test_every_function_compiles_without_warnings(tmp_path, every_model):
    """-Wall -Wextra -Werror -std=c99, and once more with -pedantic: a model using every function and tables."""
    model, lowered, eqs, params = every_model
    source = generate_c(eqs, params, model.name, outputs=lowered.outputs, tables=lowered.tables)
    assert len(lowered.tables.tables) == 4 and "mbs_sign(" in source
    for fn in ("fmax(", "fmin(", "atan2(", "asin(", "acos(", "sinh(", "cosh(", "tanh(", "exp(", "log(", "sqrt(",
               "pow(", "fabs(", " ? ", " && ", " || ", " == ", " != "):
        assert fn in source, fn
    assert treekit.CModel(source, tmp_path).warnings == ""
    c_file = tmp_path / "pedantic.c"
    c_file.write_text(source)
    result = subprocess.run(["gcc", *treekit.GCC_FLAGS, "-pedantic", "-o", str(tmp_path / "p.so"), str(c_file),
                             "-lm"], capture_output=True, text=True)
    assert result.returncode == 0 and result.stderr == "", result.stderr


@pytest.fixture(scope="module")
def every_model():
    """As written (switches = false): the functions themselves are printed (fmax, fabs, comparisons), not the
    switched branches; tests/compiler/test_pycode.py runs it with switches as well."""
    model = dataclasses.replace(load_text(EVERY_TEXT, "every.mbs"), switches=False)
    lowered = lower(model)
    params = [parameter_symbol(p.name) for p in model.parameters]
    return model, lowered, derive_equations(lowered.kinematics), params
