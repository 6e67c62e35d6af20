//! The board images build, link, and fit their budgets (8 channels
//! multiplexed, with and without the settings store; the array of 16).

/// Builds `bin` with `features`, and asserts its flash and static RAM
/// within `budget` and above `floor` (bytes: not trivially small).
fn fits(bin: &str, features: &[&str], budget: (u64, u64), floor: (u64, u64)) {
    let elf = qemu_tests::build_firmware(bin, features).unwrap();
    let (flash, ram) = qemu_tests::image_size(&elf).unwrap();
    let (max_flash, max_ram) = budget;
    println!("{bin} {features:?}: flash {flash} B (≤ {max_flash}), static RAM {ram} B (≤ {max_ram})");
    assert!(flash <= max_flash && ram <= max_ram, "flash {flash}, RAM {ram}");
    assert!(flash > floor.0 && ram > floor.1, "flash {flash}, RAM {ram}");
}

#[test]
#[ignore = "long: cargo xtask test --full"]
fn board_image_fits_64k_flash_and_16k_ram() {
    // Not trivially small either: the DMA buffers alone take 9.6 KiB
    // (the ADC's two slots 8.5, the DAC's ring 1.06).
    fits(
        "skin-board",
        &["board"],
        qemu_tests::BOARD_BUDGET,
        (16 * 1024, 9 * 1024 + 512),
    );
}

/// The multiplexed board with its settings store (feature `store`):
/// within the same 64 / 16 KiB, and above what the plain image takes
/// (docs/benchmarks.md): the request side, the store, and eight sensors'
/// settings where it keeps one.
#[test]
fn board_image_with_the_store_fits_64k_flash_and_16k_ram() {
    fits(
        "skin-board",
        &["board", "store"],
        qemu_tests::BOARD_STORE_BUDGET,
        (52 * 1024, 12 * 1024),
    );
}

/// The array's floor: the five ADC buffers (8000 B), the DAC's table
/// (8000 B) and the record queue are static.
const ARRAY_FLOOR: (u64, u64) = (32 * 1024, 20 * 1024);

#[test]
fn array_board_image_fits_96k_flash_and_48k_ram() {
    fits(
        "skin-array-board",
        &["board"],
        qemu_tests::ARRAY_BOARD_BUDGET,
        ARRAY_FLOOR,
    );
}

/// The array in 1 ms blocks (feature `array-1ms`) within the same
/// budgets.
#[test]
#[ignore = "long: cargo xtask test --full"]
fn array_board_in_1ms_blocks_fits_the_same_budgets() {
    fits(
        "skin-array-board",
        &["board", "array-1ms"],
        qemu_tests::ARRAY_BOARD_BUDGET,
        ARRAY_FLOOR,
    );
}

#[test]
#[ignore = "long: cargo xtask test --full"]
fn every_image_is_tabulated() {
    let table = qemu_tests::tables::image_table().unwrap();
    assert_eq!(
        table.lines().count(),
        2 + qemu_tests::tables::IMAGES.len(),
        "{table}"
    );
    figures::check_within("docs/benchmarks.md", "images", &table, qemu_tests::BUILD_SPREAD).unwrap();
}

/// A board image's per-block code (`firmware/hot-ram.x`): its section
/// linked in the CCM SRAM on the instruction bus (0x1000_0000, 32 KiB)
/// with its image in flash and a load segment that says so, the reset
/// handler's copy (`__pre_init`) ours and not cortex-m-rt's empty one,
/// and the functions named in `hot` inside it.
fn hot_code_in_ccm(bin: &str, features: &[&str], hot: &[&str]) {
    use object::{Object, ObjectSegment, ObjectSymbol};
    let elf = qemu_tests::build_firmware(bin, features).unwrap();
    let data = std::fs::read(&elf).unwrap();
    let file = object::File::parse(&*data).unwrap();
    let symbol = |name: &str| {
        file.symbols()
            .find(|s| s.name() == Ok(name))
            .map(|s| s.address())
            .unwrap_or_else(|| panic!("{bin}: no symbol {name}"))
    };
    let (start, end, load) = (symbol("__shot_ram"), symbol("__ehot_ram"), symbol("__sihot_ram"));
    println!(
        "{bin}: hot code {} B at {start:#x}, loaded from {load:#x}",
        end - start
    );
    assert_eq!(start, 0x1000_0000);
    assert!(end > start + 8 * 1024 && end <= start + 32 * 1024, "{end:#x}");
    assert!((0x0800_0000..0x0807_e000).contains(&load), "{load:#x}");
    // The ELF's load segment for it: at CCM SRAM, from flash.
    let ccm = file
        .segments()
        .find(|s| s.address() == start)
        .expect("a segment at the CCM SRAM");
    assert_eq!(ccm.size(), end - start);
    let raw = ccm.data().unwrap();
    assert_eq!(raw.len() as u64, end - start, "its bytes are in the image");
    // Reset calls ours: not cortex-m-rt's default.
    let pre_init = symbol("__pre_init");
    if let Some(default) = file.symbols().find(|s| s.name() == Ok("DefaultPreInit")) {
        assert_ne!(default.address(), pre_init);
    }
    for name in hot {
        let f = file
            .symbols()
            .find(|s| s.name().is_ok_and(|n| n.contains(name)) && s.size() > 0)
            .unwrap_or_else(|| panic!("{bin}: no function like {name}"));
        assert!(
            (start..end).contains(&(f.address() & !1)),
            "{name} at {:#x}",
            f.address()
        );
    }
}

#[test]
fn the_boards_run_their_per_block_code_from_ccm_sram() {
    hot_code_in_ccm(
        "skin-array-board",
        &["board"],
        &[
            "read_block",
            "twotone6refine",
            "checksum_and_stuff",
            "tones5Input2of",
        ],
    );
    hot_code_in_ccm(
        "skin-board",
        &["board", "store"],
        &["lock_ins", "read_slot", "checksum_and_stuff", "twotone6refine"],
    );
}

/// The tests and xtask build the firmware for the CPU that
/// `.cargo/config.toml` names for `cargo build-board` and its kin (their
/// flags replace the file's).
#[test]
fn the_tests_build_for_the_cpu_the_cargo_config_names() {
    let config = std::fs::read_to_string(qemu_tests::root().join(".cargo/config.toml")).unwrap();
    let flag = format!("\"target-cpu={}\"", qemu_tests::FIRMWARE_CPU);
    assert!(config.contains(&flag), "{flag} not in .cargo/config.toml");
    assert!(qemu_tests::firmware_rustflags().contains(&format!("-Ctarget-cpu={}", qemu_tests::FIRMWARE_CPU)));
}
