"""The generated dynamics functions (mbs.dynamics) against Pinocchio, and inverse against forward dynamics.

Random trees (randmodel, every joint kind but the free ones, whose linear velocity Pinocchio takes in the body
frame and we in the parent frame) are built in Pinocchio from the test's own description (pinkit), never from
our compiler. At random states q, v, a: our inverse dynamics equals pin.rnea, our bias forces
pin.nonLinearEffects, our gravity forces pin.computeGeneralizedGravity, our mass matrix pin.crba, to 1e-10.
Without force elements the model's only applied load is its weight, so rnea (no external forces) is our tau.

The round trip: the accelerations of the simulator's right-hand side (articulated-body algorithm, or the loop
solver for closed loops) put into the inverse dynamics give back zero joint forces on a tree, and the loop
closure forces G^T lambda on the Iltis quarter car (whose suspension closes kinematic loops).
"""

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
import randmodel  # noqa: E402

import mbs  # noqa: E402
from mbs.dynamics import dynamics_functions  # noqa: E402
from mbs.runtime.workspace import Workspace  # noqa: E402

TOL = 1e-10
KINDS = tuple(k for k in randmodel.KINDS if k not in ("free", "free_cardan"))
ROOT = Path(__file__).parents[2]


@pytest.mark.parametrize("seed, n_bodies", [(s, 2 + s % 3) for s in range(2)] +
                         [pytest.param(s, 3 + s % 4, marks=pytest.mark.slow) for s in range(2, 12)])
def test_dynamics_functions_match_pinocchio(seed, n_bodies):
    pin = pytest.importorskip("pinocchio")
    import pinkit
    rng = np.random.default_rng(1000 + seed)
    text, links, gravity = randmodel.random_model(rng, n_bodies, kinds=KINDS)
    dyn = dynamics_functions(mbs.loads(text))
    tree = pinkit.PinTree(links, gravity)
    model, data = tree.model, tree.data
    compiled = dyn.model
    for _ in range(3):
        values = randmodel.random_values(rng, links)
        q = np.array([values[n] for n in compiled.q_names])
        v = np.array([values[n] for n in compiled.v_names])
        a = rng.normal(size=compiled.nv)
        q_pin, v_pin, P, _, free = tree._state(values, compiled.v_names)
        assert not free
        a_pin = P @ a  # P maps our speeds onto Pinocchio's (a permutation without free joints)
        cases = ((dyn.inverse_dynamics(q, v, a), pin.rnea(model, data, q_pin, v_pin, a_pin)),
                 (dyn.bias_forces(q, v), pin.nonLinearEffects(model, data, q_pin, v_pin)),
                 (dyn.gravity_forces(q), pin.computeGeneralizedGravity(model, data, q_pin)))
        for ours, theirs in cases:
            scale = max(1.0, np.abs(theirs).max())
            np.testing.assert_allclose(ours, P.T @ np.asarray(theirs), rtol=0, atol=TOL * scale)
        M_pin = np.array(pin.crba(model, data, q_pin))
        M_pin = np.triu(M_pin) + np.triu(M_pin, 1).T
        np.testing.assert_allclose(dyn.mass_matrix(q), P.T @ M_pin @ P, rtol=0, atol=TOL * max(1, M_pin.max()))


@pytest.mark.parametrize("seed", [0, pytest.param(1, marks=pytest.mark.slow), pytest.param(2, marks=pytest.mark.slow)])
def test_frame_positions_velocities_and_jacobians_match_pinocchio(seed):
    """Frames at the centres of mass of the moving parts: pin.getFrameJacobian (LOCAL_WORLD_ALIGNED: velocity of
    the frame origin and angular velocity, world axes), data.oMf and getFrameVelocity."""
    pin = pytest.importorskip("pinocchio")
    import pinkit
    rng = np.random.default_rng(2000 + seed)
    text, links, gravity = randmodel.random_model(rng, 3, kinds=tuple(k for k in KINDS if k != "fixed"))
    names = [f"p{i}.com" for i in range(len(links))]
    dyn = dynamics_functions(mbs.loads(text), frames=names)
    tree = pinkit.PinTree(links, gravity)
    model = tree.model
    ids = []
    for i, link in enumerate(links):
        placement = pin.SE3(np.array(link.Rb, float), np.array(link.rb, float)).inverse() * \
            pin.SE3(np.eye(3), np.asarray(link.com, float))
        ids.append(model.addFrame(pin.Frame(names[i], tree.joint_id[i], 0, placement, pin.FrameType.OP_FRAME)))
    data = model.createData()
    world = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
    compiled = dyn.model
    for _ in range(3):
        values = randmodel.random_values(rng, links)
        q = np.array([values[n] for n in compiled.q_names])
        v = np.array([values[n] for n in compiled.v_names])
        q_pin, v_pin, P, _, _ = tree._state(values, compiled.v_names)
        pin.forwardKinematics(model, data, q_pin, v_pin)
        pin.updateFramePlacements(model, data)
        pin.computeJointJacobians(model, data, q_pin)
        positions, rotations = dyn.frame_positions(q)
        velocities, jacobians = dyn.frame_velocities(q, v), dyn.frame_jacobians(q)
        for k, fid in enumerate(ids):
            np.testing.assert_allclose(positions[k], data.oMf[fid].translation, rtol=0, atol=TOL)
            np.testing.assert_allclose(rotations[k], data.oMf[fid].rotation, rtol=0, atol=TOL)
            twist = pin.getFrameVelocity(model, data, fid, world)
            np.testing.assert_allclose(velocities[k], np.r_[twist.linear, twist.angular], rtol=0, atol=TOL)
            J = np.array(pin.getFrameJacobian(model, data, fid, world))
            np.testing.assert_allclose(jacobians[k], J @ P, rtol=0, atol=TOL)


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_inverse_dynamics_undoes_forward_dynamics_with_force_elements(backend):
    """The two-mass quarter car has springs and dampers: tau(q, v, vdot(q, v)) = 0 only if tau counts them."""
    system = mbs.load(ROOT / "library" / "examples" / "two_mass_quarter_car.mbs", backend=backend)
    dyn = dynamics_functions(system)
    compiled, rng = dyn.model, np.random.default_rng(3)
    data = Workspace(compiled)
    data.p = dyn.data.p
    for _ in range(3):
        x = data.x + rng.normal(scale=0.05, size=compiled.nx)
        vdot = data.function("rhs")(0.0, x)[compiled.nq:]
        tau = dyn.inverse_dynamics(x[:compiled.nq], x[compiled.nq:], vdot)
        assert np.abs(tau).max() < 1e-9 * max(1.0, np.abs(dyn.bias_forces(x[:compiled.nq], x[compiled.nq:])).max())
        assert np.abs(dyn.gravity_forces(x[:compiled.nq])).max() > 1.0  # the check is not vacuous


@pytest.mark.slow  # the Iltis loops compile and run for about 15 s
def test_inverse_dynamics_of_the_iltis_quarter_car_is_the_loop_closure_force():
    """Closed loops: M vdot = f + G^T lambda, so the tree's inverse dynamics at the loop solver's accelerations
    is G^T lambda (runtime/c/loops.c), at consistent states of a bump run."""
    system = mbs.load(ROOT / "library" / "iltis" / "quarter_car.mbs")
    dyn = dynamics_functions(system, "bump_5")
    compiled = dyn.model
    res = system.simulate("bump_5", t_end=0.3, sample=0.1)
    data = Workspace(compiled)
    data.p = dyn.data.p
    checked = 0
    for row in range(len(res.t)):
        x = np.array([res[n][row] for n in compiled.x_names])
        q, v = x[:compiled.nq], x[compiled.nq:]
        vdot = data.function("rhs")(float(res.t[row]), x)[compiled.nq:]
        tau = dyn.inverse_dynamics(q, v, vdot, t=float(res.t[row]))
        closure = dyn.constraint_jacobian(q, t=float(res.t[row])).T @ dyn.multipliers(q, v, t=float(res.t[row]))
        scale = np.abs(closure).max()
        assert scale > 100.0  # the suspension carries the car: the loop forces are large
        np.testing.assert_allclose(tau, closure, rtol=0, atol=1e-8 * scale)
        checked += 1
    assert checked >= 3


def test_the_standalone_header_exports_the_dynamics_functions_only_when_asked(tmp_path):
    """mbs compile names the exported functions with the model's prefix (spatial_arm_inverse_dynamics)."""
    from mbs.cli import main
    arm = str(ROOT / "tests" / "compiler" / "models" / "spatial_arm.mbs")
    assert main(["compile", arm, "-o", str(tmp_path / "plain")]) == 0
    assert "inverse_dynamics" not in (tmp_path / "plain" / "spatial_arm.h").read_text()
    assert main(["compile", arm, "--dynamics", "-o", str(tmp_path / "dyn")]) == 0
    header = (tmp_path / "dyn" / "spatial_arm.h").read_text()
    for name in ("inverse_dynamics", "bias_forces", "gravity_forces", "mass_matrix"):
        assert f"int spatial_arm_{name}(double t, const double *x, const double *p," in header
    assert "#define SPATIAL_ARM_NXA (SPATIAL_ARM_NX+SPATIAL_ARM_NV)" in header
    assert main(["compile", arm, "--frame", "fore.tip", "-o", str(tmp_path / "frames")]) == 0
    header = (tmp_path / "frames" / "spatial_arm.h").read_text()
    assert "#define SPATIAL_ARM_NF 1" in header and "const char *spatial_arm_frame_name(int i);" in header
    assert ("int spatial_arm_frame_jacobians(double t, const double *x, const double *p, double *mbs_jac, "
            "double *work);") in header
