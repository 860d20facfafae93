"""Random road profiles of ISO 8608 classes (or a given PSD), reproducible by a seed, as lookup tables.

ISO 8608 gives the displacement power spectral density of road classes A (very good) to H (very poor) as
Gd(n) = Gd(n0) (n / n0)^-w with n0 = 0.1 cycles/m, waviness w = 2 and Gd(n0) = 16e-6 m^3 for class A, four
times more per class. The profile is a sum of cosines with random phases and the deterministic amplitudes
sqrt(2 Gd(n) dn) at the spatial frequencies k / P of the road's own period P (the length rounded up to whole
samples) inside the standard's band, 0.011 to 2.83 cycles/m: summed by an inverse FFT, it repeats after P and
its periodogram over P is the class's PSD at every frequency of the grid (no leakage, no random amplitudes),
so a road of a few hundred metres carries the band's power up to the Riemann sum of Gd over its few lowest
frequencies. Sampled every SPACING metres: a table the generated code interpolates linearly.

Two tracks: ISO 8608 does not say how the left and right tracks of one road correlate. The right track has
the left one's amplitudes (so the same PSD, exactly) and its phases shifted by a random angle, uniform in
+-pi s(n) with s(n) = 1 - exp(-COHERENCE_RATE n B) for a track width B: long waves reach both wheels almost
in phase, short ones independently. The amplitude coherence is then E[cos] = sinc(s(n)) = sin(pi s) / (pi s),
the magnitude-squared coherence its square. The rate is our choice (a plausible shape, not a standard's);
width 0 gives identical tracks.
"""

from __future__ import annotations

import numpy as np

CLASSES = "ABCDEFGH"
GD_N0_CLASS_A = 16e-6   # m^3, geometric mean of class A at n0 (ISO 8608)
N0 = 0.1                # cycles/m, reference spatial frequency
N_MIN, N_MAX = 0.011, 2.83  # cycles/m, the standard's band
SPACING = 0.05          # m between table points (well below the shortest wavelength, 0.35 m)
COHERENCE_RATE = 2.0    # s(n) = 1 - exp(-rate n B) of the tracks' phase spread (our choice, see above)


def class_level(road_class: str) -> float:
    """Gd(n0) in m^3 of a class letter."""
    if road_class not in CLASSES:
        raise ValueError(f"ISO 8608 classes are {', '.join(CLASSES)}")
    return GD_N0_CLASS_A * 4.0 ** CLASSES.index(road_class)


def displacement_psd(road_class: str | float, n: np.ndarray, waviness: float = 2.0) -> np.ndarray:
    """Gd(n) in m^3 of a class letter (or of a given Gd(n0) in m^3) at spatial frequencies n [cycles/m]."""
    level = class_level(road_class) if isinstance(road_class, str) else float(road_class)
    return level * (np.asarray(n) / N0) ** -waviness


def coherence(n: np.ndarray, width: float) -> np.ndarray:
    """Amplitude coherence sinc(s(n)) of the two tracks a width B [m] apart (see the module docstring)."""
    return np.sinc(phase_spread(n, width))


def phase_spread(n: np.ndarray, width: float) -> np.ndarray:
    """s(n): the right track's phase shift is uniform in +-pi s(n)."""
    return 1.0 - np.exp(-COHERENCE_RATE * np.asarray(n) * width)


def profile(road_class: str | float, seed: int, length: float, *, track: str = "left", width: float = 0.0,
            waviness: float = 2.0) -> tuple[np.ndarray, np.ndarray]:
    """(x, z) samples [m] of a random road over [0, length] (and up to its period), the same for the same seed;
    `track` 'right' is the track `width` metres beside the left one (coherent as the module docstring says)."""
    if track not in ("left", "right"):
        raise ValueError("track is 'left' or 'right'")
    samples = 2 * int(np.ceil(length / SPACING / 2))          # even, covering the length
    period = samples * SPACING
    n = np.arange(samples // 2 + 1) / period
    band = (n >= N_MIN) & (n <= N_MAX)
    amplitude = np.zeros_like(n)
    amplitude[band] = np.sqrt(2.0 * displacement_psd(road_class, n[band], waviness) / period)
    rng = np.random.default_rng(seed)
    phase = rng.uniform(0.0, 2.0 * np.pi, n.size)
    shift = rng.uniform(-1.0, 1.0, n.size)    # drawn for both tracks: the left one stays the same
    if track == "right":
        phase = phase + np.pi * phase_spread(n, width) * shift
    spectrum = amplitude * np.exp(1j * phase)
    z = np.fft.irfft(spectrum * samples / 2, samples)
    z = np.append(z, z[0])                                  # one period, closed
    x = np.arange(samples + 1) * SPACING
    return x, z - z[0]  # start at road level 0
