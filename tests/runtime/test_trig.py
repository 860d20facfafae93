"""The generated C's sin and cos (compiler/ccode_trig.py) against exact values: within 1 ulp everywhere.

The helpers are compiled alone with the model units' flags and called over arrays. The reference is the x87 long
double sinl/cosl (numpy's longdouble: 11 more bits than a double, its own exact argument reduction), checked
against mpmath on the hardest arguments; the largest error is measured in ulps of the exact value.
"""

from __future__ import annotations

import ctypes
import platform
import subprocess
from pathlib import Path

import mpmath
import numpy as np
import pytest

import mbs
from former_builds import flagged_build
from mbs.compiler.ccode_trig import INLINE_DEFINITION, TRIG_HELPERS
from mbs.runtime import build
from mbs.runtime.workspace import Workspace

DOUBLE_PENDULUM = Path(__file__).resolve().parents[2] / "library" / "examples" / "double_pendulum.mbs"

#: The bound the tests hold (the measured largest error is about 0.79 ulp: bench/trig.py prints it).
MAX_ULPS = 1.0

HARNESS = """
void each_sin(const double *x, double *y, long n) { for (long i = 0; i < n; i++) y[i] = mbs_sin(x[i]); }
void each_cos(const double *x, double *y, long n) { for (long i = 0; i < n; i++) y[i] = mbs_cos(x[i]); }
"""

pytestmark = pytest.mark.skipif(np.finfo(np.longdouble).nmant < 63, reason="needs an 80-bit long double reference")


def helpers_source() -> str:
    """The helpers as a generated file defines them (each after those it calls), and the loops over arrays."""
    order = ("mbs_sin_poly", "mbs_cos_poly", "mbs_circular", "mbs_sin", "mbs_cos")
    assert set(order) == set(TRIG_HELPERS)
    return "\n".join(["#include <math.h>", *INLINE_DEFINITION, *("\n".join(TRIG_HELPERS[k]) for k in order), HARNESS])


def compiled(tmp_path, flags=()):
    source = tmp_path / "trig.c"
    source.write_text(helpers_source())
    cc = tuple(build.compiler_command())
    library = tmp_path / f"trig{len(list(tmp_path.iterdir()))}.so"
    done = subprocess.run([*cc, *build.FLAGS, *flags, "-o", str(library), str(source), "-lm"], capture_output=True,
                          text=True)
    assert done.returncode == 0 and not done.stderr, done.stderr  # -Wall quiet
    lib = ctypes.CDLL(str(library))
    array = np.ctypeslib.ndpointer(np.float64, flags="C")
    for name in ("each_sin", "each_cos"):
        getattr(lib, name).argtypes = [array, array, ctypes.c_long]

    def call(name, x):
        x = np.ascontiguousarray(x, dtype=np.float64)
        y = np.empty_like(x)
        getattr(lib, "each_" + name)(x, y, len(x))
        return y
    return call


@pytest.fixture(scope="module")
def trig(tmp_path_factory):
    return compiled(tmp_path_factory.mktemp("trig"))


def ulps(y, exact):
    """|y - exact| in ulps of the exact value (the spacing of the doubles at its magnitude)."""
    magnitude = np.abs(exact).astype(np.float64)
    below = np.nextafter(magnitude, 0)  # an exact value just below a power of two has the finer spacing
    spacing = np.where(np.abs(exact) < magnitude, np.spacing(below), np.spacing(magnitude))
    return np.abs(y.astype(np.longdouble) - exact) / spacing.astype(np.longdouble)


def near_quarter_turns(top: int = 63662) -> np.ndarray:
    """The doubles nearest to n pi/2 and their neighbours, n = 1 .. top (|x| < 1e5): the reduction's hardest cases
    (|x - n pi/2| down to 2^-60.5 at n = 29)."""
    nearest = np.arange(1, top + 1) * (np.pi / 2)  # within an ulp or two of fl(n pi/2); the neighbours cover it
    return np.concatenate([nearest, np.nextafter(nearest, 0), np.nextafter(nearest, np.inf),
                           np.nextafter(np.nextafter(nearest, 0), 0), np.nextafter(np.nextafter(nearest, 9e9), 9e9)])


RNG = np.random.default_rng(20261128)
RANGES = {
    "[-pi, pi]": RNG.uniform(-np.pi, np.pi, 400_000),
    "[-100, 100]": RNG.uniform(-100, 100, 400_000),
    "[-1e4, 1e4]": RNG.uniform(-1e4, 1e4, 400_000),
    "below 1e5": RNG.uniform(-1e5, 1e5, 200_000),
    "near n pi/2": near_quarter_turns(),
    "around pi/4": np.pi / 4 + RNG.uniform(-1e-9, 1e-9, 20_000),
    "tiny": np.concatenate([RNG.uniform(-1e-3, 1e-3, 50_000), 2.0 ** RNG.uniform(-1074, -10, 50_000),
                            -(2.0 ** RNG.uniform(-1074, -10, 50_000))]),
    "fallback": np.concatenate([RNG.uniform(1e5, 1e7, 50_000), -(10.0 ** RNG.uniform(5, 300, 50_000))]),
}


@pytest.mark.parametrize("name", sorted(RANGES))
@pytest.mark.parametrize("function", ["sin", "cos"])
def test_within_one_ulp_of_the_exact_value(trig, name, function):
    x = RANGES[name]
    exact = getattr(np, function)(x.astype(np.longdouble))
    errors = ulps(trig(function, x), exact)
    worst = int(np.argmax(errors))
    assert errors[worst] <= MAX_ULPS, f"{function}({x[worst]!r}): {float(errors[worst]):.3f} ulp"


def test_the_long_double_reference_is_exact_enough():
    """sinl/cosl against mpmath at 50 digits on the hardest arguments and a sample: within 1/1000 of an ulp."""
    x = np.concatenate([near_quarter_turns(200), RNG.uniform(-1e5, 1e5, 300)])
    for function in ("sin", "cos"):
        reference = getattr(np, function)(x.astype(np.longdouble))
        spacing = np.spacing(np.abs(reference.astype(np.float64)))
        with mpmath.workdps(50):
            exact = [getattr(mpmath, function)(mpmath.mpf(float(v))) for v in x]
            off = [abs(mpmath.mpf(float(r)) + mpmath.mpf(float(r - np.longdouble(float(r)))) - e) / s
                   for r, e, s in zip(reference, exact, spacing)]
        assert max(off) < 1e-3


def test_special_values(trig):
    x = np.array([0.0, -0.0, 5e-324, -5e-324, 2.2250738585072014e-308, np.inf, -np.inf, np.nan, 1e5, -1e5])
    with np.errstate(invalid="ignore"):
        s, c = trig("sin", x), trig("cos", x)
        assert np.array_equal(s, np.sin(x), equal_nan=True) and np.array_equal(c, np.cos(x), equal_nan=True)
    assert np.signbit(s[1]) and not np.signbit(s[0])  # sin(-0) = -0


def test_odd_and_even(trig):
    x = RANGES["[-1e4, 1e4]"]
    assert np.array_equal(trig("sin", -x), -trig("sin", x))
    assert np.array_equal(trig("cos", -x), trig("cos", x))


@pytest.mark.skipif(platform.machine().lower() not in ("x86_64", "amd64") or "avx2" not in build._cpu_features(),
                    reason="needs AVX2")
def test_the_same_bits_with_the_cpu_flags(trig, tmp_path):
    """No fused multiply-add: -mavx2 (runtime/build.py cpu_flags) gives the same bits as the portable build."""
    flagged = compiled(tmp_path, build.AVX2_FLAGS)
    for x in RANGES.values():
        for function in ("sin", "cos"):
            assert np.array_equal(flagged(function, x), trig(function, x))


def test_a_model_calls_them_and_agrees_with_the_c_library_to_round_off():
    """The double pendulum's generated C calls the helpers; its right-hand side at states with angles small and
    large agrees with the same file built with -DMBS_TRIG_FORMER=1 (the C library's sin and cos) to round-off."""
    system = mbs.load(DOUBLE_PENDULUM)
    source = system.generate("chaos").c_source
    assert "= mbs_sin(" in source and "= mbs_cos(" in source
    now, was = Workspace(system.compile("chaos")), Workspace(flagged_build(system, "chaos", ("-DMBS_TRIG_FORMER=1",)))
    rng = np.random.default_rng(7)
    for scale in (0.5, 3.0, 60.0, 3000.0):
        x = np.asarray(now.x, dtype=float).copy()
        x[:] = rng.uniform(-scale, scale, x.size)
        a, b = np.asarray(now.rhs(0.0, x)), np.asarray(was.rhs(0.0, x))
        assert np.allclose(a, b, rtol=1e-12, atol=1e-12 * np.abs(b).max())
