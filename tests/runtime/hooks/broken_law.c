/* A hook that does not compile (tests/runtime/test_hooks.py): the compiler's message must name this file. */
int friction_law(const double *arg, double *res)
{
    res[0] = arg[0] * undeclared_gain;
    return 0;
}
