"""The NumPy back end: generated C, the generated NumPy module and the tape evaluated independently (sympy's own
Python printer) agree on every function at random states of the shipped models and of a model using every
function and lookup tables; the module loads through the runtime and returns the C statuses."""

import math
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from sympy.printing.pycode import PythonCodePrinter

sys.path.insert(0, str(Path(__file__).parent))
import treekit  # noqa: E402
from test_outputs_codegen import EVERY_TEXT, TABLES, _slider, _table_points  # noqa: E402

from mbs.compiler.ccode import generate_c  # noqa: E402
from mbs.compiler.equations import derive_equations  # noqa: E402
from mbs.compiler.lower import lower  # noqa: E402
from mbs.compiler.pycode import CodegenError, PyPrinter, generate_numpy  # noqa: E402
from mbs.compiler.symbolic import parameter_symbol  # noqa: E402
from mbs.pipeline import run_parameters  # noqa: E402
from mbs.compiler.tree import t  # noqa: E402
from mbs.language import expr as X  # noqa: E402
from mbs.language.frontend import load, load_text  # noqa: E402
from mbs.runtime.backends import load_numpy_module  # noqa: E402
from mbs.runtime.errors import EvaluationError  # noqa: E402
from mbs.runtime.model import load_c, load_numpy  # noqa: E402
from mbs.runtime.workspace import Workspace  # noqa: E402

EXAMPLES = Path(__file__).parents[2] / "library" / "examples"
FUNCTIONS = ("rhs", "mass_matrix", "forces", "qdot", "outputs")
a, b, c = sp.symbols("a b c")
PRINTER = PyPrinter({a: "a", b: "b", c: "c_1", t: "t"}, 1)


@pytest.mark.parametrize("expr, text", [
    (sp.Piecewise((a, b > 0), (sp.Piecewise((b, c < 1), (c, True)), True)),
     "(a if b > 0 else (b if c_1 < 1 else c_1))"),
    (sp.Piecewise((a, a > 0), (b, b > 0)), "(a if a > 0 else (b if b > 0 else nan))"),
    (sp.Piecewise((a, sp.And(a > 0, b < 1)), (c, True)), "(a if (a > 0) and (b < 1) else c_1)"),
    (sp.Piecewise((a, sp.Or(a > 0, b < 1)), (c, True)), "(a if (a > 0) or (b < 1) else c_1)"),
    (sp.Piecewise((1, sp.Not(a)), (0, True)), "(1.0 if not (a) else 0.0)"),
    (sp.Piecewise((a, sp.Eq(a, b)), (c, sp.Ne(b, 2))), "(a if a == b else (c_1 if b != 2 else nan))"),
    (sp.sign(a - b) + sp.Abs(c), "fabs(c_1) + mbs_sign(a - b)"),
    (sp.Max(a, b, 1), "fmax(fmax(1.0, a), b)"),
    (a**sp.Rational(1, 3) + a**-3 + a**5, "1.0/(a*a*a) + pow(a, 5) + pow(a, 0.3333333333333333)"),
    (sp.Function("mbs_table_0")(a) - sp.pi, "mbs_table_0(a) - 3.141592653589793"),
])
def test_printer(expr, text):
    assert PRINTER.doprint(expr) == text


# ---- the independent oracle -----------------------------------------------------------------------------------

class _OraclePrinter(PythonCodePrinter):
    """sympy's own Python printer (math module, Python's max/min/abs/**), with our array names."""

    def __init__(self, names):
        super().__init__({"allow_unknown_functions": True, "fully_qualified_modules": True})
        self.names = names

    def _print_Symbol(self, expr):
        return self.names[expr]

    _print_Dummy = _print_Symbol

    def _print_Float(self, expr):
        return repr(float(expr))


def oracle(eqs, parameters, outputs, tables, run_time_inputs=()):
    """f(t, x, p) -> dict of every function's values, from the tape in plain Python, written by sympy. Outputs
    that read the accelerations (reactions) get the oracle's own vdot."""
    tree, tape, nq, nv = eqs.tree, eqs.tape, eqs.tree.nq, eqs.tree.nv
    results = ([e for row in eqs.mass_matrix for e in row] + list(eqs.forces) + list(eqs.qdot) + list(eqs.vdot)
               + [e for _, e in outputs])
    names = {t: "t"}
    names.update({s: f"x[{k}]" for k, s in enumerate(tree.q_symbols + tree.v_symbols)})
    names.update({s: f"p[{k}]" for k, s in enumerate(parameters)})
    names.update({s: f"acc[{k}]" for s, _, k in run_time_inputs})
    entries = tape.entries_for(results)
    names.update({e.symbol: f"w{k}" for k, e in enumerate(entries)})
    printer = _OraclePrinter(names)
    lines = ["def f(t, x, p, acc):"] + [f"    {names[e.symbol]} = {printer.doprint(e.expr)}" for e in entries]
    lines.append(f"    return [{', '.join(printer.doprint(sp.sympify(r)) for r in results)}]")
    scope = {"math": math}
    for k, tb in enumerate(tables):
        scope[f"mbs_table_{k}"] = lambda v, tb=tb: X.interpolate(v, tb.xs, tb.ys, tb.method)
    exec("\n".join(lines), scope)

    def evaluate(t_value, x, p):
        args = (float(t_value), [float(u) for u in x], [float(u) for u in p])
        v = np.array(scope["f"](*args, [0.0] * nv), dtype=float)
        k = nv * nv
        if run_time_inputs:  # again, with the accelerations this evaluation found
            v = np.array(scope["f"](*args, list(v[k + nv + nq:k + 2 * nv + nq])), dtype=float)
        out = {"mass_matrix": v[:k].reshape(nv, nv), "forces": v[k:k + nv], "qdot": v[k + nv:k + nv + nq]}
        out["rhs"] = np.concatenate([out["qdot"], v[k + nv + nq:k + 2 * nv + nq]])
        if outputs:
            out["outputs"] = v[k + 2 * nv + nq:]
        return out
    return evaluate


# ---- the three back ends on models ----------------------------------------------------------------------------

def _compile_model(text_or_path, scene, tmp_path):
    model = load_text(text_or_path, "every.mbs") if isinstance(text_or_path, str) else load(text_or_path)
    lowered = lower(model, model.scene(scene) if scene else None)
    eqs = derive_equations(lowered.kinematics)
    params = run_parameters(model, lowered)  # with the switches' branch flags and the frozen flag
    kw = dict(outputs=lowered.outputs, tables=lowered.tables, run_time_inputs=lowered.run_time_inputs)
    c_source = generate_c(eqs, params, model.name, **kw)
    py_path = tmp_path / f"{model.name}_numpy.py"
    py_path.write_text(generate_numpy(eqs, params, model.name, **kw))
    info = dict(name=model.name, y_names=[n for n, _ in lowered.outputs] or None)
    return (model, lowered, eqs, params, load_c(code=c_source, **info),
            load_numpy(py_path, **info))


MODELS = [("pendulum.mbs", "swing"), ("double_pendulum.mbs", "chaos"), ("spatial_chain.mbs", "tumble"),
          ("two_mass_quarter_car.mbs", "bump"), ("every", None)]


@pytest.mark.parametrize("name, scene", MODELS)
def test_c_numpy_and_the_tape_agree(name, scene, tmp_path):
    source = EVERY_TEXT if name == "every" else EXAMPLES / name
    model, lowered, eqs, params, c_model, np_model = _compile_model(source, scene, tmp_path)
    reference = oracle(eqs, params, lowered.outputs, lowered.tables.tables, lowered.run_time_inputs)
    assert set(c_model.functions) == set(np_model.functions) == set(FUNCTIONS[:4 + bool(lowered.outputs)])
    assert (c_model.ny, np_model.ny) == (len(lowered.outputs),) * 2
    data_c, data_np = Workspace(c_model), Workspace(np_model)
    rng = np.random.default_rng(11)
    p_default = np.array([p.value for p in model.parameters])
    flags = len(params) - p_default.size  # switches: the branches as run-time flags, then the frozen flag
    for trial in range(6):
        p = p_default * (rng.uniform(0.7, 1.3, size=p_default.size) if trial else 1.0)
        # odd trials hold random branches (frozen = 1), even ones evaluate the comparisons as written
        p = np.concatenate([p, rng.integers(0, 2, size=flags - 1), [trial % 2]] if flags else [p])
        data_c.p, data_np.p = p, p
        t_value = rng.uniform(0.0, 5.0)
        x = np.concatenate([rng.uniform(-1.2, 1.2, size=eqs.tree.nq), rng.normal(size=eqs.tree.nv)])
        expected = reference(t_value, x, p)
        for fn in c_model.functions:
            from_c, from_np = data_c.function(fn)(t_value, x), data_np.function(fn)(t_value, x)
            scale = max(1.0, np.max(np.abs(expected[fn])))
            np.testing.assert_allclose(from_np, from_c, rtol=1e-12, atol=1e-12 * scale, err_msg=f"{fn} NumPy")
            np.testing.assert_allclose(from_c, expected[fn], rtol=1e-12, atol=1e-12 * scale, err_msg=f"{fn} tape")
        # The generated functions themselves are consistent: M vdot = f.
        M, f = data_np.mass_matrix(t_value, x), data_np.forces(t_value, x)
        np.testing.assert_allclose(M @ data_np.rhs(t_value, x)[eqs.tree.nq:], f, rtol=1e-9, atol=1e-9 * scale)


def test_tables_equal_the_reference_interpolation(tmp_path):
    eqs, params = _slider()
    outputs = [(f"table{k}", sp.Function(f"mbs_table_{k}")(t)) for k in range(len(TABLES))]
    path = tmp_path / "tables.py"
    path.write_text(generate_numpy(eqs, params, "tables", outputs=outputs, tables=TABLES))
    module = load_numpy_module(path)
    out, work = np.empty(len(TABLES)), np.empty(1)
    for k, table in enumerate(TABLES):
        scale = max(abs(v) for v in table.ys)
        for x in _table_points(table.xs):
            assert module.mbs_outputs(float(x), np.zeros(2), np.ones(2), out, work) == 0
            assert out[k] == pytest.approx(X.interpolate(float(x), table.xs, table.ys, table.method),
                                           rel=1e-12, abs=1e-12 * scale), (k, x)
    assert module.mbs_outputs(math.nan, np.zeros(2), np.ones(2), out, work) == 2


# ---- statuses ----------------------------------------------------------------------------------------------------

def _both(eqs, params, outputs, tmp_path):
    """(C model via ctypes, NumPy module) of one set of equations."""
    c_model = treekit.CModel(generate_c(eqs, params, outputs=outputs), tmp_path)
    path = tmp_path / "m.py"
    path.write_text(generate_numpy(eqs, params, outputs=outputs))
    return c_model, load_numpy_module(path)


def test_statuses_equal_those_of_c(tmp_path):
    eqs, params = _slider()
    s, v = eqs.tree.q_symbols[0], eqs.tree.v_symbols[0]
    outputs = [("root", sp.sqrt(s)), ("inverse", 1 / v), ("log", sp.log(s)), ("big", sp.exp(200 * v)),
               ("power", (s - 1)**sp.Rational(1, 3))]
    c_model, module = _both(eqs, params, outputs, tmp_path)
    import ctypes
    dp = ctypes.POINTER(ctypes.c_double)
    c_model.lib.mbs_outputs.argtypes = [ctypes.c_double, dp, dp, dp, dp]
    cases = [  # (function, x, p, status)
        ("mbs_rhs", [2.0, 1.0], [1.0, 9.81], 0),
        ("mbs_rhs", [2.0, 1.0], [0.0, 9.81], 1),          # massless: the articulated inertia is zero
        ("mbs_rhs", [2.0, 1.0], [-1.0, 9.81], 1),
        ("mbs_rhs", [2.0, 1.0], [math.nan, 9.81], 2),
        ("mbs_mass_matrix", [2.0, 1.0], [-1.0, 9.81], 1),
        ("mbs_mass_matrix", [2.0, 1.0], [math.inf, 9.81], 2),
        ("mbs_forces", [2.0, 1.0], [1.0, math.nan], 2),
        ("mbs_outputs", [2.0, 1.0], [1.0, 1.0], 0),
        ("mbs_outputs", [-2.0, 1.0], [1.0, 1.0], 2),      # sqrt and log of a negative number
        ("mbs_outputs", [2.0, 0.0], [1.0, 1.0], 2),       # division by zero
        ("mbs_outputs", [0.0, 1.0], [1.0, 1.0], 2),       # log(0)
        ("mbs_outputs", [2.0, 5.0], [1.0, 1.0], 2),       # exp overflows
        ("mbs_outputs", [0.5, 1.0], [1.0, 1.0], 2),       # pow of a negative base
    ]
    for fn, x, p, status in cases:
        n = {"mbs_rhs": 2, "mbs_mass_matrix": 1, "mbs_forces": 1, "mbs_outputs": len(outputs)}[fn]
        c_status, c_out = c_model.call(fn, 0.0, x, p, n)
        out = np.full((1, 1) if fn == "mbs_mass_matrix" else n, np.nan)
        np_status = getattr(module, fn)(0.0, np.array(x), np.array(p), out, np.zeros(1))
        assert (c_status, np_status) == (status, status), (fn, x, p)
        if status == 0:
            np.testing.assert_array_equal(out.reshape(-1), c_out)


def test_runtime_raises_on_a_bad_status(tmp_path):
    eqs, params = _slider()
    path = tmp_path / "slider.py"
    path.write_text(generate_numpy(eqs, params, "slider"))
    model = load_numpy(path, p_default=[0.0, 9.81])
    with pytest.raises(EvaluationError):
        Workspace(model).rhs(0.0, np.zeros(2))


# ---- the module text ------------------------------------------------------------------------------------------

def test_module_contract(tmp_path):
    eqs, params = _slider()
    plain = generate_numpy(eqs, params, "slider")
    with_outputs = generate_numpy(eqs, params, "slider", outputs=[("pos", eqs.tree.q_symbols[0])])
    for text in (plain, with_outputs):
        compile(text, "generated", "exec")
        for line in ("MBS_NQ = 1", "MBS_NV = 1", "MBS_NX = MBS_NQ + MBS_NV", "MBS_NP = 2", "MBS_NWORK = 1",
                     "def mbs_rhs(t, x, p, out, work):", "def mbs_mass_matrix(t, x, p, out, work):",
                     "def mbs_forces(t, x, p, out, work):", "def mbs_qdot(t, x, p, out, work):"):
            assert line in text, line
    assert "MBS_NY" not in plain and "mbs_outputs" not in plain
    assert "MBS_NY = 1" in with_outputs and "def mbs_outputs(t, x, p, out, work):" in with_outputs
    assert plain.startswith('"""Equations of motion of the model \\"slider\\".') or \
        plain.startswith('"""Equations of motion of the model "slider".')
    assert "(mbs.compiler.pycode)" in plain.split('"""')[1]
    path = tmp_path / "m.py"
    path.write_text(with_outputs)
    module = load_numpy_module(path)
    assert (module.MBS_STATE_NAMES, module.MBS_PARAMETER_NAMES, module.MBS_OUTPUT_NAMES) == \
        (("slider.s", "slider.der(s)"), ("m", "g"), ("pos",))
    assert "import" not in "".join(line for line in with_outputs.splitlines()
                                   if not line.startswith(("from math import", "import numpy")))


def test_names_and_texts_cannot_inject_code(tmp_path):
    """Names become identifiers or repr'd strings, and the docstring escapes what would end it."""
    eqs, params = _slider()
    evil = 'x"""\nimport os; os.system("false")\n"""'
    outputs = [(evil, eqs.tree.q_symbols[0]), ("a\\b'c", eqs.tree.v_symbols[0])]
    text = generate_numpy(eqs, params, 'model"""', outputs=outputs, origin=evil)
    path = tmp_path / "evil.py"
    path.write_text(text)
    module = load_numpy_module(path)
    assert module.MBS_OUTPUT_NAMES == (evil, "a\\b'c") and module.MBS_MODEL == 'model"""'
    assert not hasattr(module, "os") and "os.system" in module.__doc__
    # A parameter whose name is code becomes an identifier (here "import___os_system_false").
    code = sp.Symbol('__import__("os").system("false")')
    path.write_text(generate_numpy(eqs, [*params, code], outputs=[("y", 2 * code)]))
    module, out = load_numpy_module(path), np.empty(1)
    assert module.mbs_outputs(0.0, np.zeros(2), np.array([1.0, 1.0, 4.0]), out, None) == 0 and out[0] == 8.0
    assert "import___os_system_false = p[2]" in path.read_text()
    with pytest.raises(CodegenError, match="missing.*stranger"):
        generate_numpy(eqs, params, outputs=[("y", sp.Dummy("stranger"))])
