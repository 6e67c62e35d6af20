//! A scanning ADC's block as its DMA leaves it, made ready for the comb.
//!
//! The STM32G474's ADCs with oversampling write offset binary: an
//! unsigned 16-bit sum with the bias at 2¹⁵. Flipping the top bit makes
//! it two's complement around the bias (subtracting 2¹⁵ modulo 2¹⁶), in
//! place. In the same pass each input's least and greatest result are
//! kept, so that a result on a rail (a clipped input) is known without
//! a second look at every sample.
//!
//! On Arm cores with the DSP extension the pass is `arm` inline
//! assembly for rows of four inputs (a row's two words at once: `EOR`
//! of both halves, and the extremes of two inputs per `SSUB16`/`SEL`
//! pair, 4 instructions a sample); elsewhere, and for other row
//! widths, [`portable`]. Both give the same rows and extremes (tested on
//! the host, checked on the target by the QEMU benchmark).

/// Each input's least and greatest result over a block: `[min, max]`,
/// two's complement counts (`[i16::MAX, i16::MIN]` for no rows).
pub type Extremes<const S: usize> = [[i16; 2]; S];

/// Offset binary to two's complement in place, and each input's
/// extremes (module docs).
pub fn to_signed<const S: usize>(rows: &mut [[i16; S]]) -> Extremes<S> {
    #[cfg(arm_dsp)]
    return arm::to_signed(rows);
    #[cfg(not(arm_dsp))]
    return portable(rows);
}

/// Reference implementation of [`to_signed`] (all targets, any width).
pub fn portable<const S: usize>(rows: &mut [[i16; S]]) -> Extremes<S> {
    let mut ext = [[i16::MAX, i16::MIN]; S];
    for row in rows {
        for (x, e) in row.iter_mut().zip(ext.iter_mut()) {
            *x ^= i16::MIN;
            e[0] = e[0].min(*x);
            e[1] = e[1].max(*x);
        }
    }
    ext
}

/// Cortex-M4 (DSP extension) pass in inline assembly, rows of four.
#[cfg(arm_dsp)]
#[allow(unsafe_code)]
pub mod arm {
    /// Same rows and extremes as [`portable`](super::portable), for
    /// rows of four inputs (others are left to it).
    #[inline(never)]
    pub fn to_signed<const S: usize>(rows: &mut [[i16; S]]) -> super::Extremes<S> {
        if S != 4 || rows.is_empty() {
            return super::portable(rows);
        }
        // Lanes (input 0, input 1) and (input 2, input 3): least and
        // greatest, two's complement halves.
        let (mut lo01, mut lo23) = (0x7fff_7fffu32, 0x7fff_7fffu32);
        let (mut hi01, mut hi23) = (0x8000_8000u32, 0x8000_8000u32);
        let mut p = rows.as_mut_ptr().cast::<u32>();
        // SAFETY: `p` walks the rows, two words (one row of four i16)
        // a turn, reading and writing exactly those words, and stops at
        // `end`, one past the last row (`rows` is not empty). A row of
        // i16 is aligned to 2 only: `LDR` and `STR` take that on the
        // Cortex-M4 (`LDRD` and `STRD` would fault). Only registers, the
        // flags and the rows' memory are touched.
        unsafe {
            let end = p.add(rows.len() * 2);
            core::arch::asm!(
                "2:",
                "ldr {a}, [{p}]",
                "ldr {b}, [{p}, #4]",
                "eor {a}, {a}, #0x80008000",
                "eor {b}, {b}, #0x80008000",
                "str {b}, [{p}, #4]",
                "str {a}, [{p}], #8",
                // GE per lane where a ≥ lo: keep lo there, else a.
                "ssub16 {t}, {a}, {lo01}",
                "sel {lo01}, {lo01}, {a}",
                // GE per lane where a ≥ hi: a there, else hi.
                "ssub16 {t}, {a}, {hi01}",
                "sel {hi01}, {a}, {hi01}",
                "ssub16 {t}, {b}, {lo23}",
                "sel {lo23}, {lo23}, {b}",
                "ssub16 {t}, {b}, {hi23}",
                "sel {hi23}, {b}, {hi23}",
                "cmp {p}, {end}",
                "bne 2b",
                p = inout(reg) p,
                end = in(reg) end,
                lo01 = inout(reg) lo01,
                lo23 = inout(reg) lo23,
                hi01 = inout(reg) hi01,
                hi23 = inout(reg) hi23,
                a = out(reg) _,
                b = out(reg) _,
                t = out(reg) _,
                options(nostack),
            );
        }
        let _ = p;
        let lanes = |w: u32| [w as i16, (w >> 16) as i16];
        let ([l0, l1], [l2, l3]) = (lanes(lo01), lanes(lo23));
        let ([h0, h1], [h2, h3]) = (lanes(hi01), lanes(hi23));
        let four = [[l0, h0], [l1, h1], [l2, h2], [l3, h3]];
        core::array::from_fn(|j| four[j])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The flip and the extremes, edges included; an empty block.
    #[test]
    fn offset_binary_to_signed_with_extremes() {
        let mut rows = [
            [0u16 as i16, 32_768u16 as i16, 65_535u16 as i16, 33_768u16 as i16],
            [1; 4],
        ];
        let ext = to_signed(&mut rows);
        assert_eq!(rows[0], [-32_768, 0, 32_767, 1000]);
        assert_eq!(rows[1], [-32_767; 4]);
        assert_eq!(
            ext,
            [
                [-32_768, -32_767],
                [-32_767, 0],
                [-32_767, 32_767],
                [-32_767, 1000]
            ]
        );
        let mut none: [[i16; 4]; 0] = [];
        assert_eq!(to_signed(&mut none), [[i16::MAX, i16::MIN]; 4]);
    }
}
