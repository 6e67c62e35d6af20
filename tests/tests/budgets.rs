//! The board image builds, links, and fits its budgets (8 channels).

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
