"""ISO 2631-1 weightings against the standard's tables of weighting factors (ISO 2631-1:1997, tables 3 and
4, factors x 1000 at the nominal one-third octave frequencies), the weighted RMS of sines (the factor times
the sine's RMS) and the tyre load fluctuation of a known signal."""

import math

import numpy as np
import pytest

from mbs.runtime import comfort

FREQ = (0.1, 0.125, 0.16, 0.2, 0.25, 0.315, 0.4, 0.5, 0.63, 0.8, 1, 1.25, 1.6, 2, 2.5, 3.15, 4, 5, 6.3, 8, 10,
        12.5, 16, 20, 25, 31.5, 40, 50, 63, 80)
TABLES = {
    "Wk": (31.2, 48.6, 79.0, 121, 182, 263, 352, 418, 459, 477, 482, 484, 494, 531, 631, 804, 967, 1039, 1054,
           1036, 988, 902, 768, 636, 513, 405, 314, 246, 186, 132),
    # the published Wd factor at 10 Hz, 212, is left out: the standard's own filter gives 202 there, as does
    # the 1/f slope of its neighbours (253 at 8 Hz, 161 at 12.5 Hz); every other factor agrees within 0.5 %
    "Wd": (62.4, 97.3, 158, 243, 365, 530, 713, 853, 944, 992, 1011, 1008, 968, 890, 776, 642, 512, 409, 323,
           253, None, 161, 125, 100, 80.0, 63.2, 49.4, 38.8, 29.5, 21.1),
    "Wc": (62.4, 97.2, 158, 243, 364, 527, 708, 843, 929, 972, 991, 1000, 1007, 1012, 1017, 1022, 1024, 1013, 974,
           891, 776, 647, 512, 409, 325, 256, 199, 156, 118, 84.4),
    "We": (62.5, 97.5, 159, 245, 368, 536, 723, 862, 939, 941, 880, 772, 632, 512, 409, 323, 253, 202, 160, 125,
           100, 80.1, 62.5, 50.0, 39.9, 31.6, 24.7, 19.4, 14.8, 10.5),
}
WF = {0.02: 24.2, 0.025: 37.7, 0.0315: 59.7, 0.04: 97.1, 0.05: 157, 0.063: 267, 0.08: 461, 0.1: 695, 0.125: 895,
      0.16: 1006, 0.2: 992, 0.25: 854, 0.315: 619, 0.4: 384, 0.5: 224, 0.63: 116, 0.8: 53.0, 1.0: 23.5}


@pytest.mark.parametrize("name", sorted(TABLES))
def test_weighting_factors_are_the_standards_tables(name):
    pairs = [(f, w / 1000) for f, w in zip(FREQ, TABLES[name]) if w is not None]
    f, table = np.array(pairs).T
    assert comfort.magnitude(name, f) == pytest.approx(table, rel=0.02)


def test_motion_sickness_weighting():
    f, table = np.array(list(WF.items())).T
    assert comfort.magnitude("Wf", f) == pytest.approx(table / 1000, rel=0.02)


@pytest.mark.parametrize("frequency", [1.0, 5.0, 16.0])
def test_weighted_rms_of_a_sine_is_its_factor_times_its_rms(frequency):
    t = np.arange(0.0, 40.0, 0.002)          # whole periods of every test frequency
    a = 1.5 * np.sin(2 * math.pi * frequency * t) + 0.3   # an offset: removed
    expected = comfort.magnitude("Wk", frequency) * 1.5 / math.sqrt(2)
    assert comfort.weighted_rms(t, a, "Wk") == pytest.approx(expected, rel=1e-6)


def test_load_fluctuation_and_bad_input():
    load = 4000 + 400 * np.sin(np.linspace(0, 20 * math.pi, 2001))[:-1]
    assert comfort.load_fluctuation(load) == pytest.approx(400 / math.sqrt(2) / 4000, rel=1e-9)
    with pytest.raises(ValueError, match="uniformly"):
        comfort.weighted_rms([0, 0.1, 0.3, 0.4], [0, 1, 0, 1])
    with pytest.raises(ValueError, match="unknown weighting"):
        comfort.magnitude("Wz", 1.0)


def test_the_rows_of_events_are_left_out_of_a_record():
    """A scene with events has a row before and after each event between its samples (and two more on a sample
    that falls on an event): the spectrum sees the samples alone."""
    t = np.arange(0, 2.0, 0.01)
    with_events = np.sort(np.r_[t, 0.123, 0.123, 0.5, 0.5, 1.2345, 1.2345])
    keep = comfort.sample_rows(with_events)
    assert np.array_equal(with_events[keep], t)
    a = np.sin(2 * np.pi * 5 * with_events)
    assert comfort.weighted_rms(with_events, a) == comfort.weighted_rms(t, np.sin(2 * np.pi * 5 * t))
