"""The friction law of library/examples/hook_friction.mbs with its derivative as the function's attribute
`derivative` (tests of the hook derivatives): d f / d (w, n, mu_s, mu_k), differentiated by hand."""

import math

VS, EPS = 0.05, 0.01


def friction_law(w, n, mu_s, mu_k):
    return n * (mu_k + (mu_s - mu_k) * math.exp(-(w / VS) ** 2)) * math.tanh(w / EPS)


def friction_law_derivative(w, n, mu_s, mu_k):
    e, th = math.exp(-(w / VS) ** 2), math.tanh(w / EPS)
    g = mu_k + (mu_s - mu_k) * e
    dg = (mu_s - mu_k) * e * (-2.0 * w / VS ** 2)
    return [n * (dg * th + g * (1.0 - th * th) / EPS), g * th, n * e * th, n * (1.0 - e) * th]


friction_law.derivative = friction_law_derivative


def wrong_law(w, n, mu_s, mu_k):
    """The same law with twice its derivative, on purpose: the tests see that a hook's own derivative is used."""
    return friction_law(w, n, mu_s, mu_k)


wrong_law.derivative = lambda *args: [2.0 * d for d in friction_law_derivative(*args)]
