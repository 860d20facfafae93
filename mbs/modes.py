"""Modes of a vehicle at speed: linearised about its steady straight run, named by the motion they carry.

    table = modes_at_speed(system, "settle", speed=20.0)      # [NamedMode], ascending frequency
    locus = root_locus(system, "settle", [5, 10, 20, 30])     # {speed: [NamedMode]}

Why about the steady run and not the static equilibrium: a tyre's lateral force depends on the slip angle,
i.e. on the ratio of lateral to forward speed, so the yaw and lateral modes exist only at speed (at rest the
tyre has no lateral stiffness at all) and their damping falls as the speed rises. The steady state is the
static equilibrium of the springs with the scene's initial speeds put back (the car cruising at the speed
parameter; its wheel spin follows the same parameter), which is a steady state on a flat road.

Names come from the kinetic energy of the mode shape s (position part in velocity coordinates; for one mode
the velocity shape is lambda s), coordinate by coordinate: the share of coordinate i is M_ii |s_i|^2 / sum_j
M_jj |s_j|^2 (the diagonal of the mass matrix: with tree coordinates the off-diagonal terms couple the body's
motion to every part it carries, and the cross terms would give shares above 100 % and below 0), summed over
the motions below, and a mode is named after the motion with the largest share. The car body is the part on
the first free joint from the inertial frame: its translations are 'longitudinal', 'lateral', 'bounce', its
rotations 'roll', 'pitch', 'yaw' (body axes, x forward, z up); everything else is grouped by the component
instance it belongs to ('fl', 'rr', ...), and a mode carried by instances is 'wheel hop' followed by the
instances that hold at least a third of the largest instance's share.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mbs.runtime.equilibrium import static_equilibrium

BODY_MOTIONS = {"x": "longitudinal", "y": "lateral", "z": "bounce", "wx": "roll", "wy": "pitch", "wz": "yaw",
                "alpha": "roll", "beta": "pitch", "gamma": "yaw"}


@dataclass(frozen=True)
class NamedMode:
    """One mode at one speed: eigenvalue [1/s], frequency [Hz] (|lambda| / 2 pi, 0 for a rigid-body motion),
    damping ratio [-], its name, the energy share of every motion, and the shape by coordinate."""

    speed: float
    eigenvalue: complex
    frequency: float
    damping_ratio: float
    oscillatory: bool
    name: str
    shares: dict
    shape: dict

    def as_dict(self) -> dict:
        return {"speed": self.speed, "eigenvalue": [self.eigenvalue.real, self.eigenvalue.imag],
                "frequency_hz": self.frequency, "damping_ratio": self.damping_ratio, "oscillatory": self.oscillatory,
                "name": self.name, "energy_shares": self.shares,
                "shape": {k: [v.real, v.imag] for k, v in self.shape.items()}}


def motion_of(coordinate: str, body_joint: str | None) -> str:
    """The motion a velocity coordinate belongs to (see the module docstring)."""
    if body_joint is not None and coordinate.startswith(body_joint + "."):
        return BODY_MOTIONS.get(coordinate[len(body_joint) + 1:], coordinate)
    return coordinate.split(".", 1)[0] if "." in coordinate else coordinate


def body_joint_of(model) -> str | None:
    """The interaction of the first free joint from the inertial part (a vehicle's body), if any."""
    from mbs.language import model as M
    for inter in model.interactions:
        if inter.joint is not None and inter.joint.kind == "free" and M.INERTIAL in (inter.a.part, inter.b.part):
            return inter.name
    return None


def name_mode(shares: dict, body_motions: set) -> str:
    """The dominant motion; instances of components are wheel hop (those within a third of the largest)."""
    if not shares:
        return "-"
    best = max(shares, key=shares.get)
    if best in body_motions:
        return best
    instances = {k: v for k, v in shares.items() if k not in body_motions}
    top = max(instances.values())
    carried = sorted(k for k, v in instances.items() if v >= top / 3)
    return "wheel hop " + "+".join(carried)


def energy_shares(shape: np.ndarray, mass: np.ndarray, motions: list[str]) -> dict:
    """Kinetic-energy share of every motion in a (complex) shape in velocity coordinates."""
    weights = np.diag(mass) * np.abs(shape) ** 2
    total = weights.sum()
    out: dict[str, float] = {}
    if total <= 0:
        return out
    for motion, w in zip(motions, weights):
        out[motion] = out.get(motion, 0.0) + float(w / total)
    return {k: v for k, v in sorted(out.items(), key=lambda p: -p[1]) if abs(v) > 1e-4}


def steady_state(system, scene: str | None, params: dict, hooks=None):
    """(compiled model, workspace, state) of the steady straight run: springs at rest, the scene's speeds.
    hooks: the implementations of the model's user hooks (as for System.simulate)."""
    compiled, gen, values = system._scene_parameters(scene, params, hooks)
    data = system._workspace(compiled, gen, values)
    x = static_equilibrium(compiled, data, data.x).x
    return compiled, data, x


def modes_at_speed(system, scene: str | None, speed: float, *, params: dict | None = None,
                   speed_param: str = "v", hooks=None) -> list[NamedMode]:
    """The modes about the steady run at `speed` (set as the parameter `speed_param`), ascending frequency."""
    from mbs.runtime.linearize import linearize
    overrides = dict(params or {})
    overrides[speed_param] = float(speed)
    compiled, data, x = steady_state(system, scene, overrides, hooks)
    lin = linearize(compiled, data, 0.0, x)
    body = body_joint_of(system.model)
    motions = [motion_of(n, body) for n in lin.coordinate_names]
    body_motions = set(BODY_MOTIONS.values())
    mass = data.mass_matrix(0.0, lin.x)
    out = []
    for mode in lin.modes:
        shape = np.array([mode.shape[n] for n in lin.coordinate_names])
        shares = energy_shares(shape, mass, motions)
        out.append(NamedMode(float(speed), mode.eigenvalue, mode.frequency, mode.damping_ratio, mode.oscillatory,
                             name_mode(shares, body_motions), shares, mode.shape))
    return out


def root_locus(system, scene: str | None, speeds, *, params: dict | None = None,
               speed_param: str = "v", hooks=None) -> dict[float, list[NamedMode]]:
    """The modes at every speed (one compile: the speed is a run-time parameter). hooks: as for simulate."""
    return {float(v): modes_at_speed(system, scene, v, params=params, speed_param=speed_param, hooks=hooks)
            for v in speeds}


def table(modes: list[NamedMode], rigid: bool = False) -> str:
    """Frequency [Hz], damping ratio [%], name and eigenvalue per mode (rigid-body motions only if asked)."""
    lines = [f"{'mode':>4}  {'f [Hz]':>9}  {'damping [%]':>11}  {'eigenvalue [1/s]':>22}  name (kinetic energy shares)"]
    shown = [m for m in modes if rigid or m.frequency > 0.0]
    for i, m in enumerate(shown, 1):
        lam = m.eigenvalue
        ev = (f"{lam.real:.4g} {'+' if lam.imag >= 0 else '-'} {abs(lam.imag):.4g}j" if m.oscillatory
              else f"{lam.real:.4g}")
        shares = ", ".join(f"{k} {100 * v:.0f}%" for k, v in list(m.shares.items())[:3])
        lines.append(f"{i:>4}  {m.frequency:>9.4g}  {100 * m.damping_ratio:>11.3g}  {ev:>22}  {m.name} ({shares})")
    return "\n".join(lines)


def plot_root_locus(locus: dict[float, list[NamedMode]], path, title: str) -> None:
    """Eigenvalues in the complex plane, coloured by speed, one marker per mode name; written atomically."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from mbs.base.atomic import atomic_path
    fig = Figure(figsize=(8, 6))
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    speeds = sorted(locus)
    names = sorted({m.name for modes in locus.values() for m in modes if m.frequency > 0})
    markers = "os^vD<>phX*P"
    import matplotlib
    cmap = matplotlib.colormaps["viridis"]
    lo, hi = speeds[0], speeds[-1]
    for name, marker in zip(names, markers * 4):
        pts = [(m.eigenvalue, v) for v in speeds for m in locus[v] if m.name == name and m.frequency > 0]
        if not pts:
            continue
        colours = [cmap(0.0 if hi == lo else (v - lo) / (hi - lo)) for _, v in pts]
        ax.scatter([p.real for p, _ in pts], [abs(p.imag) / (2 * np.pi) for p, _ in pts], c=colours,
                   marker=marker, label=name, s=28)
    ax.set_xlabel("Re(lambda) [1/s]")
    ax.set_ylabel("damped frequency Im(lambda) / 2 pi [Hz]")
    ax.set_title(f"{title}: root locus, speed {lo:g} to {hi:g} m/s (dark to light)")
    ax.axvline(0.0, color="grey", lw=0.8)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        fig.savefig(f, format=Path(path).suffix.lstrip(".").lower() or "png", dpi=120)


def plot_shapes(modes: list[NamedMode], path, title: str) -> None:
    """One bar per mode (frequency and name), split into the kinetic-energy shares of the motions: the mode
    shapes as a picture; written atomically."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from mbs.base.atomic import atomic_path
    shown = [m for m in modes if m.frequency > 0]
    motions = sorted({k for m in shown for k in m.shares}, key=lambda k: -sum(m.shares.get(k, 0.0) for m in shown))
    fig = Figure(figsize=(9, 0.45 * len(shown) + 1.6))
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    left = np.zeros(len(shown))
    for motion in motions:
        share = np.array([m.shares.get(motion, 0.0) for m in shown])
        ax.barh(range(len(shown)), share, left=left, label=motion)
        left += share
    ax.set_yticks(range(len(shown)), [f"{m.frequency:.3g} Hz, {100 * m.damping_ratio:.0f} %: {m.name}" for m in shown],
                  fontsize=8)
    ax.invert_yaxis()
    ax.set_xlabel("kinetic energy share")
    ax.set_title(title)
    ax.legend(fontsize=7, loc="lower right", ncol=2)
    fig.tight_layout()
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        fig.savefig(f, format=Path(path).suffix.lstrip(".").lower() or "png", dpi=120)
