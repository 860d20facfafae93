"""The friction law of hook_friction.mbs as a Python hook (arguments and result in the declared units).

    mbs simulate library/examples/hook_friction.mbs --hook friction_law=library/examples/hooks/friction_law.py:friction_law
"""

import math

VS = 0.05    # Stribeck speed [m/s]
EPS = 0.01   # regularisation speed of the sign [m/s]


def friction_law(w, n, mu_s, mu_k):
    """Friction force [N] at slip speed w [m/s] and normal force n [N]: a smooth Stribeck curve."""
    return n * (mu_k + (mu_s - mu_k) * math.exp(-(w / VS) ** 2)) * math.tanh(w / EPS)
