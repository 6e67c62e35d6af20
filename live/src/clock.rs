//! The device's clock fitted to the host's: each record's time stamp
//! (µs since the device started) against the host's UTC when its frame
//! arrived, as a straight line, host = offset + rate · device.
//!
//! One point per read that completed frames: the latest record time it
//! brought, the one that waited least in the device's and the link's
//! buffers. The fit is least squares, kept as running sums (its memory
//! does not grow with the session), centred on the first point so that a
//! day's seconds keep their microseconds. The line is the *arrival*
//! line: its offset holds the link's mean delay (a frame's time on the
//! wire and in the host's buffers, a few ms on the board's 921,600 baud
//! port), which is what lines records up with other streams stamped on
//! arrival (LSL's convention). Its 1σ are the least-squares ones; the
//! scatter of arrivals about the line (`rms_s`) is the jitter a single
//! record's arrival time carries. Until the points span
//! [`DRIFT_SPAN_S`] of the device's time, the rate is not fitted (a
//! burst of reads a few ms apart would give any slope): the line is
//! the mean offset at rate 1, and says so.

/// The device time the points must span before the rate is fitted, s
/// (a crystal's 100 ppm is 1 ms over it).
pub const DRIFT_SPAN_S: f64 = 10.0;

use serde_json::{json, Value};

/// Running sums of a least-squares line through (device s, host s).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ClockFit {
    /// The first point: device s, host UTC s since the Unix epoch.
    origin: Option<(f64, f64)>,
    n: u64,
    sx: f64,
    sy: f64,
    sxx: f64,
    sxy: f64,
    syy: f64,
    /// The device times the points span, s from the first.
    lo: f64,
    hi: f64,
}

/// A fitted line from the device's clock to the host's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Line {
    /// The host's UTC at the device's time 0, s since the Unix epoch.
    pub offset_s: f64,
    /// Host seconds per device second (1 + drift); 1 where not fitted.
    pub rate: f64,
    /// Whether the rate is fitted (the points span [`DRIFT_SPAN_S`]).
    pub rate_fitted: bool,
    /// 1σ of `offset_s`, s.
    pub sigma_offset_s: f64,
    /// 1σ of `rate`.
    pub sigma_rate: f64,
    /// RMS of the arrivals about the line, s.
    pub rms_s: f64,
    /// Points fitted.
    pub points: u64,
    /// The device time the points span, s.
    pub span_s: f64,
}

impl ClockFit {
    /// Add a point: device time `device_s` arrived at host UTC `host_s`.
    pub fn add(&mut self, device_s: f64, host_s: f64) {
        let (x0, y0) = *self.origin.get_or_insert((device_s, host_s));
        // y is the host's time less the device's: what drift moves.
        let (x, y) = (device_s - x0, (host_s - y0) - (device_s - x0));
        self.n += 1;
        self.sx += x;
        self.sy += y;
        self.sxx += x * x;
        self.sxy += x * y;
        self.syy += y * y;
        self.lo = self.lo.min(x);
        self.hi = self.hi.max(x);
    }

    /// The line, once two points at different device times are in.
    pub fn line(&self) -> Option<Line> {
        let (x0, y0) = self.origin?;
        let n = self.n as f64;
        let (mx, my) = (self.sx / n, self.sy / n);
        let vxx = self.sxx - n * mx * mx;
        if self.n < 2 || vxx <= 0.0 {
            return None;
        }
        let fitted = self.hi - self.lo >= DRIFT_SPAN_S;
        let slope = if fitted {
            (self.sxy - n * mx * my) / vxx
        } else {
            0.0
        };
        let at_origin = my - slope * mx;
        // The residuals' sum of squares, from the sums.
        let ss = (self.syy - n * my * my - slope * (self.sxy - n * mx * my)).max(0.0);
        let dof = if fitted { 2.0 } else { 1.0 };
        let s2 = if n > dof { ss / (n - dof) } else { 0.0 };
        // The offset at device time 0: the line carried back from x0.
        let a0 = at_origin - slope * x0;
        let var_a0 = match fitted {
            true => s2 * (1.0 / n + (x0 + mx).powi(2) / vxx),
            false => s2 / n,
        };
        Some(Line {
            offset_s: y0 - x0 + a0,
            rate: 1.0 + slope,
            rate_fitted: fitted,
            sigma_offset_s: var_a0.sqrt(),
            sigma_rate: if fitted { (s2 / vxx).sqrt() } else { f64::NAN },
            rms_s: (ss / n).sqrt(),
            points: self.n,
            span_s: self.hi - self.lo,
        })
    }
}

impl Line {
    /// The host's UTC (s since the epoch) at device time `device_s`.
    pub fn host_of(&self, device_s: f64) -> f64 {
        self.offset_s + self.rate * device_s
    }

    /// The device's time (s since its start) at host UTC `host_s`.
    pub fn device_of(&self, host_s: f64) -> f64 {
        (host_s - self.offset_s) / self.rate
    }

    /// The line as the manifest and the feed give it.
    pub fn json(&self) -> Value {
        json!({
            "offset_utc": utc(self.offset_s),
            "offset_unix_s": self.offset_s,
            "sigma_offset_ms": self.sigma_offset_s * 1e3,
            "rate": self.rate,
            "drift_ppm": self.rate_fitted.then_some((self.rate - 1.0) * 1e6),
            "sigma_drift_ppm": self.rate_fitted.then_some(self.sigma_rate * 1e6),
            "arrival_rms_ms": self.rms_s * 1e3,
            "points": self.points,
        })
    }
}

/// `unix_s` as an RFC 3339 UTC time with microseconds.
pub fn utc(unix_s: f64) -> Option<String> {
    let us = (unix_s * 1e6).round() as i64;
    chrono::DateTime::from_timestamp_micros(us)
        .map(|t| t.to_rfc3339_opts(chrono::SecondsFormat::Micros, true))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator (xorshift), uniform in [0, 1).
    fn uniform(state: &mut u64) -> f64 {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        (*state >> 11) as f64 / (1u64 << 53) as f64
    }

    #[test]
    fn a_drifting_clock_is_recovered_within_its_stated_sigma() {
        // A device 37 ppm fast, started at a known UTC, read every 20 ms
        // for an hour; arrivals late by 2 ms plus exponential jitter of
        // mean 1 ms (a USB serial port's buffering).
        let t0 = 1_796_300_000.123_456;
        let rate = 1.0 / (1.0 + 37e-6);
        let mut fit = ClockFit::default();
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        for k in 0..180_000 {
            let device = k as f64 * 0.02;
            let late = 2e-3 - 1e-3 * (1.0 - uniform(&mut state)).ln();
            fit.add(device, t0 + rate * device + late);
        }
        let line = fit.line().unwrap();
        // The mean delay (3 ms) is in the offset, as the docs say.
        let offset_err = line.offset_s - (t0 + 3e-3);
        assert!(
            offset_err.abs() < 4.0 * line.sigma_offset_s,
            "{offset_err} vs {}",
            line.sigma_offset_s
        );
        assert!(line.sigma_offset_s < 20e-6, "{}", line.sigma_offset_s);
        let drift_err = line.rate - rate;
        assert!(
            drift_err.abs() < 4.0 * line.sigma_rate,
            "{drift_err} vs {}",
            line.sigma_rate
        );
        assert!((line.rms_s - 1e-3).abs() < 0.05e-3, "{}", line.rms_s);
        assert!((line.span_s - 3600.0).abs() < 1.0, "{}", line.span_s);
        // Mapping and its inverse agree to a microsecond (a UTC second
        // count in f64 resolves 0.24 µs).
        for d in [0.0, 1234.5, 3599.98] {
            assert!((line.device_of(line.host_of(d)) - d).abs() < 1e-6);
        }
    }

    #[test]
    fn one_point_or_one_instant_gives_no_line() {
        let mut fit = ClockFit::default();
        assert_eq!(fit.line(), None);
        fit.add(1.0, 1e9);
        assert_eq!(fit.line(), None);
        fit.add(1.0, 1e9 + 0.1);
        assert_eq!(fit.line(), None);
        fit.add(2.0, 1e9 + 1.0);
        assert!(fit.line().is_some());
    }

    #[test]
    fn a_burst_of_reads_gives_an_offset_not_a_slope() {
        // Two reads a few ms of device time apart that arrived together
        // (a buffer emptied at once): the rate stays 1, not ~0.
        let mut fit = ClockFit::default();
        fit.add(0.002, 1e9 + 0.010);
        fit.add(0.006, 1e9 + 0.010);
        let line = fit.line().unwrap();
        assert!(!line.rate_fitted && line.rate == 1.0);
        assert!(
            (line.offset_s - (1e9 + 0.006)).abs() < 1e-6,
            "{}",
            line.offset_s - 1e9
        );
        assert!(line.json()["drift_ppm"].is_null());
        // Past DRIFT_SPAN_S the slope is fitted.
        fit.add(20.0, 1e9 + 20.004);
        assert!(fit.line().unwrap().rate_fitted);
    }

    #[test]
    fn an_exact_line_has_zero_scatter_and_utc_reads_back() {
        let mut fit = ClockFit::default();
        for k in 0..10 {
            fit.add(2.0 * k as f64, 1_700_000_000.5 + 4.0 * k as f64);
        }
        let line = fit.line().unwrap();
        assert!((line.rate - 2.0).abs() < 1e-12);
        assert!((line.offset_s - 1_700_000_000.5).abs() < 1e-6);
        assert!(line.rms_s < 1e-6 && line.sigma_rate < 1e-9);
        assert_eq!(
            utc(1_700_000_000.5).as_deref(),
            Some("2023-11-14T22:13:20.500000Z")
        );
    }
}
