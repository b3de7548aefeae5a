//! The SLAM-like distortion that turns the world into "the map".
//!
//! map = offset + Rz(yaw) · (R_tilt · (q + drift(q) − c) ) + c,  q = p − F
//!
//! with p a world (survey-frame) point, F the survey's false origin (zero
//! unless set; q is then the scene's local frame) and c the scene centre in
//! that local frame: a smooth drift field first (what accumulates along
//! a trajectory; not removable by a rigid alignment), then a tilt about a
//! horizontal axis and a yaw about the vertical through the centre, then a
//! translation. The transform is stored in the truth so anyone can re-apply it.

use crate::Point;
use nalgebra::{Rotation3, Unit, Vector3};

/// The user-facing knobs of the distortion.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DistortParams {
    /// Translation of the map relative to the scene's local frame, metres
    /// (|v| <= 1e7).
    pub offset_m: [f64; 3],
    /// Rotation about the vertical through the scene centre, degrees, in
    /// [-360, 360].
    pub yaw_deg: f64,
    /// Tilt about a horizontal axis through the scene centre, degrees (|v| <= 15).
    pub tilt_deg: f64,
    /// Direction of the tilt axis, degrees from +x.
    pub tilt_axis_deg: f64,
    /// Linear drift: displacement of the road's end relative to its start, metres.
    pub drift_m: [f64; 3],
    /// Amplitude of a sinusoidal (non-affine) drift component, metres.
    pub drift_wave_m: f64,
}

impl Default for DistortParams {
    fn default() -> Self {
        DistortParams {
            offset_m: [1.5, -1.0, 0.3],
            yaw_deg: 1.0,
            tilt_deg: 0.0,
            tilt_axis_deg: 0.0,
            drift_m: [0.04, -0.03, 0.02],
            drift_wave_m: 0.015,
        }
    }
}

impl DistortParams {
    pub(crate) fn validate(&self) -> crate::Result<()> {
        let scalars = [
            self.yaw_deg,
            self.tilt_deg,
            self.tilt_axis_deg,
            self.drift_wave_m,
        ];
        let mut all = self
            .offset_m
            .iter()
            .chain(self.drift_m.iter())
            .chain(scalars.iter());
        if all.any(|v| !v.is_finite()) {
            return Err(crate::Error::Param(
                "distortion: values must be finite".into(),
            ));
        }
        if self.tilt_deg.abs() > 15.0 || self.yaw_deg.abs() > 360.0 {
            return Err(crate::Error::Param(
                "distortion: |tilt_deg| <= 15 and |yaw_deg| <= 360".into(),
            ));
        }
        if self.offset_m.iter().any(|v| v.abs() > 1e7) {
            return Err(crate::Error::Param(
                "distortion: offset_m values must be within ±1e7 m".into(),
            ));
        }
        Ok(())
    }
}

/// A concrete distortion: the parameters plus the scene geometry they refer to.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Distortion {
    /// The knobs.
    pub params: DistortParams,
    /// Scene centre c (rotation centre, drift reference), the scene's local frame.
    pub centre: [f64; 3],
    /// Road start x (local frame): drift is −drift/2 there.
    pub drift_x0: f64,
    /// Road length along x over which the linear drift is spread.
    pub drift_length: f64,
    /// The survey's false origin F (`SynthParams::survey_false_origin_m`):
    /// world = local + F. Absent from JSON when zero.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub survey_origin: [f64; 3],
}

fn is_zero(v: &[f64; 3]) -> bool {
    *v == [0.0; 3]
}

impl Distortion {
    /// The drift displacement at point `p` of the scene's local frame.
    pub fn drift(&self, p: &Point) -> Vector3<f64> {
        let xi = ((p.x - self.drift_x0) / self.drift_length.max(1e-9)).clamp(-0.5, 1.5) - 0.5;
        let d = Vector3::from(self.params.drift_m) * xi;
        let w = self.params.drift_wave_m;
        let ph = std::f64::consts::PI * 2.0 * xi;
        d + Vector3::new(
            w * ph.sin(),
            w * (ph + 1.0).sin(),
            0.5 * w * (ph + 2.0).sin(),
        )
    }

    fn rotation(&self) -> Rotation3<f64> {
        let p = &self.params;
        let a = p.tilt_axis_deg.to_radians();
        let tilt = Rotation3::from_axis_angle(
            &Unit::new_normalize(Vector3::new(a.cos(), a.sin(), 0.0)),
            p.tilt_deg.to_radians(),
        );
        let yaw = Rotation3::from_axis_angle(&Vector3::z_axis(), p.yaw_deg.to_radians());
        yaw * tilt
    }

    /// The rigid part of world → map (drift left out): map ≈ r · world + t,
    /// with r = Rz(yaw) · R_tilt and t = c + offset − r · (c + F). The
    /// transform a perfect frame matcher would find, up to the drift.
    pub fn rigid(&self) -> (Rotation3<f64>, Vector3<f64>) {
        let r = self.rotation();
        let c = Vector3::from(self.centre);
        let t =
            c + Vector3::from(self.params.offset_m) - r * (c + Vector3::from(self.survey_origin));
        (r, t)
    }

    /// Maps a world (survey-frame) point into the distorted map frame.
    pub fn apply(&self, p: &Point) -> Point {
        self.applier()(p)
    }

    /// A closure applying the distortion to world (survey-frame) points, with
    /// the rotation computed once.
    pub(crate) fn applier(&self) -> impl Fn(&Point) -> Point + Sync + '_ {
        let local = self.local_applier();
        let f = Vector3::from(self.survey_origin);
        move |p: &Point| local(&Point::from(p.coords - f))
    }

    /// The distortion of points in the scene's local frame (world − F): how
    /// the scanned points, built in that frame, become the map.
    pub(crate) fn local_applier(&self) -> impl Fn(&Point) -> Point + Sync + '_ {
        let r = self.rotation();
        let c = Vector3::from(self.centre);
        let off = Vector3::from(self.params.offset_m);
        move |p: &Point| {
            let q = p.coords + self.drift(p) - c;
            Point::from(r * q + c + off)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identity_when_all_zero() {
        let d = Distortion {
            params: DistortParams {
                offset_m: [0.0; 3],
                yaw_deg: 0.0,
                tilt_deg: 0.0,
                tilt_axis_deg: 0.0,
                drift_m: [0.0; 3],
                drift_wave_m: 0.0,
            },
            centre: [50.0, 0.0, 3.0],
            drift_x0: -30.0,
            drift_length: 160.0,
            survey_origin: [0.0; 3],
        };
        let p = Point::new(12.0, -7.0, 1.0);
        assert!((d.apply(&p) - p).norm() < 1e-12);
    }

    #[test]
    fn rigid_part_is_the_distortion_without_drift() {
        let d = Distortion {
            params: DistortParams {
                offset_m: [9_876.5, -4_321.0, 12.0],
                yaw_deg: 237.0,
                tilt_deg: 12.0,
                tilt_axis_deg: 70.0,
                drift_m: [0.0; 3],
                drift_wave_m: 0.0,
            },
            centre: [50.0, 0.0, 3.0],
            drift_x0: -30.0,
            drift_length: 160.0,
            survey_origin: [352_000.0, 4_026_000.0, 10.0],
        };
        let (r, t) = d.rigid();
        for p in [
            Point::new(352_012.0, 4_026_007.0, 11.0),
            Point::new(352_130.0, 4_025_980.0, 14.0),
        ] {
            let m = d.apply(&p);
            assert!((Point::from(r * p.coords + t) - m).norm() < 1e-8);
        }
        // With drift, the rigid part is off by about the drift.
        let drifting = Distortion {
            params: DistortParams {
                drift_m: [0.04, -0.03, 0.02],
                ..d.params.clone()
            },
            ..d.clone()
        };
        let p = Point::new(352_130.0, 4_025_980.0, 14.0);
        let e = (drifting.apply(&p) - Point::from(r * p.coords + t)).norm();
        assert!(e > 1e-3 && e < 0.05, "{e}");
    }

    #[test]
    fn drift_is_linear_end_to_end_and_rotation_is_rigid() {
        let d = Distortion {
            params: DistortParams {
                drift_wave_m: 0.0,
                ..Default::default()
            },
            centre: [50.0, 0.0, 3.0],
            drift_x0: -30.0,
            drift_length: 160.0,
            survey_origin: [0.0; 3],
        };
        let a = d.drift(&Point::new(-30.0, 0.0, 0.0));
        let b = d.drift(&Point::new(130.0, 0.0, 0.0));
        assert!(((b - a) - Vector3::from(d.params.drift_m)).norm() < 1e-12);
        // Two points at the same station keep their distance (rigid part only).
        let p = Point::new(20.0, 5.0, 1.0);
        let q = Point::new(20.0, -5.0, 2.0);
        assert!(((d.apply(&p) - d.apply(&q)).norm() - (p - q).norm()).abs() < 1e-9);
    }
}
