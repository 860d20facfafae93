/* A friction law whose derivative fails (tests/compiler/test_hook_derivatives.py): a viscous law f = n mu_k w / 0.01
 * and a derivative that reports status 3, so a stiff integrator's Jacobian stops the run naming it. */

int friction_law(const double *arg, double *res)
{
    res[0] = arg[1] * arg[3] * arg[0] / 0.01;
    return 0;
}

int friction_law_derivative(const double *arg, double *jac)
{
    (void)arg;
    (void)jac;
    return 3;
}
