"""The tyre force element: contact kinematics of a wheel on a road surface, then the tyre's force laws.

A tyre is an interaction from a road frame a (on the inertial part; the road height is measured along its
z axis) to the wheel centre frame b, whose y axis is the spin axis. The compiler derives the contact
geometry symbolically, so any law written in the model file sees the same slip quantities:

- road normal n from the road height z(x, y) at the wheel centre, its slopes by central differences over
  +-SLOPE_STEP (a contact patch's length scale: exact enough for smooth roads, and defined for tables and
  piecewise profiles that have no derivative at their breaks); with `vertical = true` n is frame a's z axis
  (the point contact of the Iltis benchmark: the road's height counts, not its slope; on a slope the normal
  force then has no component along the road, so a car without brakes still has a static equilibrium);
- tyre axes: e_x = e_y x n / |e_y x n| forward in the road plane, e_l = n x e_x to the left in it, u = e_y x e_x
  the wheel plane's direction towards the road;
- camber gamma = asin(e_y . n) (positive when the wheel top leans to the tyre's right, -y), loaded radius
  r = h / cos(gamma) with h the centre's height above the road's tangent plane, deflection rho = r0 - r, contact
  point P = centre + r u, deflection rate rho_dot = -(n . v_centre) / cos(gamma);
- velocities of the contact point (the geometric point, not the rubber): vx forward, vsy lateral, the spin
  omega = w . e_y, the longitudinal slip velocity vsx = vx - omega r_e with the effective rolling radius
  r_e = r0 - rho / 3 (the usual approximation for radial tyres);
- slip angle alpha = atan(vsy / V) (positive when the contact slides to the left), longitudinal slip
  kappa = -vsx / V, with V = sqrt(vx^2 + v_low^2): finite at standstill, where the laws then act as stiff
  viscous dampers of the sliding velocity, and within (v_low / vx)^2 / 2 of the textbook definition at speed.

The laws are evaluated in the order road, fz, fx, fy, mz; each may read the quantities above and the forces
computed before it. The forces fx e_x + fy e_l + fz n act at P on the wheel, the torque mz about n.
"""

from __future__ import annotations

import sympy as sp

from mbs.language import expr as X
from mbs.language import model as M
from mbs.language.diagnostics import Diagnostic, MbsError

from .spatial import cross, dot
from .symbolic import ToSympy
from .tyre_relaxation import relax

SLOPE_STEP = 0.05  # m: half the base of the road slope's central difference

_STAGES = (  # law -> locals it may read (besides parameters, inputs and the state)
    ("road", ("x", "y")),
    ("fz", ("x", "y", "rho", "rho_dot", "gamma", "vx")),
    ("fx", ("x", "y", "rho", "rho_dot", "gamma", "vx", "fz", "alpha", "kappa", "vsx", "vsy", "omega")),
    ("fy", ("x", "y", "rho", "rho_dot", "gamma", "vx", "fz", "alpha", "kappa", "vsx", "vsy", "omega", "fx")),
    ("mz", ("x", "y", "rho", "rho_dot", "gamma", "vx", "fz", "alpha", "kappa", "vsx", "vsy", "omega", "fx",
            "fy")),
)

#: Laws whose comparisons and kinks become switches (events; every model unless `switches = false`): the road and the normal
#: force (the contact: lift-off where the force would pull, touch-down where the deflection returns to zero).
#: The slip laws stay as written: their kinks at zero slip (a |a|, |Fy| Fy) have a continuous slope, and as
#: switches they would fire at every sign change of the slip on a straight run.
_SWITCHED = ("road", "fz")


def _error(message: str, span) -> MbsError:
    return MbsError([Diagnostic("error", message, span)])


def _unit(tape, v, name):
    norm = tape.temp(sp.sqrt(dot(v, v)), name + "n")
    return [tape.temp(c / norm, name) for c in v], norm


def attach_tyre(lowering, inter: M.Interaction, force: M.Force) -> dict[str, sp.Expr]:
    """Attach a tyre's loads to the wheel; returns its named quantities (the tyre sensor's components)."""
    tape = lowering.kin.tape
    ba, _, pa, Ra = lowering.frame_world(inter.a)
    bb, pb_local, pb, Rb = lowering.frame_world(inter.b)
    if ba >= 0:
        raise _error("a tyre's frame a is the road: it must be a frame of the inertial part", force.span)
    to_road = lambda w: [dot([Ra[k][c] for k in range(3)], w) for c in range(3)]  # noqa: E731
    to_world = lambda r: [dot(Ra[k], r) for k in range(3)]  # noqa: E731

    values: dict[str, sp.Expr] = {}

    def law(arg: str, bound: dict[str, sp.Expr] | None = None) -> sp.Expr | None:
        expr = force.arg(arg)
        if expr is None:
            return None
        allowed = dict(_STAGES)[arg]
        scope = {**values, **(bound or {})}

        def resolve(sym: X.Sym) -> sp.Expr:
            if sym.kind != "local":
                return lowering._state_symbol(sym)
            if sym.name not in allowed or sym.name not in scope:
                raise _error(f"the {arg} law of a tyre cannot read '{sym.name}' (it may read "
                             f"{', '.join(allowed)})", force.span)
            return scope[sym.name]
        if arg in _SWITCHED:
            return sp.sympify(ToSympy(resolve, lowering.tables, lowering.switches)(expr))
        # the same law of every tyre of one component, converted once (compiler/instances.py)
        return sp.sympify(lowering.shared_laws.convert(expr, ToSympy(resolve, lowering.tables)))

    centre = to_road([p - q for p, q in zip(pb, pa)])
    x, y = tape.temp(centre[0], "tyx"), tape.temp(centre[1], "tyy")

    def road(xv, yv):
        z = law("road", {"x": xv, "y": yv})
        return sp.Integer(0) if z is None else z

    h_step = sp.Float(SLOPE_STEP)
    z_road = tape.temp(road(x, y), "tyzr")
    if force.arg("vertical"):   # a point contact that sees only the road's height
        sx = sy = sp.Integer(0)
    else:
        sx = tape.temp((road(x + h_step, y) - road(x - h_step, y)) / (2 * h_step), "tysx")
        sy = tape.temp((road(x, y + h_step) - road(x, y - h_step)) / (2 * h_step), "tysy")
    n, _ = _unit(tape, [-sx, -sy, sp.Integer(1)], "tyn")
    e_y = to_road([Rb[k][1] for k in range(3)])
    e_x, cos_gamma = _unit(tape, cross(e_y, n), "tyex")
    e_l = [tape.temp(c, "tyel") for c in cross(n, e_x)]
    u = [tape.temp(c, "tyu") for c in cross(e_y, e_x)]
    gamma = tape.temp(sp.asin(dot(e_y, n)), "tygamma")
    height = tape.temp(n[2] * (centre[2] - z_road), "tyh")   # above the tangent plane at the road point below
    radius = tape.temp(height / cos_gamma, "tyr")
    r0 = lowering.state(force.arg("radius"))
    rho = tape.temp(r0 - radius, "tyrho")

    v_centre = to_road(lowering.kin.frame_velocity(bb, pb_local))
    omega_w = to_road(lowering.kin.body_angular_velocity(bb))
    spin = tape.temp(dot(omega_w, e_y), "tyomega")
    v_contact = [v + w for v, w in zip(v_centre, cross(omega_w, [radius * c for c in u]))]
    vx = tape.temp(dot(e_x, v_contact) + spin * radius, "tyvx")   # without the rubber's rolling motion
    vsy = tape.temp(dot(e_l, v_contact), "tyvsy")
    vsx = tape.temp(vx - spin * (r0 - rho / 3), "tyvsx")
    speed = tape.temp(sp.sqrt(vx ** 2 + lowering.state(force.arg("v_low")) ** 2), "tyV")
    values.update(x=x, y=y, rho=rho, rho_dot=tape.temp(-dot(n, v_centre) / cos_gamma, "tyrhod"), gamma=gamma,
                  vx=vx)
    values["fz"] = tape.temp(law("fz"), "tyfz")
    values.update(alpha=tape.temp(sp.atan(vsy / speed), "tyalpha"), kappa=tape.temp(-vsx / speed, "tykappa"),
                  vsx=vsx, vsy=vsy, omega=spin)
    relax(lowering, force, values, speed)  # relaxation lengths (tyre_relaxation.py): relaxed slip states
    for arg in ("fx", "fy", "mz"):
        value = law(arg)
        values[arg] = sp.Integer(0) if value is None else tape.temp(value, "ty" + arg)

    contact = [c + radius * d for c, d in zip(centre, u)]
    F = to_world([values["fx"] * a + values["fy"] * b + values["fz"] * c for a, b, c in zip(e_x, e_l, n)])
    Rw, rw = lowering.kin.world_pose(bb)
    contact_world = [p + q for p, q in zip(pa, to_world(contact))]
    local = [dot([Rw[k][c] for k in range(3)], [p - r for p, r in zip(contact_world, rw)]) for c in range(3)]
    lowering.kin.add_force(bb, local, F)
    if values["mz"] != 0:
        lowering.kin.add_torque(bb, to_world([values["mz"] * c for c in n]))
    return values
