//! The power-up self-test a device reports in its start frame
//! ([`link::SelfTest`], `instrument::selftest` on the device), as `live`
//! prints it, the dashboard shows it and a recording's manifest keeps it.

use link::{SelfTest, Verdict};
use serde_json::{json, Value};

/// A path's name: bit 0 the excitation, 1–16 the sensors' stages, 17 the
/// reference network's.
pub fn path_name(path: u32) -> String {
    match path {
        0 => "excitation".to_string(),
        SelfTest::REFERENCE_PATH => "reference".to_string(),
        p => format!("sensor {}", p - 1),
    }
}

/// The names of the paths a mask sets, in order.
pub fn paths(mask: u32) -> Vec<String> {
    (0..32).filter(|p| mask >> p & 1 != 0).map(path_name).collect()
}

/// The sensors whose records the device refuses (flagged `SELF_TEST`):
/// every one if the excitation's or the reference's path failed, else
/// those whose own stage did.
pub fn refused_sensors(t: &SelfTest, sensors: u8) -> Vec<u8> {
    (0..sensors).filter(|&s| t.refuses(s)).collect()
}

/// The figures of a test that ran: the reference's worst |Z| and phase
/// errors, the excitation's worst, the noisiest path.
fn figures(t: &SelfTest) -> String {
    format!(
        "reference |Z| {:+.3} %, phase {:+.2} mrad; excitation {:+.2} %; noisiest path {:.2}× the converter's noise",
        t.gain_ppm as f64 * 1e-4,
        t.phase_urad as f64 * 1e-3,
        t.excitation_ppm as f64 * 1e-4,
        t.noise_permille as f64 * 1e-3
    )
}

/// One line for a person: the verdict, what failed, what it refuses.
pub fn line(t: &SelfTest, sensors: u8) -> String {
    let noisy = if t.noisy != 0 {
        format!("; noisy (reported only): {}", paths(t.noisy).join(", "))
    } else {
        String::new()
    };
    match t.verdict {
        Verdict::NotRun => "self-test not run (this front end has no reference network)".to_string(),
        Verdict::Passed => format!("self-test passed: {}{noisy}", figures(t)),
        Verdict::Failed => {
            let refused = refused_sensors(t, sensors);
            let which = if refused.len() == usize::from(sensors) {
                "every sensor's".to_string()
            } else {
                let list: Vec<String> = refused.iter().map(u8::to_string).collect();
                format!("sensor {}'s", list.join(", "))
            };
            format!(
                "self-test FAILED on {}: {} records refused (flagged SELF_TEST); {}{noisy}",
                paths(t.failed).join(", "),
                which,
                figures(t)
            )
        }
    }
}

/// As JSON: the fields, the paths by name, the refused sensors and the
/// line.
pub fn json(t: &SelfTest, sensors: u8) -> Value {
    json!({
        "verdict": match t.verdict {
            Verdict::NotRun => "not run",
            Verdict::Passed => "passed",
            Verdict::Failed => "failed",
        },
        "failed": paths(t.failed),
        "noisy": paths(t.noisy),
        "refused_sensors": refused_sensors(t, sensors),
        "reference_gain_ppm": t.gain_ppm,
        "reference_phase_urad": t.phase_urad,
        "excitation_ppm": t.excitation_ppm,
        "noise_permille": t.noise_permille,
        "line": line(t, sensors),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failed_stage_refuses_its_sensor_and_a_failed_chain_every_one() {
        let stage = SelfTest {
            verdict: Verdict::Failed,
            failed: 1 << 6,
            ..SelfTest::default()
        };
        assert_eq!(refused_sensors(&stage, 16), vec![5]);
        assert!(line(&stage, 16).contains("FAILED on sensor 5: sensor 5's records refused"));
        let chain = SelfTest {
            failed: 1 << 17,
            ..stage
        };
        assert_eq!(refused_sensors(&chain, 16).len(), 16);
        assert!(line(&chain, 16).contains("on reference: every sensor's records refused"));
        let passed = SelfTest {
            verdict: Verdict::Passed,
            noisy: 1,
            gain_ppm: 120,
            ..SelfTest::default()
        };
        assert!(refused_sensors(&passed, 16).is_empty());
        assert!(line(&passed, 16).contains("|Z| +0.012 %"));
        assert!(line(&passed, 16).contains("noisy (reported only): excitation"));
        assert!(line(&SelfTest::default(), 8).contains("not run"));
    }
}
