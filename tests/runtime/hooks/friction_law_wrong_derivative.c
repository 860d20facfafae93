/* A deliberately wrong derivative (twice the true one) of the friction law of hook_friction.mbs: the tests see
 * that a hook's own derivative is the one the generated Jacobians use. */
#define GAIN 2.0
#include <math.h>

#ifndef GAIN
#define GAIN 1.0
#endif

int friction_law(const double *arg, double *res)
{
    const double vs = 0.05, eps = 0.01;
    const double w = arg[0], n = arg[1], mu_s = arg[2], mu_k = arg[3];
    res[0] = n * (mu_k + (mu_s - mu_k) * exp(-(w / vs) * (w / vs))) * tanh(w / eps);
    return 0;
}

int friction_law_derivative(const double *arg, double *jac)
{
    const double vs = 0.05, eps = 0.01;
    const double w = arg[0], n = arg[1], mu_s = arg[2], mu_k = arg[3];
    const double e = exp(-(w / vs) * (w / vs)), th = tanh(w / eps), g = mu_k + (mu_s - mu_k) * e;
    const double dg = (mu_s - mu_k) * e * (-2.0 * w / (vs * vs));
    jac[0] = GAIN * n * (dg * th + g * (1.0 - th * th) / eps);
    jac[1] = GAIN * g * th;
    jac[2] = GAIN * n * e * th;
    jac[3] = GAIN * n * (1.0 - e) * th;
    return 0;
}
