//! `live config get/set` on a settings flash image: a set written is read
//! back; a refused value names the setting and its range and leaves the
//! file byte for byte as it was; `--help` names every setting.

mod common;
use common::live;

#[test]
fn settings_set_are_read_back_and_a_refused_value_changes_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let image = tmp.path().join("settings.bin");
    let f = image.to_str().unwrap();
    let (code, out, err) = live(&[
        "config",
        "set",
        "--flash",
        f,
        "sensor.3.parasitic_farad=5e-12",
        "sensor.4.loss_tangent=1.4e-3",
        "policy.tones=1,3",
    ]);
    assert_eq!(code, Some(0), "{err}");
    assert!(out.contains("generation 1"), "{out}");
    let (code, out, _) = live(&["config", "get", "--flash", f]);
    assert_eq!(code, Some(0));
    assert!(
        out.lines().any(|l| l == "sensor.3.parasitic_farad = 5e-12"),
        "{out}"
    );
    assert!(out.lines().any(|l| l == "policy.tones = 1,3"), "{out}");
    assert!(
        out.lines().any(|l| l == "sensor.4.loss_tangent = 0.0014"),
        "{out}"
    );
    assert!(out.lines().any(|l| l == "sensor.5.loss_tangent = none"), "{out}");
    assert_eq!(out.lines().filter(|l| l.contains(" = ")).count(), 7 + 9 * 16);
    // Refused: the file does not change.
    let before = std::fs::read(&image).unwrap();
    let (code, _, err) = live(&["config", "set", "--flash", f, "sensor.7.nominal_c_farad=1"]);
    assert_eq!(code, Some(1));
    assert!(
        err.contains("refused: sensor 7 nominal_c_farad: must be 1 pF … 10 nF"),
        "{err}"
    );
    let (code, _, err) = live(&["config", "set", "--flash", f, "sensor.7.loss_tangent=0.5"]);
    assert_eq!(code, Some(1));
    assert!(
        err.contains("refused: sensor 7 loss_tangent: must be 0 … 0.1, or none"),
        "{err}"
    );
    let (code, _, err) = live(&["config", "set", "--flash", f, "sensor.7.colour=red"]);
    assert_eq!(code, Some(1));
    assert!(err.contains("sensor.7.colour: no such setting"), "{err}");
    assert_eq!(std::fs::read(&image).unwrap(), before);
    // A second change lands in the other slot.
    let (code, out, err) = live(&["config", "set", "--flash", f, "record_every=5"]);
    assert_eq!(code, Some(0), "{err}");
    assert!(out.contains("generation 2"), "{out}");
    let (_, out, _) = live(&["config", "get", "--flash", f]);
    assert!(
        out.contains("record_every = 5") && out.contains("parasitic_farad = 5e-12"),
        "{out}"
    );
}

#[test]
fn help_names_every_setting_with_its_unit_and_range() {
    let (code, out, _) = live(&["config", "set", "--help"]);
    assert_eq!(code, Some(0));
    for (name, unit, range) in live::config::SETTINGS {
        assert!(
            out.contains(name) && out.contains(unit) && out.contains(range),
            "{name}: {out}"
        );
    }
}

#[test]
fn a_file_that_is_not_an_image_is_refused_by_name() {
    let tmp = tempfile::tempdir().unwrap();
    let junk = tmp.path().join("junk.bin");
    std::fs::write(&junk, b"not flash").unwrap();
    let (code, _, err) = live(&["config", "get", "--flash", junk.to_str().unwrap()]);
    assert_eq!(code, Some(1));
    assert!(
        err.contains("9 bytes, not a settings flash image (8192 bytes)"),
        "{err}"
    );
}
