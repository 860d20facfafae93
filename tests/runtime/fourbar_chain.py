"""The planar chain of N coupled four-bars (the IFToMM "N four-bar mechanism" benchmark), as .mbs text.

N + 1 rockers of length L stand on ground pivots L apart; N couplers of length L join the tops of neighbouring
rockers, so every cell is a parallelogram and the mechanism has one degree of freedom whatever N. Bars are
uniform slender rods of mass m; gravity acts along -z. The spanning tree: every rocker on the ground, coupler i
on the top of rocker i - 1; the pin from coupler i to the top of rocker i closes loop i (cut). Started upright
(rockers at 90 degrees) with the couplers moving at `speed` along x, gravity folds the rockers down through the
flat position (all bars on the ground line), where the constraint Jacobian loses one rank per loop: the
singular (bifurcation) configurations the benchmark is about.

Oracle: with theta the rockers' angle from the ground line (counter-clockwise in the x-z plane), the kinetic
energy is (N + 1) m L^2 theta'^2 / 6 + N m L^2 theta'^2 / 2 and the potential (N + 1) m g L sin(theta) / 2
+ N m g L sin(theta), so theta'' = -k cos(theta) with k = g ((N + 1) / 2 + N) / (L ((N + 1) / 3 + N)).
For N = 40, g = 9.81, L = 1: k = 11.059 rad/s^2.
"""

from __future__ import annotations

import math

G = 9.81


def acceleration_gain(n: int, length: float = 1.0, g: float = G) -> float:
    """k in theta'' = -k cos(theta) [rad/s^2 at cos(theta) = 1]."""
    return g * ((n + 1) / 2 + n) / (length * ((n + 1) / 3 + n))


def fourbar_chain(n: int = 40, *, length: float = 1.0, mass: float = 1.0, theta0_deg: float = 90.0,
                  speed: float = 1.0) -> str:
    """The .mbs text of the chain of n four-bars, rockers started at theta0 with the couplers at `speed` m/s
    (the crank's rate -speed/L at theta0 = 90 deg: the tops move along +x)."""
    omega = -speed / (length * math.sin(math.radians(theta0_deg)))
    lines = [
        f"# Planar chain of {n} coupled four-bars through its singular (flat) positions (generated).",
        f"model fourbar_chain_{n} \"{n} coupled four-bars\" {{",
        f"    param L = {length} m",
        f"    param m = {mass} kg",
        "    gravity = (0, 0, -9.81) m/s^2",
        "    part inertial {",
        *[f"        frame ground{i} at ({i} * L, 0, 0)" for i in range(n + 1)],
        "    }",
        "",
    ]
    for kind in ("rocker", "coupler"):
        count = n + 1 if kind == "rocker" else n
        for i in range(count):
            name = f"{kind}{i if kind == 'rocker' else i + 1}"
            lines += [
                f"    rigid {name} {{",
                "        body {",
                "            mass = m",
                "            com = (L / 2, 0, 0)",
                "            inertia = diag(1e-6, m * L^2 / 12, m * L^2 / 12)",
                "        }",
                "        frame tip at (L, 0, 0)",
                "    }",
            ]
    for i in range(n + 1):
        init = (f"init phi = {theta0_deg} deg\n            init der(phi) = {omega!r} rad/s" if i == 0
                else f"init phi = {theta0_deg} deg")
        lines += [
            f"    interact pivot{i} {{",
            f"        connect inertial.ground{i} -> rocker{i}",
            "        joint revolute(axis = (0, -1, 0)) {",
            f"            {init}",
            "        }",
            "    }",
        ]
    for i in range(1, n + 1):
        lines += [
            f"    interact top{i} {{",
            f"        connect rocker{i - 1}.tip -> coupler{i}",
            "        joint revolute(axis = (0, -1, 0)) {",
            f"            init phi = {-theta0_deg} deg",
            "        }",
            "    }",
            f"    interact close{i} \"closes loop {i}\" {{",
            f"        connect coupler{i}.tip -> rocker{i}.tip",
            "        joint revolute(axis = (0, -1, 0), cut = true)",
            "    }",
        ]
    lines.append("}")
    return "\n".join(lines) + "\n"
