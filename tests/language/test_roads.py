"""ISO 8608 random roads: the spectrum of the generated profile matches the class's PSD within 10 % in every
octave of the standard's band, a given PSD likewise, the two tracks have the chosen coherence, and seeds
reproduce."""

import numpy as np
import pytest

from mbs.language import roads
from mbs.language.frontend import load_text

OCTAVES = np.geomspace(roads.N_MIN, roads.N_MAX, 9)   # eight octaves spanning 0.011 .. 2.83 cycles/m


def band_powers(z, dx, level, waviness=2.0):
    """(measured, wanted) power [m^2] of each octave: the periodogram of one period (the profile repeats)
    summed over the octave, against Gd integrated over it."""
    period = z[:-1]
    spectrum = np.fft.rfft(period)
    freqs = np.fft.rfftfreq(period.size, dx)
    power = 2 * np.abs(spectrum / period.size) ** 2     # mean square of each cosine: amplitude^2 / 2
    out = []
    for lo, hi in zip(OCTAVES[:-1], OCTAVES[1:]):
        fine = np.geomspace(lo, hi, 2001)
        wanted = np.trapezoid(roads.displacement_psd(level, fine, waviness), fine)
        out.append((power[(freqs >= lo) & (freqs < hi)].sum(), wanted))
    return out


@pytest.mark.parametrize("road_class", ["A", "C", "H"])
def test_profile_psd_matches_the_class_in_every_octave(road_class):
    x, z = roads.profile(road_class, seed=3, length=2000.0)
    for measured, wanted in band_powers(z, x[1] - x[0], road_class):
        assert measured == pytest.approx(wanted, rel=0.10)


def test_class_levels_are_the_standards():
    # ISO 8608: Gd(n0) = 16e-6 m^3 for class A, 4^k times that for the k-th class after it
    assert roads.displacement_psd("C", np.array([0.1]))[0] == pytest.approx(256e-6)
    assert roads.displacement_psd("C", np.array([1.0]))[0] == pytest.approx(256e-6 / 100)


def test_given_psd_and_waviness():
    x, z = roads.profile(50e-6, seed=9, length=2000.0, waviness=2.5)
    assert x[-1] >= 2000.0
    for measured, wanted in band_powers(z, x[1] - x[0], 50e-6, 2.5):
        assert measured == pytest.approx(wanted, rel=0.10)


def test_right_track_has_the_class_psd_and_the_chosen_coherence():
    width = 1.23
    x, left = roads.profile("C", 4, 2000.0)
    _, right = roads.profile("C", 4, 2000.0, track="right", width=width)
    for measured, wanted in band_powers(right, x[1] - x[0], "C"):
        assert measured == pytest.approx(wanted, rel=0.10)
    # the tracks' cross spectrum over their (common) amplitude spectrum is the phase agreement cos(dphi),
    # whose mean over an octave is the model's amplitude coherence (a few hundred frequencies per octave)
    L, R = np.fft.rfft(left[:-1]), np.fft.rfft(right[:-1])
    freqs = np.fft.rfftfreq(left.size - 1, x[1] - x[0])
    agreement = np.real(L * np.conj(R)) / np.maximum(np.abs(L) * np.abs(R), 1e-300)
    for lo, hi in zip(OCTAVES[2:-1], OCTAVES[3:]):
        band = (freqs >= lo) & (freqs < hi)
        assert agreement[band].mean() == pytest.approx(roads.coherence(freqs[band], width).mean(), abs=0.06)
    same = roads.profile("C", 4, 100.0, track="right", width=0.0)[1]
    assert np.allclose(same, roads.profile("C", 4, 100.0)[1])


def test_same_seed_same_road_other_seed_other_road():
    a, b, c = (roads.profile("B", s, 100.0)[1] for s in (7, 7, 8))
    assert np.array_equal(a, b) and not np.allclose(a, c)


def test_random_road_in_a_model_is_a_table():
    m = load_text("""
func road(x) = iso8608(x, D, 5, 50 m)
func right(x) = iso8608(x, D, 5, 50 m, track = right, width = 1.5 m)
model m {
    param h = road(10 m)
    param hr = right(10 m)
}
""")
    assert m.parameter_map["h"].value == pytest.approx(np.interp(10.0, *roads.profile("D", 5, 50.0)))
    wanted = np.interp(10.0, *roads.profile("D", 5, 50.0, track="right", width=1.5))
    assert m.parameter_map["hr"].value == pytest.approx(wanted)
