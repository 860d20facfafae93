"""Random road profiles of ISO 8608 classes, made reproducible by a seed, as lookup tables.

ISO 8608 gives the displacement power spectral density of road classes A (very good) to H (very poor) as
Gd(n) = Gd(n0) (n / n0)^-2 with n0 = 0.1 cycles/m and Gd(n0) = 16e-6 m^3 for class A, four times more per
class. The profile is the usual sum of cosines with random phases over the standard spatial-frequency band
(0.011 to 2.83 cycles/m), sampled every SPACING metres: a table the generated code interpolates linearly.
"""

from __future__ import annotations

import numpy as np

CLASSES = "ABCDEFGH"
GD_N0_CLASS_A = 16e-6   # m^3, geometric mean of class A at n0 (ISO 8608)
N0 = 0.1                # cycles/m, reference spatial frequency
N_MIN, N_MAX = 0.011, 2.83  # cycles/m, the standard's band
COMPONENTS = 400        # cosines in the sum (log-spaced over the band)
SPACING = 0.05          # m between table points (well below the shortest wavelength, 0.35 m)


def displacement_psd(road_class: str, n: np.ndarray) -> np.ndarray:
    """Gd(n) in m^3 of a class letter at spatial frequencies n [cycles/m]."""
    level = CLASSES.index(road_class)
    return GD_N0_CLASS_A * 4.0 ** level * (n / N0) ** -2


def profile(road_class: str, seed: int, length: float) -> tuple[np.ndarray, np.ndarray]:
    """(x, z) samples [m] of a random road of the class over [0, length], the same for the same seed."""
    if road_class not in CLASSES:
        raise ValueError(f"ISO 8608 classes are {', '.join(CLASSES)}")
    rng = np.random.default_rng(seed)
    edges = np.geomspace(N_MIN, N_MAX, COMPONENTS + 1)
    n = np.sqrt(edges[:-1] * edges[1:])
    amplitude = np.sqrt(2.0 * displacement_psd(road_class, n) * np.diff(edges))
    phase = rng.uniform(0.0, 2.0 * np.pi, COMPONENTS)
    x = np.arange(0.0, length + SPACING / 2, SPACING)
    z = (amplitude[None, :] * np.cos(2.0 * np.pi * n[None, :] * x[:, None] + phase[None, :])).sum(axis=1)
    return x, z - z[0]  # start at road level 0
