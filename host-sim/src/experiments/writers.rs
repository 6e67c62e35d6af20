//! CSV writers of readings.

use super::*;

/// Write readings as a trace file of the interchange format, with the
/// truth and the line-corrected values as extra columns.
pub fn write_trace(path: &Path, rs: &[Reading], truth: bool) -> Result<()> {
    let file = std::fs::File::create(path).with_context(|| format!("writing {}", path.display()))?;
    write_trace_to(std::io::BufWriter::new(file), rs, truth)
}

/// [`write_trace`] to any writer.
pub fn write_trace_to(out: impl std::io::Write, rs: &[Reading], truth: bool) -> Result<()> {
    let mut w = csv::Writer::from_writer(out);
    let mut head = TRACE_HEADER.to_vec();
    if truth {
        head.extend([
            "c_true_pf",
            "c_corrected_pf",
            "r_corrected_ohm",
            "r_line_ohm",
            "adc_clipped",
        ]);
    }
    w.write_record(&head)?;
    // No value (a reading the ADC's clipping spoiled): an empty field.
    let opt = |v: f64, s: String| if v.is_finite() { s } else { String::new() };
    for r in rs {
        let mut row = vec![
            format!("{:.5}", r.t),
            format!("{:.4}", r.stretch_mm),
            format!("{:.0}", r.r_top),
            format!("{:.0}", r.r_bottom),
            format!("{}", r.freq_hz),
            opt(r.cs, format!("{:.4}", pf(r.cs))),
            opt(r.rs, format!("{:.0}", r.rs)),
        ];
        if truth {
            row.extend([
                format!("{:.4}", pf(r.c_true)),
                opt(r.c_corr, format!("{:.4}", pf(r.c_corr))),
                opt(r.r_corr, format!("{:.0}", r.r_corr)),
                format!("{:.0}", r.r_line),
                format!("{}", r.clipped as u8),
            ]);
        }
        w.write_record(&row)?;
    }
    w.flush()?;
    Ok(())
}
