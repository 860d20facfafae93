"""`mbs modes`: modes about the steady run at speed. A rigid car on four linear tyres has the lateral and yaw
eigenvalues of the linear single-track model, written out here from its mass, yaw inertia, axle distances
and cornering stiffnesses; the command prints a named table and draws the root locus."""

from pathlib import Path

import numpy as np
import pytest

import mbs
from mbs.cli import main
from mbs.modes import modes_at_speed

MODEL = Path(__file__).parent / "models" / "flat_car.mbs"
M, IZ, A, B, CF, CR = 1500.0, 2500.0, 1.1, 1.4, 2 * 40000.0, 2 * 45000.0


def single_track_eigenvalues(v):
    """States (v_y, r): m (v_y' + v r) = F_f + F_r, I_z r' = a F_f - b F_r, F = -C (v_y +- x r) / v."""
    matrix = np.array([[-(CF + CR) / (M * v), -v - (A * CF - B * CR) / (M * v)],
                       [-(A * CF - B * CR) / (IZ * v), -(A * A * CF + B * B * CR) / (IZ * v)]])
    return np.linalg.eigvals(matrix)


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("cache")


@pytest.fixture(scope="module")
def car(cache):
    return mbs.load(MODEL, cache_dir=str(cache))


@pytest.mark.parametrize("speed", [10.0, 30.0])
def test_lateral_and_yaw_modes_are_the_single_track_models(car, speed):
    modes = modes_at_speed(car, None, speed)
    handling = [m for m in modes if m.frequency > 0 and m.name in ("lateral", "yaw")]
    got = sorted((m.eigenvalue for m in handling), key=lambda z: (z.real, z.imag))
    want = sorted((z for z in single_track_eigenvalues(speed) if z.imag >= 0), key=lambda z: (z.real, z.imag))
    assert len(got) == len(want)
    for g, w in zip(got, want):
        assert abs(g - w) < 2e-3 * abs(w)
    # the suspension-free car's vertical modes are there too, named after their motion
    names = {m.name for m in modes if m.frequency > 0}
    assert {"bounce", "pitch", "roll"} <= names


def test_command_prints_the_table_and_draws_the_root_locus(tmp_path, capsys, monkeypatch, car, cache):
    monkeypatch.setenv("MBS_CACHE_DIR", str(cache))    # the fixture's build: no second compile
    plot, out = tmp_path / "locus.png", tmp_path / "modes.json"
    shapes = tmp_path / "shapes.png"
    assert main(["modes", str(MODEL), "--speed", "10:20:10", "--plot", str(plot), "--out", str(out),
                 "--shapes", str(shapes)]) == 0
    text = capsys.readouterr().out
    assert "steady run at 20 m/s" in text and "bounce" in text and "damping [%]" in text
    assert plot.stat().st_size > 0 and out.stat().st_size > 0 and shapes.stat().st_size > 0


def test_bad_speed_is_a_usage_error(capsys):
    assert main(["modes", str(MODEL), "--speed", "fast"]) != 0
    assert "--speed expects" in capsys.readouterr().err
