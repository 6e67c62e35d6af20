//! The board images build, link, and fit their budgets (8 channels
//! multiplexed; the array of 16).

#[test]
fn board_image_fits_64k_flash_and_16k_ram() {
    let elf = qemu_tests::build_firmware("skin-board", &["board"]).unwrap();
    let (flash, ram) = qemu_tests::image_size(&elf).unwrap();
    let (max_flash, max_ram) = qemu_tests::BOARD_BUDGET;
    println!("skin-board: flash {flash} B (≤ {max_flash}), static RAM {ram} B (≤ {max_ram})");
    assert!(flash <= max_flash && ram <= max_ram, "flash {flash}, RAM {ram}");
    // Not trivially small either: the DMA buffers alone take 13 KiB.
    assert!(ram > 12 * 1024 && flash > 16 * 1024, "flash {flash}, RAM {ram}");
}

#[test]
fn array_board_image_fits_96k_flash_and_48k_ram() {
    let elf = qemu_tests::build_firmware("skin-array-board", &["board"]).unwrap();
    let (flash, ram) = qemu_tests::image_size(&elf).unwrap();
    let (max_flash, max_ram) = qemu_tests::ARRAY_BOARD_BUDGET;
    println!("skin-array-board: flash {flash} B (≤ {max_flash}), static RAM {ram} B (≤ {max_ram})");
    assert!(flash <= max_flash && ram <= max_ram, "flash {flash}, RAM {ram}");
    // Not trivially small: the five ADC buffers (8000 B), the DAC's
    // table (8000 B) and the record queue are static.
    assert!(ram > 20 * 1024 && flash > 32 * 1024, "flash {flash}, RAM {ram}");
}

/// The array in 1 ms blocks (feature `array-1ms`) within the same
/// budgets.
#[test]
fn array_board_in_1ms_blocks_fits_the_same_budgets() {
    let elf = qemu_tests::build_firmware("skin-array-board", &["board", "array-1ms"]).unwrap();
    let (flash, ram) = qemu_tests::image_size(&elf).unwrap();
    let (max_flash, max_ram) = qemu_tests::ARRAY_BOARD_BUDGET;
    println!(
        "skin-array-board (array-1ms): flash {flash} B (≤ {max_flash}), static RAM {ram} B (≤ {max_ram})"
    );
    assert!(flash <= max_flash && ram <= max_ram, "flash {flash}, RAM {ram}");
    assert!(ram > 20 * 1024 && flash > 32 * 1024, "flash {flash}, RAM {ram}");
}

#[test]
fn every_image_is_tabulated() {
    let table = qemu_tests::tables::image_table().unwrap();
    assert_eq!(
        table.lines().count(),
        2 + qemu_tests::tables::IMAGES.len(),
        "{table}"
    );
    figures::check_within("docs/benchmarks.md", "images", &table, qemu_tests::BUILD_SPREAD).unwrap();
}
