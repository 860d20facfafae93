/* A hook that fails once the slip speed w = arg[0] drops below 0.15 m/s (tests/runtime/test_hooks.py):
 * a NaN result there, so the run must stop naming the hook. */
#include <math.h>

int friction_law(const double *arg, double *res)
{
    res[0] = arg[0] < 0.15 ? NAN : arg[1] * arg[3] * tanh(arg[0] / 0.01);
    return 0;
}
