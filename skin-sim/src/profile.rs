//! Stretch profiles: stretch (mm, relative to the prestretched rest) and
//! its rate (mm/s) as functions of time (s).

/// A stretch profile.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Profile<'a> {
    /// Hold at a constant stretch, mm.
    Constant(f64),
    /// The paper's trapezoid (Figure 4): from 0, stretch at `rate` mm/s to
    /// `amplitude` mm, hold, release at the same rate at `half_period` s,
    /// hold at 0 until `2·half_period`, repeat. The paper: 10 or 20 mm/s,
    /// 30 mm, 10 s period (stretch and release begin at the same instants).
    Trapezoid {
        /// Stretch and release rate, mm/s (> 0).
        rate: f64,
        /// Maximum stretch, mm.
        amplitude: f64,
        /// Period, s.
        period: f64,
    },
    /// Constant-rate ramp from 0 at `rate` mm/s until `amplitude`, then hold.
    Ramp {
        /// Rate, mm/s (> 0).
        rate: f64,
        /// Final stretch, mm.
        amplitude: f64,
    },
    /// A step from 0 to `amplitude` mm at time `at` s.
    Step {
        /// Time of the step, s.
        at: f64,
        /// Stretch after the step, mm.
        amplitude: f64,
    },
    /// Piecewise-linear through (time s, stretch mm) points with increasing
    /// times; held constant before the first and after the last.
    Table(&'a [(f64, f64)]),
}

impl Profile<'_> {
    /// The paper's trapezoid at `rate` mm/s: 30 mm, 10 s period.
    pub const fn paper(rate: f64) -> Profile<'static> {
        Profile::Trapezoid {
            rate,
            amplitude: 30.0,
            period: 10.0,
        }
    }

    /// Stretch (mm) and rate (mm/s) at time `t` (s).
    pub fn at(&self, t: f64) -> (f64, f64) {
        match *self {
            Profile::Constant(s) => (s, 0.0),
            Profile::Trapezoid {
                rate,
                amplitude,
                period,
            } => {
                let tp = t - period * libm::floor(t / period);
                let ramp = amplitude / rate;
                let half = 0.5 * period;
                if tp < ramp {
                    (rate * tp, rate)
                } else if tp < half {
                    (amplitude, 0.0)
                } else if tp < half + ramp {
                    (amplitude - rate * (tp - half), -rate)
                } else {
                    (0.0, 0.0)
                }
            }
            Profile::Ramp { rate, amplitude } => {
                let end = amplitude / rate;
                if t <= 0.0 {
                    (0.0, 0.0)
                } else if t < end {
                    (rate * t, rate)
                } else {
                    (amplitude, 0.0)
                }
            }
            Profile::Step { at, amplitude } => (if t >= at { amplitude } else { 0.0 }, 0.0),
            Profile::Table(pts) => table(pts, t),
        }
    }
}

fn table(pts: &[(f64, f64)], t: f64) -> (f64, f64) {
    match pts {
        [] => (0.0, 0.0),
        [(_, s)] => (*s, 0.0),
        _ => {
            if t <= pts[0].0 {
                return (pts[0].1, 0.0);
            }
            let last = pts[pts.len() - 1];
            if t >= last.0 {
                return (last.1, 0.0);
            }
            let k = pts.partition_point(|p| p.0 <= t);
            let (a, b) = (pts[k - 1], pts[k]);
            let v = (b.1 - a.1) / (b.0 - a.0);
            (a.1 + v * (t - a.0), v)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trapezoid_matches_the_paper() {
        let p = Profile::paper(20.0);
        assert_eq!(p.at(0.0), (0.0, 20.0));
        assert_eq!(p.at(0.75), (15.0, 20.0));
        assert_eq!(p.at(1.5), (30.0, 0.0));
        assert_eq!(p.at(4.9), (30.0, 0.0));
        assert_eq!(p.at(5.75), (15.0, -20.0));
        assert_eq!(p.at(7.0), (0.0, 0.0));
        assert_eq!(p.at(10.75), (15.0, 20.0));
        let p = Profile::paper(10.0);
        assert_eq!(p.at(2.0), (20.0, 10.0));
        assert_eq!(p.at(7.0), (10.0, -10.0));
    }

    #[test]
    fn ramp_step_table() {
        let r = Profile::Ramp {
            rate: 5.0,
            amplitude: 10.0,
        };
        assert_eq!(r.at(1.0), (5.0, 5.0));
        assert_eq!(r.at(3.0), (10.0, 0.0));
        let s = Profile::Step {
            at: 1.0,
            amplitude: 7.0,
        };
        assert_eq!((s.at(0.99).0, s.at(1.0).0), (0.0, 7.0));
        let pts = [(0.0, 0.0), (2.0, 10.0), (3.0, 10.0)];
        let t = Profile::Table(&pts);
        assert_eq!(t.at(1.0), (5.0, 5.0));
        assert_eq!(t.at(2.5), (10.0, 0.0));
        assert_eq!(t.at(9.0), (10.0, 0.0));
        assert_eq!(t.at(-1.0), (0.0, 0.0));
    }
}
