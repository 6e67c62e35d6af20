"""The rig: strokes with a raised-cosine profile (a cam or
a servo's S-curve), not the trapezoids of the other benches. A move of
stroke S over T s follows S/2·(1 - cos(πt/T)): zero speed at both ends,
π·S/(2T) at its middle."""

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Strokes:
    stroke_mm: float = 30.0
    peak_speed_mm_s: float = 20.0
    hold_rest_s: float = 1.2
    hold_top_s: float = 0.8
    cycles: int = 3

    @property
    def move_s(self):
        return np.pi * self.stroke_mm / (2.0 * self.peak_speed_mm_s)

    @property
    def cycle_s(self):
        return 2.0 * self.move_s + self.hold_rest_s + self.hold_top_s

    @property
    def duration_s(self):
        """The cycles, then a last hold at rest."""
        return self.cycles * self.cycle_s + self.hold_rest_s

    def stretch_mm(self, t):
        """Stretch at times `t` (s; before 0 and after the end: at rest)."""
        t = np.asarray(t, dtype=float)
        u = np.mod(t, self.cycle_s)
        m, s = self.move_s, self.stroke_mm
        out = np.zeros_like(u)
        up = (u >= self.hold_rest_s) & (u < self.hold_rest_s + m)
        out[up] = 0.5 * s * (1 - np.cos(np.pi * (u[up] - self.hold_rest_s) / m))
        top0 = self.hold_rest_s + m
        top = (u >= top0) & (u < top0 + self.hold_top_s)
        out[top] = s
        down0 = top0 + self.hold_top_s
        down = u >= down0
        out[down] = 0.5 * s * (1 + np.cos(np.pi * (u[down] - down0) / m))
        out[(t < 0) | (t >= self.cycles * self.cycle_s)] = 0.0
        return out
