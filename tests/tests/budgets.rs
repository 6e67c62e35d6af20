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
