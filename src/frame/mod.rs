//! Where the map is: its vertical ([`level`]), and the transform that puts the
//! survey on it when the map is in a frame of its own ([`matching`], [`hints`]).
//! Everything here runs before the targets are cropped; its product is where
//! to look and which way is up.

pub(crate) mod grid;
pub mod hints;
pub mod level;
pub mod matching;

pub use level::{Footprint, GroundLevel, MapGround, ground_level};

/// 2D rigid least squares on local coordinates: the yaw and translation with
/// `to ≈ R(yaw)·from + t` for the pairs `(from, to)`. Callers subtract an
/// origin first, so no large coordinate is squared.
pub(crate) fn rigid2d(pairs: &[([f64; 2], [f64; 2])]) -> (f64, [f64; 2]) {
    let n = pairs.len().max(1) as f64;
    let mf = pairs
        .iter()
        .fold([0.0; 2], |a, (f, _)| [a[0] + f[0] / n, a[1] + f[1] / n]);
    let mt = pairs
        .iter()
        .fold([0.0; 2], |a, (_, t)| [a[0] + t[0] / n, a[1] + t[1] / n]);
    let (mut c, mut s) = (0.0, 0.0);
    for (f, t) in pairs {
        let (ax, ay) = (f[0] - mf[0], f[1] - mf[1]);
        let (bx, by) = (t[0] - mt[0], t[1] - mt[1]);
        c += ax * bx + ay * by;
        s += ax * by - ay * bx;
    }
    let yaw = s.atan2(c);
    let (sn, cs) = yaw.sin_cos();
    (
        yaw,
        [
            mt[0] - (cs * mf[0] - sn * mf[1]),
            mt[1] - (sn * mf[0] + cs * mf[1]),
        ],
    )
}
