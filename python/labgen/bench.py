"""A data set from the bench (`docs/data-format.md`): static calibration
points at 120 Hz (an LCR meter's standard low frequency), static sweeps
over its standard frequencies 100 Hz-100 kHz at four stretches, and
traces of raised-cosine strokes at two speeds and three frequencies,
logged every 25 ms with the logger's jitter."""

import csv
import os
from dataclasses import dataclass, field

import numpy as np

from .effects import Effects, read
from .film import Film
from .line import series_c
from .meter import SAMPLE_S, Meter, digits, pink
from .motion import Strokes

ROW_S = 0.025
"""The logger's row interval, s."""
JITTER_S = 0.3e-3
"""RMS jitter of the logger's time stamps, s."""
CAL_HZ = 120.0
SWEEP_HZ = [100.0, 200.0, 500.0, 1e3, 2e3, 5e3, 1e4, 2e4, 5e4, 1e5]
SWEEP_MM = [0.0, 10.0, 20.0, 30.0]
TRACE_HZ = [1000.0, 3000.0, 10000.0]
SPEEDS = [(15.0, 3), (30.0, 4)]
"""Peak speeds (mm/s) and cycles of the traces."""
STATIC_READINGS = 8


@dataclass
class Bench:
    effects: Effects = field(default_factory=Effects)
    meter: Meter = field(default_factory=Meter)
    film: Film = field(default_factory=Film)
    seed: int = 0

    def static(self, rng, stretch_mm, freq_hz):
        """One static point, averaged over STATIC_READINGS readings:
        (Cs pF, Rs Ω, R top Ω, R bottom Ω)."""
        r = read(self.film, self.effects, [stretch_mm], 0.0, freq_hz)
        s = self.meter.sigma(freq_hz) / np.sqrt(STATIC_READINGS)
        z = r.z_ohm[0] * (1.0 + s * complex(rng.standard_normal(), rng.standard_normal()))
        ohm = self.ohmmeter(rng, np.array([r.r_top_ohm[0], r.r_bottom_ohm[0]]), STATIC_READINGS)
        return digits(series_c(z, freq_hz) * 1e12, 6), digits(z.real, 5), ohm[0], ohm[1]

    @staticmethod
    def ohmmeter(rng, r, readings=1):
        """A 5½-digit ohmmeter: 1e-4 of the reading, to the ohm."""
        return np.round(r * (1.0 + 1e-4 / np.sqrt(readings) * rng.standard_normal(r.shape)))

    def trace(self, rng, strokes, freq_hz):
        """Rows (time, stretch, R top, R bottom, Cs, Rs, true C) of a trace."""
        m = self.meter
        back = m.reach_s(ROW_S) + 1.0
        t = np.arange(-back, strokes.duration_s + back, SAMPLE_S)
        s = strokes.stretch_mm(t)
        dmg = self.film.damage(t, s)
        r = read(self.film, self.effects, s, dmg, freq_hz)
        y, stamp = m.analog(1.0 / r.z_ohm)
        rows = int(np.floor(strokes.duration_s / ROW_S)) + 1
        stamps = np.arange(rows) * ROW_S + JITTER_S * rng.standard_normal(rows)
        stamps[0] = abs(stamps[0])
        at = stamps - m.trigger_delay_s
        yk = np.interp(at + stamp * SAMPLE_S, t, y.real) + 1j * np.interp(at + stamp * SAMPLE_S, t, y.imag)
        eps = m.sigma(freq_hz) * (rng.standard_normal(rows) + 1j * rng.standard_normal(rows))
        z = (1.0 / yk) * (1.0 + eps)
        cs = series_c(z, freq_hz) * 1e12 + pink(rng, rows, m.drift_pf)
        cs, rs = m.logger(cs, z.real)

        def at_stamps(v):
            return np.interp(stamps, t, v)

        ohm = self.ohmmeter(rng, np.stack([at_stamps(r.r_top_ohm), at_stamps(r.r_bottom_ohm)]))
        return {
            "time_s": np.round(stamps, 5),
            "stretch_mm": np.round(strokes.stretch_mm(stamps), 3),
            "r_top_ohm": ohm[0],
            "r_bottom_ohm": ohm[1],
            "cs_pf": digits(cs, 6),
            "rs_ohm": digits(rs, 5),
            "c_true_pf": np.round(at_stamps(r.c_true_f) * 1e12, 4),
        }

    def write(self, out):
        """Write the data set into folder `out` (created)."""
        os.makedirs(out, exist_ok=True)
        rng = np.random.Generator(np.random.PCG64(self.seed))
        head = ["stretch_mm", "freq_hz", "cs_pf", "rs_ohm", "r_top_ohm", "r_bottom_ohm"]
        cal = [(s, CAL_HZ) for s in np.arange(0.0, 30.01, 2.5)]
        sweep = [(s, f) for s in SWEEP_MM for f in SWEEP_HZ]
        for name, points in (("calibration.csv", cal), ("sweep.csv", sweep)):
            with open(os.path.join(out, name), "w", newline="") as fh:
                w = csv.writer(fh)
                w.writerow(head)
                for s, f in points:
                    w.writerow([_num(s), _num(f), *(_num(v) for v in self.static(rng, s, f))])
        for speed, cycles in SPEEDS:
            strokes = Strokes(peak_speed_mm_s=speed, cycles=cycles)
            for f in TRACE_HZ:
                trng = np.random.Generator(np.random.PCG64([self.seed, int(speed), int(f)]))
                cols = self.trace(trng, strokes, f)
                cols["freq_hz"] = np.full(len(cols["time_s"]), f)
                order = ["time_s", "stretch_mm", "r_top_ohm", "r_bottom_ohm", "freq_hz", "cs_pf", "rs_ohm", "c_true_pf"]
                path = os.path.join(out, f"trace_{speed:.0f}mmps_{f:.0f}hz.csv")
                with open(path, "w", newline="") as fh:
                    w = csv.writer(fh)
                    w.writerow(order)
                    for k in range(len(cols["time_s"])):
                        w.writerow([_num(cols[c][k]) for c in order])


def _num(v):
    """A number as the CSV holds it: twelve significant digits at most
    (no binary residue of the display's rounding)."""
    return f"{float(v):.12g}"
