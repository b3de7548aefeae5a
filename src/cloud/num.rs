//! Decimal text to f64, fast and exact: the readers of ascii PCD, PLY and XYZ
//! spend most of their time here.
//!
//! The common forms (`-123.456`, `1.5e-3`, at most 19 significant digits whose
//! value is below 2^53, decimal exponent within ±22) take Clinger's fast path:
//! the integer mantissa and the power of ten are both exact doubles, so one
//! IEEE multiplication or division gives the correctly rounded result, the
//! same bits as `str::parse`. Everything else (long mantissas, large
//! exponents, `nan`, `inf`, malformed text) goes through `str::parse`.

/// Powers of ten exactly representable as f64.
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// Parses one number token exactly as `str::parse::<f64>` would (same bits,
/// same acceptance); `None` when it is not a number.
#[inline]
pub(super) fn parse_f64(tok: &[u8]) -> Option<f64> {
    match fast(tok) {
        Some(v) => Some(v),
        None => std::str::from_utf8(tok).ok()?.parse::<f64>().ok(),
    }
}

/// `tok`, already parsed to the nearest f64 `v`, rounded to the nearest f32
/// the way C++ `istream >> float` (PCL) and numpy's float32 (pypcd4) read a
/// 4-byte float: `v as f32` is that value except when `v` lies exactly halfway
/// between two f32s, where the decimal itself may not (double rounding); only
/// then is `tok` parsed again, directly as f32.
#[inline]
pub(super) fn round_f32(tok: &[u8], v: f64) -> f64 {
    let f = v as f32;
    let a = v.abs();
    if a >= f64::from(f32::MIN_POSITIVE) && a <= f64::from(f32::MAX) {
        // Normal f32 range: an f32 midpoint is an f64 whose 29 mantissa bits
        // below f32 precision are exactly 1000…0.
        if v.to_bits() & 0x1FFF_FFFF != 0x1000_0000 {
            return f64::from(f);
        }
        return reparse_f32(tok, f);
    }
    if !v.is_finite() || f64::from(f) == v {
        return f64::from(f);
    }
    let mid = if f.is_infinite() {
        // Halfway between f32::MAX and 2^128, the first value past it.
        let m = f64::from(f32::MAX.copysign(f));
        (m + 2f64.powi(128).copysign(m)) * 0.5
    } else {
        (f64::from(f) + f64::from(step(f, f64::from(f) < v))) * 0.5
    };
    if v != mid {
        return f64::from(f);
    }
    reparse_f32(tok, f)
}

/// `tok` parsed directly as f32 (`f` if that fails, which it cannot for a
/// token that parsed as f64).
#[cold]
fn reparse_f32(tok: &[u8], f: f32) -> f64 {
    std::str::from_utf8(tok)
        .ok()
        .and_then(|s| s.parse::<f32>().ok())
        .map_or(f64::from(f), f64::from)
}

/// The f32 next to finite `f`, upwards or downwards (`f32::next_up` needs
/// Rust 1.86).
fn step(f: f32, up: bool) -> f32 {
    if f == 0.0 {
        let tiny = f32::from_bits(1);
        return if up { tiny } else { -tiny };
    }
    let b = f.to_bits();
    // Away from zero is one more in the magnitude bits.
    f32::from_bits(if (f > 0.0) == up { b + 1 } else { b - 1 })
}

/// The fast path; `None` means "ask the exact parser" (not "not a number").
#[inline(always)]
fn fast(tok: &[u8]) -> Option<f64> {
    let (neg, mut i) = match tok.first() {
        Some(b'-') => (true, 1),
        Some(b'+') => (false, 1),
        _ => (false, 0),
    };
    let n = tok.len();
    let mut m: u64 = 0;
    // Significant digits accumulated (leading zeros do not count).
    let mut sig = 0u32;
    let mut digits = 0u32;
    let mut frac = 0i32;
    while i < n {
        let d = tok[i].wrapping_sub(b'0');
        if d >= 10 {
            break;
        }
        if m != 0 || d != 0 {
            sig += 1;
        }
        m = m.wrapping_mul(10).wrapping_add(u64::from(d));
        digits += 1;
        i += 1;
    }
    if i < n && tok[i] == b'.' {
        i += 1;
        while i < n {
            let d = tok[i].wrapping_sub(b'0');
            if d >= 10 {
                break;
            }
            if m != 0 || d != 0 {
                sig += 1;
            }
            m = m.wrapping_mul(10).wrapping_add(u64::from(d));
            digits += 1;
            frac += 1;
            i += 1;
        }
    }
    if digits == 0 || sig > 19 {
        return None;
    }
    let mut exp = 0i32;
    if i < n && (tok[i] | 0x20) == b'e' {
        i += 1;
        let eneg = match tok.get(i) {
            Some(b'-') => {
                i += 1;
                true
            }
            Some(b'+') => {
                i += 1;
                false
            }
            _ => false,
        };
        let start = i;
        while i < n {
            let d = tok[i].wrapping_sub(b'0');
            if d >= 10 || exp > 10_000 {
                break;
            }
            exp = exp * 10 + i32::from(d);
            i += 1;
        }
        if i == start {
            return None;
        }
        if eneg {
            exp = -exp;
        }
    }
    if i != n || m >= 1 << 53 {
        return None;
    }
    let e = exp - frac;
    let v = m as f64;
    let v = if e >= 0 {
        if e > 22 {
            return None;
        }
        v * POW10[e as usize]
    } else {
        if e < -22 {
            return None;
        }
        v / POW10[(-e) as usize]
    };
    Some(if neg { -v } else { v })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn same_f32(s: &str) {
        let want = s.parse::<f32>().unwrap();
        let got = round_f32(s.as_bytes(), parse_f64(s.as_bytes()).unwrap());
        assert_eq!(got.to_bits(), f64::from(want).to_bits(), "{s:?}");
    }

    #[test]
    fn round_f32_equals_a_direct_f32_parse() {
        // Double rounding: each decimal is within 1e-35 of an f32 midpoint,
        // so its nearest f64 IS the midpoint.
        for s in [
            "1.00000005960464477539062500000000001",
            "1.00000005960464477539062499999999999",
            "-1.00000017881393432617187500000000001",
            "350123.515625000000000000000000000001",
            "350123.515624999999999999999999999999",
            "4150234.25000000000000000000000000001",
            "4150234.24999999999999999999999999999",
            "340282356779733661637539395458142568448",
            "340282356779733661637539395458142568447",
            "1e-46",
            "0.7",
            "-0",
            "nan",
            "inf",
            "1e39",
        ] {
            same_f32(s);
        }
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        for _ in 0..200_000 {
            let v: f64 = rng.random_range(-5e6..5e6);
            let digits = rng.random_range(0..12);
            same_f32(&format!("{v:.digits$}"));
            // Exact f32 midpoints, printed in full.
            let f = v as f32;
            let m = (f64::from(f) + f64::from(step(f, true))) * 0.5;
            let n = (f64::from(f) + f64::from(step(f, false))) * 0.5;
            same_f32(&format!("{n}"));
            same_f32(&format!("{m}"));
        }
    }

    fn same(s: &str) {
        let want = s.parse::<f64>().ok().map(f64::to_bits);
        let got = parse_f64(s.as_bytes()).map(f64::to_bits);
        assert_eq!(got, want, "{s:?}");
    }

    #[test]
    fn edge_cases_match_str_parse_bit_for_bit() {
        for s in [
            "0",
            "-0",
            "+0",
            "0.0",
            "-0.0",
            "00",
            "007",
            "1.",
            "-1.",
            ".5",
            "-.5",
            "+.5",
            ".",
            "-",
            "+",
            "",
            "e5",
            "1e",
            "1e+",
            "1e-",
            "1E5",
            "1e22",
            "1e23",
            "1e-22",
            "1e-23",
            "123456789e-30",
            "0e999999",
            "-0e-999999",
            "1e999",
            "1e-999",
            "9007199254740991",
            "9007199254740992",
            "9007199254740993",
            "9007199254740993.0",
            "0.1",
            "0.2",
            "0.3",
            "1234567890123456789",
            "12345678901234567890",
            "0.0000000000000000000001",
            "1.7976931348623157e308",
            "4.9e-324",
            "2.2250738585072014e-308",
            "nan",
            "NaN",
            "-nan",
            "inf",
            "-inf",
            "Infinity",
            "infinity",
            "1.2.3",
            "1,5",
            "--1",
            "+-1",
            "1e5.5",
            " 1",
            "1 ",
            "0x10",
            "1_000",
            "١",
            "12.345678",
            "-350123.456789",
            "4150234.567891",
            "3.4028235e38",
            "1e0",
            "1e-0",
            "1e+0",
            "00000000000000000000001.5",
            "0.00000000000000000000000000001",
            "1.0000000000000000000000000001",
        ] {
            same(s);
        }
    }

    #[test]
    fn random_decimals_match_str_parse_bit_for_bit() {
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(42);
        for _ in 0..200_000 {
            let digits: u32 = rng.random_range(0..13);
            let int: u64 = rng.random_range(0..10u64.pow(digits));
            let w = rng.random_range(0..12usize);
            let top = 10u64.pow(w as u32).max(1);
            let dec: u64 = rng.random_range(0..top);
            let sign = ["", "-", "+"][rng.random_range(0..3)];
            let mut s = if w == 0 {
                format!("{sign}{int}")
            } else {
                format!("{sign}{int}.{dec:0w$}")
            };
            if rng.random_range(0..4) == 0 {
                let e: i32 = rng.random_range(-40..40);
                s.push_str(&format!("{}{e}", if rng.random() { "e" } else { "E" }));
            }
            same(&s);
        }
        // Shortest round-trip representations of random doubles and floats.
        for _ in 0..100_000 {
            let v = f64::from_bits(rng.random::<u64>());
            same(&v.to_string());
            same(&format!("{v:e}"));
            let f: f64 = rng.random_range(-1e6..1e6);
            same(&f.to_string());
            same(&(f as f32).to_string());
            same(&format!("{f:.6}"));
        }
    }
}
