//! A firmware recording, decoded by the user's tool (`host-sim decode`),
//! is a complete data set: `residual` and `identify` read it.

#[test]
#[ignore = "long: cargo xtask test --full"]
fn the_main_jobs_recording_decodes_into_a_data_set_residual_and_identify_read() {
    let (run, recs) = qemu_tests::records::run_scenario("paper").unwrap();
    let run = run.ok().unwrap();
    assert!(recs.len() > 3000, "{} records", recs.len());
    // The README's headline and the accuracy page show this run's figures.
    let channels = qemu_tests::summary::channels(&recs);
    figures::check(
        "docs/figures.md",
        "headline-multiplexed",
        &qemu_tests::summary::channel_headline(&channels),
    )
    .unwrap();
    figures::check(
        "docs/accuracy.md",
        "firmware-channels",
        &qemu_tests::summary::channel_table(&channels),
    )
    .unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let log = tmp.path().join("firmware.log");
    std::fs::write(&log, &run.stdout).unwrap();
    let ds = tmp.path().join("ds");
    let text = qemu_tests::host_sim(&[
        "decode".as_ref(),
        log.as_os_str(),
        "--out".as_ref(),
        ds.as_os_str(),
    ]);
    // Channels 2-7 are held: six calibration points; channels 0 and 1 move.
    assert!(text.contains("6 calibration points"), "{text}");
    // Every trace is long enough to model; shorter runs (the start-up block
    // at the lowest frequency) are fragments, not traces.
    for entry in std::fs::read_dir(&ds).unwrap() {
        let p = entry.unwrap().path();
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        let rows = std::fs::read_to_string(&p)
            .unwrap()
            .lines()
            .filter(|l| !l.starts_with('#'))
            .count()
            - 1;
        if name.starts_with("trace_") {
            assert!(
                rows >= host_sim::model::prepared::MIN_TRACE_ROWS,
                "{name}: {rows}"
            );
        } else if name.starts_with("fragment_") {
            assert!(rows < host_sim::model::prepared::MIN_TRACE_ROWS, "{name}: {rows}");
        }
    }
    let set = host_sim::dataset::read_dir(&ds).unwrap();
    assert_eq!(set.calibration.rows.len(), 6);
    // Channel 0 moves through two frequencies, channel 1 at least one.
    assert!(set.traces.len() >= 3, "{} traces", set.traces.len());
    qemu_tests::host_sim(&["residual".as_ref(), ds.as_os_str()]);
    let id = tmp.path().join("id");
    qemu_tests::host_sim(&[
        "identify".as_ref(),
        "--out".as_ref(),
        id.as_os_str(),
        ds.as_os_str(),
    ]);
    assert!(tmp.path().join("id/report.json").is_file());
}
