"""What the tyre tests share: reading a probe scene's tyre outputs at its start, and the fade-in of the library
tyres' forces from standstill (vx^2 / (vx^2 + v_low^2), see library/tyres/calspan.mbs), and the
check that a tyre never pulls."""

import numpy as np


def tyre_forces(system, **params) -> dict:
    """The components of `tyre.radial.forces` (fx fy fz mz alpha kappa gamma rho vx vsx vsy omega) at the scene's
    start."""
    res = system.simulate("probe", params=params)
    return {name.rsplit(".", 1)[1]: res[name][0] for name in res.names if name.startswith("tyre.radial.forces")}


def fade(vx: float, v_low: float) -> float:
    return vx ** 2 / (vx ** 2 + v_low ** 2)


class TyreProbe:
    """The compiled tyre of a probe model (tests/library/models/*_probe.mbs) evaluated at any wheel motion
    without a run: the scene's outputs at a state set by hand (thousands of points a second, so that curves
    can be searched for their peaks and zeros)."""

    def __init__(self, system, **params):
        self.data, _ = system.start("probe", params=params)
        model = self.data.model
        self.names = [n.rsplit(".", 1)[1] for n in model.y_names]
        self.index = {n: i for i, n in enumerate(model.q_names + model.v_names)}
        self.x0 = self.data.x.copy()

    def set(self, **params) -> None:
        for name, value in params.items():
            self.data.set_param(name, value)

    def __call__(self, *, vx: float, vy: float = 0.0, spin: float = 0.0, height: float | None = None) -> dict:
        """The tyre's outputs with the wheel centre moving at (vx, vy), spinning at spin, at a height."""
        x = self.x0.copy()
        x[self.index["der(free.x)"]], x[self.index["der(free.y)"]] = vx, vy
        x[self.index["der(free.beta)"]] = spin
        if height is not None:
            x[self.index["free.z"]] = height
        return dict(zip(self.names, self.data.outputs(0.0, x)))


def assert_tyre_loads_never_pull(res, tyres) -> None:
    """A tyre load is never negative, up to what the event location leaves: at a lift-off the row before the
    event evaluates the contact branch where the root finder put its zero, to 1e-12 s (times max(1, t), c/ode.c),
    so the load there is zero to that time times the load's rate. The rate is bounded from the samples
    themselves (their steepest difference quotient), not assumed."""
    t = res.t
    location = 1e-12 * max(1.0, float(t[-1]))
    apart = np.diff(t) > 0
    for tyre in tyres:
        load = res[f"{tyre}.radial.load"]
        rate = np.max(np.abs(np.diff(load)[apart] / np.diff(t)[apart]))
        round_off = 1e-14 * np.max(np.abs(load))
        assert load.min() >= -(2 * location * rate + round_off), (tyre, load.min(), rate)
