//! The benchmark and image-size tables `cargo xtask bench` prints and
//! `docs/benchmarks.md` shows (checked there by the QEMU tests).

use crate::Bench;
use anyhow::Result;
use std::fmt::Write as _;

/// What each instruction-count benchmark of `dsp-bench` measures (names
/// ending in `_{fn}` for the f32 functions are described by their
/// prefix).
pub const BENCH_NOTES: &[(&str, &str)] = &[
    (
        "demod_pair",
        "demodulation, per sample pair (with the moments of the disturbance check)",
    ),
    ("demod_block", "demodulation of one 2048-pair block"),
    ("demod_ratio_error_ppm", "V/I error of our demodulator"),
    (
        "idsp_lockin_pair",
        "quartiq idsp's lock-in on the same block, per pair (the peer)",
    ),
    ("idsp_lockin_ratio_error_ppm", "its V/I error"),
    (
        "idsp_block_pair",
        "idsp's lock-in at its best: its oscillator from a table, the block's sum for its lowpass, per pair",
    ),
    ("idsp_block_ratio_error_ppm", "its V/I error"),
    (
        "m4_floor_pair",
        "the Cortex-M4's floor: the four products of a pair by SMLALD on samples packed two to a word, nothing else",
    ),
    ("eval_ladder30", "30-element ladder evaluation"),
    ("eval_continuous", "continuous-line evaluation"),
    (
        "invert_continuous",
        "inversion without a prior, continuous line, mean (the one line that fits and its κ, or the refusal where more than one does)",
    ),
    ("invert_continuous_worst", "inversion, continuous line, worst"),
    ("invert_ladder30", "inversion, 30-element ladder, mean"),
    ("invert_ladder30_worst", "inversion, 30-element ladder, worst"),
    (
        "newton_coth",
        "the peer: f32 libm Newton on Z = γ·coth γ/(jωC), 8 lines",
    ),
    ("newton_coth_missed", "lines the Newton peer did not converge on"),
    ("newton_coth_c_error_ppm", "its C error where it converged"),
    (
        "ours_near",
        "our inversion on the same 8 lines, branch by the expected C",
    ),
    ("ours_near_c_error_ppm", "its C error"),
    ("twotone_solve", "two-tone joint line and χ², mean"),
    ("twotone_solve_worst", "two-tone joint line and χ², worst"),
    (
        "twotone_tracked",
        "two-tone line from the previous record's, mean",
    ),
    (
        "twotone_tracked_worst",
        "two-tone line from the previous record's, worst",
    ),
    (
        "twotone_tracked_film",
        "the same on silicone, its loss fitted (as the channels solve it), mean",
    ),
    (
        "twotone_tracked_film_worst",
        "the same on silicone, worst",
    ),
    (
        "lockin_pair",
        "the multiplexed channel's lock-in at the policy's tone (Nuttall window, two guard bins), per pair",
    ),
    (
        "lockin_tone_pair",
        "the same lock-in at the block's second tone, without guards, per pair",
    ),
    (
        "block_process",
        "one multiplexed block: both tones' lock-ins, checks, the two tones' line, policy, range",
    ),
    (
        "block_load_permille",
        "its share of a 170 MHz Cortex-M4 over a 5.12 ms block",
    ),
    (
        "array_comb_pair_tone",
        "the comb alone (every input's tones, Σx and Σx²; the excitation's input shared by the 16 sensors) per sensor's sample pair and tone, 4 ms blocks",
    ),
    (
        "array_comb_1ms_pair_tone",
        "the same in 1 ms blocks",
    ),
    (
        "array_comb_input",
        "the comb (5 tones) on one array input, with its share of the block's offset-binary pass and rail check",
    ),
    ("array_channel", "one array sensor's record"),
    (
        "array_block",
        "one array block as the board's task takes it: the offset-binary pass and rail check, 17 inputs, 16 records",
    ),
    (
        "array_load_permille",
        "the array's share of a 170 MHz Cortex-M4 (16 sensors × 250 records/s)",
    ),
    (
        "array_latency_us",
        "latency from a block's last result to its last record",
    ),
    (
        "array_comb_1ms_input",
        "the same on one input of a 1 ms block (`Layout::BLOCK_1MS`: 25 instants, tones of 1, 2, 3, 4, 6 kHz)",
    ),
    (
        "array_record_linked",
        "one array record with its link frame: solve, flags, its share of the levels, encoding",
    ),
    (
        "array_record_linked_1ms",
        "the same in 1 ms blocks",
    ),
    (
        "array_load_1000_permille",
        "16 sensors × 1000 records/s as measured: a 1 ms block's 17 inputs and 16 records with their link frames, share of a 170 MHz Cortex-M4",
    ),
    (
        "array_latency_1000_us",
        "the same block: from its last result to its last record framed for the link, at one instruction per cycle",
    ),
    (
        "array_share_",
        "from the measured parts of each layout (comb per input, record with its frame): share of a 170 MHz Cortex-M4 for sensors × records/s",
    ),
    (
        "link_record_frame",
        "an array record converted and encoded into its link frame (postcard, CRC-32, COBS)",
    ),
    ("link_record_bytes", "that frame's length on the wire"),
    ("micromath_", "micromath's f32 function, per call"),
    ("libm_", "libm's f32 function, per call"),
];

/// The note of benchmark `name`.
pub fn bench_note(name: &str) -> &'static str {
    BENCH_NOTES
        .iter()
        .find(|(n, _)| *n == name)
        .or_else(|| {
            BENCH_NOTES
                .iter()
                .find(|(n, _)| n.ends_with('_') && name.starts_with(n))
        })
        .map_or("", |(_, d)| d)
}

/// The Markdown table of a `dsp-bench` run, with the budgets the tests
/// hold.
pub fn bench_table(benches: &[Bench]) -> String {
    let mut md = String::from("| benchmark | what | value | budget |\n|---|---|---:|---:|\n");
    for b in benches {
        let budget = crate::DSP_BUDGETS
            .iter()
            .find(|(n, _)| *n == b.name)
            .map_or_else(|| "–".to_string(), |(_, v)| format!("≤ {v}"));
        let _ = writeln!(
            md,
            "| `{}` | {} | {} {} | {budget} |",
            b.name,
            bench_note(&b.name),
            b.value,
            b.unit
        );
    }
    md
}

/// The benchmarks in cycles: each figure's instructions, and its cycles
/// (low–high) with the code as the firmware places it (its hot section
/// in CCM SRAM), all in CCM SRAM, and all in flash.
pub fn cycle_table(rows: &[crate::cycles::CycleBench]) -> String {
    let mut md = String::from(
        "| benchmark | instructions | cycles, code as placed | all in CCM SRAM | all in flash (ART) | unit | budget (goal) |\n|---|---:|---:|---:|---:|---|---:|\n",
    );
    for r in rows {
        // Per pair to the hundredth, as the benchmark prints it.
        let fmt = |x: f64| match r.unit.ends_with("pair") {
            true => format!("{x:.2}"),
            false => format!("{x:.0}"),
        };
        let budget = crate::CYCLE_BUDGETS
            .iter()
            .find(|(n, _, _)| *n == r.name)
            .map_or_else(
                || "–".to_string(),
                |&(_, b, g)| match b == g {
                    true => format!("{b}"),
                    false => format!("{b} ({g})"),
                },
            );
        let unit = match r.unit.as_str() {
            "permille" => "‰ of a 170 MHz core".to_string(),
            "us" => "µs at 170 MHz".to_string(),
            u => u.replace("insn/", "per "),
        };
        let _ = writeln!(
            md,
            "| `{}` | {} | {}–{} | {}–{} | {}–{} | {unit} | {budget} |",
            r.name,
            fmt(r.insns),
            fmt(r.placed.0),
            fmt(r.placed.1),
            fmt(r.ccm.0),
            fmt(r.ccm.1),
            fmt(r.flash.0),
            fmt(r.flash.1)
        );
    }
    md
}

/// A firmware image: (binary, features (comma-separated: the first the
/// target's, any further named beside the binary), what it is, budget of
/// flash and static RAM in bytes where it has one).
pub type Image = (&'static str, &'static str, &'static str, Option<(u64, u64)>);

/// The firmware images.
pub const IMAGES: [Image; 7] = [
    (
        "skin-board",
        "board",
        "STM32G474, 8 sensors multiplexed",
        Some(crate::BOARD_BUDGET),
    ),
    (
        "skin-board",
        "board,store",
        "the same with its settings store (host requests, sets in flash)",
        Some(crate::BOARD_STORE_BUDGET),
    ),
    (
        "skin-array-board",
        "board",
        "STM32G474, 16 sensors at once",
        Some(crate::ARRAY_BOARD_BUDGET),
    ),
    (
        "skin-array-board",
        "board,array-1ms",
        "the same in 1 ms blocks, 1000 records/s",
        Some(crate::ARRAY_BOARD_BUDGET),
    ),
    (
        "skin-qemu",
        "qemu",
        "QEMU, multiplexed, with its simulated skin (its static RAM holds its per-block code)",
        None,
    ),
    (
        "skin-array",
        "qemu",
        "QEMU, the array, with its simulated skin",
        None,
    ),
    (
        "dsp-bench",
        "bench",
        "QEMU, the instruction-count benchmarks",
        None,
    ),
];

/// KiB with one decimal.
fn kib(bytes: u64) -> String {
    format!("{:.1} KiB", bytes as f64 / 1024.0)
}

/// Build every image (release) and tabulate its flash and static RAM.
pub fn image_table() -> Result<String> {
    let mut md = String::from("| image | what | flash | static RAM | budget |\n|---|---|---:|---:|---:|\n");
    for (bin, feature, what, budget) in IMAGES {
        let elf = crate::build_firmware(bin, &[feature])?;
        let (flash, ram) = crate::image_size(&elf)?;
        let budget = budget.map_or_else(|| "–".to_string(), |(f, r)| format!("{} / {}", kib(f), kib(r)));
        let name = match feature.split_once(',') {
            Some((_, extra)) => format!("`{bin}` (`{extra}`)"),
            None => format!("`{bin}`"),
        };
        let _ = writeln!(
            md,
            "| {name} | {what} | {} | {} | {budget} |",
            kib(flash),
            kib(ram)
        );
    }
    Ok(md)
}

/// The headline figures on speed, from a `dsp-bench` run (a table of
/// `figures`).
pub fn speed_headline(benches: &[Bench], cycles: &[crate::cycles::CycleBench]) -> String {
    let get = |n: &str| benches.iter().find(|b| b.name == n).map_or(f64::NAN, |b| b.value);
    let cyc = |n: &str| cycles.iter().find(|b| b.name == n);
    // A share in cycles (the high bound), the code as placed, and by
    // instructions, in %.
    let share = |n: &str| {
        cyc(n).map_or("–".to_string(), |c| {
            format!("{:.1} % ({:.1} %)", c.placed.1 / 10.0, c.insns / 10.0)
        })
    };
    let latency = |n: &str| {
        cyc(n).map_or("–".to_string(), |c| {
            format!("{:.0} µs ({:.0})", c.placed.1, c.insns)
        })
    };
    figures::table(&[
        (
            "Cortex-M4 at 170 MHz, share of the CPU in cycles (the cycle model's high bound, the per-block code in CCM SRAM as the firmware places it; by instructions): the array's 16 sensors × 250 records/s, each record framed for the link"
                .to_string(),
            share("array_share_16x250_permille"),
        ),
        (
            "the same at 1000 records/s (1 ms blocks); from a block's end to its last frame".to_string(),
            format!("{}; {}", share("array_load_1000_permille"), latency("array_latency_1000_us")),
        ),
        (
            "one multiplexed block".to_string(),
            share("block_load_permille"),
        ),
        (
            "the multiplexed channel's lock-ins (window; the policy's tone with two guard bins, then the second tone), instructions per sample pair"
                .to_string(),
            format!("{} + {}", get("lockin_pair"), get("lockin_tone_pair")),
        ),
        (
            "least-squares demodulation of one tone (`dsp_core::demod`, the bare tone the lock-in replaced), instructions per sample pair (quartiq idsp's lock-in on the same block, sample by sample / at its best; the Cortex-M4's floor for the products alone)"
                .to_string(),
            format!(
                "{} ({} / {}; {})",
                get("demod_pair"),
                get("idsp_lockin_pair"),
                get("idsp_block_pair"),
                get("m4_floor_pair")
            ),
        ),
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn notes_cover_names_and_prefixes() {
        assert!(bench_note("demod_pair").starts_with("demodulation"));
        assert!(bench_note("libm_exp").starts_with("libm"));
        assert_eq!(bench_note("no_such_bench"), "");
    }
}
