/* A hook that reports failure by its status once w = arg[0] drops below 0.15 m/s (tests/runtime/test_hooks.py). */
#include <math.h>

int friction_law(const double *arg, double *res)
{
    res[0] = arg[1] * arg[3] * tanh(arg[0] / 0.01);
    return arg[0] < 0.15 ? 7 : 0;
}
