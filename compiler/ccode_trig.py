"""Sine and cosine for the generated C: inline, without the C library's call below |x| = 1e5.

The C library's sin/cos (glibc's __sincos_fma, GCC fuses the sin and cos of one argument into one call) costs about
100 instructions a call with its rounding-mode save and restore, and the Iltis bump scene calls it 373,000 times in
one simulate: 12 % of its instructions. The arguments are joint angles: mostly small (a suspension's), a wheel's spin
growing to tens or thousands of radians. `mbs_sin` and `mbs_cos` (the printer's sin and cos, compiler/ccode.py
CPrinter) are static helpers of the generated file, always inlined (MBS_TRIG_INLINE: in a large function GCC's
inliner otherwise stops at its growth limits); the sin and cos of one angle, inlined into one function, share all
their arithmetic (the compiler merges the same operations on the same argument) but the pick of the result.

    |x| < pi/4: sin x = x + x z S(z), cos x = (1 - z/2) + [the rounding of 1 - z/2, exact] + z^2 C(z), z = x^2
    (a branch each call site takes the same way, a suspension's angle always: the reduction skipped);
    else x = n pi/2 + r, |r| <= pi/4 (n = |x| 2/pi rounded to an integer by adding 1.5 * 2^52 and taking it away),
    r = |x| - n P1 - n P2 - n P3 (Cody and Waite): pi/2 = P1 + P2 + P3 to 2^-130, P1 and P2 of 37 bits so that their
    products with n < 2^16 are exact (|x| < 1e5), |x| - n P1 exact (Sterbenz), the rounding of (|x| - n P1) - n P2
    recovered exactly (Knuth's two-sum): r = hi + lo. Its relative error is below 2^-61 even for the double
    nearest to a multiple of pi/2 (|r| down to 2^-60.5 at x = 45.553...: bench/trig.py --coefficients).
    sin r = hi + (hi z S(z) + lo (1 - z/2)),  cos r = (1 - z/2) + [its rounding] + (z^2 C(z) - hi lo),  z = hi^2;
    sin |x| = +-sin r or +-cos r by (n mod 4), picked from a two-element array and signed by a product with +-1.0
    (both exact, no branch), the sign of x put back for the sine.
    S, C: minimax polynomials of degree 5 in z on [0, (pi/4)^2] (relative errors 2^-58 and 2^-64 of sin and cos),
    derived by bench/trig.py --coefficients (a Remez exchange in mpmath).

Beyond 1e5, inf and NaN: the C library. No fused multiply-add (-std=c99 contracts nothing): the same bits with and
without -mavx2. The largest error found is 0.79 ulp (tests/runtime/test_trig.py holds 1 ulp against long double,
checked against mpmath; glibc's is 0.52). Per call in bench/trig.py's loops (GCC 12, -mavx2, the loop's share
included): a sin 25 instructions for |x| < 0.5 (the C library's 73), a sin-cos pair 46 (120), a pair for |x| < 100
86 (155). -DMBS_TRIG_FORMER=1 makes both the C library's again: the same-run baseline of bench/trig.py.
"""

from __future__ import annotations

#: pi/2 = P1 + P2 + P3 (to 2^-130), P1 and P2 of 37 significant bits; 2/pi; the polynomials' coefficients from
#: the constant term up (bench/trig.py --coefficients prints them again).
PIO2 = ("0x1.921fb54440000p+0", "0x1.68c234c4c0000p-39", "0x1.98a2e03707345p-77")
TWO_OVER_PI = "0x1.45f306dc9c883p-1"
SIN_COEFFICIENTS = ("-0x1.5555555555549p-3", "0x1.111111110f881p-7", "-0x1.a01a019c1269ap-13",
                    "0x1.71de3578730c7p-19", "-0x1.ae5e66d3c520ep-26", "0x1.5d932ef005cd1p-33")
COS_COEFFICIENTS = ("0x1.555555555554cp-5", "-0x1.6c16c16c15184p-10", "0x1.a01a019cb26d9p-16",
                    "-0x1.27e4f80a75589p-22", "0x1.1ee9ec4701ff8p-29", "-0x1.8faeced23c429p-37")
#: Below this |x| the reduction is exact enough (n < 2^16: n P1 and n P2 exact); from it the C library.
LIMIT = "1e5"


def _horner(coefficients: tuple[str, ...], z: str) -> str:
    """c0 + z*(c1 + z*(c2 + ...)), as C text. (In pairs, (c0 + c1 z) + z^2 ((c2 + c3 z) + ...), the same operations
    in half the chain of dependent ones, the bump_10 simulate took 0.95 of the CPU time (commit 8b1d124, reverted:
    its rounding moved tests/library/test_bearing_pendulum.py's pendulum to rest at an angle whose held
    acceleration rounds to 2.6e-17 rather than 0, as it does at 70 % of such angles with either evaluation.)"""
    text = coefficients[-1]
    for c in reversed(coefficients[:-1]):
        text = f"{c} + {z} * ({text})"
    return text


#: Every helper's head: inlined always (GCC and Clang; a sin and a cos of one angle then share their arithmetic: in
#: a large function GCC's inliner otherwise stops at its growth limits and calls one of them for each).
INLINE = "MBS_TRIG_INLINE"
INLINE_DEFINITION = ["#if defined(__GNUC__)",
                     f"#define {INLINE} inline __attribute__((always_inline))   /* compiler/ccode_trig.py */",
                     "#else",
                     f"#define {INLINE} inline",
                     "#endif"]


def _polynomials() -> dict[str, list[str]]:
    return {
        "mbs_sin_poly": ["/* S(z): sin(r) = r + r z S(z), z = r^2, |r| <= pi/4 (relative error 2^-58). */",
                         f"static {INLINE} double mbs_sin_poly(double z)",
                         "{",
                         f"    return {_horner(SIN_COEFFICIENTS, 'z')};",
                         "}"],
        "mbs_cos_poly": ["/* C(z): cos(r) = 1 - z/2 + z^2 C(z), z = r^2, |r| <= pi/4 (relative error 2^-64). */",
                         f"static {INLINE} double mbs_cos_poly(double z)",
                         "{",
                         f"    return {_horner(COS_COEFFICIENTS, 'z')};",
                         "}"]}


def _circular() -> list[str]:
    p1, p2, p3 = PIO2
    return [
        "/* sin(x) (quarter 0) or cos(x) = sin(x + pi/2) (quarter 1) within 1 ulp, without the C library below",
        " * |x| = 1e5: below pi/4 the polynomials of x, else x = n pi/2 + hi + lo (Cody-Waite in three parts, a",
        " * two-sum) and the polynomials of hi + lo, the quadrant picked without a branch; compiler/ccode_trig.py",
        " * explains it. Inlined, the sin and cos of one angle share all but the pick. */",
        f"static {INLINE} double mbs_circular(double x, unsigned quarter)",
        "{",
        "    const double ax = fabs(x);",
        "    if (ax < 0x1.921fb54442d18p-1) {  /* pi/4 */",
        "        const double z = x * x, half_z = 0.5 * z, w = 1.0 - half_z;",
        "        return quarter ? w + (((1.0 - w) - half_z) + z * z * mbs_cos_poly(z))",
        "                       : copysign(x + x * z * mbs_sin_poly(z), x);  /* (sin(-0) = -0) */",
        "    }",
        f"    if (!(ax < {LIMIT}))  /* (and inf, NaN) */",
        "        return quarter ? cos(x) : sin(x);",
        "    {",
        "        const double shift = 0x1.8p52;  /* adding it rounds to an integer */",
        f"        const double n = (ax * {TWO_OVER_PI} + shift) - shift;",
        f"        const double a = ax - n * {p1};  /* exact */",
        f"        const double b = n * {p2};  /* exact */",
        "        const double hi = a - b, a_back = hi + b, b_back = a_back - hi;",
        f"        const double lo = ((a - a_back) + (b_back - b)) - n * {p3};  /* hi + lo = |x| - n pi/2 */",
        "        const double z = hi * hi, half_z = 0.5 * z, w = 1.0 - half_z;",
        "        const double sin_r = hi + (hi * z * mbs_sin_poly(z) + lo * w);",
        "        const double cos_r = w + (((1.0 - w) - half_z) + (z * z * mbs_cos_poly(z) - hi * lo));",
        "        const double kernels[2] = {sin_r, cos_r};",
        "        const unsigned k = (unsigned)n + quarter;  /* sin(|x|) = kernel k: sin r, cos r, -sin r, -cos r */",
        "        return kernels[k & 1] * (1.0 - (double)(k & 2)) * (quarter ? 1.0 : copysign(1.0, x));",
        "    }",
        "}"]


def _wrapper(name: str, quarter: int, doc: str) -> list[str]:
    return [doc,
            f"static {INLINE} double {name}(double x)",
            "{",
            "#ifdef MBS_TRIG_FORMER",
            f"    return {name[4:]}(x);",
            "#else",
            f"    return mbs_circular(x, {quarter});",
            "#endif",
            "}"]


#: The helpers (compiler/ccode.py HELPERS), each defined only where called, and what each calls in turn.
TRIG_HELPERS = {
    **_polynomials(),
    "mbs_circular": _circular(),
    "mbs_sin": _wrapper("mbs_sin", 0, "/* sin(x), mbs_circular's (-DMBS_TRIG_FORMER=1: the C library's, the baseline "
                                      "of bench/trig.py). */"),
    "mbs_cos": _wrapper("mbs_cos", 1, "/* cos(x), mbs_circular's (-DMBS_TRIG_FORMER=1: the C library's). */"),
}
TRIG_NEEDS = {"mbs_circular": ("mbs_sin_poly", "mbs_cos_poly"), "mbs_sin": ("mbs_circular",),
              "mbs_cos": ("mbs_circular",)}
