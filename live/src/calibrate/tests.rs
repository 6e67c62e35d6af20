//! The fit on records drawn from its own model, with noise.

use super::*;
use instrument::calib::POINTS;
use instrument::faults::Flags;
use num_complex::Complex64;

/// Records of one sensor at each hold, from the model with known
/// leads, contact, parasitic capacitance and film loss, with noise.
fn records(lead: f64, rs: f64, cp: f64, tan_d: f64, holds: &[Hold]) -> Vec<link::Record> {
    let mut out = vec![];
    let mut seed = 0x1234_5678u64;
    let mut noise = || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    for h in holds {
        let c = 200e-12 * (1.0 + h.stretch_mm / 100.0);
        let mut t = h.from_s;
        while t < h.to_s {
            // The electrodes' resistance falls with stretch and
            // recovers during the hold.
            let r = 700e3 * (1.0 - 0.004 * h.stretch_mm) * (1.0 + 0.05 * (h.from_s - t).exp());
            // The pairs a calibration's sweep steps through, in turn:
            // the loss (a resistance ∝ 1/f) is told from a contact
            // (flat) and a parasitic over 0.5–6 kHz.
            let pair = if out.len() % 2 == 0 {
                [500.0f32, 2000.0]
            } else {
                [2000.0, 6000.0]
            };
            let tones = pair.map(|f| {
                let z = model(f as f64, r, c, lead, rs, cp, tan_d);
                let z = z * Complex64::new(1.0 + 2e-4 * noise(), 2e-4 * noise());
                link::Tone {
                    f_hz: f,
                    z_re_ohm: z.re as f32,
                    z_im_ohm: z.im as f32,
                }
            });
            out.push(link::Record {
                t_us: (t * 1e6) as u64,
                sensor: 0,
                tones,
                c_farad: (c * 0.97) as f32,
                r_ohm: r as f32,
                flags: Flags::UNCALIBRATED | Flags::MODEL,
                ..Default::default()
            });
            t += 0.004;
        }
    }
    out
}

/// The block period from records of two sensors interleaved, 1 ms
/// or 4 ms apart; a sweep's blocks per pair cover the span in either.
#[test]
fn the_block_period_is_read_from_the_records_and_sizes_the_sweep() {
    let at = |t_us: u64, sensor: u8| link::Record {
        t_us,
        sensor,
        ..Default::default()
    };
    assert_eq!(block_s_of(&[]), None);
    assert_eq!(block_s_of(&[at(500, 0), at(500, 1)]), None);
    for period in [1000u64, 4000] {
        let recs: Vec<link::Record> = (0..6u64)
            .flat_map(|b| [at(b * period + period / 2, 0), at(b * period + period / 2, 1)])
            .collect();
        let block_s = block_s_of(&recs).unwrap();
        assert!((block_s - period as f64 * 1e-6).abs() < 1e-12);
        // 2 s over four pairs: 500 ms a pair.
        assert_eq!(u64::from(sweep_blocks(2.0, block_s)) * period, 500_000);
    }
    // A sensor's records out of order, or repeated, are not a period.
    assert_eq!(
        block_s_of(&[at(9000, 0), at(5000, 0), at(5000, 0), at(6000, 0)]),
        Some(1e-3)
    );
    assert_eq!(sweep_blocks(1e9, 1e-3), link::SWEEP_MAX_BLOCKS);
    assert_eq!(sweep_blocks(0.0, 4e-3), 1);
}

fn stairs() -> Vec<Hold> {
    (0..11)
        .map(|k| Hold {
            stretch_mm: 3.0 * k as f64,
            from_s: 1.0 * k as f64,
            to_s: 1.0 * k as f64 + 0.6,
            sensor: None,
        })
        .collect()
}

#[test]
fn the_fit_finds_the_leads_contact_parasitic_and_loss_it_was_given() {
    let holds = stairs();
    for (lead, rs, cp, tan_d) in [
        (0.0, 0.0, 0.0, 2e-3),
        (0.64, 0.0, 12e-12, 3e-3),
        (0.3, 20e3, 5e-12, 1e-3),
        (0.3, 0.0, 5e-12, 2e-2),
    ] {
        let recs = records(lead, rs, cp, tan_d, &holds);
        let refs: Vec<&link::Record> = recs.iter().collect();
        let fit = fit_sensor(0, &refs, &holds, &Options::default()).unwrap();
        println!("{:?} {:?} χ²/dof {:.2}", fit.values, fit.sigma, fit.chi2_dof);
        assert!((fit.values[0] - lead).abs() < 0.02, "{fit:?}");
        assert!((fit.values[1] - rs).abs() < 5e3, "{fit:?}");
        assert!((fit.values[2] - cp).abs() < 0.3e-12, "{fit:?}");
        assert!((fit.values[3] - tan_d).abs() < 3e-4, "{fit:?}");
        for (k, h) in holds.iter().enumerate() {
            let c = 200e-12 * (1.0 + h.stretch_mm / 100.0);
            assert!((fit.c_farad[k] / c - 1.0).abs() < 2e-4, "{k}: {fit:?}");
        }
        assert!(fit.chi2_dof < 2.0);
        let set = fit.settings(&holds);
        assert!(set.table.windows(2).all(|w| w[1].0 > w[0].0 && w[1].1 > w[0].1));
        assert_eq!(set.table[POINTS - 1].1, 30.0);
    }
}

#[test]
fn a_sensor_the_model_does_not_explain_is_refused_and_kept() {
    let holds = stairs();
    let mut recs = records(0.3, 0.0, 5e-12, 3e-3, &holds);
    // A stretch that moved during the holds: C off by 2 % in the
    // second half of each.
    for r in recs.iter_mut() {
        let t = r.t_us as f64 * 1e-6;
        if t.fract() > 0.3 {
            for tone in r.tones.iter_mut() {
                tone.z_im_ohm *= 0.98;
            }
        }
    }
    let base = Stored::uncalibrated();
    let (set, out) = calibrate(&recs, &holds, &base, &Options::default());
    assert!(
        matches!(&out[0], Outcome::Refused(why) if why.contains("does not explain")),
        "{out:?}"
    );
    assert_eq!(set.sensors[0], base.sensors[0]);
    // The other sensors have no records: refused, kept.
    assert!(matches!(&out[1], Outcome::Refused(why) if why.contains("no usable records")));
    assert!(report(&holds, &out).contains("sensor 0 refused"));
}

#[test]
fn holds_files_say_where_they_are_wrong() {
    let ok = "stretch_mm,from_s,to_s\n0,0.2,1\n10,1.5,2\n";
    assert_eq!(parse_holds(ok, None).unwrap().len(), 2);
    let err = |t: &str| parse_holds(t, None).unwrap_err().to_string();
    assert!(err("s,f,t\n").starts_with("1:1: the header"));
    assert!(err("stretch_mm,from_s,to_s\n0,0.2,x\n").starts_with("2:7: 'x' is not"));
    assert!(err("stretch_mm,from_s,to_s\n0,0.2,1\n5,0.5,1.5\n").contains("overlaps"));
    assert!(err("stretch_mm,from_s,to_s\n0,0.2,1\n").contains("two stretches"));
    assert!(err("stretch_mm,from_s,to_s\n0,1,0.5\n").contains("end after"));
    assert!(err("stretch_mm,from_s,to_s\n0,0,1\n0,2,3\n").contains("a second hold"));
    assert!(err("stretch_mm,from_s,to_s\n0,0,1,4\n").contains("4 fields"));
    let tmp = tempfile::tempdir().unwrap();
    let p = tmp.path().join("holds.csv");
    let holds = stairs();
    write_holds(&p, &holds).unwrap();
    assert_eq!(read_holds(&p, None).unwrap(), holds);
}

#[test]
fn each_sensor_may_hold_its_own_stretch() {
    let skin = crate::skin::parse(
        "[skin]\nname = \"glove\"\n[[sensor]]\nname = \"thumb\"\nindex = 0\nplace = [0, 0]\n\
         [[sensor]]\nname = \"index-1\"\nindex = 1\ngroup = \"index\"\nplace = [1, 0]\n\
         [[sensor]]\nname = \"index-2\"\nindex = 2\ngroup = \"index\"\nplace = [2, 0]\n",
        "glove.toml",
    )
    .unwrap()
    .on_board(None)
    .unwrap();
    // The thumb bends less than the index finger over the same spans.
    let text = "sensor,stretch_mm,from_s,to_s\nthumb,0,0,1\nthumb,4,2,3\nindex,0,0,1\nindex,10,2,3\n";
    let holds = parse_holds(text, Some(&skin)).unwrap();
    assert_eq!(holds.len(), 6, "a group's row is a hold of each of its sensors");
    let stretches = |s| {
        for_sensor(&holds, s)
            .iter()
            .map(|h| h.stretch_mm)
            .collect::<Vec<_>>()
    };
    assert_eq!((stretches(0), stretches(2)), (vec![0.0, 4.0], vec![0.0, 10.0]));
    let err = |t: &str, skin| parse_holds(t, skin).unwrap_err().to_string();
    assert!(
        err(text, None).starts_with("2:1: 'thumb' is not a sensor's index"),
        "{}",
        err(text, None)
    );
    let lone = "sensor,stretch_mm,from_s,to_s\n0,0,0,1\n1,0,0,1\n1,5,2,3\n";
    assert!(
        err(lone, None).contains("sensor 0 has 1 hold"),
        "{}",
        err(lone, None)
    );
    let overlap = "sensor,stretch_mm,from_s,to_s\n0,0,0,1\n0,5,0.5,3\n";
    assert!(
        err(overlap, None).starts_with("3:1: its span overlaps the hold of sensor 0"),
        "{}",
        err(overlap, None)
    );
    let tmp = tempfile::tempdir().unwrap();
    let p = tmp.path().join("holds.csv");
    write_holds(&p, &holds).unwrap();
    assert_eq!(read_holds(&p, None).unwrap(), holds);
}

#[test]
fn a_hold_or_settling_beyond_an_hour_is_refused_before_anything_waits() {
    for (hold_s, settle_s) in [
        (f64::INFINITY, 1.0),
        (f64::NAN, 1.0),
        (0.0, 1.0),
        (5.0, 1e9),
        (5.0, -1.0),
    ] {
        let guide = Guide {
            open: false,
            at_mm: vec![0.0, 10.0],
            settle_s,
            hold_s,
            sweep: false,
        };
        let port = std::io::Cursor::new(Vec::<u8>::new());
        let err = guided(
            port,
            &guide,
            |_, _, _| Ok(Ready::Now),
            &Options::default(),
            false,
            std::time::Duration::from_secs(3600),
        )
        .unwrap_err()
        .to_string();
        assert!(
            err.contains("s at most") || err.contains("0 to 3600 s"),
            "{hold_s} {settle_s}: {err}"
        );
    }
}
