//! Target models: what a surveyed target looks like in the map, and the one
//! point of it the survey measured.
//!
//! | model    | `size` (survey CSV) | reference point                          |
//! |----------|---------------------|------------------------------------------|
//! | `l`      | plate width         | the plates' corner line at mid plate height |
//! | `sphere` | diameter            | the centre                               |
//! | `board`  | side                | the centre where the four squares meet   |
//!
//! The L is the paper's target (`crop::tight` finds it, `locate` locates it);
//! a sphere is found and fitted by [`sphere`], a checkerboard board by
//! [`board`] from its plane and its intensity print (read in a pass of its
//! own: the map's format must carry intensity, else the board is
//! `not_found` and says so). Every model ends in the same estimate, a point
//! with its covariance, so alignment, errors and reports take them alike.
//!
//! ```
//! use mapgauge::model::ModelKind;
//! let m: ModelKind = "sphere".parse().unwrap();
//! assert_eq!(m, ModelKind::Sphere);
//! assert!(m.check_size(0.145).is_ok());
//! assert!(m.check_size(14.5).is_err()); // centimetres written as metres
//! ```

pub mod board;
pub mod sphere;

pub use board::{BoardError, BoardFit, BoardParams};
pub use sphere::{SphereError, SphereFit, SphereParams};

use serde::{Deserialize, Serialize};

/// A model's `not_found` reason names what was refused where the target
/// should be: of the refused candidates within this distance (m,
/// horizontally) of the nearest one, the best supported.
pub(crate) const SAME_PLACE_M: f64 = 1.0;

/// A `not_found` reason's "closest thing seen" with the hint of a target
/// of another size standing there, either or both.
pub(crate) fn with_hint(seen: Option<String>, hint: Option<String>) -> Option<String> {
    match (seen, hint) {
        (Some(s), Some(h)) => Some(format!("{s}; {h}")),
        (s, h) => s.or(h),
    }
}

/// What a `not_found` reason names of `refused`: of those within
/// [`SAME_PLACE_M`] of the nearest (`from`: horizontal distance from the
/// expected position), the best supported. The target itself when it was
/// seen and refused; a ground blob metres away has more points and says
/// nothing of why the target failed.
pub(crate) fn at_same_place<T>(
    refused: &[T],
    from: impl Fn(&T) -> f64,
    support: impl Fn(&T) -> usize,
) -> Option<&T> {
    let nearest = refused.iter().map(&from).fold(f64::INFINITY, f64::min);
    refused
        .iter()
        .filter(|r| from(r) <= nearest + SAME_PLACE_M)
        .max_by_key(|r| support(r))
}

/// The kind of a surveyed target.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default, Serialize, Deserialize,
)]
#[serde(rename_all = "lowercase")]
pub enum ModelKind {
    /// Two perpendicular grill plates (the paper's target).
    #[default]
    L,
    /// A sphere, located by its centre (geometry only).
    Sphere,
    /// A planar checkerboard board, located where its four squares meet
    /// (needs the map's intensity).
    Board,
}

impl ModelKind {
    /// The name the survey CSV and `result.json` use.
    pub fn name(self) -> &'static str {
        match self {
            ModelKind::L => "l",
            ModelKind::Sphere => "sphere",
            ModelKind::Board => "board",
        }
    }

    /// What `size` measures for this model.
    pub fn size_name(self) -> &'static str {
        match self {
            ModelKind::L => "plate width",
            ModelKind::Sphere => "diameter",
            ModelKind::Board => "side",
        }
    }

    /// Sizes (m) a target of this model is built in: beyond them a size is a
    /// unit slip (millimetres or centimetres written as metres), refused.
    pub fn size_range(self) -> (f64, f64) {
        match self {
            ModelKind::L => (0.1, 3.0),
            ModelKind::Sphere => (0.05, 1.0),
            ModelKind::Board => (0.1, 3.0),
        }
    }

    /// `Ok` when `size` (m) is one this model is built in, else why not.
    pub fn check_size(self, size: f64) -> Result<(), String> {
        let (lo, hi) = self.size_range();
        if size.is_finite() && (lo..=hi).contains(&size) {
            Ok(())
        } else {
            Err(format!(
                "size {size} m is outside {lo}..{hi} m, the {} of a {} target (sizes are in metres)",
                self.size_name(),
                self.name()
            ))
        }
    }
}

impl std::str::FromStr for ModelKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "l" | "l-target" | "l_target" => Ok(ModelKind::L),
            "sphere" | "ball" => Ok(ModelKind::Sphere),
            "board" | "checkerboard" | "checker" => Ok(ModelKind::Board),
            _ => Err(format!(
                "model `{s}` is not one mapgauge knows: l, sphere or board"
            )),
        }
    }
}

impl std::fmt::Display for ModelKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_unknown_models_are_refused() {
        for m in [ModelKind::L, ModelKind::Sphere, ModelKind::Board] {
            assert_eq!(m.name().parse::<ModelKind>().unwrap(), m);
        }
        assert_eq!(" Sphere ".parse::<ModelKind>().unwrap(), ModelKind::Sphere);
        let e = "cone".parse::<ModelKind>().unwrap_err();
        assert!(
            e.contains("`cone`") && e.contains("l, sphere or board"),
            "{e}"
        );
    }

    #[test]
    fn sizes_outside_what_is_built_are_refused() {
        assert!(ModelKind::Sphere.check_size(0.2).is_ok());
        assert!(ModelKind::Sphere.check_size(145.0).is_err());
        assert!(ModelKind::Sphere.check_size(f64::NAN).is_err());
        assert!(ModelKind::L.check_size(0.6).is_ok());
        assert!(ModelKind::L.check_size(60.0).is_err());
    }
}
