//! The map's horizontal scale against the survey's, from the layout of the
//! located targets: a map stretched by 1.5 ‰ has E_abs and E_rel a rigid fit
//! half-hides (the errors grow with distance from the centroid), while its
//! scale, with an interval, says so in one number. Reported whatever the
//! alignment used (a similarity alignment applies it; a rigid one does not).

use serde::{Deserialize, Serialize};

/// A scale estimate: `map distance / survey distance − 1`, in parts per
/// million, with its 95 % interval.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ScaleEstimate {
    /// Scale error (ppm): positive when the map's distances are longer.
    pub ppm: f64,
    /// 95 % interval (ppm): Student's t on the fit's 2n − 4 degrees of freedom.
    pub ci95_ppm: [f64; 2],
    /// Targets the estimate used.
    pub n: usize,
}

/// The least-squares 2D similarity survey → map of matched horizontal
/// positions `(survey, map)` (Helmert: shift, rotation, scale), its scale
/// as a [`ScaleEstimate`]; `None` with fewer than 3 positions or when they
/// span less than a metre. The scale's standard error is σ̂ / √Σ|s − s̄|², σ̂
/// from the residuals (the survey's noise and the map's both in it).
pub(crate) fn layout_scale(pairs: &[([f64; 2], [f64; 2])]) -> Option<ScaleEstimate> {
    let n = pairs.len();
    if n < 3 {
        return None;
    }
    let mean = |k: usize| {
        let (mut x, mut y) = (0.0, 0.0);
        for p in pairs {
            let v = if k == 0 { p.0 } else { p.1 };
            x += v[0];
            y += v[1];
        }
        [x / n as f64, y / n as f64]
    };
    // Centred first: survey coordinates may be UTM-sized.
    let (cs, cm) = (mean(0), mean(1));
    let c: Vec<([f64; 2], [f64; 2])> = pairs
        .iter()
        .map(|(s, m)| ([s[0] - cs[0], s[1] - cs[1]], [m[0] - cm[0], m[1] - cm[1]]))
        .collect();
    // m ≈ a · s in complex numbers: a = Σ conj(s)·m / Σ|s|².
    let ss: f64 = c.iter().map(|(s, _)| s[0] * s[0] + s[1] * s[1]).sum();
    if ss < 1.0 {
        return None;
    }
    let (mut re, mut im) = (0.0, 0.0);
    for (s, m) in &c {
        re += s[0] * m[0] + s[1] * m[1];
        im += s[0] * m[1] - s[1] * m[0];
    }
    let (re, im) = (re / ss, im / ss);
    let scale = re.hypot(im);
    let sse: f64 = c
        .iter()
        .map(|(s, m)| {
            let px = re * s[0] - im * s[1];
            let py = im * s[0] + re * s[1];
            (m[0] - px).powi(2) + (m[1] - py).powi(2)
        })
        .sum();
    let dof = 2 * n - 4;
    let se = (sse / dof as f64).sqrt() / ss.sqrt();
    let h = super::stats::t975(dof) * se;
    let ppm = (scale - 1.0) * 1e6;
    Some(ScaleEstimate {
        ppm,
        ci95_ppm: [ppm - h * 1e6, ppm + h * 1e6],
        n,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A layout stretched by 1.5 ‰ and turned, with 5 mm of noise: the
    /// estimate is within its interval of 1500 ppm, and the interval
    /// excludes 0; unstretched, it includes 0.
    #[test]
    fn a_stretched_layout_shows_its_scale() {
        let sur = [
            [0.0, 0.0],
            [30.0, 5.0],
            [60.0, -8.0],
            [90.0, 3.0],
            [120.0, 10.0],
            [45.0, 20.0],
        ];
        let noise = [
            [0.004, -0.003],
            [-0.005, 0.002],
            [0.001, 0.005],
            [-0.002, -0.004],
            [0.003, 0.001],
            [-0.001, -0.002],
        ];
        let (yaw, t) = (0.3_f64, [352_000.0, 4_150_000.0]);
        let layout = |k: f64| -> Vec<([f64; 2], [f64; 2])> {
            sur.iter()
                .zip(&noise)
                .map(|(s, e)| {
                    let m = [
                        k * (yaw.cos() * s[0] - yaw.sin() * s[1]) + t[0] + e[0],
                        k * (yaw.sin() * s[0] + yaw.cos() * s[1]) + t[1] + e[1],
                    ];
                    ([s[0] + 500_000.0, s[1] + 5_400_000.0], m)
                })
                .collect()
        };
        let st = layout_scale(&layout(1.0015)).unwrap();
        assert!(st.ci95_ppm[0] > 0.0, "{st:?}");
        assert!(st.ci95_ppm[0] < 1500.0 && st.ci95_ppm[1] > 1500.0, "{st:?}");
        assert!((st.ppm - 1500.0).abs() < 150.0, "{st:?}");
        let level = layout_scale(&layout(1.0)).unwrap();
        assert!(
            level.ci95_ppm[0] < 0.0 && level.ci95_ppm[1] > 0.0,
            "{level:?}"
        );
        assert_eq!(level.n, 6);
        assert!(layout_scale(&layout(1.0)[..2]).is_none());
    }
}
