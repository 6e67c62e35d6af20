//! Instruction counts of the dsp-core kernels on a Cortex-M4, run in QEMU
//! with `-icount shift=7,align=off,sleep=off` (deterministic: the virtual
//! clock advances with every instruction executed).
//!
//! SysTick runs from the core clock; its ticks per instruction are
//! calibrated with a loop of known length (`subs`/`bne`, 2 instructions per
//! turn), so the reported counts do not depend on QEMU's clock settings.
//! Output lines: `bench <name> <instructions per unit> <unit>`.
#![no_std]
#![no_main]

use core::hint::black_box;
use core::mem::MaybeUninit;
use cortex_m::peripheral::{syst::SystClkSource, SYST};
use cortex_m_rt::entry;
use dsp_core::demod::Demodulator;
use dsp_core::invert::Inverter;
use dsp_core::tline::LineModel;
use dsp_core::{Complex32, Oscillator, OscillatorState};
use firmware::qemu;
// The device crate provides the interrupt vectors cortex-m-rt expects.
use lm3s6965 as _;
use semihosting::println;

const PAIRS: usize = 2048;

/// The most regions (calls of [`ticks`]) a cycle table holds.
const REGIONS_MAX: usize = 384;

/// What the benches read their spans with: SysTick, or, in a second run,
/// each span's cycles as the host's cycle model of the Cortex-M4 counted
/// them in the first (`cycles=PATH`: one little-endian u32 per span, in
/// order), so that every figure below comes out in cycles.
struct Clock {
    syst: SYST,
    /// The table, and how many spans it holds.
    table: Option<([u32; REGIONS_MAX], usize)>,
    next: usize,
}

impl Clock {
    /// SysTick from the core clock, and the cycle table the command line
    /// names, if it does.
    fn new(mut syst: SYST) -> Self {
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(0x00ff_ffff);
        syst.enable_counter();
        Self {
            syst,
            table: cycle_table(),
            next: 0,
        }
    }

    /// Whether the spans are the cycle model's.
    fn cycles(&self) -> bool {
        self.table.is_some()
    }
}

/// The cycle table of `cycles=PATH` on the command line, if given.
fn cycle_table() -> Option<([u32; REGIONS_MAX], usize)> {
    let args = semihosting::experimental::env::args::<256>().unwrap_or_else(|_| qemu::exit(2));
    let arg = (&args)
        .filter_map(Result::ok)
        .find_map(|a| a.strip_prefix("cycles="))?;
    let mut path = [0u8; 256];
    if arg.len() >= path.len() {
        qemu::exit(2);
    }
    path[..arg.len()].copy_from_slice(arg.as_bytes());
    let path = core::ffi::CStr::from_bytes_until_nul(&path).unwrap_or_else(|_| qemu::exit(2));
    let mut file = semihosting::fs::File::open(path).unwrap_or_else(|_| qemu::exit(2));
    let mut table = [0u32; REGIONS_MAX];
    let mut n = 0;
    let mut word = [0u8; 4];
    while n < REGIONS_MAX {
        match semihosting::io::Read::read_exact(&mut file, &mut word) {
            Ok(()) => table[n] = u32::from_le_bytes(word),
            Err(_) => break,
        }
        n += 1;
    }
    Some((table, n))
}

/// A span the host's cycle model measures: two calls of this function
/// bound it (its own instructions not counted); each returns SysTick's
/// count, read inside it, so that QEMU's count and the model's differ by
/// the same few instructions of this function in every span (the empty
/// span's, subtracted).
#[inline(never)]
#[no_mangle]
extern "C" fn bench_region() -> u32 {
    SYST::get_current()
}

/// `f` called: each measured span is compiled into its own copy of this
/// function, placed with the per-block code (`hot-ram.x`) as the
/// firmware's tasks place their bodies, so that the cycle model's "as
/// placed" counts what the board runs from CCM SRAM.
#[inline(never)]
#[allow(unsafe_code)]
#[link_section = ".hot_ram"]
fn hot(f: impl FnOnce()) {
    f()
}

/// SysTick ticks spent in `f` (reload 2^24 − 1, counting down), or, with
/// a cycle table, the span's cycles.
fn ticks(clock: &mut Clock, f: impl FnOnce()) -> u32 {
    clock.syst.clear_current();
    let a = bench_region();
    hot(f);
    let b = bench_region();
    let k = clock.next;
    clock.next += 1;
    match &clock.table {
        // More spans than the host counted: the runs differ.
        Some((t, n)) if k < *n => t[k],
        Some(_) => qemu::exit(5),
        None => a.wrapping_sub(b) & 0x00ff_ffff,
    }
}

/// 2·n instructions.
#[inline(never)]
fn spin(n: u32) {
    // SAFETY: a register-only countdown loop.
    unsafe {
        core::arch::asm!("1:", "subs {0}, #1", "bne 1b", inout(reg) n => _, options(nomem, nostack));
    }
}

/// Demodulation of one block of sample pairs, with its peers; its
/// assembly inner loop checked against the portable one.
fn demod(syst: &mut Clock, insns: &dyn Fn(u32) -> u32) {
    let osc = Oscillator::coherent(6000.0, 200e3, 11).unwrap_or_else(|_| qemu::exit(4));
    let mut st = OscillatorState::default();
    let mut buf = [[0i16; 2]; PAIRS];
    for p in buf.iter_mut() {
        let (c, s) = osc.next(&mut st);
        *p = [(c >> 17) as i16, (s >> 18) as i16];
    }
    let dm = Demodulator::<PAIRS>::new(&osc);
    let t = ticks(syst, || {
        black_box(dm.block(black_box(&buf)));
    });
    let n = insns(t);
    // The assembly inner loop must match the portable one bit for bit.
    let (fast, slow) = (
        dm.block(&buf),
        dsp_core::demod::portable([0; 4], &buf, dm.reference()),
    );
    if [fast.v.re, -fast.v.im, fast.i.re, -fast.i.im] != slow {
        println!("FAIL demod assembly differs from portable");
        qemu::exit(1);
    }
    println!("check demod_asm_equals_portable ok");
    lockin_peer(syst, insns, &buf, &fast, osc.ftw());
    idsp_block_peer(syst, insns, &buf, osc.ftw());
    m4_floor(syst, insns, &buf, dm.reference(), &slow);
    println!("bench demod_block {} insn/block", n);
    println!(
        "bench demod_pair {}.{:02} insn/pair",
        n / PAIRS as u32,
        (n % PAIRS as u32) * 100 / PAIRS as u32
    );
}

/// Model evaluations and inversions, averaged over a few x.
fn models(syst: &mut Clock, insns: &dyn Fn(u32) -> u32) {
    let xs = [0.02f32, 0.1, 0.3, 1.0, 2.0, 3.5, 5.0, 6.0];
    for (name, model) in [
        ("ladder30", LineModel::Ladder(30)),
        ("continuous", LineModel::Continuous),
    ] {
        let mut total = 0;
        for &x in &xs {
            total += insns(ticks(syst, || {
                black_box(black_box(model).zeta(black_box(x)).ok());
            }));
        }
        println!("bench eval_{} {} insn/eval", name, total / xs.len() as u32);
        let inv = Inverter::new(model);
        let mut total = 0;
        let mut worst = 0;
        for &x in &xs {
            let zeta = model.zeta(x).unwrap_or_default();
            let (w, c) = (core::f32::consts::TAU * 6000.0, 200e-12f32);
            let z: Complex32 = zeta / (w * c);
            let t = insns(ticks(syst, || {
                black_box(inv.invert(black_box(z), 6000.0).ok());
            }));
            total += t;
            worst = worst.max(t);
        }
        println!("bench invert_{} {} insn/inversion", name, total / xs.len() as u32);
        println!("bench invert_{}_worst {} insn/inversion", name, worst);
    }
}

/// The FPU's square root must give libm's bits (IEEE: both correctly
/// rounded), or host and target would differ.
fn vsqrt_equals_libm() {
    let mut x = 1e-30f32;
    while x < 1e30 {
        if dsp_core::fmath::sqrt(x).to_bits() != libm::sqrtf(x).to_bits() {
            println!("FAIL vsqrt differs from libm at f32 bits {}", x.to_bits());
            qemu::exit(1);
        }
        x *= 1.013;
    }
    println!("check vsqrt_equals_libm ok");
}

#[entry]
fn main() -> ! {
    let cp = cortex_m::Peripherals::take().unwrap_or_else(|| qemu::exit(3));
    let syst = &mut Clock::new(cp.SYST);

    // Ticks per instruction from two spin lengths (overhead cancels).
    let (t1, t2) = (ticks(syst, || spin(20_000)), ticks(syst, || spin(60_000)));
    // With a cycle table, every span is in cycles already.
    let per_insn = match syst.cycles() {
        true => 1.0,
        false => (t2 - t1) as f32 / 80_000.0,
    };
    let empty = ticks(syst, || black_box(()));
    let insns = move |t: u32| ((t.saturating_sub(empty)) as f32 / per_insn) as u32;
    // (In thousandths, and the floats above as their bits: formatting
    // an f32 is 14 KiB, and this image fills QEMU's 256 KiB of flash.)
    let milli = (per_insn * 1000.0 + 0.5) as u32;
    println!("calib ticks_per_insn={}.{:03}", milli / 1000, milli % 1000);

    demod(syst, &insns);
    models(syst, &insns);
    vsqrt_equals_libm();
    two_tones(syst, &insns);
    newton_peer(syst, &insns);
    math(syst, &insns);
    block_budget(syst, &insns);
    array_budget(syst, &insns);
    link_frame(syst, &insns);
    qemu::exit(0)
}

/// quartiq's idsp lock-in (`idsp::Lockin` with its second-order
/// `Lowpass`, the way its users demodulate) on the same block as our
/// demodulator, one lock-in per channel: instructions per pair, and the
/// error of V/I against the block's exact value (v = 16384·cos θ,
/// i = 8192·sin θ: V/I = 2j) for both. The lowpass's corner is 100 Hz,
/// the best of 100, 150, 200, 300, 500 and 1000 Hz on this 10 ms block
/// (358, 417, 712, 1596, 4389 and 17 059 ppm: lower corners settle too
/// slowly, higher ones pass the 2f ripple); its output at the block's
/// last pair is the lock-in's reading.
fn lockin_peer(
    syst: &mut Clock,
    insns: &dyn Fn(u32) -> u32,
    buf: &[[i16; 2]; PAIRS],
    ours: &dsp_core::demod::Phasors,
    ftw: u32,
) {
    use core::num::Wrapping;
    use dsp_process::SplitProcess;
    use idsp::{Lockin, Lowpass, LowpassState};
    // k = π·2³¹·f0/f_Nyquist for f0 = 100 Hz at 100 kHz Nyquist; second
    // order: [k²/2³², −k·√2] (Butterworth).
    let k = (core::f64::consts::PI * 2_147_483_648.0 * 100.0 / 100e3) as i64;
    let lockin = Lockin(Lowpass::<2>([
        ((k * k) >> 32) as i32,
        -((k as f64 * core::f64::consts::SQRT_2) as i32),
    ]));
    let mut sv = [LowpassState::<2>::default(), LowpassState::<2>::default()];
    let mut si = [LowpassState::<2>::default(), LowpassState::<2>::default()];
    let (mut yv, mut yi) = (idsp::Complex::new(0, 0), idsp::Complex::new(0, 0));
    let t = insns(ticks(syst, || {
        let mut phase = Wrapping(0i32);
        for &[v, i] in black_box(buf).iter() {
            yv = lockin.process(&mut sv, ((v as i32) << 16, phase));
            yi = lockin.process(&mut si, ((i as i32) << 16, phase));
            phase += Wrapping(ftw as i32);
        }
    }));
    let (v, i) = (
        Complex32::new(yv.re() as f32, yv.im() as f32),
        Complex32::new(yi.re() as f32, yi.im() as f32),
    );
    let exact = Complex32::new(0.0, 2.0);
    let err = |r: Complex32| (r - exact).l1_norm() / exact.l1_norm();
    // idsp mixes with e^(+jθ), we with e^(−jθ): compare conjugates.
    let theirs = v.conj() / i.conj();
    let Some(mine) = ours.ratio() else { qemu::exit(6) };
    println!(
        "bench idsp_lockin_pair {}.{:02} insn/pair",
        t / PAIRS as u32,
        (t % PAIRS as u32) * 100 / PAIRS as u32
    );
    // Relative errors in parts per million.
    println!(
        "bench idsp_lockin_ratio_error_ppm {} ppm",
        (err(theirs) * 1e6) as u32
    );
    println!("bench demod_ratio_error_ppm {} ppm", (err(mine) * 1e6) as u32);
}

/// quartiq idsp's lock-in run the way its authors would for a block at
/// its best: its local oscillator from a table (idsp's own
/// `Complex::<i32>::from_angle`, computed once per frequency, as our
/// reference is) and, for its lowpass, the block's sum in i64 (a boxcar
/// over whole periods: exact, nothing to settle), through `Lockin`'s own
/// mixing (the sample shifted to the top of an i32, times the Q32
/// oscillator). Instructions per pair for both channels, and the error of
/// V/I against the exact 2j.
#[inline(never)]
fn idsp_block_peer(syst: &mut Clock, insns: &dyn Fn(u32) -> u32, buf: &[[i16; 2]; PAIRS], ftw: u32) {
    use core::num::Wrapping;
    use dsp_fixedpoint::Q32;
    use dsp_process::SplitProcess;
    use idsp::{Complex, Lockin};
    /// The block's sum as the lock-in's lowpass (its output unused).
    struct BlockSum;
    impl SplitProcess<i32, i32, i64> for BlockSum {
        #[inline(always)]
        fn process(&self, state: &mut i64, x: i32) -> i32 {
            *state += i64::from(x);
            x
        }
    }
    let lo: [Complex<Q32<32>>; PAIRS] = core::array::from_fn(|n| {
        let phase = Wrapping((n as u32).wrapping_mul(ftw) as i32);
        Complex::<Q32<32>>::from_bits(Complex::<i32>::from_angle(phase))
    });
    let lockin = Lockin(BlockSum);
    let (mut sv, mut si) = ([0i64; 2], [0i64; 2]);
    let t = insns(ticks(syst, || {
        for (&[v, i], &lo) in black_box(buf).iter().zip(black_box(&lo).iter()) {
            lockin.process(&mut sv, ((v as i32) << 16, lo));
            lockin.process(&mut si, ((i as i32) << 16, lo));
        }
    }));
    // idsp mixes with e^(+jθ), we with e^(−jθ): the conjugates.
    let v = Complex32::new(sv[0] as f32, -(sv[1] as f32));
    let i = Complex32::new(si[0] as f32, -(si[1] as f32));
    let exact = Complex32::new(0.0, 2.0);
    let err = (v / i - exact).l1_norm() / exact.l1_norm();
    println!(
        "bench idsp_block_pair {}.{:02} insn/pair",
        t / PAIRS as u32,
        (t % PAIRS as u32) * 100 / PAIRS as u32
    );
    println!("bench idsp_block_ratio_error_ppm {} ppm", (err * 1e6) as u32);
}

/// The Cortex-M4's floor for the four products of a pair, against which
/// demodulators are measured: each channel's samples packed two to a word
/// (as a DMA stream of one ADC's halfwords leaves them) and the reference
/// two cosines and two sines to a pair of words, one `SMLALD` (two 16×16
/// products into a 64-bit sum) per two products, a channel a pass (four
/// 64-bit sums, the pointers and four loaded words fill the eleven
/// registers inline assembly may use). No moments, no checks: the
/// products alone. Its sums must equal the portable demodulator's.
#[inline(never)]
fn m4_floor(
    syst: &mut Clock,
    insns: &dyn Fn(u32) -> u32,
    buf: &[[i16; 2]; PAIRS],
    reference: &[u32; PAIRS],
    want: &[i64; 4],
) {
    let pack = |a: i16, b: i16| (a as u16 as u32) | ((b as u16 as u32) << 16);
    let v: [u32; PAIRS / 2] = core::array::from_fn(|k| pack(buf[2 * k][0], buf[2 * k + 1][0]));
    let i: [u32; PAIRS / 2] = core::array::from_fn(|k| pack(buf[2 * k][1], buf[2 * k + 1][1]));
    // Words 2k and 2k + 1: [c(2k), c(2k + 1)] and [s(2k), s(2k + 1)].
    let r: [u32; PAIRS] = core::array::from_fn(|w| {
        let (k, sine) = (w / 2, w % 2 == 1);
        let half = |x: u32| if sine { (x >> 16) as i16 } else { x as i16 };
        pack(half(reference[2 * k]), half(reference[2 * k + 1]))
    });
    let mut got = [0i64; 4];
    let t = insns(ticks(syst, || {
        let (vc, vs) = floor_pass(black_box(&v), black_box(&r));
        let (ic, is) = floor_pass(black_box(&i), black_box(&r));
        got = [vc, vs, ic, is];
    }));
    if got != *want {
        println!("FAIL the floor kernel's sums differ from the portable demodulator's");
        qemu::exit(1);
    }
    println!("check m4_floor_equals_portable ok");
    println!(
        "bench m4_floor_pair {}.{:02} insn/pair",
        t / PAIRS as u32,
        (t % PAIRS as u32) * 100 / PAIRS as u32
    );
}

/// One channel of [`m4_floor`]: Σx·c and Σx·s over packed words, four
/// pairs a turn (`x.len()` a non-zero multiple of 2, `r` twice as long).
#[allow(unsafe_code)]
fn floor_pass(x: &[u32], r: &[u32]) -> (i64, i64) {
    if x.is_empty() || x.len() % 2 != 0 || r.len() != 2 * x.len() {
        qemu::exit(7);
    }
    let (mut cl, mut ch, mut sl, mut sh) = (0u32, 0u32, 0u32, 0u32);
    let (mut p, mut q) = (x.as_ptr(), r.as_ptr());
    // SAFETY: `p` walks `x` two words a turn and `q` walks `r` four words
    // a turn; `r` is twice as long as `x`, whose length is even and
    // non-zero, so both end together when `p` reaches `end`. Only
    // registers and the two slices are touched.
    unsafe {
        let end = p.add(x.len());
        core::arch::asm!(
            "2:",
            "ldrd {x0}, {x1}, [{p}], #8",
            "ldrd {a}, {b}, [{q}], #8",
            "smlald {cl}, {ch}, {x0}, {a}",
            "smlald {sl}, {sh}, {x0}, {b}",
            "ldrd {a}, {b}, [{q}], #8",
            "smlald {cl}, {ch}, {x1}, {a}",
            "smlald {sl}, {sh}, {x1}, {b}",
            "cmp {p}, {end}",
            "bne 2b",
            p = inout(reg) p,
            q = inout(reg) q,
            end = in(reg) end,
            cl = inout(reg) cl,
            ch = inout(reg) ch,
            sl = inout(reg) sl,
            sh = inout(reg) sh,
            x0 = out(reg) _,
            x1 = out(reg) _,
            a = out(reg) _,
            b = out(reg) _,
            options(nostack, readonly),
        );
    }
    let _ = (p, q);
    (
        ((ch as u64) << 32 | cl as u64) as i64,
        ((sh as u64) << 32 | sl as u64) as i64,
    )
}

/// The peer of our continuous-line inversion: a straightforward f32
/// Newton on Z = γ·coth γ/(jωC), γ = √(jωRC), with libm (`expf`,
/// `sincosf`, `logf`), in (ln R, ln C) from the series R-C reading
/// (R₀ = 3·Rs, C₀ = Cs: the line's low-x limit), at most 30 steps of at
/// most e. On the same impedances as `invert_continuous` (6 kHz, 200 pF,
/// x = 0.02–6): instructions, the largest C error, and the lines it
/// missed (no convergence to 10⁻³). Ours, for comparison, on the same.
fn newton_peer(syst: &mut Clock, insns: &dyn Fn(u32) -> u32) {
    let xs = [0.02f32, 0.1, 0.3, 1.0, 2.0, 3.5, 5.0, 6.0];
    let (w, c) = (core::f32::consts::TAU * 6000.0, 200e-12f32);
    let inv = Inverter::new(LineModel::Continuous);
    let (mut t_newton, mut t_ours, mut e_newton, mut e_ours, mut missed) = (0, 0, 0f32, 0f32, 0);
    for &x in &xs {
        let z: Complex32 = LineModel::Continuous.zeta(x).unwrap_or_default() / (w * c);
        let mut got = None;
        t_newton += insns(ticks(syst, || {
            got = newton_coth(black_box(z), w);
        }));
        match got {
            Some(cn) if libm::fabsf(cn / c - 1.0) < 1e-3 => {
                e_newton = e_newton.max(libm::fabsf(cn / c - 1.0))
            }
            _ => missed += 1,
        }
        let mut line = None;
        t_ours += insns(ticks(syst, || {
            line = inv.invert_near(black_box(z), 6000.0, 1.05 * c).ok();
        }));
        match line {
            Some(l) => e_ours = e_ours.max(libm::fabsf(l.c_farad / c - 1.0)),
            None => {
                println!("FAIL our inversion missed x = f32 bits {}", x.to_bits());
                qemu::exit(1);
            }
        }
    }
    let n = xs.len() as u32;
    println!("bench newton_coth {} insn/inversion", t_newton / n);
    println!("bench newton_coth_missed {} of 8", missed);
    println!("bench newton_coth_c_error_ppm {} ppm", (e_newton * 1e6) as u32);
    println!("bench ours_near {} insn/inversion", t_ours / n);
    println!("bench ours_near_c_error_ppm {} ppm", (e_ours * 1e6) as u32);
}

/// C (F) of the line whose impedance at ω is `z`, by Newton (see
/// [`newton_peer`]); `None` when it does not converge.
fn newton_coth(z: Complex32, w: f32) -> Option<f32> {
    let j = Complex32::new(0.0, 1.0);
    let c0 = -1.0 / (w * z.im);
    let r0 = 3.0 * z.re;
    if !(c0 > 0.0 && r0 > 0.0) {
        return None;
    }
    let (mut lr, mut lc) = (libm::logf(r0), libm::logf(c0));
    for _ in 0..30 {
        let (r, c) = (libm::expf(lr), libm::expf(lc));
        let s = libm::sqrtf(0.5 * w * r * c);
        let g = Complex32::new(s, s);
        let (sn, cs) = libm::sincosf(2.0 * s);
        let e2 = Complex32::new(cs, sn) * libm::expf(2.0 * s);
        let coth = (e2 + 1.0) / (e2 - 1.0);
        let k = (j * (w * c)).inv();
        let model = g * coth * k;
        let f = model - z;
        // d(γ coth γ)/dγ = coth γ − γ(coth² γ − 1); dγ/d ln R = γ/2.
        let dg = coth - g * (coth * coth - 1.0);
        let a = k * dg * g * 0.5;
        let b = a - model;
        let det = a.re * b.im - a.im * b.re;
        if !(det.is_finite() && det != 0.0) {
            return None;
        }
        let dr = (-f.re * b.im + f.im * b.re) / det;
        let dc = (-a.re * f.im + a.im * f.re) / det;
        #[allow(clippy::manual_clamp)]
        let clamp = |v: f32| v.max(-1.0).min(1.0);
        lr += clamp(dr);
        lc += clamp(dc);
        if libm::fabsf(dr) < 1e-6 && libm::fabsf(dc) < 1e-6 {
            return Some(libm::expf(lc));
        }
    }
    None
}

/// micromath and libm, instructions per call of each f32 function on the
/// device path, averaged over inputs across its range.
fn math(syst: &mut Clock, insns: &dyn Fn(u32) -> u32) {
    use micromath::F32;
    let xs = [1e-9f32, 3e-4, 0.02, 0.7, 1.3, 45.0, 7e3, 2e6];
    let ex = [-25.0f32, -7.0, -1.5, -0.2, 0.3, 2.0, 9.0, 22.0];
    let mut row = |name: &str, inputs: &[f32; 8], m: &dyn Fn(f32) -> f32, l: &dyn Fn(f32) -> f32| {
        let (mut tm, mut tl) = (0, 0);
        for &x in inputs {
            tm += insns(ticks(syst, || {
                black_box(m(black_box(x)));
            }));
            tl += insns(ticks(syst, || {
                black_box(l(black_box(x)));
            }));
        }
        println!("bench micromath_{} {} insn/call", name, tm / 8);
        println!("bench libm_{} {} insn/call", name, tl / 8);
    };
    row("exp", &ex, &|x| F32(x).exp().0, &libm::expf);
    row("ln", &xs, &|x| F32(x).ln().0, &libm::logf);
    row("sqrt", &xs, &|x| F32(x).sqrt().0, &libm::sqrtf);
    row("hypot", &xs, &|x| F32(x).hypot(F32(1.7 * x)).0, &|x| {
        libm::hypotf(x, 1.7 * x)
    });
}

/// The joint line of two tones (1.5 and 6 kHz) with its χ², from the
/// single-tone inversions, averaged over the higher tone at x = 0.3–5;
/// tracked from a line 2 % off in R and C, on a lossless film and, as
/// the channels solve it, on silicone with its loss fitted.
fn two_tones(syst: &mut Clock, insns: &dyn Fn(u32) -> u32) {
    use dsp_core::dielectric::Dielectric;
    use dsp_core::twotone::{solve, solve_from, Tone};
    let inv = Inverter::new(LineModel::Continuous);
    let c = 200e-12f32;
    let (mut total, mut worst, mut count) = (0, 0, 0);
    let (mut tracked, mut tracked_worst) = (0, 0);
    let (mut film_tracked, mut film_tracked_worst) = (0, 0);
    for x_hi in [0.3f32, 1.0, 2.0, 3.5, 5.0] {
        let tones = [1500.0f32, 6000.0].map(|f| {
            let w = core::f32::consts::TAU * f;
            let z = LineModel::Continuous.zeta(x_hi * f / 6000.0).unwrap_or_default() / (w * c);
            Tone {
                z,
                f_hz: f,
                sigma_ohm: 1e-4 * z.l1_norm(),
            }
        });
        let t = insns(ticks(syst, || {
            black_box(solve(&inv, &Dielectric::IDEAL, black_box(&tones), 1.05 * c).ok());
        }));
        let Ok(s) = solve(&inv, &Dielectric::IDEAL, &tones, 1.05 * c) else {
            println!("FAIL twotone at x = f32 bits {}", x_hi.to_bits());
            qemu::exit(1);
        };
        total += t;
        worst = worst.max(t);
        count += 1;
        // Tracking: from the previous record's line, 2 % off.
        let (r0, c0) = (1.02 * s.line.r_ohm, 0.98 * s.line.c_farad);
        let t = insns(ticks(syst, || {
            black_box(solve_from(&inv, &Dielectric::IDEAL, black_box(&tones), r0, c0, 0.0).ok());
        }));
        tracked += t;
        tracked_worst = tracked_worst.max(t);
        let film = Dielectric::SILICONE;
        let Ok(s) = solve(&inv, &film, &tones, 1.05 * c) else {
            println!("FAIL twotone on silicone at x = f32 bits {}", x_hi.to_bits());
            qemu::exit(1);
        };
        let (r0, c0) = (1.02 * s.line.r_ohm, 0.98 * s.line.c_farad);
        let t = insns(ticks(syst, || {
            black_box(solve_from(&inv, &film, black_box(&tones), r0, c0, s.loss_tangent).ok());
        }));
        film_tracked += t;
        film_tracked_worst = film_tracked_worst.max(t);
    }
    println!("bench twotone_solve {} insn/record", total / count);
    println!("bench twotone_solve_worst {} insn/record", worst);
    println!("bench twotone_tracked {} insn/record", tracked / count);
    println!("bench twotone_tracked_worst {} insn/record", tracked_worst);
    println!("bench twotone_tracked_film {} insn/record", film_tracked / count);
    println!(
        "bench twotone_tracked_film_worst {} insn/record",
        film_tracked_worst
    );
}

/// The record link: a record converted and encoded into its frame
/// (postcard, CRC-32, COBS), and the frame's length on the wire.
fn link_frame(syst: &mut Clock, insns: &dyn Fn(u32) -> u32) {
    let rec = instrument::tones::ToneRecord {
        t_us: 12_345_678,
        sensor: 11,
        f_hz: [500.0, 2000.0],
        z: [Complex32::new(4.1e5, -1.6e6), Complex32::new(2.0e5, -3.9e5)],
        c_farad: 205.1e-12,
        r_ohm: 1.0e6,
        chi2: 1.2,
        sigma_ln_c: 4e-4,
        stretch_mm: 3.5,
        flags: instrument::faults::Flags(0),
    };
    let mut enc = link::Encoder::new();
    let mut out = [0u8; link::MAX_FRAME];
    let mut len = 0;
    let n = insns(ticks(syst, || {
        // As the firmware sends it: the record's own encoder.
        let record = instrument::frames::from_tone_record(black_box(&rec));
        len = enc.record(&record, black_box(&mut out)).map_or(0, <[u8]>::len);
    }));
    println!("bench link_record_frame {} insn/record", n);
    println!("bench link_record_bytes {} bytes/record", len);
}

/// One whole firmware block: the lock-ins of its two tones on 1024 pairs
/// (the policy's with its guards, the second tone alone), then fault
/// checks, the two tones' line, policy and calibration
/// (`Channel::process`); and each lock-in alone, per pair.
fn block_budget(syst: &mut Clock, insns: &dyn Fn(u32) -> u32) {
    use instrument::calib::REFERENCE;
    use instrument::channel::{Channel, Settings};
    use instrument::config::{ftw, BLOCK_PAIRS};
    let fidx = 2;
    // A plausible block: both tones of frequency 2 at their shares of a
    // 1 V excitation, a 210 pF / 712 kΩ line (x = 1.8 at 1953 Hz).
    let tones = instrument::config::tones(fidx);
    let mut buf = [[0i16; 2]; BLOCK_PAIRS];
    for (k, &share) in instrument::config::TONE_SHARES.iter().enumerate() {
        let osc = Oscillator::from_ftw(ftw(tones[k]));
        let x = 1.8 * instrument::config::freq_hz(tones[k]) / instrument::config::freq_hz(fidx);
        let zeta = LineModel::Continuous.zeta(x).unwrap_or_default();
        let mut st = OscillatorState::default();
        // i ∝ Re{e^{jθ}/ζ}·x: a capacitive current, ~1000 counts at x = 1.8.
        let d = zeta.re * zeta.re + zeta.im * zeta.im;
        let (yr, yi) = (zeta.re / d * x / 1.8, -zeta.im / d * x / 1.8);
        for p in buf.iter_mut() {
            let (c, s) = osc.next(&mut st);
            let (c, s) = (c as f32 / 2.147_483_6e9, s as f32 / 2.147_483_6e9);
            p[0] += (1240.0 * share * c) as i16;
            p[1] += (-1000.0 * share * (yr * c - yi * s)) as i16;
        }
    }
    let Ok(sensor) = instrument::sensor::Sensor::calibrated(REFERENCE, 0.0, dsp_core::fixture::Fixture::NONE)
    else {
        qemu::exit(5)
    };
    let sensors = instrument::sensor::Sensors::<{ instrument::calib::POINTS }, 1>::all(sensor);
    let settings = Settings::new(
        instrument::ranging::Ranging::DEFAULT.front_ends(instrument::design::V_GAIN as f32),
        instrument::ranging::Ranging::DEFAULT,
        &sensors,
    );
    let mut ch = Channel::new(REFERENCE.rest_capacitance());
    ch.policy.fidx = fidx;
    ch.policy.settling = 0;
    let lockin = &instrument::config::LOCKINS[fidx];
    let lockin_insns = insns(ticks(syst, || {
        black_box(lockin.block(black_box(&buf)).ok());
    }));
    let companion = &instrument::config::LOCKINS[tones[1]];
    let tone_insns = insns(ticks(syst, || {
        black_box(companion.tone(black_box(&buf)).ok());
    }));
    let mut total = 0;
    for k in 0..4 {
        total += insns(ticks(syst, || {
            let ph = instrument::config::read(fidx, black_box(&buf));
            black_box(ch.process(&settings, 0, k as u64 * 40_000, &ph, false, 0));
        }));
    }
    let per_block = total / 4;
    // 5.12 ms of samples at 170 MHz: 870 400 cycles.
    println!(
        "bench lockin_pair {}.{:02} insn/pair",
        lockin_insns / BLOCK_PAIRS as u32,
        (lockin_insns % BLOCK_PAIRS as u32) * 100 / BLOCK_PAIRS as u32
    );
    println!(
        "bench lockin_tone_pair {}.{:02} insn/pair",
        tone_insns / BLOCK_PAIRS as u32,
        (tone_insns % BLOCK_PAIRS as u32) * 100 / BLOCK_PAIRS as u32
    );
    println!("bench block_process {} insn/block", per_block);
    println!(
        "bench block_load_permille {} permille",
        per_block as u64 * 1000 / 870_400
    );
}

/// One layout's array costs, instructions: the comb per input, the
/// channel per record (its solve and flags, with its share of the
/// inputs' levels), a whole block, and a record to frame.
struct ArrayCost {
    /// The comb alone (every input's tones, Σx and Σx²) per sensor's
    /// sample pair and tone, hundredths of an instruction.
    comb_pair_tone_x100: u32,
    comb_input: u32,
    channel: u32,
    block: u32,
    last: instrument::tones::ToneRecord,
}

/// One block of the array in `layout` (`skin-array-board`'s `process`,
/// through `instrument::reader`): the ADCs' offset-binary rows to two's
/// complement with the rail check, the comb on the excitation and on 16
/// sensor inputs, then 16 channels' two-tone lines; averaged over 8
/// blocks of sixteen of the paper's sensors, the channels tracking after
/// the first. Every record must be valid, and the assembly of the comb
/// and of the offset-binary pass must equal the portable code bit for
/// bit on every input of the last block.
fn array_run(syst: &mut Clock, insns: &dyn Fn(u32) -> u32, layout: instrument::array::Layout) -> ArrayCost {
    use instrument::array::{Frame, BLOCK_INSTANTS, SENSORS};
    use instrument::tones::ToneSettings;
    use skin_sim::array::ArrayFrontEnd;
    use skin_sim::frontend::Disturbance;
    use skin_sim::sensor::{Sensor, SensorParams};
    let fe = ArrayFrontEnd::reference(layout);
    let p = SensorParams::PAPER;
    let cal = skin_sim::sensor::PAPER_CALIBRATION;
    let Ok(paper) =
        instrument::sensor::Sensor::calibrated(cal, p.effects.lead_ratio(), dsp_core::fixture::Fixture::NONE)
    else {
        qemu::exit(5)
    };
    // The sixteen sensors' tables and the reader (10 KiB each) built
    // where they stay, each from a frame of its own: with the
    // temporaries that build them, this frame would take the stack past
    // QEMU's 64 KiB of RAM.
    let mut sensors = MaybeUninit::uninit();
    let sensors = &*qemu::place(&mut sensors, || instrument::sensor::Sensors::all(paper));
    let settings = ToneSettings::new(layout, fe.dsp_front_end(), sensors);
    let mut reader = MaybeUninit::uninit();
    let Some(reader) = qemu::place_reader(&mut reader, layout, sensors, instrument::mains::MAINS_HZ) else {
        qemu::exit(5)
    };
    let hz = layout.tones_hz().map(|f| f as f64);
    let z = [Sensor::settled(p).impedances(&hz); SENSORS];
    let mut rng = skin_sim::rng::Rng::new(7);
    let mut frame: Frame = [[[0; 4]; BLOCK_INSTANTS]; 5];
    let (mut total, mut comb_t, mut solve_t, mut blocks) = (0u32, 0u32, 0u32, 0u32);
    let mut demod_t = 0u32;
    let mut valid = 0;
    let mut last = instrument::tones::ToneRecord::default();
    let block_us = layout.block_us();
    let n_instants = layout.instants();
    for b in 0..9u64 {
        fe.frame(&z, &[Disturbance::NONE; SENSORS], &mut rng, &mut frame);
        // As the board's DMA leaves them: offset binary (the flip is its
        // own inverse).
        for rows in frame.iter_mut() {
            dsp_core::scan::portable(&mut rows[..n_instants]);
        }
        let mut recs = [instrument::tones::ToneRecord::default(); SENSORS];
        let t_us = b * block_us + block_us / 2;
        let cost = array_block(syst, insns, reader, &settings, &mut frame, t_us, &mut recs);
        // The first block starts every channel from the inversions.
        if b > 0 {
            comb_t += cost.to_signed + cost.comb;
            demod_t += cost.comb;
            solve_t += cost.solve;
            total += cost.to_signed + cost.comb + cost.solve;
            blocks += 1;
            valid += recs.iter().filter(|r| r.flags.valid()).count();
            last = recs[0];
        }
    }
    if let Some(what) = assembly_differs(reader.comb(), layout, &frame) {
        println!("FAIL {what}'s assembly differs from portable");
        qemu::exit(1);
    }
    if valid != SENSORS * blocks as usize {
        println!(
            "FAIL array bench: {} valid records of {}",
            valid,
            SENSORS as u32 * blocks
        );
        qemu::exit(1);
    }
    // Per sample pair (a sensor's sample and its share of the
    // excitation's) and tone, in hundredths.
    let pair_tones = blocks * (SENSORS * n_instants * instrument::array::TONES) as u32;
    ArrayCost {
        comb_pair_tone_x100: (demod_t as u64 * 100 / pair_tones as u64) as u32,
        comb_input: comb_t / blocks / (SENSORS as u32 + 1),
        channel: solve_t / blocks / SENSORS as u32,
        block: total / blocks,
        last,
    }
}

/// Instructions of one array block, by stage.
struct BlockCost {
    /// The ADCs' rows to two's complement, with the rail check.
    to_signed: u32,
    /// The comb on every input.
    comb: u32,
    /// Every sensor's channel: its solve and flags.
    solve: u32,
}

/// One block as the board's `process` takes it, counted by stage: to
/// two's complement in place noting the inputs on a rail, the comb on
/// every input, then every channel; its records into `recs`.
fn array_block<const N: usize>(
    syst: &mut Clock,
    insns: &dyn Fn(u32) -> u32,
    reader: &mut instrument::reader::ArrayReader,
    settings: &instrument::tones::ToneSettings<'_, N>,
    frame: &mut instrument::array::Frame,
    t_us: u64,
    recs: &mut [instrument::tones::ToneRecord; instrument::array::SENSORS],
) -> BlockCost {
    let layout = settings.layout;
    let n = layout.instants();
    let mut rails = [false; instrument::array::INPUTS];
    let to_signed = insns(ticks(syst, || {
        let [f0, f1, f2, f3, f4] = black_box(&mut *frame);
        rails = instrument::array::to_signed_all(&mut [
            &mut f0[..n],
            &mut f1[..n],
            &mut f2[..n],
            &mut f3[..n],
            &mut f4[..n],
        ]);
    }));
    let mut block = instrument::reader::Demodulated::EMPTY;
    let comb = insns(ticks(syst, || {
        reader.demodulate_into(|a| layout.rows(black_box(&frame[a])), &mut block);
    }));
    let solve = insns(ticks(syst, || {
        let mut s = 0;
        reader.solve(
            settings,
            t_us,
            &block,
            |input| rails[input],
            |r| {
                recs[s] = r;
                s += 1;
            },
        );
    }));
    BlockCost {
        to_signed,
        comb,
        solve,
    }
}

/// Which of the array's assembly loops (the comb's, the hum's, the
/// offset-binary pass's) gives other integers than its portable code on
/// `frame` (a block of `layout`), if any.
fn assembly_differs(
    comb: &instrument::reader::BlockComb,
    layout: instrument::array::Layout,
    frame: &instrument::array::Frame,
) -> Option<&'static str> {
    if !comb_matches_portable(comb, layout, frame) {
        Some("the comb")
    } else if !hum_matches_portable(comb, layout, frame) {
        Some("the hum")
    } else if !offset_binary_matches_portable(frame) {
        Some("the offset-binary pass")
    } else {
        None
    }
}

/// The comb's assembly inner loop against the portable one, bit for bit,
/// on every input of `frame` (a block of `layout`).
fn comb_matches_portable(
    comb: &instrument::reader::BlockComb,
    layout: instrument::array::Layout,
    frame: &instrument::array::Frame,
) -> bool {
    use instrument::reader::BlockComb;
    frame.iter().all(|rows| {
        let rows = layout.rows(rows);
        (0..4).all(|col| match comb {
            BlockComb::Long(c) => rows.first_chunk().is_some_and(|r| column_matches(c, r, col)),
            BlockComb::Short(c) => rows.first_chunk().is_some_and(|r| column_matches(c, r, col)),
        })
    })
}

/// The hum's sums ([`dsp_core::hum::Mains::sums`], dual products in
/// assembly) against the plain ones, bit for bit, on every input of
/// `frame`, for 50 and 60 Hz beside `comb`'s tones (the 1 ms block's 25
/// instants leave one to the plain loop).
fn hum_matches_portable(
    comb: &instrument::reader::BlockComb,
    layout: instrument::array::Layout,
    frame: &instrument::array::Frame,
) -> bool {
    use instrument::mains::BlockMains;
    [50, 60].into_iter().all(|hz| {
        let mains = BlockMains::new(comb, hz);
        frame.iter().all(|rows| {
            let rows = layout.rows(rows);
            (0..4).all(|col| match &mains {
                BlockMains::Long(m) => rows.first_chunk().is_some_and(|r| hum_column_matches(m, r, col)),
                BlockMains::Short(m) => rows.first_chunk().is_some_and(|r| hum_column_matches(m, r, col)),
            })
        })
    })
}

/// One input's hum sums from `mains` equal the plain sums.
fn hum_column_matches<const B: usize, const K: usize>(
    mains: &dsp_core::hum::Mains<B, K>,
    rows: &[[i16; 4]; B],
    col: usize,
) -> bool {
    let [c, s] = dsp_core::hum::portable(mains.words().iter(), rows, col, 0);
    mains.sums(rows, col) == [c << 16, s << 16]
}

/// One input's tones and moments from `comb` equal the plain sums.
fn column_matches<const B: usize, const K: usize>(
    comb: &dsp_core::comb::Comb<B, K>,
    rows: &[[i16; 4]; B],
    col: usize,
) -> bool {
    let fast = comb.column(rows, col);
    [fast.sum, fast.sq] == dsp_core::comb::portable_moments(rows, col)
        && fast.x.iter().enumerate().all(|(k, x)| {
            comb.reference(k).is_some_and(|reference| {
                let [cs, sn] = dsp_core::comb::portable(rows, col, reference);
                x.re == cs && x.im == -sn
            })
        })
}

/// The offset-binary pass's assembly against the portable one: rows and
/// extremes, on every ADC's rows of `frame` and on the rails.
fn offset_binary_matches_portable(frame: &instrument::array::Frame) -> bool {
    use instrument::array::BLOCK_INSTANTS;
    let mut rails_rows = [[0i16; 4]; 7];
    for (k, row) in rails_rows.iter_mut().enumerate() {
        *row = [i16::MIN, i16::MAX, -1, 0].map(|x| x.wrapping_add(k as i16));
    }
    frame
        .iter()
        .map(|r| &r[..])
        .chain(core::iter::once(&rails_rows[..]))
        .all(|rows| {
            let (mut fast, mut slow) = ([[0i16; 4]; BLOCK_INSTANTS], [[0i16; 4]; BLOCK_INSTANTS]);
            fast[..rows.len()].copy_from_slice(rows);
            slow[..rows.len()].copy_from_slice(rows);
            let (f, p) = (
                dsp_core::scan::to_signed(&mut fast[..rows.len()]),
                dsp_core::scan::portable(&mut slow[..rows.len()]),
            );
            f == p && fast == slow
        })
}

/// `Comb::column` (on this target, the assembly) against the plain sums
/// (`comb::portable`, `comb::portable_moments`) on a comb of `periods`
/// over `B` instants: random codes, then the rails, every input of a
/// 4-input row.
#[inline(never)]
fn comb_shape<const B: usize>(rng: &mut skin_sim::rng::Rng, periods: [u32; 3]) -> bool {
    let Ok(comb) = dsp_core::comb::Comb::<B, 3>::new(periods) else {
        return false;
    };
    let mut rows = [[0i16; 4]; B];
    (0..4).all(|case| {
        for row in rows.iter_mut() {
            for v in row.iter_mut() {
                *v = match case {
                    0 => i16::MIN,
                    1 => i16::MAX,
                    _ => rng.next_u32() as i16,
                };
            }
        }
        (0..4).all(|col| {
            let t = comb.column(&rows, col);
            [t.sum, t.sq] == dsp_core::comb::portable_moments(&rows, col)
                && t.x.iter().enumerate().all(|(k, x)| {
                    comb.reference(k).is_some_and(|r| {
                        let [c, s] = dsp_core::comb::portable(&rows, col, r);
                        (x.re, x.im) == (c, -s)
                    })
                })
        })
    })
}

/// The array in both layouts. The load is of a block at 170 MHz (4 ms:
/// 680 000 cycles; 1 ms: 170 000), the latency from a block's last
/// sample to its last record at one instruction per cycle (for 1 ms
/// blocks, its sixteen records framed for the link too).
/// `array_channel` includes the sensor's share of the inputs' levels
/// (amplitudes and residual).
fn array_budget(syst: &mut Clock, insns: &dyn Fn(u32) -> u32) {
    use instrument::array::Layout;
    let long = array_run(syst, insns, Layout::BLOCK_4MS);
    let short = array_run(syst, insns, Layout::BLOCK_1MS);
    // And on shapes the layouts leave out: pairs the assembly's turns
    // leave to Rust, odd periods, a comb that repeats twice, odd periods
    // over halves of an odd length, a block too short for the assembly
    // (the plain sums); each
    // shape is some 7 KiB of this image, and the host tests more (Rust's
    // fold of combs that repeat more often among them).
    let mut rng = skin_sim::rng::Rng::new(30);
    if !(comb_shape::<28>(&mut rng, [2, 4, 6])
        && comb_shape::<101>(&mut rng, [1, 7, 50])
        && comb_shape::<58>(&mut rng, [1, 6, 28])
        && comb_shape::<12>(&mut rng, [1, 2, 5]))
    {
        println!("FAIL comb assembly differs from portable");
        qemu::exit(1);
    }
    println!("check comb_asm_equals_portable ok");
    println!("check hum_asm_equals_portable ok");
    for (name, cost) in [
        ("array_comb_pair_tone", &long),
        ("array_comb_1ms_pair_tone", &short),
    ] {
        println!(
            "bench {name} {}.{:02} insn/pair",
            cost.comb_pair_tone_x100 / 100,
            cost.comb_pair_tone_x100 % 100
        );
    }
    println!("bench array_comb_input {} insn/input", long.comb_input);
    println!("bench array_channel {} insn/record", long.channel);
    println!("bench array_block {} insn/block", long.block);
    println!(
        "bench array_load_permille {} permille",
        long.block as u64 * 1000 / 680_000
    );
    println!("bench array_latency_us {} us", long.block / 170);
    // A record to its link frame (postcard, CRC-32, COBS).
    let mut enc = link::Encoder::new();
    let mut out = [0u8; link::MAX_FRAME];
    let frame_t = insns(ticks(syst, || {
        let record = instrument::frames::from_tone_record(black_box(&long.last));
        black_box(enc.record(&record, black_box(&mut out)).map_or(0, <[u8]>::len));
    }));
    let record = long.channel + frame_t;
    let record_1ms = short.channel + frame_t;
    println!("bench array_comb_1ms_input {} insn/input", short.comb_input);
    println!("bench array_record_linked {} insn/record", record);
    println!("bench array_record_linked_1ms {} insn/record", record_1ms);
    // The 1 ms block as measured, with its sixteen records framed.
    let linked_1ms = short.block + 16 * frame_t;
    println!(
        "bench array_load_1000_permille {} permille",
        linked_1ms as u64 * 1000 / 170_000
    );
    println!("bench array_latency_1000_us {} us", linked_1ms / 170);
    // What 16 or 32 sensors at 250 or 1000 records/s take, from the
    // measured parts of each layout: the comb per input (the excitation's
    // besides each sensor's) and per record the channel and its frame.
    for sensors in [16u64, 32] {
        for (rate, comb, rec) in [
            (250u64, long.comb_input, record),
            (1000, short.comb_input, record_1ms),
        ] {
            let per_s = (sensors + 1) * rate * comb as u64 + sensors * rate * rec as u64;
            println!(
                "bench array_share_{}x{}_permille {} permille",
                sensors,
                rate,
                per_s * 1000 / 170_000_000
            );
        }
    }
}
