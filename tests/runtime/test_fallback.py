"""Without a C compiler a scene that names a C integrator still runs, on its nearest scipy method."""

import pytest

import mbs
from mbs.cli import main

PENDULUM = """
model p {
    gravity = (0, 0, -9.81) m/s^2
    rigid bob {
        body { mass = 1 kg
               com = (0, 0, -1) m
               inertia = diag(1e-3, 1e-3, 1e-3) kg*m^2 }
    }
    interact hinge {
        connect inertial -> bob
        joint revolute(axis = y) { init phi = 10 deg }
    }
}
scene swing {
    t_end = 0.5 s
    integrator = INTEGRATOR
}
"""


@pytest.mark.parametrize("c_method, scipy_method", [("dopri5", "RK45"), ("rodasp", "Radau")])
def test_a_c_integrator_falls_back_to_its_nearest_scipy_method(c_method, scipy_method):
    res = mbs.loads(PENDULUM.replace("INTEGRATOR", c_method), backend="numpy").simulate("swing")
    assert res.success
    assert res.metadata["integrator"] == scipy_method
    assert res.metadata["notes"] == [f"note: integrator '{c_method}' runs in C, but this model was built with "
                                     f"the numpy back end (no C compiler); using scipy's '{scipy_method}'"]


def test_without_a_c_compiler_the_library_examples_run_as_shipped(tmp_path, monkeypatch, capsys):
    """CC names a compiler that does not exist: every tree example of the library runs on the NumPy back end."""
    from pathlib import Path

    monkeypatch.setenv("CC", str(tmp_path / "no-such-cc"))
    examples = Path(mbs.__file__).resolve().parent.parent / "library" / "examples"
    for name in ("pendulum", "double_pendulum", "spatial_chain", "two_mass_quarter_car"):
        assert main(["simulate", str(examples / f"{name}.mbs"), "--t-end", "0.2"]) == 0, name
    assert "using scipy's" in capsys.readouterr().err
