//! The record wire format, in one place for every image: one defmt line
//! per block, decoded on the host by `qemu_tests::records::parse`:
//!
//! `rec t_ms channel freq_hz cs_pF rs_ohm c_pF r_ohm stretch_mm flags`

use instrument::channel::Record;

/// Log `rec` for the block that started at `t_s` (s).
pub fn record(t_s: f32, rec: &Record) {
    defmt::println!(
        "rec {=u32} {=u8} {=f32} {=f32} {=f32} {=f32} {=f32} {=f32} {=u8}",
        (t_s * 1000.0) as u32,
        rec.channel,
        rec.freq_hz,
        rec.cs_farad * 1e12,
        rec.rs_ohm,
        rec.c_farad * 1e12,
        rec.r_ohm,
        rec.stretch_mm,
        rec.flags.0
    );
}
