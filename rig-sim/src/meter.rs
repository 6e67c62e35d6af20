//! The instruments: an LCR meter (series Cs–Rs from the impedance it
//! measures, with its own averaging, time base and noise) and a
//! four-wire ohmmeter for the electrode resistances.
//!
//! The LCR meter samples the impedance Z every [`SAMPLE_S`], converts each
//! sample to Cs = −1/(ω·Im Z) and Rs = Re Z, and reports at each row
//! those readings averaged by its [`Dynamics`] (a meter's averaging of
//! readings; averaging Z itself would bias Cs by the harmonic mean).

use num_complex::Complex64;

/// The LCR meter's internal sampling period, s.
pub const SAMPLE_S: f64 = 1e-3;

/// How the meter averages its internal samples into one reading.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Dynamics {
    /// One sample at the reading's time.
    Instant,
    /// The mean of the samples over `length_s`: ending at the reading's
    /// time (trailing, the current sample included), or centred on it (a
    /// meter that time-stamps the middle of its integration).
    Window {
        /// Window length, s.
        length_s: f64,
        /// Centred on the time stamp (else trailing).
        centred: bool,
    },
    /// A first-order (exponential) average of the samples, time constant
    /// `tau_s`.
    FirstOrder {
        /// Time constant, s.
        tau_s: f64,
    },
    /// A lock-in's output filter: `sections` first-order averages of
    /// time constant `tau_s` in cascade (6 dB/octave each), each run
    /// along the samples.
    Cascade {
        /// Time constant of each section, s.
        tau_s: f64,
        /// Sections (≥ 1).
        sections: usize,
    },
    /// A meter that takes one reading per row, at the row's time, and
    /// reports the mean of its last `readings` readings, `delay` rows late
    /// (a digital meter's or logger's running average, a buffered
    /// channel): row k is the mean of readings k − delay − readings + 1
    /// … k − delay.
    MovingMean {
        /// Readings averaged (≥ 1).
        readings: usize,
        /// Rows of delay.
        delay: usize,
    },
    /// A meter that takes one reading per row and reports an
    /// exponentially weighted mean of them, `delay` rows late (a digital
    /// filter setting): y_k = w·x_(k − delay) + (1 − w)·y_(k − 1).
    Ewma {
        /// Weight w of the newest reading, 0 < w ≤ 1.
        weight: f64,
        /// Rows of delay.
        delay: usize,
    },
}

impl Dynamics {
    /// Readings before a row a discrete kernel reaches back: its length
    /// and delay (an exponential's until its weights fall under 10⁻⁵).
    pub fn rows_back(&self) -> usize {
        match *self {
            Dynamics::MovingMean { readings, delay } => readings.max(1) - 1 + delay,
            Dynamics::Ewma { weight, delay } => {
                let w = weight.clamp(1e-3, 1.0);
                let memory = if w >= 1.0 {
                    0.0
                } else {
                    (1e-5f64).ln() / (1.0 - w).ln()
                };
                memory.ceil() as usize + delay
            }
            _ => 0,
        }
    }

    /// The kernel's own centroid, s: how far back from its newest reading
    /// it averages, without its delay or where a window is stamped (T/2
    /// of a window, τ, (N − 1)/2 and (1 − w)/w readings; for n sections
    /// in cascade their spread √n·τ, their centroid n·τ being a delay to
    /// the data). Under a row interval a kernel reads as a delay alone on
    /// the data's rows.
    pub fn kernel_centroid_s(&self, row_s: f64) -> f64 {
        match *self {
            Dynamics::Instant => 0.0,
            Dynamics::Window { length_s, .. } => 0.5 * length_s,
            Dynamics::FirstOrder { tau_s } => tau_s,
            // The centroid n·τ of n sections reads as a delay; what a
            // delay does not take is the kernel's spread, √n·τ (for one
            // section the two agree).
            Dynamics::Cascade { tau_s, sections } => (sections as f64).sqrt() * tau_s,
            Dynamics::MovingMean { readings, .. } => 0.5 * (readings.max(1) - 1) as f64 * row_s,
            Dynamics::Ewma { weight, .. } => (1.0 - weight) / weight * row_s,
        }
    }

    /// The centroid of the reading's kernel behind its time stamp, s
    /// (with the delay).
    pub fn centroid_s(&self, row_s: f64) -> f64 {
        match *self {
            Dynamics::Instant => 0.0,
            Dynamics::Window { length_s, centred } => {
                if centred {
                    0.0
                } else {
                    0.5 * length_s
                }
            }
            Dynamics::FirstOrder { tau_s } => tau_s,
            Dynamics::Cascade { tau_s, sections } => sections as f64 * tau_s,
            Dynamics::MovingMean { readings, delay } => {
                (0.5 * (readings.max(1) - 1) as f64 + delay as f64) * row_s
            }
            Dynamics::Ewma { weight, delay } => ((1.0 - weight) / weight + delay as f64) * row_s,
        }
    }
}

/// The noise of the instruments.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Noise {
    /// White noise of Cs independent of the reading, pF (1σ).
    pub floor_pf: f64,
    /// Relative white noise of Cs at 500 Hz (1σ); it scales as
    /// 1 + 500 Hz/f, the meter being less precise on high impedances.
    pub relative_500hz: f64,
    /// Slow drift of Cs: first-order autoregressive, 1σ, pF.
    pub drift_pf: f64,
    /// Its correlation from one row to the next.
    pub drift_rho: f64,
    /// Relative noise of Rs and of the ohmmeter (1σ).
    pub resistance_relative: f64,
    /// Readings averaged per static point (calibration, sweep).
    pub static_average: usize,
}

impl Noise {
    /// The bench's meters.
    pub const BENCH: Noise = Noise {
        floor_pf: 0.012,
        relative_500hz: 0.6e-4,
        drift_pf: 0.006,
        drift_rho: 0.85,
        resistance_relative: 3e-4,
        static_average: 4,
    };

    /// White σ of a Cs reading of `cs_pf` at `freq_hz`, pF.
    pub fn white_pf(&self, cs_pf: f64, freq_hz: f64) -> f64 {
        let rel = self.relative_500hz * (1.0 + 500.0 / freq_hz) * cs_pf;
        (self.floor_pf * self.floor_pf + rel * rel).sqrt()
    }
}

/// The LCR meter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Meter {
    /// Its averaging.
    pub dynamics: Dynamics,
    /// Its time base against the rig's (a reading stamped t saw the sensor
    /// around t + offset), s.
    pub offset_s: f64,
    /// Its noise.
    pub noise: Noise,
}

impl Meter {
    /// The bench's meter: instant readings, aligned.
    pub const BENCH: Meter = Meter {
        dynamics: Dynamics::Instant,
        offset_s: 0.0,
        noise: Noise::BENCH,
    };

    /// How far before and after the time stamp the meter looks, s, with
    /// rows every `row_s`.
    pub fn reach(&self, row_s: f64) -> (f64, f64) {
        let (before, after) = match self.dynamics {
            Dynamics::Instant => (0.0, 0.0),
            Dynamics::Window {
                length_s,
                centred: false,
            } => (length_s, 0.0),
            Dynamics::Window {
                length_s,
                centred: true,
            } => (0.5 * length_s, 0.5 * length_s),
            // e^-12: what lies further back is below 1e-5 of a reading.
            Dynamics::FirstOrder { tau_s } => (12.0 * tau_s, 0.0),
            // The Erlang kernel's tail past (10 + 4n)·τ is below 10⁻⁵.
            Dynamics::Cascade { tau_s, sections } => ((10.0 + 4.0 * sections as f64) * tau_s, 0.0),
            Dynamics::MovingMean { .. } | Dynamics::Ewma { .. } => {
                (self.dynamics.rows_back() as f64 * row_s, 0.0)
            }
        };
        (before - self.offset_s.min(0.0), after + self.offset_s.max(0.0))
    }
}

/// A first-order average run along the meter's samples (a pair of
/// readings packed in a complex number).
#[derive(Clone, Debug)]
pub struct Exponential {
    decay: f64,
    state: Option<Complex64>,
}

impl Exponential {
    /// Time constant `tau_s`, one update per [`SAMPLE_S`].
    pub fn new(tau_s: f64) -> Self {
        Self {
            decay: (-SAMPLE_S / tau_s).exp(),
            state: None,
        }
    }

    /// The average so far (0 before the first sample).
    pub fn value(&self) -> Complex64 {
        self.state.unwrap_or_default()
    }

    /// The average after the sample `z`.
    pub fn update(&mut self, z: Complex64) -> Complex64 {
        let s = match self.state {
            None => z,
            Some(s) => z + (s - z) * self.decay,
        };
        self.state = Some(s);
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_exponential_average_has_its_time_constant() {
        let tau = 0.05;
        let mut e = Exponential::new(tau);
        e.update(Complex64::new(0.0, 0.0));
        let mut y = Complex64::default();
        let steps = (tau / SAMPLE_S).round() as usize;
        for _ in 0..steps {
            y = e.update(Complex64::new(1.0, 0.0));
        }
        assert!((y.re - (1.0 - (-1.0f64).exp())).abs() < 1e-9, "{y}");
    }

    /// Three sections of τ in cascade, sample by sample, against the
    /// Erlang step response 1 − e^(−t/τ)·Σ_(k<3) (t/τ)ᵏ/k!: within 1 %
    /// of the step (each section sees its input a fraction of a sample
    /// early, as a digital filter does).
    #[test]
    fn sections_in_cascade_have_the_erlang_step_response() {
        let tau = 0.05;
        let mut avgs: Vec<Exponential> = (0..3).map(|_| Exponential::new(tau)).collect();
        let mut run = |z: f64| avgs.iter_mut().fold(Complex64::new(z, 0.0), |x, a| a.update(x));
        run(0.0);
        let mut worst = 0.0f64;
        for k in 1..=1000 {
            let y = run(1.0).re;
            let x = k as f64 * SAMPLE_S / tau;
            let want = 1.0 - (-x).exp() * (1.0 + x + 0.5 * x * x);
            worst = worst.max((y - want).abs());
        }
        assert!(worst < 0.01, "{worst}");
    }

    #[test]
    fn the_reach_covers_window_and_offset() {
        let m = Meter {
            dynamics: Dynamics::Window {
                length_s: 0.4,
                centred: true,
            },
            offset_s: -0.1,
            ..Meter::BENCH
        };
        let (b, a) = m.reach(0.02);
        assert!((b - 0.3).abs() < 1e-12 && (a - 0.2).abs() < 1e-12);
        assert!(Noise::BENCH.white_pf(200.0, 500.0) > Noise::BENCH.white_pf(200.0, 6000.0));
    }
}
