//! ISO 19157 positional-accuracy measures of the checkpoints' residuals
//! (aligned − survey, the same ones ASPRS uses): the mean bias per axis with
//! its 95 % interval, the linear and circular errors at 90 and 95 % (LE90,
//! LE95, CE90, CE95) with the bias accounted for, and how many checkpoints
//! err beyond a threshold. docs/standards.md gives each formula.
//!
//! ISO 19157's CE/LE formulas in closed form (CE90 = 2.1460 σ_c, LE90 =
//! 1.6449 σ) assume errors without bias and, for CE, equal σ on both axes.
//! A map's residuals after a fit need neither: here the error is modelled as
//! a normal with the residuals' mean and sample covariance, and CE_p is the
//! radius holding the share p of it (numerically, to 1e-9 m), LE_p the
//! half-width about zero; without bias and with equal σ they are the
//! closed forms.

use nalgebra::{Matrix2, Vector3};
use serde::{Deserialize, Serialize};

/// One axis' mean residual and its 95 % interval (Student's t over the
/// checkpoints).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Bias {
    /// Mean residual (m).
    pub mean: f64,
    /// 95 % interval of the mean [lo, hi] (m); `null` with fewer than 2.
    pub ci95: Option<[f64; 2]>,
}

/// ISO 19157 measures of one set of checkpoints.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Iso19157 {
    /// Checkpoints measured.
    pub n: usize,
    /// Mean bias along x, y (and z when heights are compared); empty
    /// without checkpoints.
    pub bias: Vec<Bias>,
    /// Circular error at 90 % (m): the radius holding 90 % of the modelled
    /// horizontal error, bias included; `null` with fewer than 3 checkpoints.
    pub ce90: Option<f64>,
    /// Circular error at 95 % (m).
    pub ce95: Option<f64>,
    /// Linear (vertical) error at 90 % (m), bias included; `null` without
    /// heights or with fewer than 3 checkpoints.
    pub le90: Option<f64>,
    /// Linear error at 95 % (m).
    pub le95: Option<f64>,
    /// The threshold the counts below use (m), when one was set.
    pub threshold_m: Option<f64>,
    /// Checkpoints whose horizontal error exceeds the threshold.
    pub above_h: Option<usize>,
    /// Their share of the checkpoints (0–1).
    pub rate_above_h: Option<f64>,
    /// Checkpoints whose vertical error exceeds the threshold.
    pub above_v: Option<usize>,
    /// Their share (0–1).
    pub rate_above_v: Option<f64>,
}

/// The measures of `res` (aligned − survey, one per checkpoint); `vertical`
/// when heights are compared.
pub(crate) fn iso19157(res: &[Vector3<f64>], vertical: bool, threshold: Option<f64>) -> Iso19157 {
    let n = res.len();
    let axes = if vertical { 3 } else { 2 };
    let col = |k: usize| res.iter().map(|r| r[k]).collect::<Vec<f64>>();
    let bias: Vec<Bias> = if n == 0 {
        Vec::new()
    } else {
        (0..axes).map(|k| bias(&col(k))).collect()
    };
    let enough = n >= 3;
    let (ce90, ce95) = match enough.then(|| horizontal_model(res)).flatten() {
        Some((b, s)) => (
            Some(circular_error(b, s, 0.90)),
            Some(circular_error(b, s, 0.95)),
        ),
        None => (None, None),
    };
    let (le90, le95) = if vertical && enough {
        let z = col(2);
        let (m, s) = mean_std(&z);
        (
            Some(linear_error(m, s, 0.90)),
            Some(linear_error(m, s, 0.95)),
        )
    } else {
        (None, None)
    };
    let count = |e: &dyn Fn(&Vector3<f64>) -> f64| {
        threshold.map(|t| res.iter().filter(|r| e(r) > t).count())
    };
    let above_h = count(&|r| r.x.hypot(r.y));
    let above_v = if vertical {
        count(&|r| r.z.abs())
    } else {
        None
    };
    let rate = |c: Option<usize>| c.filter(|_| n > 0).map(|c| c as f64 / n as f64);
    Iso19157 {
        n,
        bias,
        ce90,
        ce95,
        le90,
        le95,
        threshold_m: threshold,
        above_h,
        rate_above_h: rate(above_h),
        above_v,
        rate_above_v: rate(above_v),
    }
}

fn mean_std(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let s2 = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    (m, s2.sqrt())
}

fn bias(v: &[f64]) -> Bias {
    let (m, s) = mean_std(v);
    let ci95 = (v.len() >= 2).then(|| {
        let h = super::t975(v.len() - 1) * s / (v.len() as f64).sqrt();
        [m - h, m + h]
    });
    Bias { mean: m, ci95 }
}

/// The horizontal residuals' mean and sample covariance in its principal
/// axes: (bias along each axis, σ along each axis).
fn horizontal_model(res: &[Vector3<f64>]) -> Option<([f64; 2], [f64; 2])> {
    let n = res.len() as f64;
    let (mx, my) = (
        res.iter().map(|r| r.x).sum::<f64>() / n,
        res.iter().map(|r| r.y).sum::<f64>() / n,
    );
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for r in res {
        let (dx, dy) = (r.x - mx, r.y - my);
        sxx += dx * dx;
        sxy += dx * dy;
        syy += dy * dy;
    }
    let c = Matrix2::new(sxx, sxy, sxy, syy) / (n - 1.0);
    let e = c.symmetric_eigen();
    let v = e.eigenvectors;
    let b = [
        v[(0, 0)] * mx + v[(1, 0)] * my,
        v[(0, 1)] * mx + v[(1, 1)] * my,
    ];
    let s = [
        e.eigenvalues[0].max(0.0).sqrt(),
        e.eigenvalues[1].max(0.0).sqrt(),
    ];
    (s[0].is_finite() && s[1].is_finite()).then_some((b, s))
}

/// Standard normal CDF.
fn phi(x: f64) -> f64 {
    0.5 * erfc(-x / std::f64::consts::SQRT_2)
}

/// erfc(x): a Chebyshev fit (Numerical Recipes' `erfcc`), fractional error
/// < 1.2e-7 everywhere — ample for an error radius solved to a share of
/// 1e-7 (nanometres at centimetres); no crate needed for one function.
fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let r = t
        * (-z * z - 1.265_512_23
            + t * (1.000_023_68
                + t * (0.374_091_96
                    + t * (0.096_784_18
                        + t * (-0.186_288_06
                            + t * (0.278_868_07
                                + t * (-1.135_203_98
                                    + t * (1.488_515_87
                                        + t * (-0.822_152_23 + t * 0.170_872_77)))))))))
            .exp();
    if x >= 0.0 { r } else { 2.0 - r }
}

/// P(|e| ≤ h) for e ~ N(m, s²).
fn linear_share(m: f64, s: f64, h: f64) -> f64 {
    if s <= 0.0 {
        return f64::from(u8::from(m.abs() <= h));
    }
    phi((h - m) / s) - phi((-h - m) / s)
}

/// P(|e| ≤ r) for e ~ N(b, diag(s²)) in the plane: over x = r sin θ along
/// the wider axis, the share of y within ±r cos θ. Simpson's rule in θ (smooth
/// at the disc's edges) over the x where the mass is (b₀ ± 9 s₀): the steps
/// always resolve the density, however narrow it is against the radius.
fn circular_share(b: [f64; 2], s: [f64; 2], r: f64) -> f64 {
    if r <= 0.0 {
        return 0.0;
    }
    // Along the wider axis outside, the narrower inside (exactly, by Φ).
    let (b, s) = if s[0] >= s[1] {
        (b, s)
    } else {
        ([b[1], b[0]], [s[1], s[0]])
    };
    if s[0] <= 0.0 {
        // Both σ zero: the error is its bias.
        return f64::from(u8::from(b[0].hypot(b[1]) <= r));
    }
    const STEPS: usize = 256;
    let lo = (b[0] - 9.0 * s[0]).max(-r);
    let hi = (b[0] + 9.0 * s[0]).min(r);
    if lo >= hi {
        return 0.0;
    }
    let (t0, t1) = (
        (lo / r).clamp(-1.0, 1.0).asin(),
        (hi / r).clamp(-1.0, 1.0).asin(),
    );
    let h = (t1 - t0) / STEPS as f64;
    let f = |theta: f64| {
        let (sn, cs) = theta.sin_cos();
        let x = r * sn;
        let density = (-0.5 * ((x - b[0]) / s[0]).powi(2)).exp()
            / (s[0] * (2.0 * std::f64::consts::PI).sqrt());
        density * linear_share(b[1], s[1], r * cs) * r * cs
    };
    let mut sum = f(t0) + f(t1);
    for k in 1..STEPS {
        sum += f(t0 + k as f64 * h) * if k % 2 == 1 { 4.0 } else { 2.0 };
    }
    sum * h / 3.0
}

/// The smallest `r` with `share(r) ≥ p` (bisection; `share` grows with r).
fn solve(p: f64, hi: f64, share: impl Fn(f64) -> f64) -> f64 {
    let (mut lo, mut hi) = (0.0, hi.max(1e-12));
    while share(hi) < p {
        hi *= 2.0;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if share(mid) < p {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo < 1e-9 * hi.max(1e-3) {
            break;
        }
    }
    0.5 * (lo + hi)
}

/// CE_p: the radius about the surveyed point holding the share `p` of the
/// modelled horizontal error (bias `b` and σ `s` along its principal axes).
fn circular_error(b: [f64; 2], s: [f64; 2], p: f64) -> f64 {
    let scale = b[0].hypot(b[1]) + 4.0 * s[0].max(s[1]);
    solve(p, scale, |r| circular_share(b, s, r))
}

/// LE_p: the half-width about zero holding the share `p` of N(m, s²).
fn linear_error(m: f64, s: f64, p: f64) -> f64 {
    solve(p, m.abs() + 3.0 * s, |h| linear_share(m, s, h))
}

#[cfg(test)]
mod tests;
