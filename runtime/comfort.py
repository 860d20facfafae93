"""Ride comfort of simulated results: ISO 2631-1 frequency weightings, weighted RMS acceleration, and the
dynamic tyre load (RMS of the load fluctuation over the static load).

    a_w = weighted_rms(res.t, res["seat_acc_z"], "Wk")       # m/s^2, vertical, seated
    ratio = load_fluctuation(res["tyre_fl.radial.load"])    # -

The weightings are ISO 2631-1:1997's, defined there as products of analog filters (its equations and table of
parameters): band limiting (second-order high pass at f1 and low pass at f2, Butterworth),
acceleration-velocity transition (f3, f4, Q4) and upward step (f5, Q5, f6, Q6). The standard's tables of
weighting factors at the one-third octave frequencies are these filters' magnitudes, rounded; the test
compares them. Weighting is applied in the frequency domain (FFT of the record, times the filter's complex
response, inverse FFT): exact for the record as one period of a periodic signal, and without the frequency
warping of a discretised filter near the Nyquist frequency (a simulation sampled at 200 Hz has its Nyquist
frequency at Wk's band limit of 100 Hz). Records should span many periods of the lowest frequency of interest;
the mean is removed first.
"""

from __future__ import annotations

import math

import numpy as np

INF = math.inf

#: ISO 2631-1:1997, table 3 (principal weightings) and table 4 (additional ones): f1, f2, f3, f4 [Hz], Q4,
#: f5 [Hz], Q5, f6 [Hz], Q6. Infinite frequencies leave their stage out.
WEIGHTINGS = {
    "Wk": (0.4, 100.0, 12.5, 12.5, 0.63, 2.37, 0.91, 3.35, 0.91),   # vertical, seated/standing/recumbent
    "Wd": (0.4, 100.0, 2.0, 2.0, 0.63, INF, 1.0, INF, 1.0),         # horizontal
    "Wf": (0.08, 0.63, INF, 0.25, 0.86, 0.0625, 0.80, 0.1, 0.80),   # motion sickness
    "Wc": (0.4, 100.0, 8.0, 8.0, 0.63, INF, 1.0, INF, 1.0),         # seat back, x
    "We": (0.4, 100.0, 1.0, 1.0, 0.63, INF, 1.0, INF, 1.0),         # rotational
    "Wj": (0.4, 100.0, INF, INF, 1.0, 3.75, 0.91, 5.32, 0.91),      # head, recumbent
}


def response(name: str, f) -> np.ndarray:
    """Complex frequency response of a weighting at frequencies f [Hz] (f >= 0)."""
    if name not in WEIGHTINGS:
        raise ValueError(f"unknown weighting '{name}' (ISO 2631-1: {', '.join(WEIGHTINGS)})")
    f1, f2, f3, f4, q4, f5, q5, f6, q6 = WEIGHTINGS[name]
    s = 2j * np.pi * np.asarray(f, dtype=float)
    q1 = 1.0 / math.sqrt(2.0)
    w = {k: 2 * math.pi * v for k, v in (("1", f1), ("2", f2), ("3", f3), ("4", f4), ("5", f5), ("6", f6))}
    h = s ** 2 / (s ** 2 + w["1"] * s / q1 + w["1"] ** 2)                 # high pass
    h = h * w["2"] ** 2 / (s ** 2 + w["2"] * s / q1 + w["2"] ** 2)         # low pass
    numerator = 1.0 if math.isinf(f3) else 1.0 + s / w["3"]
    if not math.isinf(f4):                                                  # acceleration-velocity transition
        h = h * numerator / (1.0 + s / (w["4"] * q4) + (s / w["4"]) ** 2)
    if not math.isinf(f5):                                                  # upward step
        h = h * (1.0 + s / (w["5"] * q5) + (s / w["5"]) ** 2) / (1.0 + s / (w["6"] * q6) + (s / w["6"]) ** 2) \
            * (w["5"] / w["6"]) ** 2
    return h


def magnitude(name: str, f) -> np.ndarray:
    """|W(f)|: the weighting factor at frequencies f [Hz]."""
    return np.abs(response(name, f))


def sample_rows(t) -> np.ndarray:
    """The rows of a record on its sample grid (a boolean mask): a scene with events has, besides its samples, a
    row just before and just after each event between them, which a spectrum must not see. The grid's step is the
    most common one; of rows at the same grid point the first is kept."""
    t = np.asarray(t, dtype=float)
    steps = np.diff(t)
    if t.size < 2 or not np.any(steps > 0):
        return np.ones(t.shape, dtype=bool)
    values, counts = np.unique(np.round(steps[steps > 0], 12), return_counts=True)
    dt = float(values[np.argmax(counts)])
    k = np.round((t - t[0]) / dt)
    keep = np.abs(t - t[0] - k * dt) <= 1e-9 * max(dt, abs(t[-1]))
    rows = np.flatnonzero(keep)
    keep[rows[1:][k[rows[1:]] == k[rows[:-1]]]] = False  # a grid point's later rows (an event on it)
    return keep


def _uniform(t, signal) -> tuple[np.ndarray, float]:
    t, signal = np.asarray(t, dtype=float), np.asarray(signal, dtype=float)
    if t.shape != signal.shape or t.size < 4:
        raise ValueError("time and signal need the same length, at least 4 samples")
    keep = sample_rows(t)
    t, signal = t[keep], signal[keep]
    dt = np.diff(t)
    if np.max(np.abs(dt - dt.mean())) > 1e-6 * dt.mean():
        raise ValueError("the record must be sampled uniformly (give the scene a 'sample' interval)")
    return signal, float(dt.mean())


def weighted(t, acceleration, name: str) -> np.ndarray:
    """The frequency-weighted acceleration history [m/s^2] (mean removed; see the module docstring)."""
    a, dt = _uniform(t, acceleration)
    spectrum = np.fft.rfft(a - a.mean())
    f = np.fft.rfftfreq(a.size, dt)
    return np.fft.irfft(spectrum * response(name, f), a.size)


def weighted_rms(t, acceleration, name: str = "Wk") -> float:
    """ISO 2631-1 weighted RMS acceleration a_w [m/s^2] of a uniformly sampled record."""
    return float(np.sqrt(np.mean(weighted(t, acceleration, name) ** 2)))


def load_fluctuation(load) -> float:
    """RMS of the dynamic tyre load over the static (mean) load: 0 for a steady load; above about 1/3 the tyre
    leaves the road now and then (a Gaussian load reaches zero at three standard deviations)."""
    load = np.asarray(load, dtype=float)
    mean = load.mean()
    if mean <= 0:
        raise ValueError("the mean tyre load must be positive")
    return float(np.std(load) / mean)
