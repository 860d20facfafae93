"""The full Iltis vehicle of the library: static sums, symmetry over the in-phase bump, lift-off at 10 m/s."""

import sys
from pathlib import Path

import numpy as np
import pytest

import mbs

sys.path.insert(0, str(Path(__file__).resolve().parent))
from tyrekit import assert_tyre_loads_never_pull  # noqa: E402

G = 9.81


@pytest.fixture(scope="module")
def vehicle():
    return mbs.load("library/iltis/vehicle.mbs")


def total_weight(system) -> float:
    p = {x.name: x.value for x in system.model.parameters}
    corner = sum(p[f"fl.{m}"] for m in ("m_leaf", "m_arm", "m_carrier", "m_rod", "m_wheel"))
    return G * (p["m_body"] + 4 * corner)


TYRES = ("tyre_fl", "tyre_fr", "tyre_rl", "tyre_rr")


def test_static_tyre_forces_add_up_to_the_weight(vehicle):
    result, outputs = vehicle.equilibrium("bump_5")
    res = vehicle.simulate("bump_5", t_end=0.005)
    loads = {t: res[f"{t}.radial.load"][0] for t in ("tyre_fl", "tyre_rl")}
    # left and right carry the same (symmetry), so the four loads are twice the left ones
    total = 2 * (loads["tyre_fl"] + loads["tyre_rl"])
    assert total == pytest.approx(total_weight(vehicle), rel=1e-6)


def test_the_start_is_the_mirror_image_of_itself(vehicle):
    """The model is symmetric about the car's xz plane, so its rest is: no roll, no heading, no lateral offset, and
    each right coordinate the mirror image of its left twin, to round-off. Heading and lateral position feel no
    force at rest, so the equilibrium must leave them where they start (0); it moved the heading by 9e-10 rad by
    the noise of its Jacobian, which rolled the car over the in-phase bump at 10 m/s by 5e-9 rad. What is left is
    the round-off of the Newton steps, a spread: with the car body's mass changed by -4 ... 4 ulp the heading
    ended between 1.6e-14 and 1.07e-12 rad (median 5.0e-13; with the body frames at the joints, compiler/lower.py,
    1.0e-14 to 1.14e-12, median 4.9e-13), so the bound is 1e-11, two decades below the former noise."""
    result, outputs = vehicle.equilibrium("bump_5")
    for name in ("roll", "yaw", "lateral"):
        assert abs(outputs[name]) < 1e-11, name
    compiled = vehicle.compile("bump_5")
    names = list(compiled.q_names) + list(compiled.v_names)
    mirrored = ("lower_ball.qx", "lower_ball.qz", "lower_ball.wx", "lower_ball.wz")  # components that change sign
    for i, name in enumerate(names):
        for left, right in (("fl.", "fr."), ("rl.", "rr.")):
            if left in name:
                sign = -1.0 if name.endswith(mirrored) else 1.0
                twin = result.x[names.index(name.replace(left, right))]
                assert result.x[i] == pytest.approx(sign * twin, abs=1e-12), name


@pytest.mark.slow
@pytest.mark.parametrize("scene, lifts_off", [("bump_5", False), ("bump_10", True)])
def test_in_phase_bump_stays_symmetric_and_tyres_never_pull(vehicle, scene, lifts_off):
    res = vehicle.simulate(scene)
    assert res.success, res.message
    assert np.max(np.abs(res["roll"])) < 1e-9
    assert_tyre_loads_never_pull(res, ("tyre_fl", "tyre_rl"))
    loads = np.concatenate([res[f"{t}.radial.load"] for t in ("tyre_fl", "tyre_rl")])
    assert (loads.min() <= 0.0) == lifts_off  # a lift-off shows as a load of zero (to the event location)
    assert np.ptp(res["heave"]) > 0.1  # it did go over the 0.2 m bump
