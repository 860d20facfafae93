"""Units on results: the model's own named units (N*m, not kg*m^2/s^2), and quantities from Python."""

import pytest

import mbs

ARM = """
model arm {
    param m = 2 kg
    param l = 0.5 m
    param kt = 3 N*m/rad "torque per radian"
    param kk = 2 kN*m/rad
    param tilt = 10 deg
    param gain = 4
    gravity = (0, 0, -9.81) m/s^2
    rigid link {
        body {
            mass = m
            com = (0, 0, -l)
            inertia = diag(1e-3, 1e-3, 1e-3) kg*m^2
        }
        frame pivot at (0, 0, 0) m
    }
    interact hinge {
        connect inertial.origin -> link.pivot
        joint revolute(axis = y) { init phi = tilt }
        sensor load = reaction(in = inertial)
    }
    output spring_torque = kt * hinge.phi
    output rate = der(hinge.phi)
    output ratio = hinge.phi / (1 rad)
    output double_phi = 2 * hinge.phi
}
"""


@pytest.fixture(scope="module")
def arm():
    return mbs.loads(ARM, backend="numpy")


def test_parameters_keep_the_unit_written_when_it_is_si(arm):
    units = {p.name: p.unit for p in arm.model.parameters}
    assert units["kt"] == "N*m/rad"          # as written
    assert units["kk"] == "N*m"              # kN*m/rad is not SI: the named SI unit of a torque
    assert units["tilt"] == "rad"            # values are SI: an angle in degrees is stored in rad
    assert units["m"] == "kg" and units["l"] == "m"
    assert units["gain"] is None          # a bare number takes any dimension: no unit to show


def test_outputs_and_states_carry_named_units(arm):
    compiled = arm.compile()
    assert compiled.units["spring_torque"] == "N*m"
    assert compiled.units["rate"] == "rad/s"
    assert compiled.units["ratio"] == "1"        # an expression of an angle is a plain number
    assert "double_phi" not in compiled.units     # a bare number has a free dimension: no unit claimed
    assert compiled.units["hinge.phi"] == "rad" and compiled.units["der(hinge.phi)"] == "rad/s"


def test_results_files_keep_the_units(arm, tmp_path):
    res = arm.simulate(t_end=0.05, sample=0.01)
    for path, read in ((tmp_path / "r.csv", mbs.Results.from_csv), (tmp_path / "r.npz", mbs.Results.from_npz)):
        (res.to_csv if path.suffix == ".csv" else res.to_npz)(path)
        back = read(path)
        assert back.unit("spring_torque") == "N*m" and back.unit("time") == "s"


def test_python_takes_quantities_as_the_cli_does(arm):
    a = arm.simulate(t_end=0.2, params={"l": "50 cm", "tilt": "0.2 rad"})
    b = arm.simulate(t_end=0.2, params={"l": 0.5, "tilt": 0.2})
    assert a["hinge.phi"][-1] == b["hinge.phi"][-1]
    c = arm.simulate(t_end=0.2, params={"l": "30 cm", "tilt": "0.2 rad"})
    assert c["hinge.phi"][-1] != b["hinge.phi"][-1]


@pytest.mark.parametrize("params, message", [
    ({"l": "2 kg"}, "parameter l: expected length (m), got mass (kg)"),
    ({"l": "two m"}, "parameter l: expected a number"),
    ({"lenght": 1.0}, "has no parameter 'lenght'"),
])
def test_bad_quantities_are_model_errors(arm, params, message):
    with pytest.raises(mbs.MbsError, match=message.replace("(", r"\(").replace(")", r"\)")):
        arm.simulate(t_end=0.1, params=params)


def test_results_hand_off_to_pandas_and_xarray_with_units(arm):
    res = arm.simulate(t_end=0.05, sample=0.01)
    pd = pytest.importorskip("pandas")
    frame = res.to_pandas()
    assert isinstance(frame, pd.DataFrame) and frame.index.name == "time"
    assert frame["spring_torque"].iloc[-1] == res["spring_torque"][-1]
    assert frame.attrs["units"]["spring_torque"] == "N*m"
    pytest.importorskip("xarray")
    ds = res.to_xarray()
    assert ds["spring_torque"].attrs["units"] == "N*m" and ds["time"].attrs["units"] == "s"
    assert float(ds["hinge.phi"][-1]) == res["hinge.phi"][-1]


def test_workspace_functions_are_typed_methods(arm):
    from mbs.runtime.workspace import Workspace
    compiled = arm.compile()
    data = Workspace(compiled)
    assert "rhs" in Workspace.__dict__ and "mass_matrix" in Workspace.__dict__
    assert data.rhs(0.0, compiled.x0).shape == (compiled.nx,)
