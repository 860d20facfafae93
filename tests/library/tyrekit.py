"""What the tyre tests share: reading a probe scene's tyre outputs at its start, and the fade-in of the library
tyres' forces from standstill (vx^2 / (vx^2 + v_low^2), see library/tyres/calspan.mbs)."""


def tyre_forces(system, **params) -> dict:
    """The components of `tyre.radial.forces` (fx fy fz mz alpha kappa gamma rho vx) at the scene's start."""
    res = system.simulate("probe", params=params)
    return {name.rsplit(".", 1)[1]: res[name][0] for name in res.names if name.startswith("tyre.radial.forces")}


def fade(vx: float, v_low: float) -> float:
    return vx ** 2 / (vx ** 2 + v_low ** 2)
