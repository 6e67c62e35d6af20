//! Numbers with SI prefixes on the command line: `700k`, `200p`, `6e3`,
//! `1.5M`, `10meg` (SPICE style), optionally followed by a unit (`200pF`).

/// Parse a number with an optional SI prefix and an optional unit suffix
/// (`F`, `Ω`, `ohm`, `Hz`, `S`, `s`). Rejects non-finite values.
pub fn parse(s: &str) -> Result<f64, String> {
    let t = s.trim();
    let t = ["ohm", "Ohm", "Ω", "Hz", "hz", "F", "S", "s"]
        .iter()
        .find_map(|u| t.strip_suffix(u))
        .unwrap_or(t);
    let (num, mult) = if let Some(n) = t.strip_suffix("meg").or_else(|| t.strip_suffix("MEG")) {
        (n, 1e6)
    } else {
        match t.chars().last() {
            Some(c) if c.is_ascii_digit() || c == '.' => (t, 1.0),
            Some(c) => {
                let m = match c {
                    'T' => 1e12,
                    'G' => 1e9,
                    'M' => 1e6,
                    'k' | 'K' => 1e3,
                    'm' => 1e-3,
                    'u' | 'µ' => 1e-6,
                    'n' => 1e-9,
                    'p' => 1e-12,
                    'f' => 1e-15,
                    _ => return Err(format!("unknown SI prefix '{c}' in '{s}'")),
                };
                (&t[..t.len() - c.len_utf8()], m)
            }
            None => return Err("empty number".into()),
        }
    };
    let v: f64 = num.parse().map_err(|_| format!("'{s}' is not a number"))?;
    let v = v * mult;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("'{s}' is not finite"))
    }
}

/// Format with an SI prefix and 5 significant digits: `209.87 p`.
pub fn fmt(v: f64, unit: &str) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v} {unit}");
    }
    const P: [(f64, &str); 9] = [
        (1e9, "G"),
        (1e6, "M"),
        (1e3, "k"),
        (1.0, ""),
        (1e-3, "m"),
        (1e-6, "µ"),
        (1e-9, "n"),
        (1e-12, "p"),
        (1e-15, "f"),
    ];
    let (scale, pre) = P
        .iter()
        .find(|(s, _)| v.abs() >= *s * 0.999_995)
        .copied()
        .unwrap_or((1e-15, "f"));
    let m = v / scale;
    let digits = if m.abs() >= 100.0 {
        2
    } else if m.abs() >= 10.0 {
        3
    } else {
        4
    };
    format!("{m:.digits$} {pre}{unit}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_prefixes_and_units() {
        let close = |a: f64, b: f64| (a / b - 1.0).abs() < 1e-12;
        assert!(close(parse("700k").unwrap(), 700e3));
        assert!(close(parse("200p").unwrap(), 200e-12));
        assert!(close(parse("200pF").unwrap(), 200e-12));
        assert!(close(parse("6e3").unwrap(), 6e3));
        assert!(close(parse("6kHz").unwrap(), 6e3));
        assert!(close(parse("1.5M").unwrap(), 1.5e6));
        assert!(close(parse("10meg").unwrap(), 10e6));
        assert!(close(parse("350kΩ").unwrap(), 350e3));
        assert!(parse("12x").unwrap_err().contains("unknown SI prefix"));
        assert!(parse("abc").is_err());
        assert!(parse("").is_err());
        assert!(parse("1e999").is_err());
    }

    #[test]
    fn formats() {
        assert_eq!(fmt(209.87e-12, "F"), "209.87 pF");
        assert_eq!(fmt(700e3, "Ω"), "700.00 kΩ");
        assert_eq!(fmt(6.0e3, "Hz"), "6.0000 kHz");
    }
}
