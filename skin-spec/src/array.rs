//! The simultaneous front end: every sensor of the skin at once.
//!
//! ```text
//! DAC1 (1 MSa/s, the comb) ─ 2-pole filter ─ buffer ─┬─► top tab ┄ sensor 0 ┄ bottom tab ─► TIA 0 (R_f) ─► ADC input 1
//!                                                   ├─► top tab ┄ sensor 1 ┄ bottom tab ─► TIA 1 (R_f) ─► ADC input 2
//!                                                   ├─ …                                   (16 sensors)
//!                                                   └──────────────────────────────────────────────────► ADC input 0 (voltage)
//! ```
//!
//! One excitation drives every sensor: a comb of [`TONES`] tones, each
//! making whole periods per block, played by the DAC from a table at
//! [`DAC_RATE_HZ`] (40 samples per ADC instant, so its images lie above
//! 950 kHz, far beyond the reconstruction filter). A [`Layout`] says how
//! long a block is and which comb it carries: [`Layout::BLOCK_4MS`]
//! (250 records/s, tones of 250 Hz … 4 kHz) or [`Layout::BLOCK_1MS`]
//! (1000 records/s, 1 … 6 kHz, for a control loop that wants a record
//! every millisecond, at twice the noise).
//! Each sensor's bottom tab is held at the bias by its own inverting
//! transimpedance stage of [`SENSOR_TIA_OHM`]. The five ADCs, started together by
//! one timer at [`RATE_HZ`], each scan [`SCAN`] inputs with 16× hardware
//! oversampling (16-bit results: the sum of sixteen 12-bit conversions);
//! input `4a + j` is position `j` of ADC `a`. Input 0 reads the excitation,
//! inputs 1–16 the sensors, 17–19 are spare. Every sensor is read once a
//! block, at both tones its channel chose, from one excitation, with no
//! multiplexer to settle.
//!
//! **Scan skew.** Position j of a scan is converted j·[`SCAN_STEP_S`]
//! after position 0, so a sensor whose input sits at another position
//! than the voltage's is sampled later: its current phasor at tone f
//! carries a phase of 2π·f·Δt that the sensor does not have. The channel
//! takes it out ([`Layout::skew_rotation`]); at 6 kHz and 28.2 µs it is 1.06 rad.
//! Sixteen oversampled conversions average over the scan step alike on
//! every input, so the ratio V/I keeps no trace of it.
//!
//! **Why 25 kHz.** What sets the noise of a tone is the number of
//! conversions, not of results: 16× oversampling at 25 kHz has the
//! noise of 8× at 50 kHz, and half the results to demodulate (the
//! comb's cost is per result and tone). 6 kHz, the highest tone, is
//! well under the 12.5 kHz Nyquist frequency; each TIA's feedback
//! capacitor and the ADC's 16-conversion average filter above it.

use core::f32::consts::TAU;
use dsp_core::Complex32;

/// Sensors of the skin read at once.
pub const SENSORS: usize = 16;
/// ADCs scanning together.
pub const ADCS: usize = 5;
/// Inputs each ADC scans per instant.
pub const SCAN: usize = 4;
/// Instants per second (the timer's rate), Hz.
pub const RATE_HZ: u32 = 25_000;
/// Instants of the longest block, 4 ms ([`Layout::BLOCK_4MS`]): what a
/// [`Frame`] and the DAC's table hold.
pub const BLOCK_INSTANTS: usize = 100;
/// Instants of the short block, 1 ms ([`Layout::BLOCK_1MS`]).
pub const SHORT_INSTANTS: usize = 25;
/// Tones of the comb.
pub const TONES: usize = 5;
/// The ADCs' clock, Hz: the 170 MHz AHB clock over 4 (synchronous, so
/// all five start on the same edge of the timer's trigger).
pub const ADC_CLOCK_HZ: u32 = crate::design::SYSCLK_HZ / 4;
/// ADC clock cycles per conversion: 12.5 of sampling and 12.5 of
/// successive approximation (12 bits).
pub const CONVERSION_CYCLES: f32 = 25.0;
/// Time between two positions of a scan, s: the sixteen conversions of
/// one position, 9.41 µs (the four take 37.6 µs of the 40 µs instant).
pub const SCAN_STEP_S: f32 = OVERSAMPLING as f32 * CONVERSION_CYCLES / ADC_CLOCK_HZ as f32;
/// The DAC's sample rate, Hz.
pub const DAC_RATE_HZ: u32 = 1_000_000;
/// DAC samples per ADC instant.
pub const DAC_PER_INSTANT: usize = (DAC_RATE_HZ / RATE_HZ) as usize;
/// Samples of the DAC's table: the longest block (a shorter one plays
/// its first [`Layout::dac_samples`]).
pub const DAC_TABLE: usize = BLOCK_INSTANTS * DAC_PER_INSTANT;
/// Input of the excitation voltage.
pub const VOLTAGE_INPUT: usize = 0;
/// Feedback resistance of every sensor's transimpedance stage, Ω: the
/// largest E6 value that kept the lowest-impedance sensor of the design
/// range (0.46 MΩ electrodes, 290 pF) inside the ADC under the design's
/// five 0.3 V tones of 500 Hz … 6 kHz. The 4 ms comb, held by the
/// buffer's swing, uses half of [`TIA_PEAK_VOLT`] at the documented
/// range's (0.35 MΩ electrodes, 290 pF, 20 pF of cable): 0.81 V; the
/// 1 ms comb fills it.
pub const SENSOR_TIA_OHM: f64 = 330e3;
/// The most a transimpedance stage's output may swing from the bias
/// under the whole comb, V: the ADC's ±1.65 V less 0.2 V for the bias's
/// and the stage's offsets (`the_comb_keeps_the_adc_headroom`).
pub const TIA_PEAK_VOLT: f64 = 1.45;
/// ADC result bits (12-bit conversions, 16× oversampled and summed).
pub const RESULT_BITS: u32 = 16;
/// Conversions summed per result.
pub const OVERSAMPLING: u32 = 16;
/// The largest result: sixteen full-scale 12-bit conversions, less the
/// bias at [`HALF_SCALE`].
pub const MAX_CODE: i32 = OVERSAMPLING as i32 * 4095 - HALF_SCALE;
/// How close to a rail a result counts as clipped, counts: within 8 LSB
/// of one conversion on average. A result is the mean of 9.4 µs, so a
/// peak past a rail pulls its neighbours near it too.
pub const RAIL_MARGIN: i32 = 8 * OVERSAMPLING as i32;
/// Half of the ADC's span, counts (the bias at mid-scale).
pub const HALF_SCALE: i32 = 1 << (RESULT_BITS - 1);
/// Noise of one oversampled result, counts rms: sixteen conversions
/// each with the 12-bit converter's 0.7 LSB of input noise and 0.29 LSB
/// of rounding, summed: √16·0.76 ≈ 3.05.
pub const NOISE_COUNTS: f32 = 3.05;

/// The ADC input of sensor `s`.
pub const fn input_of(sensor: usize) -> usize {
    sensor + 1
}

/// (ADC, scan position) of input `input`.
pub const fn adc_position(input: usize) -> (usize, usize) {
    (input / SCAN, input % SCAN)
}

/// The input of the power-up self-test's reference network (a spare of
/// the scan: ADC 4, position 1): [`REFERENCE_OHM`] in series with
/// [`REFERENCE_FARAD`] from the excitation to a stage of its own, laid
/// out as the sensors' are (`front-end/`'s board, `instrument::selftest`).
pub const REFERENCE_INPUT: usize = SENSORS + 1;
/// The reference network's resistor, Ω (thin film).
pub const REFERENCE_OHM: f64 = 680e3;
/// Its tolerance, relative (0.1 %).
pub const REFERENCE_OHM_TOLERANCE: f64 = 0.001;
/// The reference network's capacitor, F (C0G).
pub const REFERENCE_FARAD: f64 = 220e-12;
/// Its tolerance, relative (1 %).
pub const REFERENCE_FARAD_TOLERANCE: f64 = 0.01;

/// How much later than the voltage sensor `s`'s current is sampled, s.
pub fn skew_s(sensor: usize) -> f32 {
    skew_of_input(input_of(sensor))
}

/// How much later than the voltage input `input` is sampled, s.
pub fn skew_of_input(input: usize) -> f32 {
    let (_, j) = adc_position(input);
    let (_, jv) = adc_position(VOLTAGE_INPUT);
    (j as f32 - jv as f32) * SCAN_STEP_S
}

/// How a block is laid out: how many instants it has, and the comb it
/// carries (each tone's whole periods per block, amplitude and phase).
/// Two layouts exist, [`Layout::BLOCK_4MS`] and [`Layout::BLOCK_1MS`]:
/// the firmware, the reader (`instrument::reader::ArrayReader`) and the
/// channels' settings (`instrument::tones::ToneSettings`) must use the same.
///
/// **Why the comb falls with f.** A high-resistance sensor reads at the
/// lowest tones (the policy keeps x = 2π·f·R·C bounded), where its
/// current, ∝ V·f at the pair's switch point, is smallest: a flat comb
/// starves exactly the sensors whose inversion already amplifies noise
/// most. A 1/f comb gives every pair the same current at its switch
/// point, and starves the highest tones, which only the low-resistance
/// sensors read, and they read them well. The 4 ms comb falls as
/// f^−0.75 and the 1 ms one as 1/f, the shapes that kept the most
/// records across the documented sensors (docs/accuracy.md); each is
/// scaled to what holds it: the 4 ms comb the buffer's swing, the 1 ms
/// comb [`TIA_PEAK_VOLT`] at the output of the documented range's
/// lowest-impedance sensor (0.35 MΩ, 290 pF, 20 pF of cable), with
/// every tone in its phase (`the_comb_keeps_the_adc_headroom`).
///
/// **Phases.** Each comb's phases are the lowest peak a random search
/// (40 000 sets) and a local refinement found for its amplitudes;
/// `the_comb_fits_the_dac_and_its_crest_factor_is_low` checks that a
/// fresh search does no better.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Layout {
    instants: usize,
    comb: [u32; TONES],
    tone_volts: [f64; TONES],
    phases: [f32; TONES],
    tones_hz: [f32; TONES],
    leak_ratio: f32,
}

/// [`Layout::near_leak`], 4 ms blocks, before the floor of 1: row k the
/// tone the sinusoid is near, column j the tone it leaks into (the f64
/// worst, 3 % added and rounded up).
pub const NEAR_LEAK: [[f32; TONES]; TONES] = [
    [0.0, 3.66, 0.511, 0.231, 0.12],
    [5.11, 0.0, 0.467, 0.21, 0.106],
    [0.363, 0.461, 0.0, 0.198, 0.083],
    [0.154, 0.161, 0.201, 0.0, 0.099],
    [0.076, 0.077, 0.081, 0.099, 0.0],
];

/// max(1, c) without a library call.
const fn fmath_max1(c: f32) -> f32 {
    if c > 1.0 {
        c
    } else {
        1.0
    }
}

/// [`Layout::sideband_leak`]'s c, 4 ms blocks: row k the sideband's
/// tone, column j the tone it leaks into (the least c for which the
/// f64 envelope stays below c·δ·(1 + 2δ), 3 % added and rounded up).
pub const SIDEBAND_LEAK: [[f32; TONES]; TONES] = [
    [0.0, 0.251, 0.0036, 0.00763, 0.00491],
    [0.943, 0.0, 0.044, 0.0399, 0.0218],
    [0.0525, 0.0896, 0.0, 0.0255, 0.0104],
    [0.0183, 0.0196, 0.027, 0.0, 0.01029],
    [0.00816, 0.00828, 0.00879, 0.0117, 0.0],
];

impl Layout {
    /// Blocks of 4 ms (100 instants), 250 records/s: tones of 250, 500,
    /// 1000, 2000 and 4000 Hz (1, 2, 4, 8 and 16 periods), of 0.974 …
    /// 0.122 V. The 250 Hz tone, one period of the block, gives a
    /// high-resistance sensor a lowest three (250 Hz – 1 kHz) inside the
    /// line's sensitive range: with 500 Hz the lowest, electrodes twice
    /// the paper's read at x ≈ 6 on the three's top tone and lost 9 % of
    /// their records held (docs/accuracy.md). Its price: the comb no
    /// longer repeats within the block, so the fold pairs only mirrors
    /// (twice the products of a repeating comb), and the amplitudes are
    /// set by the buffer's swing, not by the sensors' current: the comb
    /// peaks at 1.320 V of ±1.45 V, a crest factor of 1.55 (in phase it
    /// would peak at 2.225 V).
    pub const BLOCK_4MS: Self = Self::new(
        BLOCK_INSTANTS,
        [1, 2, 4, 8, 16],
        [0.974, 0.579, 0.345, 0.205, 0.122],
        [0.0, 1.3984, 4.818, 5.0418, 1.5542],
        10.4,
    );
    /// Blocks of 1 ms (25 instants), 1000 records/s: tones of 1, 2, 3, 4
    /// and 6 kHz (whole periods of 1 ms), of 0.694 … 0.116 V, falling as
    /// 1/f and held by the stages' headroom, not the buffer's. A quarter
    /// of the conversions per record: twice the noise. The comb peaks at
    /// 0.787 V, a crest factor of 1.33 (in phase: 1.563 V).
    pub const BLOCK_1MS: Self = Self::new(
        SHORT_INSTANTS,
        [1, 2, 3, 4, 6],
        [0.694, 0.347, 0.231, 0.173, 0.116],
        [0.0, 0.4511, 3.8901, 2.9526, 0.3238],
        20.0,
    );
    /// Both layouts, the longer block first.
    pub const ALL: [Self; 2] = [Self::BLOCK_4MS, Self::BLOCK_1MS];

    const fn new(
        instants: usize,
        comb: [u32; TONES],
        tone_volts: [f64; TONES],
        phases: [f32; TONES],
        leak_ratio: f32,
    ) -> Self {
        let mut tones_hz = [0f32; TONES];
        let mut k = 0;
        while k < TONES {
            tones_hz[k] = comb[k] as f32 * (RATE_HZ as f32 / instants as f32);
            k += 1;
        }
        Self {
            instants,
            comb,
            tone_volts,
            phases,
            tones_hz,
            leak_ratio,
        }
    }

    /// The layout whose blocks give `records_per_s` (250 or 1000).
    pub fn of_records_per_s(records_per_s: u32) -> Option<Self> {
        Self::ALL.into_iter().find(|l| l.records_per_s() == records_per_s)
    }

    /// Instants per block.
    pub const fn instants(&self) -> usize {
        self.instants
    }

    /// Records per second per sensor (blocks per second).
    pub const fn records_per_s(&self) -> u32 {
        RATE_HZ / self.instants as u32
    }

    /// The block period, µs.
    pub const fn block_us(&self) -> u64 {
        self.instants as u64 * 1_000_000 / RATE_HZ as u64
    }

    /// Whole periods per block of each tone, ascending.
    pub const fn comb(&self) -> [u32; TONES] {
        self.comb
    }

    /// Each tone's amplitude at the sensors, V (peak), lowest tone first.
    pub const fn tone_volts(&self) -> [f64; TONES] {
        self.tone_volts
    }

    /// Each tone's phase at the block's first instant, rad.
    pub const fn phases(&self) -> [f32; TONES] {
        self.phases
    }

    /// Frequency of comb tone `k`, Hz (the highest for an index beyond).
    pub fn tone_hz(&self, k: usize) -> f32 {
        self.tones_hz[k.min(TONES - 1)]
    }

    /// The comb's frequencies, Hz, ascending.
    pub const fn tones_hz(&self) -> [f32; TONES] {
        self.tones_hz
    }

    /// The most a sinusoid half a bin or more from every frequency a block
    /// fits (its mean and the comb's tones) puts into one tone, in units
    /// of what it leaves in the residual, √2·rms: the bound on a tone's
    /// disturbance that the residual alone gives. The comb's tones are
    /// orthogonal over the block, so a tone takes the sinusoid's
    /// projection and the residual keeps the rest; the worst lies half a
    /// bin above the mean (62.5 Hz in 4 ms blocks, 500 Hz in 1 ms), whose
    /// leak into the lowest tone the residual sees a tenth (a twentieth)
    /// of. `the_leak_ratio_bounds_every_sinusoid_between_the_bins`
    /// recomputes it in f64.
    pub const fn leak_ratio(&self) -> f32 {
        self.leak_ratio
    }

    /// The most a sinusoid within half a bin of tone `k` leaks into tone
    /// `j`, in units of what it leaves in the residual, √2·rms, and 1 at
    /// least (the residual's own bound, [`Layout::leak_ratio`]'s unit):
    /// where a record was rescued without tone k, or its channel moved
    /// off it, that is where an interferer sits. Of the 4 ms comb's
    /// tones only the adjacent 250 and 500 Hz leak more (up to 5.0 times
    /// into 250 Hz from 0.4 of a bin below 500: its leak into 250 Hz is
    /// large and its residual small); 1 for 1 ms blocks (they neither
    /// rescue nor move) and for k = j.
    /// `the_near_leak_bounds_every_sinusoid_in_the_bin` recomputes it in
    /// f64. (Out of line and cold: the record's path calls it only for a
    /// rescued record.)
    #[cold]
    #[inline(never)]
    pub fn near_leak(&self, k: usize, j: usize) -> f32 {
        match NEAR_LEAK.get(k).and_then(|r| r.get(j)) {
            Some(&c) if self.instants == BLOCK_INSTANTS => fmath_max1(c),
            _ => 1.0,
        }
    }

    /// What a sinusoid within `delta` of a bin (|δ| ≤ ½) of tone `k` still
    /// leaks into tone `j` once tone k's sideband is fitted beside the
    /// comb ([`dsp_core::sideband`]), in units of the sideband fitted,
    /// |p| (counts per unit of its basis): the leak left is of order δ²
    /// and the sideband of order δ, so the ratio grows with |δ|, bounded
    /// by c·δ·(1 + 2δ) with c of [`SIDEBAND_LEAK`] (the 250 Hz tone beside
    /// the 500 Hz sideband leaks 0.94 of |p| at half a bin, the others
    /// under 0.09). Unbounded (∞) for tone k itself, for 1 ms blocks
    /// (their channels never move off a tone) and beyond half a bin.
    /// `the_sideband_leak_bounds_every_sinusoid_in_the_bin` recomputes it
    /// in f64.
    pub fn sideband_leak(&self, k: usize, j: usize, delta: f32) -> f32 {
        let d = delta.abs();
        let c = match SIDEBAND_LEAK.get(k).and_then(|r| r.get(j)) {
            Some(&c) if self.instants == BLOCK_INSTANTS && j != k && d <= 0.5 => c,
            _ => return f32::INFINITY,
        };
        c * d * (1.0 + 2.0 * d)
    }

    /// Degrees of freedom of a block's residual: N instants less the mean
    /// and two per tone.
    pub const fn residual_dof(&self) -> u32 {
        (self.instants - 2 * TONES - 1) as u32
    }

    /// A block's rows of one ADC: the first [`Layout::instants`] of
    /// `rows`.
    pub fn rows<'a>(&self, rows: &'a Rows) -> &'a [[i16; SCAN]] {
        &rows[..self.instants.min(BLOCK_INSTANTS)]
    }

    /// Samples of the DAC's table the block plays.
    pub const fn dac_samples(&self) -> usize {
        self.instants * DAC_PER_INSTANT
    }

    /// The factor that takes sensor `s`'s scan skew out of its V/I at each
    /// tone: e^(+j·2π·f·Δt) (the current's phasor carries e^(+j·2π·f·Δt)
    /// too many, so V/I carries its inverse).
    pub fn skew_rotation(&self, sensor: usize) -> [Complex32; TONES] {
        self.input_rotation(input_of(sensor))
    }

    /// [`Layout::skew_rotation`] of ADC input `input` (the self-test's
    /// reference, [`REFERENCE_INPUT`], as a sensor's).
    pub fn input_rotation(&self, input: usize) -> [Complex32; TONES] {
        let dt = skew_of_input(input);
        core::array::from_fn(|k| {
            let (s, c) = libm::sincosf(TAU * self.tone_hz(k) * dt);
            Complex32::new(c, s)
        })
    }

    /// The comb's peak over one block, V, on a grid of `points` instants
    /// (the DAC's table: [`Layout::dac_samples`]).
    pub fn comb_peak(&self, points: usize) -> f32 {
        self.peak_of(&self.phases, points)
    }

    fn peak_of(&self, phases: &[f32; TONES], points: usize) -> f32 {
        let mut peak = 0f32;
        for n in 0..points {
            let t = n as f32 / points as f32;
            let v: f32 = (0..TONES)
                .map(|k| self.tone_volts[k] as f32 * libm::cosf(TAU * self.comb[k] as f32 * t + phases[k]))
                .sum();
            peak = peak.max(libm::fabsf(v));
        }
        peak
    }

    /// Each tone's amplitude in DAC codes: [`Layout::tone_volts`] of the
    /// 3.3 V reference's 4096 codes (1030.2 at 250 Hz … 256.9 at 4 kHz
    /// for the 4 ms comb; the reconstruction filter and buffer after the
    /// DAC have a gain of 1).
    pub fn tone_codes(&self) -> [f32; TONES] {
        let full = (1u32 << crate::design::DAC_BITS) as f64;
        self.tone_volts
            .map(|v| (v / crate::design::VREF_VOLT * full) as f32)
    }

    /// The DAC's table: one block of the comb at [`DAC_RATE_HZ`] in the
    /// first [`Layout::dac_samples`] of `table` (returned), sample n the
    /// code of [`DAC_MID`] + Σₖ cₖ·cos(2π·pₖ·n/L + φₖ), rounded, with cₖ
    /// the [`Layout::tone_codes`] and L the samples. Phases from
    /// dsp-core's integer `cossin`, so the table is the same on the host
    /// and the target.
    pub fn dac_table<'a>(&self, table: &'a mut [u16; DAC_TABLE]) -> &'a [u16] {
        let turn = 4_294_967_296.0f64;
        let offset: [u32; TONES] = core::array::from_fn(|k| {
            let t = self.phases[k] as f64 / core::f64::consts::TAU;
            ((t - libm::floor(t)) * turn) as u64 as u32
        });
        let codes = self.tone_codes();
        let q = 1.0 / 2_147_483_648.0f32;
        let samples = self.dac_samples().min(DAC_TABLE);
        let n_table = samples as u64;
        let table = &mut table[..samples];
        for (n, code) in table.iter_mut().enumerate() {
            let mut x = 0f32;
            for (k, &p) in self.comb.iter().enumerate() {
                let m = (p as u64 * n as u64) % n_table;
                let base = (((m << 32) + n_table / 2) / n_table) as u32;
                let (c, _) = dsp_core::cossin::cossin(base.wrapping_add(offset[k]) as i32);
                x += codes[k] * c as f32 * q;
            }
            let v = DAC_MID as f32 + x + 0.5;
            *code = (v as u16).min((1 << crate::design::DAC_BITS) - 1);
        }
        table
    }
}

/// Inputs of the five ADCs (sensors, the excitation and the spares).
pub const INPUTS: usize = ADCS * SCAN;

/// One ADC's rows of a block: per instant, its scan.
pub type Rows = [[i16; SCAN]; BLOCK_INSTANTS];

/// One block as the ADCs' DMA leaves it: per ADC, per instant, its scan.
pub type Frame = [Rows; ADCS];

/// The rows of input `input`'s ADC and its position in each row.
pub fn rows_of(frame: &Frame, input: usize) -> (&Rows, usize) {
    let (a, j) = adc_position(input);
    (&frame[a.min(ADCS - 1)], j)
}

/// Does a result sit on a rail (within [`RAIL_MARGIN`])?
pub const fn on_rail(code: i16) -> bool {
    let c = code as i32;
    c <= -HALF_SCALE + RAIL_MARGIN || c >= MAX_CODE - RAIL_MARGIN
}

/// One ADC's rows of a block as its DMA leaves them, offset binary (0 …
/// 65 520, the bias at 32 768), made two's complement around the bias in
/// place; returns which of its inputs had a result on a rail
/// ([`on_rail`]; none for no rows). One pass
/// ([`dsp_core::scan::to_signed`]: each input's extremes as it goes).
pub fn to_signed(rows: &mut [[i16; SCAN]]) -> [bool; SCAN] {
    if rows.is_empty() {
        return [false; SCAN];
    }
    dsp_core::scan::to_signed(rows).map(|[lo, hi]| on_rail(lo) || on_rail(hi))
}

/// A block's ADCs' rows ([`Layout::rows`] of each) to two's complement in
/// place ([`to_signed`]); returns which inputs had a result on a rail,
/// by input number.
pub fn to_signed_all(rows: &mut [&mut [[i16; SCAN]]; ADCS]) -> [bool; INPUTS] {
    let mut rails = [false; INPUTS];
    for (r, adc) in rails.chunks_exact_mut(SCAN).zip(rows.iter_mut()) {
        r.copy_from_slice(&to_signed(adc));
    }
    rails
}

/// The DAC's mid-scale code: the bias.
pub const DAC_MID: u16 = 1 << (crate::design::DAC_BITS - 1);

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    #[test]
    fn the_layout_adds_up() {
        let (long, short) = (Layout::BLOCK_4MS, Layout::BLOCK_1MS);
        assert_eq!((long.records_per_s(), short.records_per_s()), (250, 1000));
        assert_eq!((long.block_us(), short.block_us()), (4000, 1000));
        assert_eq!(long.tones_hz(), [250.0, 500.0, 1000.0, 2000.0, 4000.0]);
        assert_eq!(short.tones_hz(), [1000.0, 2000.0, 3000.0, 4000.0, 6000.0]);
        assert_eq!((long.residual_dof(), short.residual_dof()), (89, 14));
        assert_eq!(Layout::of_records_per_s(1000), Some(short));
        assert_eq!(Layout::of_records_per_s(250), Some(long));
        assert_eq!(Layout::of_records_per_s(500), None);
        for layout in Layout::ALL {
            assert!(layout.instants() <= BLOCK_INSTANTS && layout.dac_samples() <= DAC_TABLE);
            // Every tone makes whole periods, under Nyquist, none twice.
            // (The reader's comb is laid out for one of the two lengths.)
            assert!([BLOCK_INSTANTS, SHORT_INSTANTS].contains(&layout.instants()));
            assert!(layout.tones_hz().windows(2).all(|w| w[0] < w[1]));
            assert_eq!(layout.tone_hz(TONES + 3), layout.tone_hz(TONES - 1));
        }
        assert!(input_of(SENSORS - 1) < ADCS * SCAN);
        assert_eq!(adc_position(input_of(0)), (0, 1));
        assert_eq!(adc_position(input_of(15)), (4, 0));
        // Sensor 2 sits at position 3: three scan steps after the
        // voltage, 28.2 µs; the scan of four fits in an instant.
        assert!((SCAN_STEP_S - 16.0 * 25.0 / 42.5e6).abs() < 1e-12);
        assert!((skew_s(2) - 3.0 * SCAN_STEP_S).abs() < 1e-12);
        assert!(SCAN as f32 * SCAN_STEP_S < 1.0 / RATE_HZ as f32);
        assert_eq!(skew_s(3), 0.0);
        for layout in Layout::ALL {
            let r = layout.skew_rotation(2)[4];
            let want = TAU * layout.tone_hz(4) * 3.0 * SCAN_STEP_S;
            assert!((r.arg() - want).abs() < 1e-5);
        }
        assert_eq!(DAC_TABLE, 4000);
        assert_eq!(Layout::BLOCK_1MS.dac_samples(), 1000);
        // The ADC's rate: 4 inputs × 16 conversions × 25 kHz = 1.6 MSa/s,
        // under the G474's 4 MSa/s.
        assert!(SCAN as u32 * OVERSAMPLING * RATE_HZ <= 4_000_000);
    }

    /// A unit sinusoid of `nu` bins at `phase` over `n` instants, projected
    /// on the block's mean and on each of `comb`'s tones (orthogonal over
    /// the block): each tone's amplitude, and the mean square the
    /// projections leave (the residual's).
    pub(crate) fn projected(n: usize, comb: &[u32; TONES], nu: f64, phase: f64) -> ([f64; TONES], f64) {
        use core::f64::consts::PI;
        let x: std::vec::Vec<f64> = (0..n)
            .map(|t| libm::cos(2.0 * PI * nu * t as f64 / n as f64 + phase))
            .collect();
        let mean = x.iter().sum::<f64>() / n as f64;
        let mut energy = x.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n as f64;
        let mut amplitude = [0f64; TONES];
        for (a, &k) in amplitude.iter_mut().zip(comb) {
            let w = 2.0 * PI * k as f64 / n as f64;
            let c: f64 = x
                .iter()
                .enumerate()
                .map(|(t, v)| v * libm::cos(w * t as f64))
                .sum();
            let s: f64 = x
                .iter()
                .enumerate()
                .map(|(t, v)| v * libm::sin(w * t as f64))
                .sum();
            *a = 2.0 / n as f64 * libm::sqrt(c * c + s * s);
            // Each tone takes a²/2 of the mean square.
            energy -= *a * *a / 2.0;
        }
        (amplitude, energy)
    }

    /// Each layout's [`Layout::leak_ratio`], against the f64 projection of
    /// a unit sinusoid at every 1/200 of a bin from 0 to Nyquist at least
    /// half a bin from the mean and every tone, at 24 phases: none leaks
    /// more, and the worst within 1 % of it.
    #[test]
    fn the_leak_ratio_bounds_every_sinusoid_between_the_bins() {
        use core::f64::consts::PI;
        for layout in Layout::ALL {
            let n = layout.instants();
            let comb = layout.comb();
            let mut worst = 0f64;
            for step in 0..(n * 100) {
                let nu = step as f64 / 200.0;
                let far = |k: u32| libm::fabs(nu - k as f64) >= 0.5;
                if !(far(0) && comb.iter().all(|&k| far(k))) {
                    continue;
                }
                for p in 0..24 {
                    let (amplitude, energy) = projected(n, &comb, nu, p as f64 * PI / 24.0);
                    let leak = amplitude.iter().fold(0f64, |w, &a| w.max(a));
                    let residual = libm::sqrt(energy.max(0.0));
                    worst = worst.max(leak / (core::f64::consts::SQRT_2 * residual));
                }
            }
            let bound = layout.leak_ratio() as f64;
            assert!(worst <= bound && worst > 0.99 * bound, "{layout:?}: {worst}");
        }
    }

    /// [`NEAR_LEAK`] against the f64 projection of a unit sinusoid at
    /// every 1/400 of a bin within half a bin of each tone, at 24 phases,
    /// on the mean and the comb's tones: no tone takes more of it, per
    /// unit of the residual's √2·rms, and each entry is within 6 % of the
    /// worst.
    #[test]
    fn the_near_leak_bounds_every_sinusoid_in_the_bin() {
        use core::f64::consts::PI;
        let layout = Layout::BLOCK_4MS;
        let n = layout.instants();
        let comb = layout.comb();
        let mut worst = [[0f64; TONES]; TONES];
        for (k, &mk) in comb.iter().enumerate() {
            for step in -200i32..=200 {
                if step == 0 {
                    continue;
                }
                let nu = mk as f64 + step as f64 / 400.0;
                for p in 0..24 {
                    let (amplitude, energy) = projected(n, &comb, nu, p as f64 * PI / 24.0);
                    let residual = core::f64::consts::SQRT_2 * libm::sqrt(energy.max(1e-30));
                    for j in 0..TONES {
                        if j != k {
                            worst[k][j] = worst[k][j].max(amplitude[j] / residual);
                        }
                    }
                }
            }
        }
        for k in 0..TONES {
            for j in 0..TONES {
                let c = NEAR_LEAK[k][j] as f64;
                let w = worst[k][j];
                assert!(
                    w <= c && c <= 1.06 * w.max(1e-9) || (j == k && c == 0.0),
                    "{k}→{j}: {c} for {worst:?}"
                );
                if j != k {
                    assert_eq!(layout.near_leak(k, j), NEAR_LEAK[k][j].max(1.0));
                }
            }
        }
        assert_eq!(Layout::BLOCK_1MS.near_leak(1, 0), 1.0);
    }

    /// [`Layout::sideband_leak`] against the f64 fit of a unit sinusoid
    /// at every 1/400 of a bin within half a bin of each tone, at 24
    /// phases, to the mean, the comb's tones and that tone's sideband:
    /// what each other tone keeps of it, over the sideband's size, never
    /// exceeds the bound at its δ, and each c is within 6 % of the least
    /// that holds.
    #[test]
    fn the_sideband_leak_bounds_every_sinusoid_in_the_bin() {
        use core::f64::consts::PI;
        let layout = Layout::BLOCK_4MS;
        let n = layout.instants();
        let comb = layout.comb();
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
        let tone = |m: u32, sin: bool| -> std::vec::Vec<f64> {
            (0..n)
                .map(|t| {
                    let w = 2.0 * PI * m as f64 * t as f64 / n as f64;
                    if sin {
                        libm::sin(w)
                    } else {
                        libm::cos(w)
                    }
                })
                .collect()
        };
        // x less its mean and its projection on every tone (orthogonal
        // over the block).
        let perp = |x: &[f64]| -> std::vec::Vec<f64> {
            let mean = x.iter().sum::<f64>() / n as f64;
            let mut out: std::vec::Vec<f64> = x.iter().map(|v| v - mean).collect();
            for &m in &comb {
                for sin in [false, true] {
                    let b = tone(m, sin);
                    let c = dot(x, &b) * 2.0 / n as f64;
                    out.iter_mut().zip(&b).for_each(|(o, b)| *o -= c * b);
                }
            }
            out
        };
        let (mut table, mut worsts) = ([[0f64; TONES]; TONES], [0f64; TONES]);
        for (k, &mk) in comb.iter().enumerate() {
            let ramp = |sin: bool| -> std::vec::Vec<f64> {
                tone(mk, sin)
                    .iter()
                    .enumerate()
                    .map(|(t, v)| v * (2.0 * t as f64 - (n as f64 - 1.0)) / n as f64)
                    .collect()
            };
            let b = [ramp(false), ramp(true)];
            let pb = [perp(&b[0]), perp(&b[1])];
            let q = [
                [dot(&pb[0], &pb[0]), dot(&pb[0], &pb[1])],
                [dot(&pb[1], &pb[0]), dot(&pb[1], &pb[1])],
            ];
            let det = q[0][0] * q[1][1] - q[0][1] * q[1][0];
            let mut least = [0f64; TONES];
            let mut worst = 0f64;
            for step in 1..=200 {
                let delta = step as f64 / 400.0;
                for sign in [-1.0, 1.0] {
                    for ph in 0..24 {
                        let phase = ph as f64 * PI / 24.0;
                        let nu = mk as f64 + sign * delta;
                        let x: std::vec::Vec<f64> = (0..n)
                            .map(|t| libm::cos(2.0 * PI * nu * t as f64 / n as f64 + phase))
                            .collect();
                        let u = [dot(&x, &pb[0]), dot(&x, &pb[1])];
                        let p = [
                            (q[1][1] * u[0] - q[0][1] * u[1]) / det,
                            (q[0][0] * u[1] - q[1][0] * u[0]) / det,
                        ];
                        let y: std::vec::Vec<f64> =
                            (0..n).map(|t| x[t] - p[0] * b[0][t] - p[1] * b[1][t]).collect();
                        let size = libm::sqrt(p[0] * p[0] + p[1] * p[1]);
                        for (j, &mj) in comb.iter().enumerate() {
                            if j == k {
                                continue;
                            }
                            let (c, s) = (dot(&y, &tone(mj, false)), dot(&y, &tone(mj, true)));
                            let leak = 2.0 / n as f64 * libm::sqrt(c * c + s * s) / size;
                            let bound = layout.sideband_leak(k, j, delta as f32) as f64;
                            worst = worst.max(leak / bound);
                            least[j] = least[j].max(leak / (delta * (1.0 + 2.0 * delta)));
                        }
                    }
                }
            }
            table[k] = least;
            worsts[k] = worst;
        }
        for (k, row) in table.iter().enumerate() {
            assert!(worsts[k] <= 1.0, "tone {k}: {worsts:?}, least c {table:?}");
            for (j, &l) in row.iter().enumerate() {
                let c = SIDEBAND_LEAK[k][j] as f64;
                assert!(
                    j == k || c < 1.06 * l,
                    "tone {k} into {j}: c {c}, least {table:?}"
                );
            }
        }
        assert_eq!(Layout::BLOCK_1MS.sideband_leak(1, 0, 0.1), f32::INFINITY);
        assert_eq!(layout.sideband_leak(1, 0, 0.6), f32::INFINITY);
    }

    #[test]
    fn the_comb_fits_the_dac_and_its_crest_factor_is_low() {
        // Each layout's peak and crest factor as documented.
        for (layout, most, crest_most) in [(Layout::BLOCK_4MS, 1.321, 1.55), (Layout::BLOCK_1MS, 0.788, 1.34)]
        {
            let peak = layout.comb_peak(layout.dac_samples());
            let volts = layout.tone_volts();
            let rms = libm::sqrt(volts.iter().map(|a| a * a).sum::<f64>() / 2.0) as f32;
            let crest = peak / rms;
            assert!(peak < most && crest < crest_most, "peak {peak} crest {crest}");
            // A fresh random search (another generator, 3000 sets on a
            // coarser grid: 100 points a block) finds nothing 3 % lower.
            let mut s: u64 = 0x9e37_79b9_7f4a_7c15;
            let mut best = f32::MAX;
            for _ in 0..3000 {
                let mut ph = [0f32; TONES];
                for p in ph.iter_mut().skip(1) {
                    s = s
                        .wrapping_mul(6_364_136_223_846_793_005)
                        .wrapping_add(1_442_695_040_888_963_407);
                    *p = (s >> 40) as f32 / (1u64 << 24) as f32 * TAU;
                }
                best = best.min(layout.peak_of(&ph, BLOCK_INSTANTS));
            }
            assert!(best > 0.97 * peak, "a search found {best} against {peak}");
            // The excitation's peak stays inside the buffer's ±1.45 V swing.
            assert!(peak < 1.45);
        }
    }

    /// Every sensor of the documented range (electrodes from half the
    /// paper's, 0.35 MΩ, up, 120–290 pF, a uniform line read at
    /// one end: Z = R·coth(γ)/γ, γ = √(jωRC); 0 or 20 pF of cable in
    /// parallel at the meter) under the whole comb, its tones in their
    /// phases: the transimpedance output's peak over the block stays
    /// within [`TIA_PEAK_VOLT`], and the 1 ms comb, which the stages
    /// hold (the 4 ms one is held by the buffer's swing), fills it within
    /// 1 %. The amplitudes fall as each layout's documented power of f.
    #[test]
    fn the_comb_keeps_the_adc_headroom() {
        use num_complex::Complex64;
        for layout in Layout::ALL {
            let (volts, phases) = (layout.tone_volts(), layout.phases());
            let mut worst = 0f64;
            for (r, c, cable) in documented_corners() {
                let i: [Complex64; TONES] = core::array::from_fn(|k| {
                    let w = core::f64::consts::TAU * layout.tone_hz(k) as f64;
                    let g = Complex64::new(0.0, w * r * c).sqrt();
                    let y = g * g.sinh() / (g.cosh() * r) + Complex64::new(0.0, w * cable);
                    y * SENSOR_TIA_OHM * volts[k] * Complex64::from_polar(1.0, phases[k] as f64)
                });
                worst = worst.max(time_peak(&layout, &i));
            }
            assert!(worst <= TIA_PEAK_VOLT, "{worst} V");
            if layout == Layout::BLOCK_1MS {
                assert!(worst > 0.99 * TIA_PEAK_VOLT, "{worst} V");
            }
            let power = if layout == Layout::BLOCK_1MS { 1.0 } else { 0.75 };
            for (k, &v) in volts.iter().enumerate() {
                let ratio = layout.tone_hz(0) as f64 / layout.tone_hz(k) as f64;
                let want = volts[0] * libm::pow(ratio, power);
                assert!((v / want - 1.0).abs() < 0.01, "tone {k}: {v} V, not {want} V");
            }
        }
    }

    /// The corners of the documented range the headroom is checked at:
    /// (R Ω, C F, cable F).
    fn documented_corners() -> impl Iterator<Item = (f64, f64, f64)> {
        (0..22).flat_map(|j| {
            let r = 0.35e6 * libm::pow(1.15, j as f64);
            [120e-12, 170e-12, 230e-12, 290e-12]
                .into_iter()
                .flat_map(move |c| [0.0, 20e-12].map(|cable| (r, c, cable)))
        })
    }

    /// The largest |Σ Re(iₖ·e^(jωₖt))| over a block of `layout`, sampled
    /// at 20 000 points (its tones whole periods of the block).
    fn time_peak(layout: &Layout, i: &[num_complex::Complex64; TONES]) -> f64 {
        const POINTS: usize = 20_000;
        let comb = layout.comb();
        (0..POINTS)
            .map(|n| {
                let turn = n as f64 / POINTS as f64;
                let x: f64 = (0..TONES)
                    .map(|k| {
                        let th = core::f64::consts::TAU * comb[k] as f64 * turn;
                        i[k].re * th.cos() - i[k].im * th.sin()
                    })
                    .sum();
                x.abs()
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn the_dac_table_is_the_comb_within_half_a_code() {
        for layout in Layout::ALL {
            let mut full = [0u16; DAC_TABLE];
            let table = layout.dac_table(&mut full);
            assert_eq!(table.len(), layout.dac_samples());
            // Against f64: the rounding alone (RMS 1/√12 = 0.289 code).
            let volts = layout.tone_volts();
            let (comb, phases) = (layout.comb(), layout.phases());
            let code = |k: usize| volts[k] / crate::design::VREF_VOLT * 4096.0;
            let (mut sq, mut max) = (0f64, 0f64);
            for (n, &c) in table.iter().enumerate() {
                let t = n as f64 / table.len() as f64;
                let x: f64 = (0..TONES)
                    .map(|k| code(k) * (core::f64::consts::TAU * comb[k] as f64 * t + phases[k] as f64).cos())
                    .sum();
                let e = c as f64 - (2048.0 + x);
                sq += e * e;
                max = max.max(e.abs());
            }
            let rms = (sq / table.len() as f64).sqrt();
            assert!(rms < 0.31 && max <= 0.5 + 1e-3, "rms {rms} max {max}");
            // Its farther extreme: the comb's peak (a comb need not swing
            // alike both ways), inside the 12-bit range.
            let (lo, hi) = (*table.iter().min().unwrap(), *table.iter().max().unwrap());
            let peak = layout.comb_peak(table.len()) as f64 / crate::design::VREF_VOLT * 4096.0;
            let farther = (2048.0 - lo as f64).max(hi as f64 - 2048.0);
            assert!((farther - peak).abs() < 1.5, "{lo}..{hi}, peak {peak}");
            // … and inside the buffer's ±1.45 V swing (1800 codes).
            let swing = 1.45 / crate::design::VREF_VOLT * 4096.0;
            assert!(
                lo as f64 > 2048.0 - swing && (hi as f64) < 2048.0 + swing,
                "{lo}..{hi}"
            );
        }
    }

    #[test]
    fn offset_binary_and_the_rails() {
        let mut rows: Rows = [[0; SCAN]; BLOCK_INSTANTS];
        // Raw DMA words (as i16 bits): 0, the bias, the largest sum.
        let raw = [0u16, 32_768, 65_520, 32_768 + 1000];
        for (j, &r) in raw.iter().enumerate() {
            rows[7][j] = r as i16;
        }
        for row in rows.iter_mut().skip(8) {
            *row = [32_768u16 as i16; SCAN];
        }
        let rails = to_signed(&mut rows);
        assert_eq!(rows[7], [-32_768, 0, MAX_CODE as i16, 1000]);
        assert_eq!(rows[0], [-32_768; SCAN], "a zero word is the low rail");
        assert_eq!(rows[8], [0; SCAN]);
        assert_eq!(
            rails,
            [true, true, true, true],
            "the zero rows are on the low rail"
        );
        assert!(on_rail(-32_768) && on_rail(MAX_CODE as i16) && on_rail((MAX_CODE - RAIL_MARGIN) as i16));
        assert!(!on_rail(0) && !on_rail((MAX_CODE - RAIL_MARGIN - 1) as i16));
        assert!(!on_rail((-HALF_SCALE + RAIL_MARGIN + 1) as i16));
        assert_eq!(to_signed(&mut []), [false; SCAN], "no rows, no rail");
        // A frame of offset-binary words: 100 above the bias, one input
        // at the top rail and one near the bottom.
        let mut frame: Frame = [[[(32_768u16 + 100) as i16; SCAN]; BLOCK_INSTANTS]; ADCS];
        frame[3][50][2] = (MAX_CODE + HALF_SCALE) as u16 as i16;
        frame[0][0][0] = 68;
        let [f0, f1, f2, f3, f4] = &mut frame;
        let c = to_signed_all(&mut [&mut f0[..], &mut f1[..], &mut f2[..], &mut f3[..], &mut f4[..]]);
        assert_eq!(c.iter().filter(|&&x| x).count(), 2);
        assert!(c[14] && c[VOLTAGE_INPUT]);
        assert_eq!(frame[1][9][1], 100);
        assert_eq!(frame[3][50][2], MAX_CODE as i16);
    }
}
