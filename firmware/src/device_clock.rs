//! A device clock that is off: the time stamps a board whose crystal
//! runs fast or slow, started at another moment, would give. The QEMU
//! images take it from their command line (`offset_us=N`,
//! `drift_ppm=N`) so that a skin of several simulated boards has clocks
//! that disagree as real boards' do, and the host's fit of each clock
//! to its own (`live`'s `clock` module) has something to find.
//!
//! The simulated world (the skin's stretching) runs on true time; only
//! the stamps on what the device sends are skewed:
//! `device = offset + true · (1 + drift)`.

/// The widest drift taken, ppm: ten times a crystal's worst.
pub const DRIFT_MAX_PPM: i32 = 1000;

/// A clock's offset and drift from true time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DeviceClock {
    /// The device's time at true time 0, µs.
    pub offset_us: u32,
    /// How fast it runs, ppm (positive: fast), within ±[`DRIFT_MAX_PPM`].
    pub drift_ppm: i32,
}

impl DeviceClock {
    /// Take `arg` if it is one of this clock's options: `Some(Ok(()))`
    /// taken, `Some(Err(why))` its value refused, `None` not one.
    pub fn take(&mut self, arg: &str) -> Option<Result<(), &'static str>> {
        if let Some(v) = arg.strip_prefix("offset_us=") {
            return Some(match v.parse() {
                Ok(us) => {
                    self.offset_us = us;
                    Ok(())
                }
                Err(_) => Err("offset_us=: whole µs, 0 to 4294967295"),
            });
        }
        let v = arg.strip_prefix("drift_ppm=")?;
        Some(match v.parse::<i32>() {
            Ok(ppm) if (-DRIFT_MAX_PPM..=DRIFT_MAX_PPM).contains(&ppm) => {
                self.drift_ppm = ppm;
                Ok(())
            }
            _ => Err("drift_ppm=: whole ppm, -1000 to 1000"),
        })
    }

    /// The device's stamp for true time `t_us`, µs (exact to 1 µs: the
    /// drift's part rounded down; no overflow below 2⁶³ / 1000 µs,
    /// 292 years).
    pub fn stamp(&self, t_us: u64) -> u64 {
        let skew = (t_us as i128 * self.drift_ppm as i128).div_euclid(1_000_000) as i64;
        (t_us as i64 + skew + self.offset_us as i64).max(0) as u64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_true_clock_stamps_true_time() {
        let c = DeviceClock::default();
        for t in [0, 1, 999_999, 86_400_000_000] {
            assert_eq!(c.stamp(t), t);
        }
    }

    #[test]
    fn stamps_follow_the_offset_and_drift_against_an_f64_reference() {
        // Across the declared range: every drift, a day of true time.
        let mut worst = 0.0f64;
        for ppm in [-1000, -250, -1, 0, 1, 37, 999, 1000] {
            for offset_us in [0u32, 1, 1_234_567, u32::MAX] {
                let c = DeviceClock {
                    offset_us,
                    drift_ppm: ppm,
                };
                for t in (0..100).map(|k| k * 864_000_000u64 + k * 7) {
                    let exact = offset_us as f64 + t as f64 * (1.0 + ppm as f64 * 1e-6);
                    worst = worst.max((c.stamp(t) as f64 - exact).abs());
                }
            }
        }
        // Rounded down to the µs: under 1 µs off.
        assert!(worst < 1.0, "{worst} µs");
    }

    #[test]
    fn stamps_never_go_back() {
        let c = DeviceClock {
            offset_us: 5,
            drift_ppm: -1000,
        };
        let mut last = 0;
        for t in 0..10_000u64 {
            let s = c.stamp(t * 997);
            assert!(s >= last);
            last = s;
        }
    }

    #[test]
    fn options_are_taken_or_refused_with_a_reason() {
        let mut c = DeviceClock::default();
        assert_eq!(c.take("offset_us=2500000"), Some(Ok(())));
        assert_eq!(c.take("drift_ppm=-120"), Some(Ok(())));
        assert_eq!(
            c,
            DeviceClock {
                offset_us: 2_500_000,
                drift_ppm: -120
            }
        );
        assert!(matches!(c.take("drift_ppm=1001"), Some(Err(_))));
        assert!(matches!(c.take("offset_us=-1"), Some(Err(_))));
        assert_eq!(c.take("seconds=3"), None);
    }
}
