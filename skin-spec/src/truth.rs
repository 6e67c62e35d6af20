//! What the simulated skin truly was during one block: the rig's view of
//! a sensor, which the QEMU images log beside each record (as a `truth`
//! line of the record wire format, `instrument::wire`) so that the tests
//! and the main job compare every record with it.

/// The first word of a truth line.
pub const TRUTH: &str = "truth";

/// What the simulated skin truly was during one block (QEMU only).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TruthLine {
    /// Middle of the block, µs.
    pub t_us: u64,
    /// Sensor.
    pub sensor: u8,
    /// Line capacitance, F.
    pub c_farad: f32,
    /// Line resistance (both electrodes, no contacts), Ω.
    pub r_line_ohm: f32,
    /// Stretch, mm.
    pub stretch_mm: f32,
    /// End-to-end top electrode resistance through its tabs, Ω.
    pub r_top_ohm: f32,
    /// End-to-end bottom electrode resistance, Ω.
    pub r_bottom_ohm: f32,
}

#[cfg(feature = "defmt")]
impl defmt::Format for TruthLine {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(
            f,
            "truth {=u64} {=u8} {=f32} {=f32} {=f32} {=f32} {=f32}",
            self.t_us,
            self.sensor,
            self.c_farad * 1e12,
            self.r_line_ohm,
            self.stretch_mm,
            self.r_top_ohm,
            self.r_bottom_ohm
        )
    }
}
