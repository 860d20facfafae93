"""Isotropic dry friction at a point contact that slides in a plane (``coulomb(..., surface_normal = axis)``).

The contact is two rows of compiler/friction.py's machinery, one per tangent t1, t2 of the plane (each a
`_Contact` along it), with one mode: 0 sticks, 1 slips.

**Stick.** Both relative tangential accelerations are locked: the two forces solve their 2 x 2 block of
a0 + W F = 0 with the other elements, and the stick holds while the force lies in the static cone
|F| <= mu_s N.

**Slip.** The force opposes the slip velocity w = (w1, w2): F = -mu(|w|) N w / |w|. Where w is exactly zero (the
moment after a slip onset from rest) the direction is the one the slip event chose: e = (e1, e2), run-time values
next to the mode (language/friction.py).

**Slip onset** (event ``<force>.slip``): |F_req| rises through mu_s N while sticking; the element slips along w
when it moves (faster than GRIP_SPEED: a run that starts sliding), else towards -F_req / |F_req|, where the
system accelerates when let go (exact when the contact's response W is isotropic,
a body's centre of mass on the plane; otherwise the direction settles within the first moments of the slide, as
w / |w| takes over).

**Stick onset** (event ``<force>.grip``): the slip speed reaching zero is not a sign change of anything smooth,
so the event watches the component of w along the slip direction e stored at the last onset, w . e, which falls
through zero when the slide stops. It falls through zero too when the slide has turned by 90 degrees without
stopping (a block circling on a spring): then |w| is still above GRIP_SPEED and the event only re-arms, e = w /
|w|, and the slide goes on. Otherwise (a stop: |w| at the located event is of the order of the event tolerance
times the deceleration) the element sticks if the holding force is within the cone, else slips on towards
-F_req. The contact point's residual speed is not reset (it has no coordinate of its own; it is below
GRIP_SPEED and the stick holds it constant).
"""

from __future__ import annotations

import sympy as sp

from .events import LoweredEvent

#: Slip speed [m/s] below which a located fall of w . e is a stop, above which the slide turned and goes on.
GRIP_SPEED = 1e-6


def plane_tangents(normal) -> tuple[tuple, tuple]:
    """Two unit tangents (t1, t2) with t1 x t2 along `normal` (a numeric axis): for a coordinate axis the next
    two in cyclic order (z: x, y), which are the directions the slip-direction values e1, e2 refer to."""
    n = [sp.nsimplify(sp.sympify(c)) for c in normal]
    if not all(c.is_number for c in n):
        raise ValueError("the surface normal of a plane contact must be a numeric axis")
    size = sp.sqrt(sum(c * c for c in n))
    n = [c / size for c in n]
    axes = [(1, 0, 0), (0, 1, 0), (0, 0, 1)]
    for k in range(3):
        if n == [sp.Integer(c) for c in axes[k]]:
            return tuple(map(sp.Integer, axes[(k + 1) % 3])), tuple(map(sp.Integer, axes[(k + 2) % 3]))
    e = axes[min(range(3), key=lambda k: abs(float(n[k])))]
    u = [n[1] * e[2] - n[2] * e[1], n[2] * e[0] - n[0] * e[2], n[0] * e[1] - n[1] * e[0]]
    size = sp.sqrt(sum(c * c for c in u))
    u = [sp.simplify(c / size) for c in u]
    w = [n[1] * u[2] - n[2] * u[1], n[2] * u[0] - n[0] * u[2], n[0] * u[1] - n[1] * u[0]]
    return tuple(u), tuple(sp.simplify(c) for c in w)


def slip_speed(w) -> sp.Expr:
    return sp.sqrt(w[0] ** 2 + w[1] ** 2)


def kinetic_directions(w, e) -> tuple[sp.Expr, sp.Expr]:
    """The unit direction of the slip velocity w, or e where w is exactly zero."""
    speed = slip_speed(w)
    return tuple(sp.Piecewise((wi / speed, speed > 0), (ei, True)) for wi, ei in zip(w, e))


def plane_events(name: str, span, mode, e, w, required, limit) -> tuple[LoweredEvent, LoweredEvent]:
    """slip: |F_req| rises through the limit while sticking; grip: w . e falls through zero while slipping (see
    the module docstring for what the grip then does)."""
    from mbs.language.friction import direction_names, mode_name
    stick = 1 - mode ** 2
    held = sp.sqrt(required[0] ** 2 + required[1] ** 2)
    let_go = [sp.Piecewise((-r / held, held > 0), (ei, True)) for r, ei in zip(required, e)]
    speed = slip_speed(w)
    moving = [sp.Piecewise((wi / speed, speed > GRIP_SPEED), (d, True)) for wi, d in zip(w, let_go)]
    names = direction_names(name)
    slip = LoweredEvent(f"{name}.slip", stick * (held - limit) - mode ** 2, 1, False,
                        (("set", mode_name(name), sp.S.One),) + tuple(("set", n, d) for n, d in zip(names, moving)),
                        span)
    turned = speed > GRIP_SPEED
    after = sp.Piecewise((1, turned), (0, held <= limit), (1, True))
    direction = [sp.Piecewise((wi / speed, turned), (ei, held <= limit), (d, True))
                 for wi, ei, d in zip(w, e, let_go)]
    # mode * (w . e) while slipping; with e unset (0, a run starting to slide) it reads |w|
    watched = w[0] * e[0] + w[1] * e[1] + (1 - e[0] ** 2 - e[1] ** 2) * speed
    grip = LoweredEvent(f"{name}.grip", mode * watched + stick, -1, False,
                        (("set", mode_name(name), after),) + tuple(("set", n, d) for n, d in zip(names, direction)),
                        span)
    return slip, grip


__all__ = ["GRIP_SPEED", "kinetic_directions", "plane_events", "plane_tangents", "slip_speed"]
