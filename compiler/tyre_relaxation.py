"""First-order relaxation of a tyre's slip: the lag between a change of slip and the force it builds up.

A real tyre's carcass deflects before its contact patch slides, so after a steering step the lateral force
builds up over a rolled distance of the order of the relaxation length sigma (Pacejka, "Tyre and Vehicle
Dynamics", ch. 7), not at once. With the element argument ``relax_y = sigma`` the tyre's laws see, instead
of the kinematic slip angle alpha, the relaxed one alpha_r, an extra differential state of the model:

    sigma * alpha_r' + V * alpha_r = V * alpha,      V = sqrt(vx^2 + v_low^2)

(``relax_x`` does the same for the longitudinal slip kappa). V is the slip denominator of compiler/tyre.py:
at speed it is |vx| (the textbook form, a distance constant sigma), and with alpha ~ vsy / V at low speed
V * alpha ~ vsy: the deflection form, which stays finite and well damped at standstill, where the textbook
form would freeze alpha_r. Without the arguments nothing changes: no state, the same code. The tyre
sensor's alpha and kappa are then the relaxed values, the ones the laws see; its vsx, vsy and vx give the
kinematic ones.

A length that is the number 0 once the inputs are put in (`relax_y = relax` with `input relax = 0 m`) is
off in the same way: no state, the same code. A scene that replaces the input (`input relax = 0.5 m`)
switches the relaxation on, which changes the compiled code, so a scene can do it and a parameter cannot
(library/iltis/vehicle.mbs: scene steer_ramp_20_relax).
"""

from __future__ import annotations

from collections.abc import Mapping

from mbs.language import expr as X
from mbs.language import model as M

#: element argument -> (slip quantity it relaxes, unit of the relaxed state)
RELAXED = {"relax_y": ("alpha", "rad"), "relax_x": ("kappa", "1")}


def relaxed_name(force_name: str, slip: str) -> str:
    return f"{force_name}.{slip}_r"


def switched_off(length: X.E | None, inputs: Mapping[str, X.E]) -> bool:
    """True when there is no relaxation length, or it is the number 0 once the inputs (the model's, as a scene
    replaces them) are put in: no state then."""
    seen = set()
    while isinstance(length, X.Sym) and length.kind == "input" and length.name in inputs and length not in seen:
        seen.add(length)
        length = inputs[length.name]
    return length is None or (isinstance(length, X.Const) and length.value == 0)


def model_inputs(model: M.Model, scene: M.Scene | None = None) -> dict[str, X.E]:
    """The inputs' expressions by name, the scene's replacing the model's."""
    inputs = {i.name: i.value for i in model.inputs}
    if scene is not None:
        inputs.update(dict(scene.inputs))
    return inputs


def relaxation_states(model: M.Model, inputs: Mapping[str, X.E] | None = None) -> list[tuple[str, str]]:
    """(state name, unit) of every relaxed slip of the model's tyres that is switched on, in element order;
    `inputs`: as `model_inputs` gives them (default: the model's own)."""
    inputs = model_inputs(model) if inputs is None else inputs
    out = []
    for inter in model.interactions:
        for force in inter.forces:
            if force.kind == "tyre":
                out += [(relaxed_name(force.name, slip), unit) for arg, (slip, unit) in RELAXED.items()
                        if not switched_off(force.arg(arg), inputs)]
    return out


def structural_inputs(model: M.Model) -> frozenset[str]:
    """Names of the inputs that a tyre reads as a relaxation length: their value decides the compiled code (a
    state per relaxed slip, or none), so they cannot be run-time values (mbs/inputs.py leaves them undriven: a
    linearisation has no B column for a length that adds or removes a state)."""
    names = set()
    for inter in model.interactions:
        for force in inter.forces:
            if force.kind == "tyre":
                for arg in RELAXED:
                    length = force.arg(arg)
                    if isinstance(length, X.Sym) and length.kind == "input":
                        names.add(length.name)
    return frozenset(names)


def relax(lowering, force: M.Force, values: dict, speed) -> None:
    """Replace alpha and kappa in `values` by their relaxed states where the element asks for it, and register
    the states' rates with the lowering."""
    for arg, (slip, _) in RELAXED.items():
        length = force.arg(arg)
        if switched_off(length, lowering.inputs):
            continue
        import sympy as sp  # the run's pipeline reads the names above without sympy (a cached derivation)
        state = sp.Symbol(relaxed_name(force.name, slip))
        lowering.element_rates[state] = speed * (values[slip] - state) / lowering.state(length)
        values[slip] = state
