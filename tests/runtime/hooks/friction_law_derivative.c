/* The friction law of library/examples/hook_friction.mbs with its derivative (tests of the hook derivatives):
 * f = n (mu_k + (mu_s - mu_k) exp(-(w/vs)^2)) tanh(w/eps), and jac[j] = d f / d arg[j] for arg = {w, n, mu_s,
 * mu_k}, differentiated by hand. */
#include <math.h>

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
    jac[0] = n * (dg * th + g * (1.0 - th * th) / eps);
    jac[1] = g * th;
    jac[2] = n * e * th;
    jac[3] = n * (1.0 - e) * th;
    return 0;
}
