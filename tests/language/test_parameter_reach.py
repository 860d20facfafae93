"""Every parameter reaches every place it is used: a run with `params=` (and `--param`, and a scene's `param`)
must give the same result as the same model whose default was edited to that value, for each construct that
holds an expression (lookup tables, prescribed motions, inputs, component arguments, function arguments,
initial values). The oracle is the edited text, which the validator evaluates by itself."""

import math
import random

import pytest

import mbs
from mbs.cli import main
from mbs.language import expr as X
from mbs.language.tables import parametric_table

# A block on a rail along x, pushed by forces that use the parameter P in the construct under test.
TEMPLATE = """
component pusher {
    param f = 1 N
    port a
    port b
    interact push {
        connect a -> b
        force f = line(f = -f, along = x)
    }
}
model slide {
    param P = DEFAULT
    input u = P * t / 1 s
    func law(l) = lookup(l, [[-10 m, 0 N], [0 m, P], [10 m, 2 * P]], "METHOD")
    rigid block {
        body {
            mass = 1 kg
            inertia = diag(1, 1, 1) kg*m^2
        }
        frame o at (0, 0, 0) m
    }
    rigid arm {
        body {
            mass = 1 kg
            com = (0, 0, -1) m
            inertia = diag(1, 1, 1) kg*m^2
        }
    }
    interact rail {
        connect inertial.origin -> block.o
        joint prismatic(axis = x) {
            INIT
        }
        FORCE
    }
    interact drive {
        connect block.o -> arm
        joint revolute(axis = y) {
            PRESCRIBE
        }
    }
    USE
    output x = rail.s
    output phi = drive.phi
}
scene run {
    t_end = 1 s
    sample = 0.25 s
    SCENE
}
"""

CONSTRUCTS = {
    "table": dict(FORCE='force f = line(f = -lookup(l, [[-10 m, 0 N], [0 m, P], [10 m, 2 * P]], "linear"), '
                        'along = x)'),
    "smooth table": dict(FORCE='force f = line(f = -lookup(l, [[-10 m, 0 N], [0 m, P], [1 m, 3 * P], '
                               '[10 m, 4 * P]], "smooth"), along = x)'),
    "table in a function": dict(FORCE="force f = line(f = -law(l), along = x)"),
    "input": dict(FORCE="force f = line(f = -u, along = x)"),
    "component argument": dict(USE="use pusher as p(f = P) { a = inertial.origin; b = block.o }"),
    "prescribed motion": dict(PRESCRIBE="prescribe phi = P * t / 1 N / 1 s * 1 rad"),
    "initial value": dict(INIT="init s = P / 1 N * 1 m"),
}


def model_text(construct: str, default: float, scene: str = "") -> str:
    text = TEMPLATE.replace("DEFAULT", f"{default} N").replace("METHOD", "linear").replace("SCENE", scene)
    fill = {"FORCE": "", "USE": "", "PRESCRIBE": "", "INIT": ""} | CONSTRUCTS[construct]
    for key, value in fill.items():
        text = text.replace(key, value)
    return text


def final(res):
    return res["x"][-1], res["phi"][-1]


@pytest.mark.parametrize("construct", sorted(CONSTRUCTS))
def test_python_params_reach_the_construct(construct):
    edited = final(mbs.loads(model_text(construct, 3.0), backend="numpy").simulate("run"))
    overridden = final(mbs.loads(model_text(construct, 1.0), backend="numpy").simulate("run", params={"P": 3.0}))
    unchanged = final(mbs.loads(model_text(construct, 1.0), backend="numpy").simulate("run"))
    assert overridden == pytest.approx(edited, rel=1e-9, abs=1e-12)
    assert unchanged != pytest.approx(edited, rel=1e-6)  # the parameter matters here


@pytest.mark.parametrize("construct", ["table", "smooth table", "prescribed motion"])
def test_a_scene_param_reaches_the_construct(construct):
    edited = final(mbs.loads(model_text(construct, 3.0), backend="numpy").simulate("run"))
    scene = final(mbs.loads(model_text(construct, 1.0, "param P = 3 N"), backend="numpy").simulate("run"))
    assert scene == pytest.approx(edited, rel=1e-9, abs=1e-12)


def test_the_command_line_param_reaches_a_table_in_the_compiled_model(tmp_path, capsys):
    """The issue's case, through `mbs simulate --param` and the C back end."""
    src, edited = tmp_path / "slide.mbs", tmp_path / "edited.mbs"
    src.write_text(model_text("table", 1.0))
    edited.write_text(model_text("table", 3.0))
    out_edited, out_param = tmp_path / "a.csv", tmp_path / "b.csv"
    assert main(["simulate", str(edited), "--scene", "run", "--out", str(out_edited)]) == 0
    assert main(["simulate", str(src), "--scene", "run", "--param", "P=3N", "--out", str(out_param)]) == 0
    last = [[float(v) for v in path.read_text().strip().splitlines()[-1].split(",")] for path in (out_edited, out_param)]
    assert last[1] == pytest.approx(last[0], rel=1e-9, abs=1e-12)


def test_a_parametric_table_interpolates_as_the_table_of_numbers():
    """The expression written for a table of parameters against the numeric table lookup (expr.interpolate),
    with random points and arguments, both methods, inside and beyond the ends."""
    rng = random.Random(7)
    for _ in range(40):
        n = rng.randint(2, 6)
        xs = sorted(rng.sample(range(-50, 50), n))
        ys = [rng.uniform(-5, 5) for _ in range(n)]
        env = {f"x{i}": float(v) for i, v in enumerate(xs)} | {f"y{i}": v for i, v in enumerate(ys)}
        for method in ("linear", "smooth"):
            e = parametric_table(X.Sym("input", "arg"), [X.Sym("param", f"x{i}") for i in range(n)],
                                 [X.Sym("param", f"y{i}") for i in range(n)], method)
            for arg in [rng.uniform(-60, 60) for _ in range(10)] + [float(xs[0]), float(xs[-1])]:
                want = X.interpolate(arg, xs, ys, method)
                assert X.evaluate(e, env | {"arg": arg}) == pytest.approx(want, rel=1e-12, abs=1e-12)
    assert math.isfinite(X.evaluate(parametric_table(X.Sym("input", "arg"), [X.ZERO, X.ONE], [X.ONE, X.ONE],
                                                     "smooth"), {"arg": 0.5}))


def test_a_random_road_refuses_a_parameter_it_could_not_follow():
    """The profile of iso8608() is drawn when the model is built; a parameter there would be frozen silently."""
    text = """
model m {
    param seed = 3
    func road(x) = iso8608(x, C, seed, 50 m)
    rigid b { body { mass = 1 kg
                     inertia = diag(1, 1, 1) kg*m^2 } }
    interact j {
        connect inertial -> b
        joint prismatic(axis = z) { prescribe s = road(t * 1 m/s) }
    }
}
"""
    with pytest.raises(mbs.MbsError, match="random road are fixed when the model is built") as info:
        mbs.loads(text)
    assert info.value.diagnostics[0].span is not None
