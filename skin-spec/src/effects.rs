//! The effect catalogue: every non-ideal effect the project knows, listed
//! once, in SI units, with what the rest of the code needs to know about it.
//!
//! The simulated sensor (`skin-sim`), the fitting model of `host-sim
//! identify`, the command-line flags of `host-sim dataset`/`trace`, the
//! identify report and the firmware's wiring calibration all derive from
//! this list. The generator and the fitting model implement the physics
//! twice on purpose (each checks the other); the names, units and ranges
//! are this file's alone.
//!
//! Adding an effect: a [`Effect`] variant, its [`Info`] in [`Effect::info`],
//! then its physics in `skin_sim::sensor` (the generator) and
//! `host_sim::model` (the fitting model); see the README's contributor
//! section.

/// How an effect enters the physics of the measurement.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Entry {
    /// A resistance at each tab: two in series with the line (the
    /// capacitance path), and two inside each end-to-end electrode
    /// resistance measured through the tabs.
    SeriesPerTab,
    /// An admittance in parallel with the sensor at the meter.
    ShuntAtMeter,
    /// A change of the line's distribution along the sensor (series or
    /// shunt per length).
    AlongLine,
    /// A frequency dependence of the dielectric.
    Dielectric,
    /// The timing of the recording (the meter's integration, the alignment
    /// of its columns).
    Time,
    /// A fraction of each electrode's end-to-end resistance that lies in
    /// its tab leads, outside the capacitor: the line keeps the rest, and
    /// the two leads at the read end are in series with it. Proportional
    /// to the electrode's resistance, so no fixed wiring calibration holds
    /// it.
    Leads,
}

/// Whose property an effect is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scope {
    /// The sensor and its wiring: static, so a device calibration can hold
    /// it.
    Sensor,
    /// One recording (its meter, its alignment): not a property of the
    /// device.
    Recording,
}

/// What the code knows about one effect.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Info {
    /// Identifier in reports, on the command line (with `-` for `_`) and in
    /// device arguments.
    pub id: &'static str,
    /// Key of its parameter in reports, with the display unit.
    pub key: &'static str,
    /// What the parameter is, with its SI unit.
    pub doc: &'static str,
    /// SI unit of the parameter ("" for a ratio).
    pub unit: &'static str,
    /// Display unit in reports ("" for a ratio).
    pub display_unit: &'static str,
    /// Display value = SI value × `display_scale`.
    pub display_scale: f64,
    /// Decimals shown in reports, in the display unit.
    pub display_decimals: usize,
    /// The physically possible values (SI): what a generator accepts.
    pub limits: (f64, f64),
    /// The limits themselves are excluded (a ratio at ±1 would leave no
    /// resistance or no stretch at one end).
    pub open: bool,
    /// The range `identify` searches (SI).
    pub search: (f64, f64),
    /// Whose property it is.
    pub scope: Scope,
    /// How it enters the physics.
    pub entry: Entry,
    /// In `identify`'s library (false: only the generator has it, as an
    /// effect the library must report as unexplained).
    pub fitted: bool,
}

impl Info {
    /// Is `v` (SI) a physically possible value?
    pub fn valid(&self, v: f64) -> bool {
        let (lo, hi) = self.limits;
        v.is_finite()
            && if self.open {
                lo < v && v < hi
            } else {
                lo <= v && v <= hi
            }
    }

    /// The display value of `v` (SI).
    pub fn display(&self, v: f64) -> f64 {
        v * self.display_scale
    }
}

/// The number of effects in the catalogue.
pub const COUNT: usize = 22;

/// An effect of the catalogue.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Effect {
    /// Contact resistance of each tab, Ω.
    ContactResistance,
    /// Capacitance in parallel with the sensor at the meter (cable,
    /// fixture), F.
    ParasiticCapacitance,
    /// Electrode resistance per length ∝ 1 + g·(2ξ − 1), ξ = 0 at the read
    /// end: g > 0 is more resistive away from the tabs; total unchanged.
    ResistanceGradient,
    /// Dielectric leakage: conductance per capacitance G/C = σ/ε of the
    /// film (bulk conduction), S/F: distributed with the capacitance and
    /// growing with it as the film stretches (G = (σ/ε)·C).
    DielectricLeakage,
    /// The meter's integration window: a reading is the mean over the
    /// window (its admittance, or its readings) ending at the reading's
    /// time stamp, s; a stamp elsewhere in the window (centred) is a
    /// [`Effect::TimeOffset`] within it, fitted with it.
    MeterLag,
    /// The capacitance channel's time offset against the stretch and
    /// resistance columns (> 0: late), s.
    TimeOffset,
    /// Local stretch ∝ 1 + u·(2ξ − 1) along the sensor (u > 0: the far end
    /// stretches more); mean unchanged.
    NonuniformStretch,
    /// Dielectric dispersion: the permittivity, and so the capacitance,
    /// falls by this fraction per decade of frequency above 1 kHz (rises
    /// below); the truth is the 1 kHz value.
    DielectricDispersion,
    /// Fraction β of each electrode's end-to-end resistance in its two tab
    /// leads (β/2 each) and where the current crowds into the electrode,
    /// outside the capacitor. The leads are the electrode's own material,
    /// so they follow its resistance: R_line = (1 − β)·R_rec, and β/2·R_rec
    /// is in series at the read end.
    LeadResistance,
    /// The electrode film's conductivity rises with frequency (Debye: the
    /// film is a resistance in parallel with the capacitance between its
    /// carbon-black clusters, per length): r(f) = r/(1 + j·2πf·τ), τ in s
    /// (0: none). The recorded end-to-end resistances are the DC values.
    ElectrodeDispersion,
    /// The symmetric mode of the stretch along the sensor: local stretch
    /// ∝ 1 + v·(6ξ(1 − ξ) − 1) (v > 0: the middle stretches more than
    /// the clamped ends; mean unchanged), beside the linear mode of
    /// [`Effect::NonuniformStretch`].
    StretchBulge,
    /// The meter's first-order response: a reading is the exponentially
    /// weighted mean of what it measured before, e^(−u/τ)/τ, τ in s (a
    /// lock-in's RC output filter, a meter's running average).
    MeterResponse,
    /// The symmetric mode of the electrode resistance along the sensor:
    /// per length ∝ 1 + b·(6ξ(1 − ξ) − 1) (b > 0: the middle more
    /// resistive than the ends; total unchanged), beside the linear mode
    /// of [`Effect::ResistanceGradient`].
    ResistanceBulge,
    /// A meter that takes one reading per row and reports the mean of
    /// its last N readings (a digital meter's or logger's running
    /// average), on the data's own row grid: N readings (0: none; a
    /// fraction weighs the oldest reading in part). A delay of whole
    /// readings is a [`Effect::TimeOffset`] fitted with it.
    MeterMean,
    /// A meter that takes one reading per row and reports an
    /// exponentially weighted mean of them, on the data's own row grid:
    /// y_k = (1 − m)·x_k + m·y_(k−1), m the memory (0: none), 0…1. A
    /// delay of whole readings is a [`Effect::TimeOffset`] fitted with it.
    MeterEwma,
    /// Dielectric loss: the film's permittivity is ε'·(1 − j·tan δ), so
    /// each length of the line has a conductance ω·C·tan δ beside its
    /// capacitance (the polymer's dipolar relaxation; frequency-flat over
    /// the instrument's band). The loss tangent tan δ, 0…1.
    DielectricLoss,
    /// A localized bump of stretch along the sensor (a press, a bend, a
    /// fold of the skin under it): local stretch + a·(B(ξ) − B̄), B the
    /// bump of [`Effect::BumpCentre`] and [`Effect::BumpWidth`]
    /// ([`bump`]), B̄ its mean, so the mean stretch is unchanged; a > 0
    /// stretches the bump more than the rest.
    StretchBump,
    /// A localized bump of electrode resistance along the sensor (a
    /// thinner or cracked patch of the film, a > 0, or a thicker one,
    /// a < 0): resistance per length + a·(B(ξ) − B̄), total unchanged.
    ResistanceBump,
    /// Where a bump lies along the sensor: its centre ξ₀ (0: the read
    /// end, 1: the far end). A shape parameter, fitted with a bump,
    /// never alone.
    BumpCentre,
    /// A bump's full width w, a fraction of the sensor's length (0: no
    /// bump). A shape parameter, fitted with a bump, never alone.
    BumpWidth,
    /// The order n of the meter's response: n first-order sections of
    /// the time constant of [`Effect::MeterResponse`] in cascade (a
    /// lock-in's output filter at 6·n dB/octave), 1…4; its kernel is
    /// uⁿ⁻¹e^(−u/τ)/((n − 1)!·τⁿ), a bump in time peaking (n − 1)·τ back
    /// and about √n·τ wide. A fraction mixes in the next order's
    /// response in part; 0 (unset) is first order. A shape parameter,
    /// fitted with its response, never alone.
    MeterOrder,
    /// The power k of the symmetric modes ([`Effect::StretchBulge`],
    /// [`Effect::ResistanceBulge`]): their profile is (4ξ(1 − ξ))^k over
    /// its mean, less 1 ([`symmetric`]); k = 1 the parabola
    /// 6ξ(1 − ξ) − 1, about 2.4 a sin²(πξ)-like profile, below 1 flatter
    /// than the parabola; 0 (unset) is 1. A shape parameter, fitted with a
    /// bulge, never alone.
    BulgePower,
}

/// A localized bump along the sensor at ξ (0…1): cos²(π(ξ − ξ₀)/w) within
/// w/2 of its centre ξ₀, 0 elsewhere (smooth, with a continuous slope);
/// 0 everywhere for w ≤ 0.
pub fn bump(xi: f64, centre: f64, width: f64) -> f64 {
    let x = xi - centre;
    if width <= 0.0 || x.abs() >= 0.5 * width {
        return 0.0;
    }
    let c = libm::cos(core::f64::consts::PI * x / width);
    c * c
}

/// The symmetric mode of power `k` at ξ (0…1): (4ξ(1 − ξ))^k / m_k − 1,
/// m_k = 4^k·Γ(k + 1)²/Γ(2k + 2) its mean, so its own mean is 0 and it is
/// 6ξ(1 − ξ) − 1 at k = 1 (and at k = 0, unset).
pub fn symmetric(xi: f64, k: f64) -> f64 {
    let x = 4.0 * xi * (1.0 - xi);
    if k == 0.0 || k == 1.0 {
        return 1.5 * x - 1.0;
    }
    let ln_mean =
        k * core::f64::consts::LN_2 * 2.0 + 2.0 * libm::lgamma(k + 1.0) - libm::lgamma(2.0 * k + 2.0);
    if x <= 0.0 {
        return -1.0;
    }
    libm::exp(k * libm::log(x) - ln_mean) - 1.0
}

/// The mean of [`bump`] over the sensor (ξ in 0…1), in closed form: the
/// integral x/2 + w/(4π)·sin(2πx/w) over the part of the bump on the
/// sensor.
pub fn bump_mean(centre: f64, width: f64) -> f64 {
    if width <= 0.0 {
        return 0.0;
    }
    let f = |x: f64| {
        0.5 * x + width / (4.0 * core::f64::consts::PI) * libm::sin(2.0 * core::f64::consts::PI * x / width)
    };
    let (a, b) = ((-0.5 * width).max(-centre), (0.5 * width).min(1.0 - centre));
    if b <= a {
        0.0
    } else {
        f(b) - f(a)
    }
}

impl Effect {
    /// The catalogue, in the order of [`EffectSet`].
    pub const ALL: [Effect; COUNT] = [
        Effect::ContactResistance,
        Effect::ParasiticCapacitance,
        Effect::ResistanceGradient,
        Effect::DielectricLeakage,
        Effect::MeterLag,
        Effect::TimeOffset,
        Effect::NonuniformStretch,
        Effect::DielectricDispersion,
        Effect::LeadResistance,
        Effect::ElectrodeDispersion,
        Effect::StretchBulge,
        Effect::MeterResponse,
        Effect::ResistanceBulge,
        Effect::MeterMean,
        Effect::MeterEwma,
        Effect::DielectricLoss,
        Effect::StretchBump,
        Effect::ResistanceBump,
        Effect::BumpCentre,
        Effect::BumpWidth,
        Effect::MeterOrder,
        Effect::BulgePower,
    ];

    /// The shape parameters: part of another effect's model (a bump's
    /// place and width, a response's order, a bulge's power), fitted with
    /// it, never as an effect alone.
    pub const SHAPES: [Effect; 4] = [
        Effect::BumpCentre,
        Effect::BumpWidth,
        Effect::MeterOrder,
        Effect::BulgePower,
    ];

    /// The bumps, whose place and width are [`Effect::BUMP_SHAPES`].
    pub const BUMPS: [Effect; 2] = [Effect::StretchBump, Effect::ResistanceBump];

    /// A bump's place and width (of [`Effect::SHAPES`]).
    pub const BUMP_SHAPES: [Effect; 2] = [Effect::BumpCentre, Effect::BumpWidth];

    /// Its entry in the catalogue: the catalogue itself, one entry per
    /// effect, so one long `match` on purpose (an effect is added here and
    /// nowhere else).
    pub const fn info(self) -> &'static Info {
        match self {
            // Physical range: a clamped or glued tab on a carbon-black
            // film ranges from a few Ω (silver paint) to MΩ (a dry press
            // contact); a recording through the tabs holds four of them
            // (two per electrode), so R_rec/4 bounds what the data allow.
            Effect::ContactResistance => &Info {
                id: "contact_resistance",
                key: "contact_resistance_ohm",
                doc: "contact resistance of each tab, Ω",
                unit: "Ω",
                display_unit: "Ω",
                display_scale: 1.0,
                display_decimals: 0,
                limits: (0.0, f64::INFINITY),
                open: false,
                search: (0.0, 5e6),
                scope: Scope::Sensor,
                entry: Entry::SeriesPerTab,
                fitted: true,
            },
            Effect::ParasiticCapacitance => &Info {
                id: "parasitic_capacitance",
                key: "parasitic_capacitance_pf",
                doc: "capacitance in parallel at the meter (cable, fixture), F",
                unit: "F",
                display_unit: "pF",
                display_scale: 1e12,
                display_decimals: 3,
                limits: (0.0, f64::INFINITY),
                open: false,
                search: (0.0, 50e-12),
                scope: Scope::Sensor,
                entry: Entry::ShuntAtMeter,
                fitted: true,
            },
            Effect::ResistanceGradient => &Info {
                id: "resistance_gradient",
                key: "gradient_ratio",
                doc: "electrode resistance gradient along the sensor, -1..1",
                unit: "",
                display_unit: "",
                display_scale: 1.0,
                display_decimals: 4,
                limits: (-1.0, 1.0),
                open: true,
                search: (-0.98, 0.98),
                scope: Scope::Sensor,
                entry: Entry::AlongLine,
                fitted: true,
            },
            // Physical range: a silicone film conducts σ ≈ 10⁻¹³ S/m
            // (σ/ε ≈ 0.004 S/F); moisture, ionic fillers and conductive
            // particles that crossed the film raise it by orders of
            // magnitude. Searched to 5000 S/F (1 µS on 200 pF, a loss
            // tangent of 4 at 1 kHz).
            Effect::DielectricLeakage => &Info {
                id: "dielectric_leakage",
                key: "leakage_ns_per_pf",
                doc: "dielectric leakage conductance per capacitance G/C = σ/ε (distributed with C, and growing with it as the film stretches), S/F",
                unit: "S/F",
                display_unit: "nS/pF",
                display_scale: 1e-3,
                display_decimals: 4,
                limits: (0.0, f64::INFINITY),
                open: false,
                search: (0.0, 5000.0),
                scope: Scope::Sensor,
                entry: Entry::AlongLine,
                fitted: true,
            },
            Effect::MeterLag => &Info {
                id: "meter_lag",
                key: "window_ms",
                doc: "the meter's integration window, s",
                unit: "s",
                display_unit: "ms",
                display_scale: 1e3,
                display_decimals: 2,
                limits: (0.0, 10.0),
                open: false,
                // From one sample to an LCR meter's slow mode (~0.1–1 s)
                // and a logger's averaging (seconds). `identify` searches
                // as far as the traces hold (host-sim `model::search`: the
                // rows a window could not see out, a fifth of the shortest
                // trace; 2 s on 30 s traces), within these limits.
                search: (0.0, 10.0),
                scope: Scope::Recording,
                entry: Entry::Time,
                fitted: true,
            },
            Effect::TimeOffset => &Info {
                id: "time_offset",
                key: "offset_ms",
                doc: "time offset of the capacitance channel (> 0: late), s",
                unit: "s",
                display_unit: "ms",
                display_scale: 1e3,
                display_decimals: 2,
                limits: (-10.0, 10.0),
                open: true,
                // Two instruments started by hand, or a buffered channel:
                // tenths of a second to seconds. Searched as far as the
                // traces hold (host-sim `model::search`: ±2 s on 30 s
                // traces), within these limits.
                search: (-10.0, 10.0),
                scope: Scope::Recording,
                entry: Entry::Time,
                fitted: true,
            },
            Effect::NonuniformStretch => &Info {
                id: "nonuniform_stretch",
                key: "nonuniformity_ratio",
                doc: "stretch nonuniformity along the sensor, -1..1",
                unit: "",
                display_unit: "",
                display_scale: 1.0,
                display_decimals: 4,
                limits: (-1.0, 1.0),
                open: true,
                search: (-0.98, 0.98),
                scope: Scope::Sensor,
                entry: Entry::AlongLine,
                fitted: true,
            },
            Effect::DielectricDispersion => &Info {
                id: "dielectric_dispersion",
                key: "dispersion_per_decade",
                doc: "fraction of C lost per decade of frequency above 1 kHz",
                unit: "",
                display_unit: "",
                display_scale: 1.0,
                display_decimals: 4,
                limits: (-0.2, 0.2),
                open: false,
                search: (-0.2, 0.2),
                scope: Scope::Sensor,
                entry: Entry::Dielectric,
                fitted: false,
            },
            // Physical range: a lead is a strip of the electrode's film of
            // l/w squares (a 30 mm lead 5 mm wide: 6 squares, against the
            // electrode's 100 mm / 15 mm = 6.7), plus ≈ (2/π)·ln(W/w)
            // squares where the current crowds into the electrode; up to
            // well over half of the end-to-end resistance.
            Effect::LeadResistance => &Info {
                id: "lead_resistance",
                key: "lead_fraction",
                doc: "fraction of each electrode's end-to-end resistance in its tab leads, 0..0.99",
                unit: "",
                display_unit: "",
                display_scale: 1.0,
                display_decimals: 4,
                limits: (0.0, 0.99),
                open: false,
                search: (0.0, 0.95),
                scope: Scope::Sensor,
                entry: Entry::Leads,
                fitted: true,
            },
            // Physical range: carbon-black/silicone films conduct by
            // tunnelling between clusters, whose capacitance shunts the
            // film above f_c = 1/(2πτ); f_c from 160 Hz (τ = 1 ms) up.
            Effect::ElectrodeDispersion => &Info {
                id: "electrode_dispersion",
                key: "film_tau_us",
                doc: "relaxation time τ of the electrode film's conductivity, r/(1 + jωτ), s",
                unit: "s",
                display_unit: "µs",
                display_scale: 1e6,
                display_decimals: 2,
                limits: (0.0, 1e-3),
                open: false,
                search: (0.0, 1e-3),
                scope: Scope::Sensor,
                entry: Entry::AlongLine,
                fitted: true,
            },
            // Physical range: clamps hold the ends back (v > 0) up to
            // ends that do not stretch at all (v → 1); a film that slips
            // in its clamps and necks at the ends gives v < 0, down to a
            // middle that does not stretch (v → −2).
            Effect::StretchBulge => &Info {
                id: "stretch_bulge",
                key: "bulge_ratio",
                doc: "symmetric stretch mode along the sensor (middle over ends), -2..1",
                unit: "",
                display_unit: "",
                display_scale: 1.0,
                display_decimals: 4,
                limits: (-2.0, 1.0),
                open: true,
                search: (-0.98, 0.98),
                scope: Scope::Sensor,
                entry: Entry::AlongLine,
                fitted: true,
            },
            // Physical range: a lock-in's output filter from 1 ms to
            // seconds; a meter's running average over a few readings
            // (0.05–0.5 s). Searched as far as the traces hold (host-sim
            // `model::search`: τ to 1 s on 30 s traces, whose first 2τ
            // are left out: the filter starts settled on the first row).
            Effect::MeterResponse => &Info {
                id: "meter_response",
                key: "response_tau_ms",
                doc: "time constant of the meter's first-order response, s",
                unit: "s",
                display_unit: "ms",
                display_scale: 1e3,
                display_decimals: 2,
                limits: (0.0, 10.0),
                open: false,
                search: (0.0, 10.0),
                scope: Scope::Recording,
                entry: Entry::Time,
                fitted: true,
            },
            // Physical range: a film sprayed or bladed thicker in the
            // middle than at its edges (b < 0, down to ends that carry
            // the whole resistance, b → −2) or thinner (b > 0, up to ends
            // that conduct perfectly, b → 1); carbon-black films vary by
            // tens of percent in thickness.
            Effect::ResistanceBulge => &Info {
                id: "resistance_bulge",
                key: "r_bulge_ratio",
                doc: "symmetric mode of the electrode resistance along the sensor (middle over ends), -2..1",
                unit: "",
                display_unit: "",
                display_scale: 1.0,
                display_decimals: 4,
                limits: (-2.0, 1.0),
                open: true,
                search: (-0.98, 0.98),
                scope: Scope::Sensor,
                entry: Entry::AlongLine,
                fitted: true,
            },
            // Physical range: a digital LCR meter's or logger's running
            // average over 2 to a few tens of readings. Searched as far as
            // the traces hold (host-sim `model::search`: a fifth of the
            // shortest trace, in rows).
            Effect::MeterMean => &Info {
                id: "meter_mean",
                key: "mean_readings",
                doc: "the meter's running mean over its last N readings, one per row, N readings",
                unit: "",
                display_unit: "readings",
                display_scale: 1.0,
                display_decimals: 2,
                limits: (0.0, 1e6),
                open: false,
                search: (1.0, 1e6),
                scope: Scope::Recording,
                entry: Entry::Time,
                fitted: true,
            },
            // Physical range: a digital filter's memory, from none to a
            // time constant of a few hundred readings. Searched to a
            // time constant a tenth of the shortest trace (host-sim
            // `model::search`).
            Effect::MeterEwma => &Info {
                id: "meter_ewma",
                key: "ewma_memory",
                doc: "the meter's exponentially weighted mean of its readings, one per row: the memory m of y_k = (1 − m)·x_k + m·y_(k−1), 0..1",
                unit: "",
                display_unit: "",
                display_scale: 1.0,
                display_decimals: 4,
                limits: (0.0, 0.9999),
                open: false,
                search: (0.0, 0.999),
                scope: Scope::Recording,
                entry: Entry::Time,
                fitted: true,
            },
            // Physical range: silicone films (PDMS, the paper's) have
            // tan δ ≈ 1–5·10⁻³ at 0.1–10 kHz, acrylic (VHB) films
            // 1–5·10⁻², more when warm, wet or filled; 1 would be a film
            // that conducts as much as it stores.
            Effect::DielectricLoss => &Info {
                id: "dielectric_loss",
                key: "loss_tangent",
                doc: "loss tangent tan δ of the film (a conductance ω·C·tan δ with each length's C), 0..1",
                unit: "",
                display_unit: "",
                display_scale: 1.0,
                display_decimals: 4,
                limits: (0.0, 1.0),
                open: false,
                search: (0.0, 0.1),
                scope: Scope::Sensor,
                entry: Entry::Dielectric,
                fitted: false,
            },
            // Physical range: a fingertip or an edge pressed into the skin,
            // a fold, a bend over a joint stretch a patch of the film up
            // to three times as much as the rest, or hold it back to
            // nothing (a → −1 for a narrow bump). Searched to twice.
            Effect::StretchBump => &Info {
                id: "stretch_bump",
                key: "stretch_bump_ratio",
                doc: "a localized bump of stretch along the sensor (bump over mean), -1..3",
                unit: "",
                display_unit: "",
                display_scale: 1.0,
                display_decimals: 4,
                limits: (-1.0, 3.0),
                open: true,
                search: (-0.95, 2.0),
                scope: Scope::Sensor,
                entry: Entry::AlongLine,
                fitted: true,
            },
            // Physical range: a crack or a thin patch of a carbon-black
            // film conducts several times less than the rest (a up to
            // ~10); a thick or overlapping patch down to nothing
            // (a → −1). Searched to 8.
            Effect::ResistanceBump => &Info {
                id: "resistance_bump",
                key: "r_bump_ratio",
                doc: "a localized bump of electrode resistance along the sensor (bump over mean), -1..20",
                unit: "",
                display_unit: "",
                display_scale: 1.0,
                display_decimals: 4,
                limits: (-1.0, 20.0),
                open: true,
                search: (-0.95, 8.0),
                scope: Scope::Sensor,
                entry: Entry::AlongLine,
                fitted: true,
            },
            Effect::BumpCentre => &Info {
                id: "bump_centre",
                key: "bump_centre",
                doc: "the centre of a bump along the sensor (0: the read end, 1: the far end)",
                unit: "",
                display_unit: "",
                display_scale: 1.0,
                display_decimals: 3,
                limits: (0.0, 1.0),
                open: false,
                search: (0.0, 1.0),
                scope: Scope::Sensor,
                entry: Entry::AlongLine,
                fitted: false,
            },
            // What the data resolve: a line read at one end at f sees
            // along it to about its diffusion length, 1/√(ωRC/2) of the
            // sensor (a third at 10 kHz on 700 kΩ and 200 pF): the
            // width of a bump narrower than that trades against its
            // amplitude (the data fix its area a·w and its place). It is
            // searched down to a fifth of the sensor, which `identify`'s
            // model cascades on 48 pieces (within 0.002 pF of a
            // 240-segment line to 30 kHz).
            Effect::BumpWidth => &Info {
                id: "bump_width",
                key: "bump_width",
                doc: "the full width of a bump, a fraction of the sensor's length, 0..1",
                unit: "",
                display_unit: "",
                display_scale: 1.0,
                display_decimals: 3,
                limits: (0.0, 1.0),
                open: false,
                search: (0.2, 1.0),
                scope: Scope::Sensor,
                entry: Entry::AlongLine,
                fitted: false,
            },
            // Physical range: lock-in amplifiers offer output filters of
            // 6, 12, 18 and 24 dB/octave (1 to 4 sections); a
            // sigma-delta meter's sinc³ decimator reads like order 3.
            Effect::MeterOrder => &Info {
                id: "meter_order",
                key: "response_order",
                doc: "sections in the meter's response (6 dB/octave each), 1..4",
                unit: "",
                display_unit: "",
                display_scale: 1.0,
                display_decimals: 2,
                limits: (0.0, 4.0),
                open: false,
                search: (1.0, 4.0),
                scope: Scope::Recording,
                entry: Entry::Time,
                fitted: false,
            },
            // Physical range: a strip whose clamps hold its width at the
            // ends stretches most in its middle, from a parabola to a
            // sin²-like bell (k ≈ 2.4) as the strip narrows against its
            // length; a sprayed electrode thins toward its edges alike.
            Effect::BulgePower => &Info {
                id: "bulge_power",
                key: "bulge_power",
                doc: "power k of the symmetric modes' profile (4ξ(1 − ξ))^k, 1 the parabola",
                unit: "",
                display_unit: "",
                display_scale: 1.0,
                display_decimals: 2,
                limits: (0.0, 8.0),
                open: false,
                search: (1.0, 3.5),
                scope: Scope::Sensor,
                entry: Entry::AlongLine,
                fitted: false,
            },
        }
    }

    /// Its identifier.
    pub const fn id(self) -> &'static str {
        self.info().id
    }

    /// The effect whose id is `id`.
    pub fn from_id(id: &str) -> Option<Effect> {
        Effect::ALL.into_iter().find(|e| e.id() == id)
    }

    /// The effects `identify` fits (a shape parameter only with its
    /// bump).
    pub fn library() -> impl Iterator<Item = Effect> {
        Effect::ALL.into_iter().filter(|e| e.info().fitted)
    }

    /// A shape parameter ([`Effect::SHAPES`]): part of a bump.
    pub fn is_shape(self) -> bool {
        Effect::SHAPES.contains(&self)
    }

    /// The value at which a shape parameter reduces its effect to the
    /// model without it (a response of order 1 is the first-order
    /// response), where there is one: a fit with the parameter then
    /// differs in shape from one without only where it is resolved from
    /// that value. None for the others (a bump's place and width are
    /// always fitted with it).
    pub fn reduces_at(self) -> Option<f64> {
        match self {
            Effect::MeterOrder | Effect::BulgePower => Some(1.0),
            _ => None,
        }
    }

    /// A property of the sensor and its wiring (a device calibration can
    /// hold it).
    pub const fn is_static(self) -> bool {
        matches!(self.info().scope, Scope::Sensor)
    }
}

/// A value for every effect of the catalogue, SI (0: absent).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EffectSet(pub [f64; COUNT]);

/// Why a value cannot be set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EffectError {
    /// No effect has this id.
    Unknown,
    /// The value is outside the effect's physical limits.
    OutOfLimits(Effect),
    /// Not `id=value` with a number.
    Syntax,
}

impl core::fmt::Display for EffectError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            EffectError::Unknown => write!(f, "no effect of the catalogue has this id"),
            EffectError::OutOfLimits(e) => {
                let i = e.info();
                let (a, b) = if i.open { ('(', ')') } else { ('[', ']') };
                write!(
                    f,
                    "{} must be within {a}{}, {}{b} {}",
                    i.id, i.limits.0, i.limits.1, i.unit
                )
            }
            EffectError::Syntax => write!(f, "expected id=value (SI units)"),
        }
    }
}

impl core::error::Error for EffectError {}

impl EffectSet {
    /// No effect.
    pub const NONE: EffectSet = EffectSet([0.0; COUNT]);

    /// The value of `e`, SI.
    pub const fn get(&self, e: Effect) -> f64 {
        self.0[e as usize]
    }

    /// With `e` set to `v` (SI).
    pub const fn with(mut self, e: Effect, v: f64) -> Self {
        self.0[e as usize] = v;
        self
    }

    /// Set `e` to `v` (SI), checking the physical limits.
    pub fn set(&mut self, e: Effect, v: f64) -> Result<(), EffectError> {
        if !e.info().valid(v) {
            return Err(EffectError::OutOfLimits(e));
        }
        self.0[e as usize] = v;
        Ok(())
    }

    /// Is `e` present?
    pub fn has(&self, e: Effect) -> bool {
        self.get(e) != 0.0
    }

    /// Is any effect present?
    pub fn any(&self) -> bool {
        self.0.iter().any(|&v| v != 0.0)
    }

    /// Apply one `id=value` argument (value in SI, a plain number).
    pub fn apply(&mut self, arg: &str) -> Result<Effect, EffectError> {
        let (id, v) = arg.split_once('=').ok_or(EffectError::Syntax)?;
        let e = Effect::from_id(id.trim()).ok_or(EffectError::Unknown)?;
        let v: f64 = v.trim().parse().map_err(|_| EffectError::Syntax)?;
        self.set(e, v)?;
        Ok(e)
    }

    /// Only the effects of the sensor and its wiring (what a device
    /// calibration holds).
    pub fn statics(&self) -> Self {
        let mut s = *self;
        for e in Effect::ALL {
            if !e.is_static() {
                s.0[e as usize] = 0.0;
            }
        }
        s
    }

    /// Local stretch over mean stretch at ξ along the sensor (0: the read
    /// end, 1: the far end): 1 + u·(2ξ − 1) + v·S_k(ξ) +
    /// a·(B(ξ) − B̄), u the [`Effect::NonuniformStretch`] (linear) and v
    /// the [`Effect::StretchBulge`] (symmetric) mode of power k
    /// ([`symmetric`] S_k, [`Effect::BulgePower`]), a the
    /// [`Effect::StretchBump`] of the bump B ([`bump`]); each term's mean
    /// is 0. Floored at 0.
    pub fn stretch_profile(&self, xi: f64) -> f64 {
        let (u, v) = (
            self.get(Effect::NonuniformStretch),
            self.get(Effect::StretchBulge),
        );
        (1.0 + u * (2.0 * xi - 1.0)
            + v * symmetric(xi, self.get(Effect::BulgePower))
            + self.bump_term(Effect::StretchBump, xi))
        .max(0.0)
    }

    /// Electrode resistance per length over its mean at ξ along the
    /// sensor: 1 + g·(2ξ − 1) + b·S_k(ξ) + a·(B(ξ) − B̄), g the
    /// [`Effect::ResistanceGradient`] (linear) and b the
    /// [`Effect::ResistanceBulge`] (symmetric) mode of power k, a the
    /// [`Effect::ResistanceBump`], floored at 0.
    pub fn resistance_profile(&self, xi: f64) -> f64 {
        let (g, b) = (
            self.get(Effect::ResistanceGradient),
            self.get(Effect::ResistanceBulge),
        );
        (1.0 + g * (2.0 * xi - 1.0)
            + b * symmetric(xi, self.get(Effect::BulgePower))
            + self.bump_term(Effect::ResistanceBump, xi))
        .max(0.0)
    }

    /// a·(B(ξ) − B̄) of the bump `e` (0 without it).
    fn bump_term(&self, e: Effect, xi: f64) -> f64 {
        let a = self.get(e);
        if a == 0.0 {
            return 0.0;
        }
        let (c, w) = (self.get(Effect::BumpCentre), self.get(Effect::BumpWidth));
        a * (bump(xi, c, w) - bump_mean(c, w))
    }

    /// Is the stretch nonuniform along the sensor (any stretch mode or
    /// bump)?
    pub fn stretched(&self) -> bool {
        self.has(Effect::NonuniformStretch) || self.has(Effect::StretchBulge) || self.has(Effect::StretchBump)
    }

    /// Is the line nonuniform along the sensor (any stretch or
    /// resistance mode or bump)?
    pub fn nonuniform(&self) -> bool {
        self.stretched()
            || self.has(Effect::ResistanceGradient)
            || self.has(Effect::ResistanceBulge)
            || self.has(Effect::ResistanceBump)
    }

    /// The wiring as the meter sees it: (resistance in series with the
    /// line, Ω; capacitance in parallel at the meter, F), from the effects
    /// that enter as [`Entry::SeriesPerTab`] (two tabs in the path) and
    /// [`Entry::ShuntAtMeter`].
    pub fn wiring(&self) -> (f64, f64) {
        let (mut series, mut shunt) = (0.0, 0.0);
        for e in Effect::ALL {
            match e.info().entry {
                Entry::SeriesPerTab => series += 2.0 * self.get(e),
                Entry::ShuntAtMeter => shunt += self.get(e),
                _ => {}
            }
        }
        (series, shunt)
    }

    /// The tab leads as the firmware's inversion takes them: the series
    /// resistance at the read end per line resistance, ℓ = β/(2(1 − β))
    /// (`dsp_core::invert::Inverter::with_leads`), for a fraction β of
    /// each electrode's resistance in its leads; 0 without leads.
    pub fn lead_ratio(&self) -> f32 {
        let beta = self.get(Effect::LeadResistance);
        if beta > 0.0 && beta < 1.0 {
            (0.5 * beta / (1.0 - beta)) as f32
        } else {
            0.0
        }
    }

    /// The wiring as a de-embedding calibration for the firmware
    /// ([`EffectSet::wiring`] in `f32`).
    pub fn fixture(&self) -> dsp_core::fixture::Fixture {
        let (series, shunt) = self.wiring();
        dsp_core::fixture::Fixture {
            parallel_farad: shunt as f32,
            series_ohm: series as f32,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`symmetric`] against an f64 reference that does not use Γ: its
    /// mean by Simpson's rule on 20 000 intervals in t, ξ = (1 − cos πt)/2
    /// (so 4ξ(1 − ξ) = sin²πt and no end has an infinite slope), over the
    /// power's whole range (0 < k ≤ 8): the profile's mean within 1e-9 of
    /// 0, each value within 1e-9 relative of (4ξ(1 − ξ))^k/mean − 1 at
    /// 101 points (RMS below 1e-9); the parabola at k = 1 and unset, to
    /// the bit.
    #[test]
    fn the_symmetric_mode_has_mean_zero_at_every_power() {
        let n = 20_000;
        let simpson = |f: &dyn Fn(f64) -> f64| {
            let h = 1.0 / n as f64;
            let w = |i: usize| match i {
                0 => 1.0,
                i if i == n => 1.0,
                i if i % 2 == 1 => 4.0,
                _ => 2.0,
            };
            let pi = core::f64::consts::PI;
            let g = |t: f64| f(0.5 * (1.0 - libm::cos(pi * t))) * 0.5 * pi * libm::sin(pi * t);
            (0..=n).map(|i| w(i) * g(i as f64 * h)).sum::<f64>() * h / 3.0
        };
        for k in [0.25, 0.5, 1.0, 1.22, 2.0, 2.4, 3.5, 5.0, 8.0] {
            let mean = simpson(&|x| symmetric(x, k));
            assert!(mean.abs() < 1e-9, "k {k}: mean {mean}");
            let m = simpson(&|x: f64| (4.0 * x * (1.0 - x)).powf(k));
            let (mut worst, mut sq) = (0.0f64, 0.0);
            for i in 0..=100 {
                let x = i as f64 / 100.0;
                let want = (4.0 * x * (1.0 - x)).powf(k) / m - 1.0;
                let e = (symmetric(x, k) - want).abs() / (1.0 + want.abs());
                worst = worst.max(e);
                sq += e * e;
            }
            let rms = (sq / 101.0).sqrt();
            assert!(worst < 1e-9 && rms < 1e-9, "k {k}: worst {worst:e}, rms {rms:e}");
        }
        for x in [0.0, 0.1, 0.37, 0.5, 0.9] {
            let parabola = 6.0 * x * (1.0 - x) - 1.0;
            assert_eq!(
                symmetric(x, 1.0).to_bits(),
                (1.5 * (4.0 * x * (1.0 - x)) - 1.0).to_bits()
            );
            assert!((symmetric(x, 0.0) - parabola).abs() < 1e-15);
        }
    }

    #[test]
    fn ids_are_unique_and_ordered() {
        for (i, e) in Effect::ALL.iter().enumerate() {
            assert_eq!(*e as usize, i);
            assert_eq!(Effect::from_id(e.id()), Some(*e));
            for f in &Effect::ALL[i + 1..] {
                assert_ne!(e.id(), f.id());
                assert_ne!(e.info().key, f.info().key);
            }
            let i = e.info();
            assert!(i.limits.0 <= i.search.0 && i.search.1 <= i.limits.1, "{}", i.id);
            assert!(i.valid(0.0), "{}: 0 means absent", i.id);
        }
        assert_eq!(Effect::from_id("nothing"), None);
    }

    #[test]
    fn arguments_are_checked_against_the_limits() {
        let mut s = EffectSet::NONE;
        assert_eq!(
            s.apply("parasitic_capacitance=12e-12"),
            Ok(Effect::ParasiticCapacitance)
        );
        assert_eq!(s.get(Effect::ParasiticCapacitance), 12e-12);
        assert_eq!(
            s.apply("contact_resistance=-1"),
            Err(EffectError::OutOfLimits(Effect::ContactResistance))
        );
        assert_eq!(
            s.apply("resistance_gradient=1"),
            Err(EffectError::OutOfLimits(Effect::ResistanceGradient))
        );
        assert_eq!(
            s.apply("resistance_gradient=0.99"),
            Ok(Effect::ResistanceGradient)
        );
        assert_eq!(s.apply("x=1"), Err(EffectError::Unknown));
        assert_eq!(s.apply("contact_resistance"), Err(EffectError::Syntax));
        assert_eq!(
            s.apply("contact_resistance=NaN"),
            Err(EffectError::OutOfLimits(Effect::ContactResistance))
        );
        s.set(Effect::ContactResistance, 5e3).unwrap();
        s.set(Effect::MeterLag, 0.05).unwrap();
        assert_eq!(s.wiring(), (10e3, 12e-12));
        let f = s.fixture();
        assert_eq!((f.series_ohm, f.parallel_farad), (10e3, 12e-12));
        assert!(!s.statics().has(Effect::MeterLag));
        assert!(s.statics().has(Effect::ResistanceGradient));
    }

    /// The bump's mean in closed form is the integral over the sensor
    /// (midpoint rule on 10⁵ points, within 10⁻⁹) wherever the bump lies,
    /// cut by either end or not, and the profiles with a bump keep their
    /// mean (1 within 10⁻⁹) and peak where the bump is.
    #[test]
    fn a_bump_keeps_the_mean_of_its_profile() {
        const M: usize = 100_000;
        let mean =
            |f: &dyn Fn(f64) -> f64| (0..M).map(|i| f((i as f64 + 0.5) / M as f64)).sum::<f64>() / M as f64;
        for (c, w) in [
            (0.5, 0.3),
            (0.1, 0.5),
            (0.95, 0.4),
            (0.0, 1.0),
            (1.0, 0.2),
            (0.5, 1.0),
            (0.3, 0.0),
        ] {
            let numeric = mean(&|x| bump(x, c, w));
            assert!(
                (bump_mean(c, w) - numeric).abs() < 1e-9,
                "{c} {w}: {} {numeric}",
                bump_mean(c, w)
            );
            let fx = EffectSet::NONE
                .with(Effect::StretchBump, 0.7)
                .with(Effect::ResistanceBump, -0.6)
                .with(Effect::BumpCentre, c)
                .with(Effect::BumpWidth, w);
            assert!((mean(&|x| fx.stretch_profile(x)) - 1.0).abs() < 1e-9);
            assert!((mean(&|x| fx.resistance_profile(x)) - 1.0).abs() < 1e-9);
            assert!(fx.nonuniform());
            if w > 0.0 && c > 0.0 && c < 1.0 {
                assert!(fx.stretch_profile(c) > fx.stretch_profile((c + 0.5 * w + 0.01).min(1.0)));
                assert!(fx.resistance_profile(c) < fx.resistance_profile((c - 0.5 * w - 0.01).max(0.0)));
            }
        }
        assert_eq!(bump(0.5, 0.5, 0.4), 1.0);
        assert!(bump(0.7, 0.5, 0.4) < 1e-20 && bump(0.75, 0.5, 0.4) == 0.0);
        assert!(!EffectSet::NONE.with(Effect::BumpCentre, 0.5).nonuniform());
        assert!(Effect::library().all(|e| !e.is_shape()));
    }
}
