"""User hooks in the generated code: a call in an expression becomes a helper that calls the implementation.

In the equations a hook call is a sympy function ``mbs_hook__NAME__K__N(t, arg...)`` (result K of N, a
HookCall): sympy keeps it opaque, the tape shares equal calls, and its partial derivatives are helpers of
their own (below, "Derivatives"), so the generated Jacobians exist for models with hooks.

**C.** Each helper used is a static function returning one result:

    static double mbs_hook__friction_law__0__1(double t, double a0, double a1)

It packs the arguments, calls the implementation ``int friction_law(const double *arg, double *res)``
(declared here, defined by the binding that runtime/hooks.py appends: the user's C file, or a trampoline
to a Python callable), and returns NaN when the implementation fails (non-zero status or a non-finite
result). The NaN makes the model function return status 2, so every integrator stops (or retries smaller
steps until the step collapses, as for any non-finite value); the first failure (hook, t, arguments) is kept
per thread for the message until ``mbs_hook_reset``. The record is the one mutable static datum of a model
with hooks: thread-local, written only on failure. The samples before the failure keep their outputs: the
hook is called again there and succeeds.

**Derivatives.** The generated Jacobians (mbs_jacobian for the stiff integrators, mbs_param_jacobian for
forward sensitivities) need d(result)/d(argument). A hook call is a sympy function whose partial derivative
with respect to argument j is another helper, ``mbs_hookd__NAME__K__N__J(t, arg...)``: it calls the user's
derivative ``int NAME_derivative(const double *arg, double *jac)`` (jac: the results' rows, the arguments'
columns, row-major, in the declared units) when the implementation defines one (a weak symbol: defined or
NULL), else takes a central difference of the hook with the step h = cbrt(DBL_EPSILON) * max(|arg_j|, 1)
(in the argument's declared unit; about 1e-10 relative for a smooth law, the truncation and the rounding
error balanced). A hook ignores t, so d/dt of a call is zero.

**NumPy.** The same names are called; runtime/hooks.py puts Python functions of those names into the
generated module.
"""

from __future__ import annotations

import functools
import re

import sympy as sp

from mbs.language.hooks import DIFFERENCE_STEP, derivative_name

#: The function name of result k of n of a hook in the equations and the generated code.
HOOK_FUNCTION = re.compile(r"mbs_hook__([A-Za-z_][A-Za-z_0-9]*?)__(\d+)__(\d+)$")
#: The function name of d(result k of n)/d(argument j) of a hook.
HOOK_DERIVATIVE = re.compile(r"mbs_hookd__([A-Za-z_][A-Za-z_0-9]*?)__(\d+)__(\d+)__(\d+)$")


class HookCall(sp.Function):
    """A call f(t, *args) of one result of a hook: opaque to sympy except for its partial derivatives."""

    hook: tuple[str, int, int] = ("", 0, 1)

    def fdiff(self, argindex: int = 1):
        if argindex == 1:  # t is passed for the failure message only: a hook does not depend on it
            return sp.S.Zero
        name, k, n = self.hook
        return sp.Function(derivative_name(name, k, n, argindex - 2))(*self.args)


@functools.lru_cache(maxsize=None)
def hook_function(name: str, result: int, results: int) -> type:
    """The sympy function standing for result `result` of hook `name`; called as f(t, *args). One class per
    name (cached), so that equal calls are equal expressions and the tape shares them."""
    return type(f"mbs_hook__{name}__{result}__{results}", (HookCall,), {"hook": (name, result, results)})


def parse_helper(name: str) -> tuple[str, int, int] | None:
    """(hook, result, results) of a helper name, or None for another function."""
    m = HOOK_FUNCTION.match(name)
    return (m.group(1), int(m.group(2)), int(m.group(3))) if m else None


def parse_derivative(name: str) -> tuple[str, int, int, int] | None:
    """(hook, result, results, argument) of a derivative helper's name, or None for another function."""
    m = HOOK_DERIVATIVE.match(name)
    return (m.group(1), int(m.group(2)), int(m.group(3)), int(m.group(4))) if m else None


def is_helper(name: str) -> bool:
    """A hook's value or derivative helper (the emitters print its call and collect it)."""
    return HOOK_FUNCTION.match(name) is not None or HOOK_DERIVATIVE.match(name) is not None


def c_helpers(calls: dict[str, int]) -> list[str]:
    """The C text of the helpers used: `calls` maps helper name -> number of arguments (after t)."""
    if not calls:
        return []
    hooks: dict[str, int] = {}
    derivatives: dict[str, int] = {}  # hook -> results, of the hooks whose derivatives are called
    for helper, nargs in calls.items():
        value, partial = parse_helper(helper), parse_derivative(helper)
        hook = (value or partial)[0]
        hooks[hook] = nargs
        if partial is not None:
            derivatives[hook] = partial[2]
    max_args = max(1, *hooks.values())
    lines = ["/* ---- user hooks: implementations supplied when running (docs/language.md, \"User hooks\") ----",
             " * Each hook is called as  int NAME(const double *arg, double *res)  with its arguments and results",
             " * in the units the model declares; 0 means success. */"]
    lines += [f"int {name}(const double *arg, double *res);" for name in sorted(hooks)]
    if derivatives:
        lines += ["",
                  "/* A hook's own derivative, when its implementation defines one (else NULL: central differences):",
                  " * int NAME_derivative(const double *arg, double *jac), jac[i * narg + j] = d res[i] / d arg[j]. */",
                  "#if defined(__GNUC__) || defined(__clang__)",
                  "#define MBS_HOOK_WEAK __attribute__((weak))",
                  "#else",
                  "#define MBS_HOOK_WEAK",
                  "#endif"]
        lines += [f"int {name}_derivative(const double *arg, double *jac) MBS_HOOK_WEAK;" for name in sorted(derivatives)]
    lines += ["",
              "/* The first failure of a hook in this thread (read by runtime/hooks.py). */",
              f"#define MBS_HOOK_MAXARG {max_args}",
              "static __thread struct {",
              "    const char *name;",
              "    int status, narg;",
              "    double t, arg[MBS_HOOK_MAXARG];",
              "} mbs_hook_failed;",
              "",
              "/* The hook that failed first since the last reset (NULL: none); its time, status and arguments. */",
              "const char *mbs_hook_failure(double *t, int *status, double *arg, int *narg)",
              "{",
              "    int i;",
              "    *t = mbs_hook_failed.t;",
              "    *status = mbs_hook_failed.status;",
              "    *narg = mbs_hook_failed.narg;",
              "    for (i = 0; i < mbs_hook_failed.narg; ++i)",
              "        arg[i] = mbs_hook_failed.arg[i];",
              "    return mbs_hook_failed.name;",
              "}",
              "",
              "void mbs_hook_reset(void)",
              "{",
              "    mbs_hook_failed.name = NULL;",
              "}",
              "",
              "/* Record the first failure (hook, status, time, arguments); NaN for the caller to return. */",
              "static double mbs_hook_fail(const char *name, int status, double t, const double *arg, int narg)",
              "{",
              "    int i;",
              "    if (mbs_hook_failed.name != NULL)",
              "        return NAN;",
              "    mbs_hook_failed.name = name;",
              "    mbs_hook_failed.status = status;",
              "    mbs_hook_failed.t = t;",
              "    mbs_hook_failed.narg = narg < MBS_HOOK_MAXARG ? narg : MBS_HOOK_MAXARG;",
              "    for (i = 0; i < mbs_hook_failed.narg; ++i)",
              "        mbs_hook_failed.arg[i] = arg[i];",
              "    return NAN;",
              "}",
              "",
              "/* Result k of n of fn at arg, or NaN (and the failure recorded) when fn fails. */",
              "static double mbs_hook_result(int (*fn)(const double *, double *), const char *name, double t,",
              "                              const double *arg, int narg, double *res, int k, int n)",
              "{",
              "    int i, status = fn(arg, res);",
              "    for (i = 0; i < n && status == 0; ++i)",
              "        if (!isfinite(res[i]))",
              "            status = -2;",
              "    return status == 0 ? res[k] : mbs_hook_fail(name, status, t, arg, narg);",
              "}",
              ""]
    if derivatives:
        max_jac = max(hooks[h] * n for h, n in derivatives.items())
        lines += [f"#define MBS_HOOK_MAXJAC {max(1, max_jac)}",
                  "/* d(result k of n)/d(argument j) of fn at arg: the user's derivative dfn when there is one, else a",
                  f" * central difference with the step h = {DIFFERENCE_STEP!r} * max(|arg[j]|, 1) (cbrt(DBL_EPSILON):",
                  " * truncation and rounding error balanced). NaN (and the failure recorded) when a call fails. */",
                  "static double mbs_hook_partial(int (*fn)(const double *, double *), int (*dfn)(const double *, double *),",
                  "                               const char *name, const char *dname, double t, double *arg, int narg,",
                  "                               double *res, int k, int n, int j)",
                  "{",
                  "    double jac[MBS_HOOK_MAXJAC], a = arg[j], h, up, down;",
                  "    volatile double moved;",
                  "    int status;",
                  "    if (dfn != NULL) {  /* a failure of the derivative is recorded under its own name */",
                  "        status = dfn(arg, jac);",
                  "        if (status == 0 && !isfinite(jac[k * narg + j]))",
                  "            status = -2;",
                  "        return status == 0 ? jac[k * narg + j] : mbs_hook_fail(dname, status, t, arg, narg);",
                  "    }",
                  f"    h = {DIFFERENCE_STEP!r} * fmax(fabs(a), 1.0);",
                  "    moved = a + h;  /* the step as the machine represents it */",
                  "    h = moved - a;",
                  "    arg[j] = a + h;",
                  "    up = mbs_hook_result(fn, name, t, arg, narg, res, k, n);",
                  "    arg[j] = a - h;",
                  "    down = mbs_hook_result(fn, name, t, arg, narg, res, k, n);",
                  "    arg[j] = a;",
                  "    return (up - down) / (2.0 * h);",
                  "}",
                  ""]
    for helper in sorted(calls):
        nargs = calls[helper]
        params = "".join(f", double a{i}" for i in range(nargs))
        packed = " ".join(f"arg[{i}] = a{i};" for i in range(nargs))
        value, partial = parse_helper(helper), parse_derivative(helper)
        if value is not None:
            name, k, n = value
            comment, call = f"result {k} of {n}", f"mbs_hook_result({name}, \"{name}\", t, arg, {nargs}, res, {k}, {n})"
        else:
            name, k, n, j = partial
            comment = f"d(result {k} of {n})/d(argument {j})"
            call = (f"mbs_hook_partial({name}, {name}_derivative, \"{name}\", \"{name}_derivative\", t, arg, "
                    f"{nargs}, res, {k}, {n}, {j})")
        lines += [f"/* {name}: {comment} */",
                  f"static double {helper}(double t{params})",
                  "{",
                  f"    double arg[{max(1, nargs)}], res[{n}];",
                  f"    {packed}" if packed else "    arg[0] = 0.0;",
                  f"    return {call};",
                  "}",
                  ""]
    return ["\n".join(lines)]
