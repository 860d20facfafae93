"""mbs animate: the parts' poses against the pendulum's closed-form kinematics, the road of the Iltis quarter car
under its tyre, and the page in headless Chromium (loads without errors; two times differ where parts moved)."""

from __future__ import annotations

import math
import shutil
import subprocess

import numpy as np
import pytest

import mbs
from mbs import pipeline
from mbs.animation import animation
from mbs.animation_page import page, write_page
from mbs.cli import main


def make(path, scene, t_end=None):
    system = mbs.load(path)
    res = system.simulate(scene, t_end=t_end)
    params = pipeline.parameter_values(system.model, pipeline.scene_overrides(system.scene(scene)))
    return system, res, animation(system, scene, res, params)


def rotate(q, v):
    """v rotated by the unit quaternion q = (x, y, z, w)."""
    u, w = np.asarray(q[:3]), q[3]
    return v + 2 * w * np.cross(u, v) + 2 * np.cross(u, np.cross(u, v))


def test_pendulum_bob_follows_the_hinge_angle():
    system, res, anim = make("library/examples/pendulum.mbs", "swing", t_end=2.0)
    (bob,) = anim.bodies
    l = 1.0  # library/examples/pendulum.mbs: com = (0, 0, -l)
    for k in (0, len(anim.t) // 3, len(anim.t) - 1):
        phi = np.interp(anim.t[k], res.t, res["hinge.phi"])
        pose = bob["poses"][k]
        com = pose[:3] + rotate(pose[3:], np.array(bob["com"]))
        # a rotation by phi about y carries (0, 0, -l) to (-l sin phi, 0, -l cos phi)
        np.testing.assert_allclose(com, [-l * math.sin(phi), 0.0, -l * math.cos(phi)], atol=1e-9)


def test_quarter_car_road_moves_under_the_tyre_and_has_the_bump():
    system, res, anim = make("library/iltis/quarter_car.mbs", "bump_5", t_end=1.0)
    (road,) = anim.roads
    assert road["moving"] and road["z"].shape == (len(anim.t), road["x"].size)
    assert np.max(road["z"]) == pytest.approx(0.2, abs=1e-3)  # the benchmark's cosine bump, 0.1 m * (1 - cos)
    assert any(b.get("wheel_radius") == pytest.approx(0.364325) for b in anim.bodies)


def test_page_is_self_contained(tmp_path):
    _, _, anim = make("library/examples/pendulum.mbs", "swing", t_end=0.5)
    text = page(anim)
    assert '"imports": {"three": "data:text/javascript;base64,' in text
    assert "http://" not in text.split("<script type=\"module\">")[1] and "https://" not in text.split("<style>")[1]


def test_cli_refuses_other_suffixes(capsys):
    assert main(["animate", "library/examples/pendulum.mbs", "-o", "x.png"]) == 1
    assert "an .html page" in capsys.readouterr().err


CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")


def chromium(*args, url):
    command = [CHROMIUM, "--headless", "--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
               "--window-size=640,400", "--virtual-time-budget=8000", *args, url]
    return subprocess.run(command, capture_output=True, text=True, timeout=120)


@pytest.mark.slow  # three browser starts, 15 s
@pytest.mark.skipif(CHROMIUM is None, reason="no Chromium installed (Debian: apt-get install chromium): the page "
                                             "is not rendered")
def test_page_renders_in_headless_chromium_and_moves(tmp_path):
    from matplotlib.image import imread
    _, _, anim = make("library/examples/pendulum.mbs", "swing", t_end=1.2)
    html = write_page(anim, tmp_path / "pendulum.html")
    url = html.as_uri()
    dom = chromium("--dump-dom", url=url + "#t=0").stdout
    assert 'data-status="ready"' in dom, dom[-500:]
    shots = []
    for time in (0.0, 0.5):  # the bob swings from +30 deg through the bottom (quarter period 0.5 s)
        png = tmp_path / f"t{time}.png"
        chromium(f"--screenshot={png}", url=f"{url}#t={time}")
        shots.append(imread(png)[:-60])  # the scene, above the control bar (whose time label differs too)
    changed = np.any(np.abs(shots[0] - shots[1]) > 0.05, axis=-1)
    assert changed.mean() > 0.002, "the two times look the same"
    assert changed.mean() < 0.5, "everything changed: the camera or the scene jumped"
