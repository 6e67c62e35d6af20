"""The LCR meter and its logger.

The meter measures the current phasor at a fixed drive, so its analog
averaging (an integration window, a lock-in's RC sections) acts on the
admittance; it is computed here as the convolution of the admittance,
sampled every millisecond, with the kernel's own samples (a boxcar, or
uⁿ⁻¹e^(-u/τ) for n sections), normalised to unit sum. A logger's
averaging (a running mean of N readings, an exponential one) acts on the
numbers the meter reported, Cs and Rs, one reading per row.

Noise: an LCR meter's error is a fraction of |Z| on both axes, larger at
low frequencies (fewer cycles per reading), so each reading's Z is
multiplied by 1 + ε, ε complex Gaussian; a slow 1/f drift of Cs over the
trace; and the display's six significant digits.
"""

from dataclasses import dataclass

import numpy as np

SAMPLE_S = 1e-3
"""The meter's internal sample interval, s."""


@dataclass(frozen=True)
class Meter:
    kind: str = "instant"
    """instant | window | response | mean | ewma."""
    length_s: float = 0.0
    """A window's length, s."""
    stamp: float = 0.0
    """Where in its window a reading is stamped: 0 its end, 1 its start."""
    tau_s: float = 0.0
    """A response's section time constant, s."""
    sections: int = 1
    readings: int = 1
    """A running mean's readings."""
    ewma_readings: float = 0.0
    """An exponential mean's time constant in readings, K: a new reading
    weighs 1 - e^(-1/K)."""
    delay_rows: int = 0
    """A logger's kernel: readings late."""
    trigger_delay_s: float = 0.0
    """The meter's reading stamped t measured the sensor at t - delay."""
    relative: float = 6e-5
    """ε's σ per axis at high frequency."""
    corner_hz: float = 300.0
    """ε's σ grows as √(1 + corner/f) below it."""
    drift_pf: float = 0.004
    """RMS of the 1/f drift of Cs over a trace, pF."""

    def reach_s(self, row_s):
        """How far back (s) a reading's kernel reaches."""
        k = {
            "window": self.length_s,
            "response": 14.0 * self.sections * self.tau_s,
            "mean": (self.readings + self.delay_rows) * row_s,
            "ewma": (12.0 * max(self.ewma_readings, 0.1) + self.delay_rows) * row_s,
        }
        return k.get(self.kind, 0.0) + abs(self.trigger_delay_s) + 0.1

    def centroid_s(self, row_s):
        """The kernel's own centroid (no delay), s."""
        if self.kind == "window":
            return 0.5 * self.length_s
        if self.kind == "response":
            return self.sections * self.tau_s
        if self.kind == "mean":
            return 0.5 * (self.readings - 1) * row_s
        if self.kind == "ewma":
            m = np.exp(-1.0 / self.ewma_readings)
            return m / (1.0 - m) * row_s
        return 0.0

    def analog(self, y):
        """The meter's analog averaging of admittance samples `y` (every
        SAMPLE_S): (kernel, where the stamp sits in samples from its
        newest)."""
        if self.kind == "window":
            n = max(int(round(self.length_s / SAMPLE_S)), 1)
            k = np.full(n, 1.0 / n)
            return np.convolve(y, k)[: len(y)], self.stamp * (n - 1)
        if self.kind == "response":
            u = np.arange(0.0, 14.0 * self.sections * self.tau_s, SAMPLE_S) + 0.5 * SAMPLE_S
            k = u ** (self.sections - 1) * np.exp(-u / self.tau_s)
            k /= k.sum()
            return np.convolve(y, k)[: len(y)], -0.5
        return y, 0.0

    def logger(self, cs, rs):
        """A logger's averaging of the readings (one per row)."""
        if self.kind == "mean":
            k = np.full(self.readings, 1.0 / self.readings)
            cs, rs = (np.convolve(v, k)[: len(v)] for v in (cs, rs))
        elif self.kind == "ewma":
            a = 1.0 - np.exp(-1.0 / self.ewma_readings)
            cs, rs = (_ewma(v, a) for v in (cs, rs))
        if self.kind in ("mean", "ewma") and self.delay_rows:
            d = self.delay_rows
            cs, rs = (np.concatenate([np.full(d, v[0]), v[:-d]]) for v in (cs, rs))
        return cs, rs

    def sigma(self, freq_hz):
        """ε's σ per axis at `freq_hz`."""
        return self.relative * np.sqrt(1.0 + self.corner_hz / freq_hz)


def _ewma(v, a):
    out = np.empty_like(v)
    acc = v[0]
    for k, x in enumerate(v):
        acc += a * (x - acc)
        out[k] = acc
    return out


def pink(rng, n, rms):
    """n samples of 1/f noise of the given RMS (white Gaussian shaped by
    1/√f in the frequency domain; the mean removed)."""
    if n < 4 or rms == 0.0:
        return np.zeros(n)
    spec = np.fft.rfft(rng.standard_normal(n))
    f = np.arange(len(spec), dtype=float)
    f[0] = 1.0
    spec /= np.sqrt(f)
    spec[0] = 0.0
    x = np.fft.irfft(spec, n)
    return x * (rms / np.std(x))


def digits(v, significant):
    """`v` rounded to `significant` digits (a meter's display)."""
    v = np.asarray(v, dtype=float)
    mag = np.floor(np.log10(np.maximum(np.abs(v), 1e-300)))
    scale = 10.0 ** (significant - 1 - mag)
    return np.round(v * scale) / scale
