//! The per-block code's load into zero-wait RAM (`hot-ram.x`): the
//! section `.hot_ram` is linked at the RAM it runs from (the G474's CCM
//! SRAM; the QEMU images leave it in flash), its image kept in flash;
//! `__pre_init`,
//! which cortex-m-rt's reset handler calls before it initialises the
//! statics, copies it word by word. In assembly, as cortex-m-rt asks of
//! code that runs before Rust's statics exist; every image links it
//! (the reset handler calls it by name), so none can start with the
//! section unloaded.

// SAFETY: runs before any Rust code; touches only the section's RAM,
// which nothing else owns, from its image in flash (the linker's symbols,
// both word-aligned: `hot-ram.x`).
#[allow(unsafe_code)]
mod load {
    core::arch::global_asm!(
        ".section .text.__pre_init,\"ax\"",
        ".global __pre_init",
        ".type __pre_init,%function",
        ".thumb_func",
        "__pre_init:",
        "    ldr r0, =__shot_ram",
        "    ldr r1, =__ehot_ram",
        "    ldr r2, =__sihot_ram",
        // Linked where it lies (the benchmark image): nothing to copy.
        "    cmp r0, r2",
        "    beq 1f",
        "0:  cmp r1, r0",
        "    beq 1f",
        "    ldm r2!, {{r3}}",
        "    stm r0!, {{r3}}",
        "    b 0b",
        // The copied code is fetched next: the writes done, the pipeline
        // refilled.
        "1:  dsb",
        "    isb",
        "    bx lr",
        ".ltorg",
    );
}
