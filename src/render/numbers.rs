//! Numbers as every rendering prints them: millimetres to a tenth, fixed
//! decimals and signed parts per million, none of them ever "-0".

/// Millimetres with one decimal, never "-0.0".
pub fn mm(m: f64) -> String {
    if !m.is_finite() {
        return "–".into();
    }
    let v = (m * 1e4).round() / 10.0;
    if v == 0.0 {
        "0.0".into()
    } else {
        format!("{v:.1}")
    }
}

/// `v` with `d` decimals, never a negative zero ("-0.000").
pub(crate) fn fixed(v: f64, d: usize) -> String {
    let s = format!("{v:.d$}");
    if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
        s[1..].to_string()
    } else {
        s
    }
}

/// Parts per million with a sign and no decimals ("+1520", "−310", "0").
pub(crate) fn signed_ppm(v: f64) -> String {
    let r = v.round();
    if r == 0.0 {
        "0".into()
    } else {
        format!("{r:+.0}")
    }
}
