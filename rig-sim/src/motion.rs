//! The stretching rig: a linear stage moving between rest and full stroke
//! with a trapezoidal velocity profile (constant acceleration to the set
//! speed, cruise, constant deceleration), holding at both ends.

/// One stroke cycle repeated: hold at rest, move out, hold, move back.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cycle {
    /// Stroke, mm.
    pub stroke_mm: f64,
    /// Cruise speed, mm/s.
    pub speed_mm_s: f64,
    /// Acceleration and deceleration, mm/s².
    pub accel_mm_s2: f64,
    /// Hold at rest before each move out, s.
    pub hold_rest_s: f64,
    /// Hold at full stroke, s.
    pub hold_top_s: f64,
    /// Cycles recorded.
    pub cycles: usize,
}

impl Cycle {
    /// The bench's cycle at `speed_mm_s`: 30 mm stroke, 250 mm/s², 1 s
    /// holds.
    pub fn bench(speed_mm_s: f64, cycles: usize) -> Self {
        Self {
            stroke_mm: 30.0,
            speed_mm_s,
            accel_mm_s2: 250.0,
            hold_rest_s: 1.0,
            hold_top_s: 1.0,
            cycles,
        }
    }

    /// Duration of one move, s.
    pub fn move_s(&self) -> f64 {
        let (d, v, a) = (self.stroke_mm, self.speed_mm_s, self.accel_mm_s2);
        if v * v / a >= d {
            // Never reaches cruise: accelerate half way, decelerate.
            2.0 * (d / a).sqrt()
        } else {
            d / v + v / a
        }
    }

    /// Duration of one cycle, s.
    pub fn period_s(&self) -> f64 {
        self.hold_rest_s + self.hold_top_s + 2.0 * self.move_s()
    }

    /// Duration of the recording, s (the cycles, then a last hold at rest).
    pub fn duration_s(&self) -> f64 {
        self.cycles as f64 * self.period_s() + self.hold_rest_s
    }

    /// Distance covered `t` s into a move, mm.
    fn along(&self, t: f64) -> f64 {
        let (d, a) = (self.stroke_mm, self.accel_mm_s2);
        let total = self.move_s();
        let t = t.clamp(0.0, total);
        let v = self.speed_mm_s.min((a * d).sqrt());
        let ta = v / a;
        if t < ta {
            0.5 * a * t * t
        } else if t > total - ta {
            let r = total - t;
            d - 0.5 * a * r * r
        } else {
            0.5 * a * ta * ta + v * (t - ta)
        }
    }

    /// Stretch at time `t` (s; before 0 and after the end: at rest), mm.
    pub fn stretch_mm(&self, t: f64) -> f64 {
        if t <= 0.0 || t >= self.cycles as f64 * self.period_s() {
            return 0.0;
        }
        let u = t % self.period_s();
        let m = self.move_s();
        let up = self.hold_rest_s;
        let top = up + m;
        let down = top + self.hold_top_s;
        if u < up {
            0.0
        } else if u < top {
            self.along(u - up)
        } else if u < down {
            self.stroke_mm
        } else {
            self.stroke_mm - self.along(u - down)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn moves_reach_the_stroke_at_the_set_speed() {
        let c = Cycle::bench(20.0, 2);
        assert!((c.move_s() - (1.5 + 0.08)).abs() < 1e-12);
        let t_mid = c.hold_rest_s + 0.5 * c.move_s();
        let dt = 1e-4;
        let v = (c.stretch_mm(t_mid + dt) - c.stretch_mm(t_mid - dt)) / (2.0 * dt);
        assert!((v - 20.0).abs() < 1e-6, "{v}");
        assert!((c.stretch_mm(c.hold_rest_s + c.move_s() + 0.5) - 30.0).abs() < 1e-12);
        assert_eq!(c.stretch_mm(-1.0), 0.0);
        assert_eq!(c.stretch_mm(c.duration_s() + 1.0), 0.0);
        // Continuous everywhere (no jumps at the phase boundaries).
        let mut last = c.stretch_mm(0.0);
        let mut t = 0.0;
        while t < c.duration_s() {
            t += 1e-3;
            let s = c.stretch_mm(t);
            assert!((s - last).abs() <= 20.0 * 1e-3 + 1e-9, "jump at {t}");
            last = s;
        }
    }

    #[test]
    fn a_short_stroke_never_cruises() {
        let c = Cycle {
            stroke_mm: 1.0,
            ..Cycle::bench(20.0, 1)
        };
        assert!((c.move_s() - 2.0 * (1.0f64 / 250.0).sqrt()).abs() < 1e-12);
        let end = c.hold_rest_s + c.move_s();
        assert!((c.stretch_mm(end) - 1.0).abs() < 1e-9);
    }
}
