"""Body frames at the joints (compiler/lower.py, _Lowering._body_origin): each part's body frame has its origin at the
child frame of the joint that moves it in the tree, so that a revolute or spherical joint's motion subspace has no
linear part and the composite-rigid-body algorithm's columns and the inverse dynamics' joint forces read entries
instead of products (the Iltis's loop terms: 27,390 -> 20,900 instructions a call).  Against the former lowering
(every body frame at its part's origin: `_body_origin` made 0), built in a cache of its own, at random states:
the mass matrix, the forces, the constraint Jacobian and the constraint acceleration of a loop model, the outputs
(frame sensors: positions, velocities, reactions, tyre loads), the named frames' poses and velocities, the
inverse dynamics and the parts' poses the animation draws agree to round-off."""

import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import mbs
from mbs.compiler import lower as lowering
from mbs.runtime import build
from mbs.runtime.workspace import Workspace

sys.path.insert(0, str(Path(__file__).parent))
from test_relative_line_forces import MODEL as RELATIVE_LINES  # noqa: E402

pytestmark = pytest.mark.skipif(not build.have_c_compiler(), reason="needs a C compiler")
ROOT = Path(__file__).resolve().parents[2]
#: (model file or text, scene, frames): a floating car with line forces between arms (rotated frames on the body
#: and an arm), a two-link arm with a position sensor, the Iltis quarter car (closed loops, a tyre, reactions).
CASES = [
    ("relative_lines", RELATIVE_LINES, None, ("car.top", "arm.tip", "link.end", "car", "arm")),
    ("arm", ROOT / "library" / "examples" / "arm.mbs", "release", ("fore.hand", "upper.elbow", "fore")),
    ("quarter_car", ROOT / "library" / "iltis" / "quarter_car.mbs", "bump_5", ()),
]


def evaluate(source, scene, frames, cache: Path, rng_seed=3):
    """The model functions at random states around the scene's start: a list of arrays per function name."""
    system = mbs.load(source, cache_dir=str(cache)) if isinstance(source, Path) else \
        mbs.loads(source, cache_dir=str(cache))
    start, _ = system.start(scene, jacobian=False)
    compiled = start.model
    data = Workspace(compiled)
    data.p = start.p
    names = ["mass_matrix", "forces"]
    if "constraint_jacobian" in compiled.backend.functions:
        names += ["constraint_jacobian", "constraint_acceleration"]
    if "outputs" in compiled.backend.functions:
        names.append("outputs")
    dynamics = None
    if frames:
        from mbs.dynamics import dynamics_functions
        dynamics = dynamics_functions(system, scene, frames=list(frames))
    rng = np.random.default_rng(rng_seed)
    if frames:
        names_of_frames = ["frames", "frame velocities", "inverse dynamics", "animated poses"]
    found = {name: [] for name in names + (names_of_frames if frames else [])}
    for _ in range(4):
        x = start.x.copy()
        x[:compiled.nq] += rng.normal(0.0, 0.05, compiled.nq)
        x[compiled.nq:] += rng.normal(0.0, 1.0, compiled.nv)
        x = data.normalize(0.1, x) if "normalize" in compiled.backend.functions else x
        for name in names:
            found[name].append(np.ravel(data.function(name)(0.1, x)))
        if frames:
            from mbs.animation import world_poses
            params = {p.name: p.value for p in system.model.parameters}
            poses = world_poses(system, scene, np.array([0.1]), x[None, :compiled.nq], params)
            found["animated poses"].append(np.ravel(poses))
            q, v = x[:compiled.nq], x[compiled.nq:]
            found["frames"].append(np.concatenate([np.ravel(a) for a in dynamics.frame_positions(q, 0.1)]))
            found["frame velocities"].append(np.ravel(dynamics.frame_velocities(q, v, 0.1)))
            found["inverse dynamics"].append(dynamics.inverse_dynamics(q, v, rng.normal(0.0, 1.0, compiled.nv), 0.1))
    return found


@pytest.mark.parametrize("name, source, scene, frames", CASES, ids=[c[0] for c in CASES])
def test_body_frames_at_the_joints_give_the_former_functions(name, source, scene, frames, tmp_path, monkeypatch):
    ours = evaluate(source, scene, frames, tmp_path / "joints")
    with monkeypatch.context() as patch:
        patch.setattr(lowering._Lowering, "_body_origin", lambda self, i: sp.zeros(3, 1))
        former = evaluate(source, scene, frames, tmp_path / "origins")
    assert ours.keys() == former.keys()
    for function in ours:
        for a, b in zip(ours[function], former[function]):
            scale = np.max(np.abs(b))
            assert scale > 0.0, function
            assert np.max(np.abs(a - b)) <= 1e-12 * scale, (function, np.max(np.abs(a - b)) / scale)
