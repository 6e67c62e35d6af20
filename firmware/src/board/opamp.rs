//! Three of the G474's op-amps as unity followers whose outputs go inside
//! the chip to an ADC channel (OPAINTOEN), not to a pin: they bring the
//! array's three pins that no free ADC channel reaches on the LQFP64 to
//! ADC3 and ADC5 ([`super::scan::INPUT_PINS`]). Each follows its VINP2
//! input: OPAMP3 PA1 (→ ADC3 IN13), OPAMP4 PB11 (→ ADC5 IN5), OPAMP5 PC3
//! (→ ADC5 IN3). A follower adds its offset (a DC term the comb rejects)
//! and a gain of 1 to 6 kHz: the same on every tone, so V/I keeps none.

use super::pac::opamp;

/// OPAMP3, 4 and 5: enabled, follower (VM_SEL = output), VINP2,
/// output to the ADC.
pub fn followers(op: &opamp::RegisterBlock) {
    // Each op-amp's CSR is its own type in the PAC: one write, three
    // registers.
    macro_rules! follower {
        ($csr:expr) => {
            $csr.write(|w| {
                w.opaen()
                    .enabled()
                    .vm_sel()
                    .output()
                    .vp_sel()
                    .vinp2()
                    .opaintoen()
                    .adcchannel()
            })
        };
    }
    follower!(op.opamp3_csr());
    follower!(op.opamp4_csr());
    follower!(op.opamp5_csr());
}
