"""The indicators printed without the sines and cosines of angles they do not depend on (compiler/angle_free.py
angle_free_tape): a wheel centre's world velocity composed from the spinning wheel's rotation and its velocity in
its own frame loses the spin (c^2 + s^2 = 1) and keeps its value; what does depend on the angle is left as it is;
the Iltis quarter car's mbs_events no longer evaluates the hub's spin, its right-hand side still does."""

import random
from pathlib import Path

import pytest
import sympy as sp

from mbs.compiler import angle_free
from mbs.compiler.angle_free import angle_free_tape
from mbs.compiler.tape import Tape

ROOT = Path(__file__).resolve().parents[2]


def spinning_wheel():
    """A tape of a wheel's centre velocity, world z component: row 2 of R0 Ry(a) times Ry(a)^T vp, and the symbols
    (a, the row's entries, vp, an extra term)."""
    tape = Tape()
    a = sp.Symbol("a")
    r0, r2, v0, v2, z = sp.symbols("r0 r2 v0 v2 z")
    c, s = tape.temp(sp.cos(a), "c"), tape.temp(sp.sin(a), "s")
    row0, row2 = tape.temp(r0 * c - r2 * s, "R_20"), tape.temp(r0 * s + r2 * c, "R_22")
    w0, w2 = tape.temp(c * v0 - s * v2, "w_0"), tape.temp(c * v2 + s * v0, "w_2")
    vel = tape.temp(row0 * w0 + row2 * w2 + z, "vel")
    return tape, vel, (a, r0, r2, v0, v2, z), (c, s, row0, w0)


def values(tape, outputs, point):
    return [float(e.xreplace(point)) for e in tape.expand(outputs)]


def test_the_spin_cancels_in_the_velocity_of_the_wheel_centre():
    tape, vel, symbols, (c, s, *_) = spinning_wheel()
    fork = angle_free_tape(tape, [vel])
    assert fork is not tape
    entries = {e.symbol for e in fork.entries_for([vel])}
    assert c not in entries and s not in entries  # neither sine nor cosine left to evaluate
    a, r0, r2, v0, v2, z = symbols
    assert sp.expand(fork.entry(vel).expr - (r0 * v0 + r2 * v2 + z)) == 0
    rng = random.Random(5)
    for _ in range(5):
        point = {x: sp.Float(rng.uniform(-2.0, 2.0)) for x in symbols}
        assert values(fork, [vel], point) == pytest.approx(values(tape, [vel], point), rel=1e-13, abs=1e-13)
    assert {e.symbol for e in tape.entries_for([vel])} >= {c, s}  # the equations' tape is left as it was


def test_what_depends_on_the_angle_is_left_as_it_is():
    tape, vel, (a, r0, r2, v0, v2, z), (c, s, row0, w0) = spinning_wheel()
    one_product = tape.temp(row0 * w0, "p")       # c^2 r0 v0 - ...: depends on a
    square = tape.temp(c * c + s, "q")            # 1 - s^2 + s: depends on a
    assert angle_free_tape(tape, [one_product, square]) is tape
    # the velocity alone would lose the angle, but the product reads c and s anyway: nothing to save
    assert angle_free_tape(tape, [vel, one_product]) is tape


def test_pythagoras_alone_and_a_division_by_the_angle():
    tape = Tape()
    a, x = sp.symbols("a x")
    c, s = tape.temp(sp.cos(a), "c"), tape.temp(sp.sin(a), "s")
    one = tape.temp(x * c ** 2 + x * s ** 2, "one")
    quotient = tape.temp(x / (c * c + s * s), "quotient")  # not a polynomial in c, s: not examined
    assert sp.expand(angle_free_tape(tape, [one]).entry(one).expr - x) == 0
    assert angle_free_tape(tape, [quotient]) is tape


def test_the_switch_off_gives_the_tape_itself(monkeypatch):
    tape, vel, *_ = spinning_wheel()
    monkeypatch.setattr(angle_free, "ANGLE_FREE_INDICATORS", False)
    assert angle_free_tape(tape, [vel]) is tape


def function_text(source: str, name: str) -> str:
    start = source.index(f"int {name}(")
    return source[start:source.index("\n}\n", start)]


def test_the_quarter_car_indicators_do_not_evaluate_the_hub_spin():
    import mbs
    system = mbs.load(ROOT / "library" / "iltis" / "quarter_car.mbs")
    generated = system.generate("bump_5")
    source = generated.c_source
    spin = [line.split("=")[0].split()[-1] for line in source.splitlines()
            if "fl_omega*t" in line and "const double" in line]
    assert spin, "the hub's spin angle is on the tape"
    indicators = function_text(source, "mbs_events")
    assert not any(f"{name})" in indicators for name in spin)  # no cos(phi), sin(phi) of it
    assert "fl_omega" not in indicators
    assert any(f"cos({name})" in source for name in spin)  # the right-hand side still rotates the wheel


def test_the_quarter_car_locates_the_same_events_as_with_the_former_indicators():
    """bump_10 of the quarter car with mbs_events printed both ways (the former: ANGLE_FREE_INDICATORS False, through
    mbs.pipeline.generate, which the derivation cache does not stand between): the same events in the same order,
    at the same times and with the same results to round-off."""
    import dataclasses

    import numpy as np

    import mbs
    from mbs import pipeline
    from mbs.runtime import build
    from mbs.runtime.backends import CBackend
    from mbs.runtime.translation_units import COLD_APART

    system = mbs.load(ROOT / "library" / "iltis" / "quarter_car.mbs")
    current = system.simulate("bump_10")
    angle_free.ANGLE_FREE_INDICATORS = False
    try:
        former = pipeline.generate(system.model, system.scene("bump_10"), cold_apart=COLD_APART)
    finally:
        angle_free.ANGLE_FREE_INDICATORS = True
    assert function_text(former.c_source, "mbs_events") != function_text(system.generate("bump_10").c_source,
                                                                         "mbs_events")
    compiled = system.compile("bump_10")
    model = dataclasses.replace(compiled, backend=CBackend(build.load(build.build(former.c_source))))
    for key in [key for key, value in system._compiled.items() if value is compiled]:
        system._compiled[key] = model
    before = system.simulate("bump_10")
    assert len(current.events) > 0
    assert [(e["event"], e["direction"]) for e in current.events] == [
        (e["event"], e["direction"]) for e in before.events]
    assert np.allclose([e["time"] for e in current.events], [e["time"] for e in before.events], rtol=0, atol=1e-12)
    for name in current.names:
        scale = max(1.0, float(np.max(np.abs(before[name]))))
        assert np.max(np.abs(current[name] - before[name])) <= 1e-9 * scale, name


# ---- the lookups a parameter at 0 scales away (gated_lookups) ----

def table_call(x):
    return sp.Function("mbs_table_0")(x)


def test_a_lookup_scaled_by_a_parameter_is_gated_by_it_on_the_tape_and_in_the_outputs():
    tape = Tape()
    rough, bump, x, z = sp.symbols("rough bump x z")
    road = tape.temp(bump * x + rough * table_call(x), "road")
    scaled_by_state = tape.temp(z * table_call(x), "by_state")  # a state's product: always evaluated
    fork, (first, second, third) = angle_free.gated_lookups(tape, [road - z, scaled_by_state, rough * table_call(z)],
                                                            [rough, bump])
    assert fork is not tape
    gated = sp.Piecewise((rough * table_call(x), sp.Ne(rough, 0)), (0, True))
    assert fork.entry(road).expr == bump * x + gated
    assert fork.entry(scaled_by_state).expr == z * table_call(x)
    assert first == road - z and second == scaled_by_state
    assert third == sp.Piecewise((rough * table_call(z), sp.Ne(rough, 0)), (0, True))
    assert tape.entry(road).expr == bump * x + rough * table_call(x)  # the equations' tape is left as it was


def test_without_a_gated_lookup_or_with_the_switch_off_the_tape_is_itself(monkeypatch):
    tape = Tape()
    rough, x = sp.symbols("rough x")
    plain = tape.temp(rough * sp.cos(x), "plain")  # no table
    assert angle_free.gated_lookups(tape, [plain], [rough])[0] is tape
    road = tape.temp(rough * table_call(x), "road")
    monkeypatch.setattr(angle_free, "GATED_LOOKUPS", False)
    fork, outputs = angle_free.gated_lookups(tape, [road, rough * table_call(x)], [rough])
    assert fork is tape and outputs == [road, rough * table_call(x)]


def test_the_floor_profile_is_looked_up_only_where_it_is_scaled_and_the_runs_are_the_same_to_the_bit():
    """A ball bouncing on a floor whose height is `rough` times a table (tests/compiler/models/gated_floor.mbs):
    mbs_events evaluates the lookup only where rough is not 0, its right-hand side as written; the runs at rough 0
    and 1 are those of the former text (GATED_LOOKUPS False, through mbs.pipeline.generate) to the bit."""
    import dataclasses

    import numpy as np

    import mbs
    from mbs import pipeline
    from mbs.runtime import build
    from mbs.runtime.backends import CBackend
    from mbs.runtime.translation_units import COLD_APART

    system = mbs.load(Path(__file__).parent / "models" / "gated_floor.mbs")
    source = system.generate("bounce").c_source
    assert "(rough != 0 ? rough*mbs_table_0(speed*t) : 0.0)" in function_text(source, "mbs_events")
    assert "rough != 0" not in function_text(source, "mbs_rhs")
    angle_free.GATED_LOOKUPS = False
    try:
        former = pipeline.generate(system.model, system.scene("bounce"), cold_apart=COLD_APART)
    finally:
        angle_free.GATED_LOOKUPS = True
    assert "rough != 0" not in function_text(former.c_source, "mbs_events")
    compiled = system.compile("bounce")
    model = dataclasses.replace(compiled, backend=CBackend(build.load(build.build(former.c_source))))
    for rough in (0.0, 1.0):
        current = system.simulate("bounce", params={"rough": rough})
        keys = [key for key, value in system._compiled.items() if value is compiled]
        for key in keys:
            system._compiled[key] = model
        try:
            before = system.simulate("bounce", params={"rough": rough})
        finally:
            for key in keys:
                system._compiled[key] = compiled
        assert len(current.events) > 10
        assert current.events == before.events
        assert np.array_equal(np.asarray(current.data), np.asarray(before.data))


# ---- one indicator alone (mbs_event_indicator, compiler/ccode.py) ----

def test_each_indicator_alone_is_printed_as_mbs_events_prints_it():
    """mbs_event_indicator's case k holds the statements of mbs_events that g[k] needs, each line as mbs_events has
    it (the same inlining: the same operations, the same bits; c/ode.c's root finding relies on it), and writes g[k]
    alone; the quarter car's damper limits need neither the tyre's lookups nor its contact geometry."""
    import re

    import mbs
    system = mbs.load(ROOT / "library" / "iltis" / "quarter_car.mbs")
    source = system.generate("bump_10").c_source
    whole = set(function_text(source, "mbs_events").splitlines())
    alone = function_text(source, "mbs_event_indicator")
    cases = re.split(r"\n    case (\d+): \{\n", alone)[1:]
    nev = int(re.search(r"#define MBS_NEV (\d+)", source).group(1))
    assert [int(k) for k in cases[::2]] == list(range(nev))
    for k, body in zip(cases[::2], cases[1::2]):
        lines = body.split("\n    }")[0].splitlines()
        assert lines[-1] == f"        return mbs_all_finite(g + {k}, 1) ? 0 : 2;"
        statements = [line[4:] for line in lines[:-1] if not line.strip().startswith("(void)")]
        assert [line for line in statements if line not in whole] == []
        assert {int(i) for i in re.findall(r"\bg\[(\d+)\] =", body)} == {int(k)}
    sizes = [len(body.splitlines()) for body in cases[1::2]]
    assert min(sizes) < len(whole) / 3  # a switch's indicator needs a small part of mbs_events
