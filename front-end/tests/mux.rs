//! ngspice on the multiplexed board's netlist, against the constants the
//! firmware assumes: a mismatch fails.

mod common;

use common::{c_of, range};
use front_end::circuit::{Circuit, Sensor};
use front_end::{mux, spice};
use num_complex::Complex64;
use skin_spec::config::FREQS_HZ;
use skin_spec::design::TIA_RANGES_OHM;

/// Sensor 0's impedance as the firmware reads it through range `range`
/// (k = −R_k: `Ranging::front_ends`), and as it is between its tabs, at
/// every tone of the set: (Hz, read, true).
fn reads(board: &Circuit, range: usize) -> Vec<(f64, Complex64, Complex64)> {
    let board = mux::select(board, 0, range);
    let freqs: Vec<f64> = FREQS_HZ.iter().map(|&f| f as f64).collect();
    let vectors = ["v(PA0)", "v(PA1)", "v(TOP0)", "v(BOT0)", "i(VJ1_i)"];
    let rows = spice::ac(&board, spice::AC_STIMULUS, "", &vectors, &freqs).expect("ngspice's AC analysis");
    let k = -TIA_RANGES_OHM[range];
    freqs
        .iter()
        .zip(rows)
        .map(|(&f, r)| (f, k * r[0] / r[1], (r[2] - r[3]) / r[4]))
        .collect()
}

/// The range the firmware's auto-ranging may hold `sensor` at while it
/// reads tone `i` of the set with its companion (`skin_spec::config`):
/// the largest whose stage output, both tones' currents at their peaks
/// together, stays under the ranging's step-down level (0.85 of the
/// ADC's half scale), where the error of a larger feedback is largest.
fn range_for(sensor: &Sensor, i: usize) -> usize {
    use skin_spec::config::COMPANION;
    use skin_spec::ranging::Ranging;
    let (f1, f2) = (FREQS_HZ[i] as f64, FREQS_HZ[COMPANION[i]] as f64);
    let amp = 0.6 / sensor.impedance(f1).norm() + 0.4 / sensor.impedance(f2).norm();
    let limit = Ranging::DEFAULT.down as f64 * skin_spec::design::ADC_HALF_SCALE_VOLT;
    (0..TIA_RANGES_OHM.len())
        .rev()
        .find(|&k| amp * TIA_RANGES_OHM[k] <= limit)
        .unwrap_or(0)
}

/// Through the range the auto-ranging holds each sensor of the range at,
/// for every tone of the set the policy may read it at (x ≤ 4) and its
/// companion, the impedance the firmware reads is the sensor's within
/// 0.2 % and 1 mrad, and C from one tone within 0.2 % of C from the
/// sensor's own (where x ≤ 4): the op-amp's finite gain against the
/// multiplexer's capacitance at its input.
#[test]
fn every_range_reads_the_sensor_as_the_firmware_assumes() {
    use skin_spec::config::COMPANION;
    let board = mux::board();
    let mut md = String::from("| sensor | tone, companion | range | worst \\|Z\\| | worst phase | worst C (x ≤ 4) |\n|---|---|---:|---:|---:|---:|\n");
    let (mut worst_z, mut worst_phase, mut worst_c) = (0f64, 0f64, 0f64);
    for (name, sensor) in range() {
        let rows_by_range: Vec<_> = (0..TIA_RANGES_OHM.len())
            .map(|k| reads(&board.with_sensors(sensor), k))
            .collect();
        for i in 0..FREQS_HZ.len() {
            let x = |f: f64| std::f64::consts::TAU * f * sensor.r_ohm * sensor.c_farad;
            if x(FREQS_HZ[i] as f64) > 4.0 {
                continue;
            }
            let k = range_for(&sensor, i);
            let mut row = (0f64, 0f64, 0f64);
            for j in [i, COMPANION[i]] {
                let (f, read, truth) = rows_by_range[k][j];
                let e = read / truth;
                let c = if x(f) <= 4.0 {
                    let inverts = |z| c_of(z, f).expect("the impedance inverts");
                    (inverts(read) / inverts(truth) - 1.0).abs()
                } else {
                    0.0
                };
                row = (
                    row.0.max((e.norm() - 1.0).abs()),
                    row.1.max(e.arg().abs()),
                    row.2.max(c),
                );
            }
            md += &format!(
                "| {name} | {:.0} Hz, {:.0} Hz | {:.0} kΩ | {:.3} % | {:.2} mrad | {:.3} % |\n",
                FREQS_HZ[i],
                FREQS_HZ[COMPANION[i]],
                TIA_RANGES_OHM[k] / 1e3,
                100.0 * row.0,
                1e3 * row.1,
                100.0 * row.2
            );
            (worst_z, worst_phase, worst_c) =
                (worst_z.max(row.0), worst_phase.max(row.1), worst_c.max(row.2));
        }
    }
    println!("{md}");
    figures::check_within("docs/hardware.md", "mux-transfer", &md, 0.02).unwrap();
    assert!(worst_z <= 2e-3, "|Z| off by {worst_z:e}");
    assert!(worst_phase <= 1e-3, "phase off by {worst_phase:e} rad");
    assert!(worst_c <= 2e-3, "C off by {worst_c:e}");
}

/// The DAC's two tones for a slot of the set's tone `i` and its
/// companion, at the amplitudes the firmware plays (0.6 V and 0.4 V:
/// `instrument::config::tones`), as codes of the 12-bit DAC at the pair
/// rate, each held one sample: a SPICE source's value, `slots` slots
/// long.
fn two_tones(i: usize, slots: usize) -> String {
    use skin_spec::config::{COMPANION, SLOT_PAIRS};
    use skin_spec::design::{BIAS_VOLT, SAMPLE_RATE, VREF_VOLT};
    let dt = 1.0 / SAMPLE_RATE as f64;
    let (f1, f2) = (FREQS_HZ[i] as f64, FREQS_HZ[COMPANION[i]] as f64);
    let volts = |n: usize| {
        let t = n as f64 * dt;
        let v = BIAS_VOLT
            + 0.6 * (std::f64::consts::TAU * f1 * t).cos()
            + 0.4 * (std::f64::consts::TAU * f2 * t).cos();
        (v / VREF_VOLT * 4096.0).round() * VREF_VOLT / 4096.0
    };
    let mut s = format!("PWL(0 {:.6}", volts(0));
    for n in 0..slots * SLOT_PAIRS {
        let t = n as f64 * dt;
        if n > 0 {
            s += &format!(" {:e} {:.6}", t + 2e-7, volts(n));
        }
        s += &format!(" {:e} {:.6}", t + dt, volts(n));
    }
    s + ")"
}

/// A logic line that is `from` and steps to `to` at `t` s.
fn line(from: bool, to: bool, t: f64) -> String {
    let v = |b: bool| if b { 3.3 } else { 0.0 };
    format!("PWL(0 {} {t:e} {} {:e} {})", v(from), v(from), t + 2e-8, v(to))
}

/// Tone `f`'s phasor in `x` through the lock-in's window (Nuttall's
/// four terms, `dsp_core::lockin::NUTTALL`), the block's mean taken out
/// first.
fn windowed(x: &[f64], periods: u32) -> Complex64 {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    let a = dsp_core::lockin::NUTTALL;
    x.iter()
        .enumerate()
        .map(|(m, v)| {
            let u = std::f64::consts::TAU * m as f64 / n;
            let w = a[0] - a[1] * u.cos() + a[2] * (2.0 * u).cos() - a[3] * (3.0 * u).cos();
            let th = u * periods as f64;
            (v - mean) * w * Complex64::new(th.cos(), -th.sin())
        })
        .sum()
}

/// Sensor `b` read in the slot after sensor `a`'s: channel 0 then 1,
/// each at the range the auto-ranging holds it at, both at tone `i` and
/// its companion. The block after the firmware's settling pairs
/// (`SETTLE_PAIRS`) gives each tone's impedance as the lock-in reads it;
/// against the same board's steady state (AC) the two differ by what the
/// switch leaves unsettled: returned, relative, the larger of the tones.
fn unsettled(a: &Sensor, b: &Sensor, i: usize) -> f64 {
    use skin_spec::config::{BLOCK_PAIRS, COMPANION, PERIODS, SETTLE_PAIRS, SLOT_PAIRS};
    let (ka, kb) = (range_for(a, i), range_for(b, i));
    let dt = 1.0 / skin_spec::design::SAMPLE_RATE as f64;
    let switch = SLOT_PAIRS as f64 * dt;
    let mut board = mux::board().with_sensors(*a).with_sections(8);
    board.sensors[1].1 = *b;
    for (bit, pin) in mux::MUX_PINS.iter().enumerate() {
        board = board.driven(pin, &line(false, bit == 0, switch));
    }
    for (bit, pin) in mux::RANGE_PINS.iter().enumerate() {
        board = board.driven(pin, &line(ka >> bit & 1 == 1, kb >> bit & 1 == 1, switch));
    }
    let from = switch + SETTLE_PAIRS as f64 * dt;
    let rows = spice::tran(
        &board,
        &two_tones(i, 2),
        "",
        &["PA0", "PA1"],
        dt,
        from,
        from + (BLOCK_PAIRS as f64 - 0.5) * dt,
    )
    .expect("ngspice's transient");
    assert!(
        rows.len() >= BLOCK_PAIRS,
        "{} rows for a block's pairs",
        rows.len()
    );
    let rows = &rows[..BLOCK_PAIRS];
    let steady = mux::select(&board, 1, kb);
    let freqs = [FREQS_HZ[i] as f64, FREQS_HZ[COMPANION[i]] as f64];
    let ac = spice::ac(&steady, spice::AC_STIMULUS, "", &["v(PA0)", "v(PA1)"], &freqs)
        .expect("ngspice's AC analysis");
    let (v, cur): (Vec<f64>, Vec<f64>) = rows.iter().map(|r| (r[1], r[2])).unzip();
    [i, COMPANION[i]]
        .iter()
        .zip(&ac)
        .map(|(&j, s)| {
            let read = windowed(&v, PERIODS[j]) / windowed(&cur, PERIODS[j]);
            (read / (s[0] / s[1]) - 1.0).norm()
        })
        .fold(0.0, f64::max)
}

/// A switch from one sensor to the next, with a change of range, leaves
/// the block after the firmware's settling pairs within 2·10⁻⁴ of the
/// steady state at both its tones: what is left is the DAC's images
/// (its steps at the ADC's own rate), not the switch (with none, the same
/// to 10⁻⁵). Three switches of the range's sensors, each to the slowest
/// settling or the widest range step.
#[test]
fn a_switch_settles_within_the_settling_pairs() {
    let [(pn, paper), (ln, low), (hn, high)] = range();
    let mut md =
        String::from("| from | to | tones | ranges | off the steady state |\n|---|---|---|---|---:|\n");
    for ((an, a), (bn, b), i) in [
        ((ln, low), (hn, high), 1),
        ((hn, high), (pn, paper), 1),
        ((pn, paper), (ln, low), 3),
    ] {
        let e = unsettled(&a, &b, i);
        let companion = skin_spec::config::COMPANION[i];
        md += &format!(
            "| {an} | {bn} | {:.0} Hz, {:.0} Hz | {:.0} → {:.0} kΩ | {e:.1e} |\n",
            FREQS_HZ[i],
            FREQS_HZ[companion],
            TIA_RANGES_OHM[range_for(&a, i)] / 1e3,
            TIA_RANGES_OHM[range_for(&b, i)] / 1e3
        );
        assert!(e <= 2e-4, "{an} to {bn}: {e:e} off");
    }
    println!("{md}");
    figures::check_within("docs/hardware.md", "mux-settling", &md, 0.05).unwrap();
}

/// The analog path's noise in a sample at the current's and the
/// voltage's pins, through every range with the paper's sensor, against
/// the converter's own 0.7 LSB that the accuracy figures assume
/// (`FrontEndParams::REFERENCE`): at most 10 % more in quadrature. One
/// conversion a sample: every frequency the op-amp passes folds in.
#[test]
fn the_noise_of_every_range_is_within_what_the_figures_assume() {
    let assumed = 0.7;
    let lsb = skin_spec::design::VREF_VOLT / 4096.0;
    let mut md = String::from("| range | the current's pin | the voltage's pin | with the converter's, in quadrature |\n|---|---:|---:|---:|\n");
    for (k, r) in TIA_RANGES_OHM.iter().enumerate() {
        let board = mux::select(&mux::board(), 0, k);
        let [i, v] = [mux::CURRENT_PIN, front_end::blocks::VOLTAGE_PIN]
            .map(|node| common::result_noise(&board, node, 1, 0.0, lsb));
        let total = i.hypot(assumed);
        md += &format!(
            "| {:.0} kΩ | {i:.2} LSB | {v:.2} LSB | {total:.2} LSB ({:+.1} %) |\n",
            r / 1e3,
            100.0 * (total / assumed - 1.0)
        );
        assert!(
            total <= 1.1 * assumed && v.hypot(assumed) <= 1.1 * assumed,
            "range {k}: {i}, {v} LSB"
        );
    }
    println!("{md}");
    figures::check_within("docs/hardware.md", "mux-noise", &md, 0.02).unwrap();
}

/// A current step into the stage through every range, 20 pF of cable
/// across the selected sensor and to its shield: overshoot under 3 %, and
/// settled to 0.2 % of R_k times the step 38 µs after it (eight of the
/// ranges' 4.7 µs), long before the settling pairs end.
#[test]
fn every_range_is_stable_with_the_longest_cable() {
    let [(_, paper), ..] = range();
    let sensor = Sensor {
        cable_farad: 20e-12,
        shield_farad: 20e-12,
        ..paper
    };
    let mut md = String::from("| range | overshoot | off 38 µs after the step |\n|---|---:|---:|\n");
    for (k, r) in TIA_RANGES_OHM.iter().enumerate() {
        let board = mux::select(&mux::board().with_sensors(sensor), 0, k);
        let out = common::step(&board, "TABM", "TIA", 40e-6);
        let want = r * 1e-6;
        let (overshoot, off) = common::settling(&out, want, f64::INFINITY);
        assert!(overshoot <= 0.03, "range {k}: overshoot {overshoot} of {want} V");
        assert!(off <= 2e-3, "range {k}: {off} off {want} V 38 µs after the step");
        md += &format!(
            "| {:.0} kΩ | {:.1} % | {:.2} % |\n",
            r / 1e3,
            100.0 * overshoot,
            100.0 * off
        );
    }
    println!("{md}");
    figures::check_within("docs/hardware.md", "mux-step", &md, 0.02).unwrap();
}

/// The largest sensor the docs allow (0.35 MΩ electrodes, 290 pF, 20 pF
/// of cable across and to the shield) through the lowest range at each
/// tone of the set with its companion, both at their peaks together:
/// the stage's output keeps 0.1 V from either rail; and each tone reaches
/// the sensor within 5 % of the amplitude the firmware plays (the
/// reconstruction filter's droop: the firmware reads the voltage, so only
/// the headroom depends on it).
#[test]
fn the_largest_sensor_does_not_clip_the_lowest_range() {
    use skin_spec::config::{COMPANION, PERIODS, SLOT_PAIRS};
    let largest = Sensor {
        r_ohm: 350e3,
        c_farad: 290e-12,
        cable_farad: 20e-12,
        shield_farad: 20e-12,
    };
    let board = mux::select(&mux::board().with_sensors(largest).with_sections(8), 0, 0);
    let bias = skin_spec::design::BIAS_VOLT;
    let dt = 1.0 / skin_spec::design::SAMPLE_RATE as f64;
    let mut md = String::from("| tone, companion | stage's swing | tone at the sensor | companion at the sensor |\n|---|---:|---:|---:|\n");
    for i in 0..FREQS_HZ.len() {
        let block = skin_spec::config::BLOCK_PAIRS;
        let from = (SLOT_PAIRS - block) as f64 * dt;
        let rows = spice::tran(
            &board,
            &two_tones(i, 1),
            "",
            &["TIA", "TOP0"],
            dt,
            from,
            from + (block as f64 - 0.5) * dt,
        )
        .expect("ngspice's transient");
        let rows = &rows[..block];
        let swing = rows.iter().map(|r| (r[1] - bias).abs()).fold(0.0, f64::max);
        let top: Vec<f64> = rows.iter().map(|r| r[2] - bias).collect();
        let at = |j: usize| windowed(&top, PERIODS[j]).norm() / (0.355768 * block as f64 / 2.0);
        let (a1, a2) = (at(i), at(COMPANION[i]));
        md += &format!(
            "| {:.0} Hz, {:.0} Hz | ±{swing:.3} V | {a1:.3} V | {a2:.3} V |\n",
            FREQS_HZ[i], FREQS_HZ[COMPANION[i]]
        );
        assert!(
            swing <= bias - 0.1,
            "{} Hz: the stage swings ±{swing} V",
            FREQS_HZ[i]
        );
        assert!(
            (a1 / 0.6 - 1.0).abs() <= 0.05 && (a2 / 0.4 - 1.0).abs() <= 0.05,
            "{a1} V, {a2} V"
        );
    }
    println!("{md}");
    figures::check_within("docs/hardware.md", "mux-swing", &md, 0.02).unwrap();
}

/// An interferer at the sample rate less each tone of the set, against
/// the tone, both entering at the selected sensor's bottom tab, through
/// the range the paper's sensor is read at there: what the stage's pole
/// and the anti-alias filter reject (one conversion a sample: no
/// averaging helps).
#[test]
fn the_aliases_of_every_tone_are_tabulated() {
    use skin_spec::design::SAMPLE_RATE;
    let [(_, paper), ..] = range();
    let mut md = String::from("| tone | its alias | range | rejection |\n|---|---:|---:|---:|\n");
    for (i, f) in FREQS_HZ.iter().enumerate() {
        let k = range_for(&paper, i);
        let board = mux::select(&mux::board(), 0, k);
        let f = *f as f64;
        let alias = SAMPLE_RATE as f64 - f;
        let rows = spice::ac(&board, "DC 1.65", "IINJ 0 TABM AC 1", &["v(PA1)"], &[f, alias])
            .expect("ngspice's AC analysis");
        let db = 20.0 * (rows[0][0].norm() / rows[1][0].norm()).log10();
        assert!(db >= 6.0, "{f} Hz: its alias only {db} dB down");
        md += &format!(
            "| {f:.0} Hz | {alias:.0} Hz | {:.0} kΩ | {db:.1} dB |\n",
            TIA_RANGES_OHM[k] / 1e3
        );
    }
    println!("{md}");
    figures::check_within("docs/hardware.md", "mux-aliases", &md, 0.02).unwrap();
}
