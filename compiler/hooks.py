"""User hooks in the generated code: a call in an expression becomes a helper that calls the implementation.

In the equations a hook call is an undefined sympy function ``mbs_hook__NAME__K__N(t, arg...)`` (result K
of N): sympy keeps it opaque, the tape shares equal calls, and the generated Jacobian, which cannot
differentiate it, falls back to finite differences (compiler/differentiate.py raises NotDifferentiable).

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

**NumPy.** The same names are called; runtime/hooks.py puts Python functions of those names into the
generated module.
"""

from __future__ import annotations

import re

import sympy as sp

#: The function name of result k of n of a hook in the equations and the generated code.
HOOK_FUNCTION = re.compile(r"mbs_hook__([A-Za-z_][A-Za-z_0-9]*?)__(\d+)__(\d+)$")


def hook_function(name: str, result: int, results: int) -> type:
    """The undefined sympy function standing for result `result` of hook `name`; called as f(t, *args)."""
    return sp.Function(f"mbs_hook__{name}__{result}__{results}")


def parse_helper(name: str) -> tuple[str, int, int] | None:
    """(hook, result, results) of a helper name, or None for another function."""
    m = HOOK_FUNCTION.match(name)
    return (m.group(1), int(m.group(2)), int(m.group(3))) if m else None


def c_helpers(calls: dict[str, int]) -> list[str]:
    """The C text of the helpers used: `calls` maps helper name -> number of arguments (after t)."""
    if not calls:
        return []
    hooks: dict[str, int] = {}
    for helper, nargs in calls.items():
        hooks[parse_helper(helper)[0]] = nargs
    max_args = max(1, *hooks.values())
    lines = ["/* ---- user hooks: implementations supplied when running (docs/language.md, \"Hooks\") ----",
             " * Each hook is called as  int NAME(const double *arg, double *res)  with its arguments and results",
             " * in the units the model declares; 0 means success. */"]
    lines += [f"int {name}(const double *arg, double *res);" for name in sorted(hooks)]
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
              "/* Result k of n of fn at arg, or NaN (and the failure recorded) when fn fails. */",
              "static double mbs_hook_result(int (*fn)(const double *, double *), const char *name, double t,",
              "                              const double *arg, int narg, double *res, int k, int n)",
              "{",
              "    int i, status = fn(arg, res);",
              "    for (i = 0; i < n && status == 0; ++i)",
              "        if (!isfinite(res[i]))",
              "            status = -2;",
              "    if (status == 0)",
              "        return res[k];",
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
              ""]
    for helper in sorted(calls):
        name, k, n = parse_helper(helper)
        nargs = calls[helper]
        params = "".join(f", double a{i}" for i in range(nargs))
        packed = " ".join(f"arg[{i}] = a{i};" for i in range(nargs))
        lines += [f"/* {name}: result {k} of {n} */",
                  f"static double {helper}(double t{params})",
                  "{",
                  f"    double arg[{max(1, nargs)}], res[{n}];",
                  f"    {packed}" if packed else "    arg[0] = 0.0;",
                  f"    return mbs_hook_result({name}, \"{name}\", t, arg, {nargs}, res, {k}, {n});",
                  "}",
                  ""]
    return ["\n".join(lines)]
