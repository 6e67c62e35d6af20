//! ngspice on the array board's netlist, against the constants the
//! firmware assumes: a mismatch fails.

mod common;

use common::{amplitude, c_of, range};
use front_end::array;
use front_end::circuit::{Circuit, Sensor};
use front_end::spice;
use num_complex::Complex64;
use skin_spec::array::{Layout, SENSOR_TIA_OHM, TIA_PEAK_VOLT};

/// The firmware's k in Z = k·V/I (`ArrayFrontEnd::dsp_front_end`: one
/// real transimpedance, the stage inverting).
const K: f64 = -SENSOR_TIA_OHM;

/// The parts' tolerances at their worst for the ratio V/I: the
/// stage's pole (R_f·C_f) against the voltage path's (R4·C3) one way,
/// and the other way, R_f's own 0.1 % with it.
fn corners(board: &Circuit) -> [(&'static str, Circuit); 3] {
    let tol = |r: &str| board.element(r).and_then(|e| e.part).map_or(0.0, |p| p.tol);
    let skew = |sign: f64| {
        board
            .scaled("RF0", 1.0 + sign * tol("RF0"))
            .scaled("CF0", 1.0 + sign * tol("CF0"))
            .scaled("R4", 1.0 - sign * tol("R4"))
            .scaled("C3", 1.0 - sign * tol("C3"))
    };
    [
        ("nominal", board.clone()),
        ("stage slow", skew(1.0)),
        ("stage fast", skew(-1.0)),
    ]
}

/// Every tone of both layouts, Hz, each once.
fn tones() -> Vec<f64> {
    let mut f: Vec<f64> = Layout::ALL
        .iter()
        .flat_map(|l| l.tones_hz())
        .map(f64::from)
        .collect();
    f.sort_by(f64::total_cmp);
    f.dedup();
    f
}

/// Sensor 0's impedance as the firmware reads it, k·V/I from its two
/// ADC pins, and as it is between its tabs: (Hz, read, true).
fn reads(board: &Circuit) -> Vec<(f64, Complex64, Complex64)> {
    let freqs = tones();
    let vectors = ["v(PA0)", "v(PC0)", "v(EXC)", "v(TAB0)", "i(VJ1_i)"];
    let rows = spice::ac(board, spice::AC_STIMULUS, "", &vectors, &freqs).expect("ngspice's AC analysis");
    freqs
        .iter()
        .zip(rows)
        .map(|(&f, r)| (f, K * r[0] / r[1], (r[2] - r[3]) / r[4]))
        .collect()
}

/// The nominal board: at every tone of both layouts, for every sensor of
/// the range, the impedance the firmware reads from the ADC pins is the
/// sensor's within 0.15 % and 0.5 mrad (the op-amps' finite gain), and C
/// from it within 0.2 % of C from the sensor's own wherever the policy
/// may read (x = 2π·f·R·C ≤ 4, where the inversion amplifies a phase
/// error up to 1.5-fold). The netlist's sensors themselves, 30 midpoint
/// sections, are the continuous line within 10⁻³ up to x = 8.
#[test]
fn the_nominal_board_reads_every_sensor_as_the_firmware_assumes() {
    let board = array::board();
    let (mut worst_z, mut worst_phase, mut worst_c, mut worst_line) = (0f64, 0f64, 0f64, 0f64);
    let mut md =
        String::from("| sensor | worst \\|Z\\| | worst phase | worst C (x ≤ 4) |\n|---|---:|---:|---:|\n");
    for (name, sensor) in range() {
        let mut row = (0f64, 0f64, 0f64);
        for (f, read, truth) in reads(&board.with_sensors(sensor)) {
            let e = read / truth;
            let (mag, phase) = ((e.norm() - 1.0).abs(), e.arg().abs());
            let x = std::f64::consts::TAU * f * sensor.r_ohm * sensor.c_farad;
            if x <= 8.0 {
                // The netlist's line of sections against the continuous one.
                worst_line = worst_line.max((truth / sensor.impedance(f) - 1.0).norm());
            }
            let c = if x <= 4.0 {
                let (a, b) = (
                    c_of(read, f).expect("the read inverts"),
                    c_of(truth, f).expect("the truth inverts"),
                );
                (a / b - 1.0).abs()
            } else {
                0.0
            };
            println!("{name:>16} {f:>6} Hz x {x:>5.2}: |Z| {mag:.2e}, phase {phase:.2e} rad, C {c:.2e}");
            row = (row.0.max(mag), row.1.max(phase), row.2.max(c));
        }
        md += &format!(
            "| {name} | {:.3} % | {:.2} mrad | {:.3} % |\n",
            100.0 * row.0,
            1e3 * row.1,
            100.0 * row.2
        );
        (worst_z, worst_phase, worst_c) = (worst_z.max(row.0), worst_phase.max(row.1), worst_c.max(row.2));
    }
    println!("{md}");
    figures::check_within("docs/hardware.md", "array-transfer", &md, 0.02).unwrap();
    println!("the netlist's lines against the continuous line (x ≤ 8): {worst_line:.2e}");
    assert!(
        worst_line <= 1e-3,
        "the lines of sections are {worst_line:e} off the continuous line"
    );
    assert!(worst_z <= 1.5e-3, "|Z| off by {worst_z:e}");
    assert!(worst_phase <= 5e-4, "phase off by {worst_phase:e} rad");
    assert!(worst_c <= 2e-3, "C off by {worst_c:e}");
}

/// The parts' spread is a gain and a delay per path: at the tolerance
/// corners the ratio read/true is g·e^(jωΔt) within 10⁻⁴ at every tone,
/// with |g − 1| ≤ 0.1 % (R_f) and Δt within 10 % of the two poles'
/// spread to first order, τ·(Σ tolerances): 27 ns, two thirds of it C_f's
/// ±0.05 pF across 330 kΩ: what a path's calibration must measure
/// (docs/hardware.md).
#[test]
fn the_parts_spread_is_a_gain_and_a_delay_per_path() {
    let board = array::board();
    let nominal: Vec<Complex64> = reads(&board).iter().map(|(_, r, t)| r / t).collect();
    let part = |r: &str| board.element(r).and_then(|e| e.part).expect("a part");
    let tau = part("RF0").si * part("CF0").si;
    let spread = tau
        * ["RF0", "CF0", "R4", "C3"]
            .iter()
            .map(|r| part(r).tol)
            .sum::<f64>();
    let mut md = String::from(
        "| corner | gain − 1 | delay Δt | beyond gain and delay | C uncalibrated, 4 ms tones | 1 ms tones |\n|---|---:|---:|---:|---:|---:|\n",
    );
    for (corner, b) in corners(&board).into_iter().skip(1) {
        let rows = reads(&b);
        let each: Vec<_> = range()
            .iter()
            .skip(1)
            .map(|(_, sensor)| reads(&b.with_sensors(*sensor)))
            .collect();
        let every: Vec<&[_]> = std::iter::once(rows.as_slice())
            .chain(each.iter().map(Vec::as_slice))
            .collect();
        let c_off = |layout: Layout| uncalibrated_c(&layout, &every);
        // Against the nominal board's own ratio: what the spread adds.
        let ratio: Vec<(f64, Complex64)> = rows
            .iter()
            .zip(&nominal)
            .map(|((f, r, t), n)| (*f, r / t / n))
            .collect();
        let g = ratio[0].1.norm();
        // Δt from the highest tone's phase; then every tone against it.
        let (f_hi, e_hi) = ratio[ratio.len() - 1];
        let dt = e_hi.arg() / (std::f64::consts::TAU * f_hi);
        let mut worst = 0f64;
        for (f, e) in &ratio {
            let model = Complex64::from_polar(g, std::f64::consts::TAU * f * dt);
            worst = worst.max((e / model - 1.0).norm());
        }
        println!(
            "{corner}: g − 1 = {:.2e}, Δt = {:.1} ns, worst {worst:.1e}",
            g - 1.0,
            dt * 1e9
        );
        assert!((g - 1.0).abs() <= 1.05e-3, "{corner}: gain {g}");
        assert!(
            (dt.abs() / spread - 1.0).abs() <= 0.1,
            "{corner}: delay {dt:e} s, not {spread:e}"
        );
        assert!(worst <= 1e-4, "{corner}: {worst:e} beyond a gain and a delay");
        md += &format!(
            "| {corner} | {:+.3} % | {:+.1} ns | {worst:.0e} | {:.2} % | {:.2} % |\n",
            100.0 * (g - 1.0),
            dt * 1e9,
            100.0 * c_off(Layout::BLOCK_4MS),
            100.0 * c_off(Layout::BLOCK_1MS)
        );
    }
    println!("{md}");
    figures::check_within("docs/hardware.md", "array-spread", &md, 0.02).unwrap();
}

/// The worst error of C from one tone of `layout`, over the sensors of
/// the range (`reads`: each one's, in the order of [`range`]) where the
/// policy may read it (x ≤ 4): what the spread leaves a board that no
/// calibration corrects.
fn uncalibrated_c(layout: &Layout, reads: &[&[(f64, Complex64, Complex64)]]) -> f64 {
    let mut worst = 0f64;
    for ((_, sensor), rows) in range().iter().zip(reads) {
        for &(f, read, truth) in rows.iter() {
            let x = std::f64::consts::TAU * f * sensor.r_ohm * sensor.c_farad;
            if x <= 4.0 && layout.tones_hz().contains(&(f as f32)) {
                let (a, t) = (
                    c_of(read, f).expect("the read inverts"),
                    c_of(truth, f).expect("the truth inverts"),
                );
                worst = worst.max((a / t - 1.0).abs());
            }
        }
    }
    worst
}

/// The analog path's noise in a result, against the converter's own that
/// the accuracy figures assume ([`skin_spec::array::NOISE_COUNTS`]): at
/// most 10 % more in quadrature, at every stage input and at the voltage
/// input, for every sensor of the range (their electrodes' own thermal
/// noise included).
#[test]
fn the_analog_noise_is_within_what_the_accuracy_figures_assume() {
    let assumed = skin_spec::array::NOISE_COUNTS as f64;
    let allowed = assumed * (1.1f64.powi(2) - 1.0).sqrt();
    let mut worst = 0f64;
    let mut md = String::from("| sensor | a stage's input | the voltage input | with the converter's, in quadrature |\n|---|---:|---:|---:|\n");
    for (name, sensor) in range() {
        let board = array::board().with_sensors(sensor);
        let n = [array::SENSOR_PINS[0], array::VOLTAGE_PIN].map(|node| {
            use skin_spec::array::{ADC_CLOCK_HZ, CONVERSION_CYCLES, OVERSAMPLING};
            let ts = CONVERSION_CYCLES as f64 / ADC_CLOCK_HZ as f64;
            common::result_noise(
                &board,
                node,
                OVERSAMPLING as usize,
                ts,
                skin_spec::design::VREF_VOLT / 4096.0,
            )
        });
        md += &format!(
            "| {name} | {:.2} | {:.2} | {:.2} ({:+.1} %) |\n",
            n[0],
            n[1],
            n[0].hypot(assumed),
            100.0 * (n[0].hypot(assumed) / assumed - 1.0)
        );
        worst = worst.max(n[0]).max(n[1]);
    }
    println!("{md}");
    figures::check_within("docs/hardware.md", "array-noise", &md, 0.02).unwrap();
    assert!(worst <= allowed, "{worst} counts, more than {allowed}");
}

/// The DAC's output as a SPICE source: `layout`'s table
/// ([`Layout::dac_table`]), each code held 1 µs, repeating.
fn dac_pwl(layout: &Layout) -> String {
    use skin_spec::array::{DAC_RATE_HZ, DAC_TABLE};
    let mut table = [0u16; DAC_TABLE];
    let codes = layout.dac_table(&mut table);
    let dt = 1.0 / DAC_RATE_HZ as f64;
    let volts = |c: u16| c as f64 * skin_spec::design::VREF_VOLT / 4096.0;
    let mut s = format!("PWL(0 {:.6}", volts(codes[0]));
    for (n, &c) in codes.iter().enumerate() {
        let t = n as f64 * dt;
        // Each step takes 100 ns (the DAC's buffer slews), so that the
        // solver need not resolve 8,000 sharp edges.
        if n > 0 {
            s += &format!(" {:e} {:.6}", t + 1e-7, volts(c));
        }
        s += &format!(" {:e} {:.6}", t + dt, volts(c));
    }
    s + ") r=0"
}

/// The excitation and sensor 0's stage output over the second block of
/// `layout`'s comb (the first lets the sensors' lines settle), each 1 µs:
/// rows of [t, EXC, TIA0].
fn comb_run(board: &Circuit, layout: &Layout) -> Vec<Vec<f64>> {
    let block = layout.block_us() as f64 * 1e-6;
    spice::tran(
        board,
        &dac_pwl(layout),
        "",
        &["EXC", "TIA0"],
        1e-6,
        block,
        2.0 * block,
    )
    .expect("ngspice's transient")
}

/// The DAC's table through the reconstruction filter and the buffer, all
/// sixteen connectors carrying the largest sensor the docs allow (0.35 MΩ
/// electrodes, 290 pF, 20 pF of cable across and 20 pF to the shield):
/// every tone reaches the sensors at the amplitude the firmware assumes
/// ([`Layout::tone_volts`], the chain's gain 1) within 0.3 %; the buffer
/// swings within the ±1.45 V the comb was sized for; and each stage's
/// output within the headroom the comb was sized for,
/// [`TIA_PEAK_VOLT`] of the bias, which keeps it 0.2 V from either rail
/// (the op-amp's swing and the ADC's span, 0–3.3 V).
#[test]
fn the_comb_reaches_the_sensors_and_no_stage_clips() {
    let largest = Sensor {
        r_ohm: 350e3,
        c_farad: 290e-12,
        cable_farad: 20e-12,
        shield_farad: 20e-12,
    };
    // Eight sections a line: the current's shape within 10⁻³ (x ≤ 2).
    let board = array::board().with_sensors(largest).with_sections(8);
    let bias = skin_spec::design::BIAS_VOLT;
    let mut md = String::from(
        "| block | worst tone at the sensors | buffer's swing | stage 0's swing |\n|---|---:|---:|---:|\n",
    );
    for layout in Layout::ALL {
        let mut off = 0f64;
        let rows = comb_run(&board, &layout);
        let n = layout.instants() * skin_spec::array::DAC_PER_INSTANT;
        let rows = &rows[rows.len() - n..];
        let exc: Vec<f64> = rows.iter().map(|r| r[1] - bias).collect();
        for (f, want) in layout.tones_hz().iter().zip(layout.tone_volts()) {
            let got = amplitude(&exc, 1e-6, *f as f64);
            println!(
                "{} ms, {f} Hz: {got:.4} V at the sensors, {want} V assumed",
                layout.block_us() / 1000
            );
            assert!((got / want - 1.0).abs() <= 3e-3, "{f} Hz: {got} V, not {want} V");
            off = off.max((got / want - 1.0).abs());
        }
        let peak = |k: usize| rows.iter().map(|r| (r[k] - bias).abs()).fold(0.0, f64::max);
        let (swing, out) = (peak(1), peak(2));
        println!("buffer ±{swing:.3} V, stage 0 ±{out:.3} V around {bias} V");
        assert!(swing <= 1.45, "the buffer swings ±{swing} V");
        assert!(out <= TIA_PEAK_VOLT, "stage 0 swings ±{out} V");
        md += &format!(
            "| {} ms | {:.2} % off | ±{swing:.3} V | ±{out:.3} V |\n",
            layout.block_us() / 1000,
            100.0 * off
        );
    }
    println!("{md}");
    figures::check_within("docs/hardware.md", "array-swing", &md, 0.02).unwrap();
}

/// A current step into sensor 0's stage, with every sensor of the range
/// and 20 pF of cable both across and to the shield: the stage settles
/// without ringing (overshoot under 3 %: a phase margin over 60°) to R_f
/// times the step within 0.2 % by 10 µs, long before the next
/// instant's first conversion could see it.
#[test]
fn every_stage_is_stable_with_the_longest_cable() {
    let mut md = String::from(
        "| sensor, with 20 pF across and to the shield | overshoot | off after 10 µs |\n|---|---:|---:|\n",
    );
    for (name, sensor) in range() {
        let sensor = Sensor {
            cable_farad: 20e-12,
            shield_farad: 20e-12,
            ..sensor
        };
        let board = array::board().with_sensors(sensor);
        let out = common::step(&board, "TAB0", "TIA0", 14e-6);
        let want = SENSOR_TIA_OHM * 1e-6;
        let (overshoot, off) = common::settling(&out, want, 12e-6);
        assert!(overshoot <= 0.03, "{name}: overshoot {overshoot} of {want} V");
        assert!(off <= 2e-3, "{name}: {off} off {want} V 10 µs after the step");
        md += &format!("| {name} | {:.1} % | {:.2} % |\n", 100.0 * overshoot, 100.0 * off);
    }
    println!("{md}");
    figures::check_within("docs/hardware.md", "array-step", &md, 0.02).unwrap();
}

/// What the analog path and the mean of a result's 16 conversions do to
/// an interferer at an alias of each tone (the sample rate less the
/// tone, as the disturbance table's alias row puts one), against the
/// tone itself, both entering at a sensor's tab: the array has no
/// anti-alias filter of its own (one that passed 6 kHz flat to 10⁻³ in
/// phase across two paths' parts would reject little at 19 kHz), so this
/// is the rejection docs/disturbances.md's alias rows are worth at the
/// sensor.
#[test]
fn the_aliases_of_every_tone_are_tabulated() {
    use skin_spec::array::{ADC_CLOCK_HZ, CONVERSION_CYCLES, OVERSAMPLING, RATE_HZ};
    let ts = CONVERSION_CYCLES as f64 / ADC_CLOCK_HZ as f64;
    let mean = |f: f64| {
        let x = std::f64::consts::PI * f * ts;
        let m = OVERSAMPLING as f64;
        ((m * x).sin() / (m * x.sin())).abs()
    };
    let tones = tones();
    let aliases: Vec<f64> = tones.iter().map(|f| RATE_HZ as f64 - f).collect();
    let all: Vec<f64> = tones.iter().chain(&aliases).copied().collect();
    let rows = spice::ac(&array::board(), "DC 1.65", "IINJ 0 TAB0 AC 1", &["v(PC0)"], &all)
        .expect("ngspice's AC analysis");
    let mut md = String::from("| tone | its alias | rejection |\n|---|---:|---:|\n");
    for (k, f) in tones.iter().enumerate() {
        let (at_tone, at_alias) = (
            rows[k][0].norm() * mean(*f),
            rows[tones.len() + k][0].norm() * mean(aliases[k]),
        );
        let db = 20.0 * (at_tone / at_alias).log10();
        assert!(db >= 0.0, "{f} Hz: its alias passes {db} dB more");
        md += &format!("| {f} Hz | {} Hz | {db:.1} dB |\n", aliases[k]);
    }
    println!("{md}");
    figures::check_within("docs/hardware.md", "array-aliases", &md, 0.02).unwrap();
}
