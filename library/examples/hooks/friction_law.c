/* The friction law of hook_friction.mbs as a C hook, compiled into the model's library:
 *
 *     mbs simulate library/examples/hook_friction.mbs --hook friction_law=library/examples/hooks/friction_law.c
 *
 * Signature of every hook: int NAME(const double *arg, double *res); arguments and results in the units the
 * model declares (here arg = {w [m/s], n [N], mu_s, mu_k}, res = {f [N]}); return 0 on success. */
#include <math.h>

int friction_law(const double *arg, double *res)
{
    const double vs = 0.05;   /* Stribeck speed [m/s] */
    const double eps = 0.01;  /* regularisation speed of the sign [m/s] */
    const double w = arg[0], n = arg[1], mu_s = arg[2], mu_k = arg[3];
    res[0] = n * (mu_k + (mu_s - mu_k) * exp(-(w / vs) * (w / vs))) * tanh(w / eps);
    return 0;
}
