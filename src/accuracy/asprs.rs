//! ASPRS Positional Accuracy Standards (Ed. 2, 2023) and NSSDA figures from
//! aligned − survey residuals. Numbers only: the statements a report prints
//! ("Tested 0.041 m horizontal accuracy …") are written by `record`.

use super::stats::{AxisStats, axis};
use nalgebra::Vector3;

/// Why the ASPRS figures may not mean what the standard says.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AsprsCaveat {
    /// The checkpoints were also used to fit the alignment.
    NotIndependent,
    /// Fewer than the 20 checkpoints NSSDA requires (the count).
    FewerThanNssda(usize),
    /// Fewer than the 30 checkpoints ASPRS (2023) requires (the count).
    FewerThanAsprs(usize),
}

/// ASPRS figures and NSSDA 95 % values.
#[derive(Debug, Clone, PartialEq)]
pub struct Asprs {
    /// Checkpoints used.
    pub n_checkpoints: usize,
    /// True when the checkpoints were not used to fit the alignment.
    pub independent: bool,
    /// x axis.
    pub x: AxisStats,
    /// y axis.
    pub y: AxisStats,
    /// z axis, when heights were fitted.
    pub z: Option<AxisStats>,
    /// RMSE_H = √(RMSE_x² + RMSE_y²), survey error folded in when given (m).
    pub rmse_h: f64,
    /// RMSE_V, survey error folded in when given (m).
    pub rmse_v: Option<f64>,
    /// RMSE_3D = √(RMSE_H² + RMSE_V²) (m).
    pub rmse_3d: Option<f64>,
    /// RMSE_H of the data alone (m).
    pub rmse_h_measured: f64,
    /// RMSE_V of the data alone (m).
    pub rmse_v_measured: Option<f64>,
    /// Survey horizontal σ folded in (m).
    pub survey_sigma_h: Option<f64>,
    /// Survey vertical σ folded in (m).
    pub survey_sigma_v: Option<f64>,
    /// 1.7308 · RMSE_H (m).
    pub nssda_horizontal_95: f64,
    /// 1.96 · RMSE_V (m).
    pub nssda_vertical_95: Option<f64>,
    /// Caveats, in the order a reader should see them.
    pub caveats: Vec<AsprsCaveat>,
}

/// ASPRS (2023, Ed. 2) figures from aligned − survey residuals; `sigma` is the
/// survey's own (horizontal, vertical) 1-σ, folded in as √(measured² + survey²).
pub(crate) fn asprs(
    res: &[Vector3<f64>],
    vertical: bool,
    sigma: Option<(f64, Option<f64>)>,
    independent: bool,
) -> Asprs {
    let n = res.len();
    let x = axis(&res.iter().map(|r| r.x).collect::<Vec<_>>());
    let y = axis(&res.iter().map(|r| r.y).collect::<Vec<_>>());
    let z = vertical.then(|| axis(&res.iter().map(|r| r.z).collect::<Vec<_>>()));
    let rmse_h_measured = x.rmse.hypot(y.rmse);
    let rmse_v_measured = z.map(|z| z.rmse);
    let (sh, sv) = sigma.unwrap_or((0.0, None));
    let rmse_h = rmse_h_measured.hypot(sh);
    let rmse_v = rmse_v_measured.map(|v| v.hypot(sv.unwrap_or(0.0)));
    let rmse_3d = rmse_v.map(|v| rmse_h.hypot(v));
    let mut caveats = Vec::new();
    if !independent {
        caveats.push(AsprsCaveat::NotIndependent);
    }
    if n < 20 {
        caveats.push(AsprsCaveat::FewerThanNssda(n));
    }
    if n < 30 {
        caveats.push(AsprsCaveat::FewerThanAsprs(n));
    }
    Asprs {
        n_checkpoints: n,
        independent,
        x,
        y,
        z,
        rmse_h,
        rmse_v,
        rmse_3d,
        rmse_h_measured,
        rmse_v_measured,
        survey_sigma_h: sigma.map(|s| s.0),
        survey_sigma_v: sigma.and_then(|s| s.1),
        nssda_horizontal_95: 1.7308 * rmse_h,
        nssda_vertical_95: rmse_v.map(|v| 1.96 * v),
        caveats,
    }
}
