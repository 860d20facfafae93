/* The three hooks of tests/runtime/models/hook_ball.mbs in one C file (tests/runtime/test_hooks.py): the
 * floor at 25 cm, restitution 0.8, and the ball's kinetic and potential energies. */

int floor_height(const double *arg, double *res)
{
    (void)arg;
    res[0] = 25.0;  /* cm, as declared */
    return 0;
}

int impact_law(const double *arg, double *res)
{
    res[0] = -0.8 * arg[0];
    return 0;
}

int energy(const double *arg, double *res)
{
    const double m = arg[0], z = arg[1], v = arg[2];
    res[0] = 0.5 * m * v * v;
    res[1] = m * 9.81 * z;
    return 0;
}
