//! Settings kept in flash survive a restart of QEMU: the firmware stores
//! the set it measures with in its flash file (`flash=PATH save`), the
//! host reads that file with the same store and finds the same set and
//! digest, changes one sensor and writes it back, and the next run of the
//! firmware loads the host's set. A flash file of the wrong size is
//! refused with exit code 2.

use instrument::digest::Digest;
use instrument::store::{RamFlash, Store, REGION_BYTES, SLOT_BYTES};
use instrument::stored::SENSORS_MAX;
use std::time::Duration;

/// Run `skin-qemu` with `args`; its exit code and its log's lines.
fn run(args: &[&str]) -> (Option<i32>, Vec<String>) {
    let elf = qemu_tests::build_firmware("skin-qemu", &["qemu"]).unwrap();
    let run = qemu_tests::run_qemu_args(&elf, args, Duration::from_secs(600)).unwrap();
    let log = host_sim::recording::decode_defmt(&elf, &run.raw)
        .unwrap()
        .into_iter()
        .map(|(_, l)| l)
        .collect();
    (run.code, log)
}

/// The digest a `settings…digest 0x…` line of the log names.
fn digest_in(log: &[String], prefix: &str) -> u32 {
    let line = log
        .iter()
        .find(|l| l.starts_with(prefix))
        .unwrap_or_else(|| panic!("no '{prefix}' in {log:?}"));
    let hex = line.rsplit("0x").next().unwrap();
    u32::from_str_radix(hex.trim(), 16).unwrap()
}

#[test]
fn settings_stored_by_the_firmware_come_back_after_a_restart_and_from_the_host() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("settings.bin");
    let flash = format!("flash={}", path.display());

    // A new device: nothing stored; it stores what it measures with.
    let (code, log) = run(&["faults", &flash, "save"]);
    assert_eq!(code, Some(0), "{log:?}");
    assert!(log.iter().any(|l| l == "settings: none stored"), "{log:?}");
    let saved = digest_in(&log, "settings saved: generation 1");

    // The host reads the same file with the same store.
    let mut image = std::fs::read(&path).unwrap();
    assert_eq!(image.len(), REGION_BYTES);
    let mut store = Store::new(RamFlash::new(&mut image), 0, SLOT_BYTES).unwrap();
    let loaded = store.load().unwrap().expect("a set");
    assert_eq!((loaded.generation, Digest::of(&loaded.set)), (1, saved));
    let set = loaded.set;
    assert_eq!(set.check(), Ok(()));
    assert!(set.sensors[..8].iter().all(|s| s.in_use && s.calibrated));
    assert!(set.sensors[8..SENSORS_MAX].iter().all(|s| !s.in_use));
    assert!(
        (set.sensors[0].nominal_c_farad - 210e-12).abs() < 15e-12,
        "{:?}",
        set.sensors[0]
    );

    // The host changes sensor 3's parasitic capacitance and stores it.
    let mut mine = set;
    mine.sensors[3].parasitic_farad = 5e-12;
    assert_eq!(store.save(&mine), Ok(2));
    let _ = store.release();
    std::fs::write(&path, &image).unwrap();

    // The next run finds the host's set.
    let (code, log) = run(&["faults", &flash]);
    assert_eq!(code, Some(0), "{log:?}");
    assert_eq!(digest_in(&log, "settings: generation 2"), Digest::of(&mine));
    assert!(!log.iter().any(|l| l.starts_with("settings saved")), "{log:?}");
}

#[test]
fn a_flash_file_of_the_wrong_size_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("short.bin");
    std::fs::write(&path, [0xFFu8; 100]).unwrap();
    let (code, log) = run(&["faults", &format!("flash={}", path.display())]);
    assert_eq!(code, Some(2), "{log:?}");
    assert!(
        log.iter()
            .any(|l| l.contains("the flash file cannot be used (Length)")),
        "{log:?}"
    );
    assert!(!log.iter().any(|l| l.starts_with("start")), "{log:?}");
}
