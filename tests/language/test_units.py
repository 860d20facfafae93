"""Units: conversions against exactly defined values, dimension algebra, and the error texts users see."""

import math

import pytest

from mbs.language.units import (
    ACCELERATION,
    ANGLE,
    ANGULAR_VELOCITY,
    DAMPING,
    DIMENSIONLESS,
    FORCE,
    FREQUENCY,
    INERTIA,
    LENGTH,
    MASS,
    PRESSURE,
    ROT_DAMPING,
    ROT_STIFFNESS,
    STIFFNESS,
    TIME,
    TORQUE,
    UNITS,
    VELOCITY,
    Dimension,
    UnitError,
    describe,
    format_quantity,
    parse_unit,
)

REL = 1e-15  # conversions are a handful of float operations on exactly defined factors


@pytest.mark.parametrize(
    "text, factor, dim",
    [
        ("kg", 1.0, MASS),
        ("g", 1e-3, MASS),
        ("mm", 1e-3, LENGTH),
        ("cm", 1e-2, LENGTH),
        ("km", 1e3, LENGTH),
        ("ms", 1e-3, TIME),
        ("min", 60.0, TIME),
        ("h", 3600.0, TIME),
        ("km/h", 1 / 3.6, VELOCITY),
        ("mph", 1609.344 / 3600, VELOCITY),
        ("deg", math.pi / 180, ANGLE),
        ("rev", 2 * math.pi, ANGLE),
        ("rpm", 2 * math.pi / 60, ANGULAR_VELOCITY),
        ("Hz", 1.0, FREQUENCY),
        ("kN", 1e3, FORCE),
        ("kN*m", 1e3, TORQUE),
        ("Nm", 1.0, TORQUE),
        ("bar", 1e5, PRESSURE),
        ("kPa", 1e3, PRESSURE),
        ("MPa", 1e6, PRESSURE),
        ("mm^2", 1e-6, LENGTH**2),
        ("%", 1e-2, DIMENSIONLESS),
        ("deg/s", math.pi / 180, ANGULAR_VELOCITY),
        ("g*cm^2", 1e-7, INERTIA),
    ],
)
def test_conversion_to_si(text, factor, dim):
    got_factor, got_dim = parse_unit(text)
    assert got_factor == pytest.approx(factor, rel=REL)
    assert got_dim == dim


@pytest.mark.parametrize(
    "text, dim",
    [
        ("N/m", STIFFNESS),
        ("N*s/m", DAMPING),
        ("N*m/rad", ROT_STIFFNESS),
        ("N*m*s/rad", ROT_DAMPING),
        ("kg*m^2", INERTIA),
        ("m/s^2", ACCELERATION),
        ("rad/s", ANGULAR_VELOCITY),
        ("1/s", FREQUENCY),
        ("s^-1", FREQUENCY),
        ("N", FORCE),
        ("Pa", PRESSURE),
    ],
)
def test_unit_text_has_expected_dimension(text, dim):
    assert parse_unit(text) == (pytest.approx(1.0, rel=REL), dim)


def test_dimension_algebra():
    assert STIFFNESS == Dimension(M=1, T=-2)  # N/m == kg/s^2
    assert DAMPING == Dimension(M=1, T=-1)  # N*s/m == kg/s
    assert parse_unit("rad/s")[1] == parse_unit("1/s")[1]
    assert ANGLE == DIMENSIONLESS and ANGLE.is_dimensionless
    assert not LENGTH.is_dimensionless
    assert LENGTH**3 / LENGTH == LENGTH * LENGTH
    assert LENGTH**-1 == DIMENSIONLESS / LENGTH
    assert FORCE == MASS * LENGTH / TIME**2
    assert len({STIFFNESS, parse_unit("kg/s^2")[1], FORCE / LENGTH}) == 1  # hash agrees with ==


def test_dimension_power_needs_an_integer():
    with pytest.raises(TypeError):
        LENGTH**0.5


def test_division_is_left_associative():
    assert parse_unit("m/s/s") == parse_unit("m/s^2")
    assert parse_unit("kg/m/s^2")[1] == Dimension(M=1, L=-1, T=-2)
    assert parse_unit("m*m/m")[1] == LENGTH


@pytest.mark.parametrize(
    "dim, text",
    [
        (DIMENSIONLESS, "1"),
        (MASS, "kg"),
        (INERTIA, "kg*m^2"),
        (STIFFNESS, "kg/s^2"),
        (FREQUENCY, "1/s"),
        (Dimension(M=1, L=-1, T=-2), "kg/m/s^2"),
        (Dimension(L=-1, T=-1), "1/m/s"),
    ],
)
def test_dimension_str_is_si_product_that_parses_back(dim, text):
    assert str(dim) == text
    if not dim.is_dimensionless:
        assert parse_unit(text) == (1.0, dim)


@pytest.mark.parametrize(
    "dim, text",
    [
        (MASS, "mass (kg)"),
        (LENGTH, "length (m)"),
        (TIME, "time (s)"),
        (STIFFNESS, "stiffness (N/m)"),
        (DAMPING, "damping (N*s/m)"),
        (FORCE, "force (N)"),
        (TORQUE, "torque (N*m)"),
        (INERTIA, "inertia (kg*m^2)"),
        (VELOCITY, "velocity (m/s)"),
        (ACCELERATION, "acceleration (m/s^2)"),
        (ANGULAR_VELOCITY, "angular velocity or frequency (1/s)"),
        (DIMENSIONLESS, "dimensionless"),
        (Dimension(M=1, L=3, T=-1), "kg*m^3/s"),
    ],
)
def test_describe(dim, text):
    assert describe(dim) == text


@pytest.mark.parametrize(
    "value, dim, text",
    [
        (1260.0, MASS, "1260 kg"),
        (0.3, LENGTH, "0.3 m"),
        (35906.0, STIFFNESS, "35906 N/m"),
        (0.5, DIMENSIONLESS, "0.5"),
        (2.0, Dimension(L=3), "2 m^3"),
    ],
)
def test_format_quantity(value, dim, text):
    assert format_quantity(value, dim) == text


@pytest.mark.parametrize(
    "text, offset, length, message",
    [
        ("kgg", 0, 3, "unknown unit 'kgg'; did you mean 'kg'?"),
        ("N*s/mm2", 6, 1, "unexpected '2' in unit 'N*s/mm2'; write an exponent as 'mm^2'"),
        ("N*mx/s", 2, 2, "unknown unit 'mx'; did you mean 'm'?"),
        ("KG", 0, 2, "unknown unit 'KG'; did you mean 'kg'?"),
        ("kg*zzzz", 3, 4, "unknown unit 'zzzz'"),
        ("t", 0, 1, "unknown unit 't'; 't' is reserved for time; write 1000 kg for a tonne"),
        ("km/t", 3, 1, "unknown unit 't'; 't' is reserved for time; write 1000 kg for a tonne"),
        ("kmh", 0, 3, "unknown unit 'kmh'; did you mean 'km/h'?"),
    ],
)
def test_unknown_names_are_located_and_get_a_suggestion(text, offset, length, message):
    with pytest.raises(UnitError) as info:
        parse_unit(text)
    err = info.value
    assert (err.message, err.offset, err.length) == (message, offset, length)
    assert str(err) == message


@pytest.mark.parametrize(
    "text, offset, message",
    [
        ("", 0, "empty unit"),
        ("N**m", 2, "expected a unit name after '*', found '*' in 'N**m'"),
        ("m^", 1, "expected an integer exponent after '^' in 'm^'"),
        ("m^x", 1, "expected an integer exponent after '^' in 'm^x'"),
        ("^2", 0, "expected a unit name, found '^' in '^2'"),
        ("m/", 2, "expected a unit name after '/', found end of unit in 'm/'"),
        ("1/", 2, "expected a unit name after '/', found end of unit in '1/'"),
        ("1", 0, "expected a unit name, found '1' in '1'"),
        ("N m", 1, "unexpected ' ' in unit 'N m'; join units with '*' or '/'"),
    ],
)
def test_malformed_text(text, offset, message):
    with pytest.raises(UnitError) as info:
        parse_unit(text)
    assert (info.value.message, info.value.offset) == (message, offset)


def test_t_is_not_a_unit():
    assert "t" not in UNITS


def test_results_are_cached():
    parse_unit.cache_clear()
    first = parse_unit("N*s/m")
    assert parse_unit("N*s/m") is first
    assert parse_unit.cache_info().hits == 1
