"""`scenes = NAME` (language/shared_scenes.py): a model runs the scenes of an imported model file too; its own
scenes of the same name win, a borrowed scene that does not fit is left out with a warning, and a NAME that is
not an imported model file is a located error."""

import pytest

from mbs.language import frontend
from mbs.language.diagnostics import MbsError

BASE = """
model base {
    param k = 100 N/m
    param drop = 0.1 m
    rigid mass {
        body {
            mass = 1 kg
            inertia = diag(1, 1, 1) kg*m^2
        }
    }
    interact spring {
        connect inertial -> mass
        joint prismatic(axis = z) {
            init s = -drop
        }
        force f = spring(k = k)
    }
    output height = spring.s
}

scene soft "a soft spring" {
    param k = 10 N/m
    t_end = 2 s
    output height
}

scene stiff {
    param k = 1000 N/m
    output height
}

scene dropped "needs a parameter the variant lacks" {
    param drop = 0.2 m
    output height
}
"""

VARIANT = """
import base as original

model variant {
    scenes = original
    param k = 100 N/m
    rigid mass {
        body {
            mass = 2 kg
            inertia = diag(1, 1, 1) kg*m^2
        }
    }
    interact spring {
        connect inertial -> mass
        joint prismatic(axis = z)
        force f = spring(k = k)
    }
    output height = spring.s
}

scene stiff "the variant's own" {
    param k = 5000 N/m
    output height
}
"""


def write(tmp_path, variant=VARIANT):
    (tmp_path / "base.mbs").write_text(BASE)
    path = tmp_path / "variant.mbs"
    path.write_text(variant)
    return path


def test_a_variant_runs_the_scenes_of_the_model_file_it_names(tmp_path):
    result = frontend.check(write(tmp_path))
    model = result.model("variant")
    scenes = {s.name: s for s in model.scenes}
    assert set(scenes) == {"stiff", "soft"}
    assert dict(scenes["soft"].params)["k"].value == pytest.approx(10.0)       # borrowed as written
    assert scenes["soft"].t_end == pytest.approx(2.0) and scenes["soft"].model == "variant"
    assert dict(scenes["stiff"].params)["k"].value == pytest.approx(5000.0)    # its own wins
    warnings = [d for d in result.diagnostics if d.severity == "warning"]
    assert any("scene 'dropped' of base is left out: the model has no parameter 'drop'" in d.message
               for d in warnings)


def test_scenes_must_name_an_imported_model_file(tmp_path):
    with pytest.raises(MbsError) as err:
        frontend.check(write(tmp_path, VARIANT.replace("scenes = original", "scenes = nowhere")))
    message = err.value.diagnostics[0]
    assert "scenes = NAME: NAME must be a model file imported by this file" in message.message
    assert message.span.line == 5


def test_the_free_hub_iltis_runs_every_scene_of_the_benchmark_vehicle():
    vehicle = frontend.load("library/iltis/vehicle.mbs")
    result = frontend.check("library/iltis/free_hub.mbs")
    free_hub = result.model()
    borrowed = {s.name for s in free_hub.scenes}
    left_out = {d.message.split("'")[1] for d in result.diagnostics if "left out" in d.message}
    assert {s.name for s in vehicle.scenes} <= borrowed | left_out   # a scene added later may not fit: it says so
    assert {"settle", "bump_5", "bump_10", "anti_5", "anti_10", "steer_ramp_10", "steer_ramp_20", "steer_ramp_30",
            "cornering", "steer_ramp", "steer_sine_1", "steer_sine_2", "steer_sine_4", "ride_c_15",
            "balance"} <= borrowed
    # a borrowed scene overrides some parameters and relies on the defaults of the others (bump = 1 ...); the
    # tyres are other models by design
    shared = set(vehicle.parameter_map) & set(free_hub.parameter_map)
    assert {"v", "bump", "anti", "rough", "steer_rate", "fl.x_axle", "fl.damping"} <= shared
    for name in shared - {"fl.omega", "fr.omega", "rl.omega", "rr.omega"}:   # the flanges stand still
        if not name.startswith("tyre_") and not any(name.endswith(x) for x in (".m_wheel", ".i_wheel", ".i_spin")):
            assert free_hub.parameter_map[name].value == vehicle.parameter_map[name].value, name
