//! What a checkerboard board's returns read as intensity: the print under
//! the beam's footprint, in the map frame the points are written in.

use super::SynthParams;
use crate::Point;
use nalgebra::Vector3;

/// A board's face in the map frame.
pub(crate) struct BoardFace {
    centre: Point,
    normal: Vector3<f64>,
    /// In the face: horizontal, then up.
    e: [Vector3<f64>; 2],
    half: f64,
    /// The print's turn (cos, sin).
    turn: (f64, f64),
    levels: [f64; 2],
    footprint: f64,
}

/// The faces of the scene's boards, moved into the map by its distortion
/// (rigid over a board: its centre and axes are moved).
pub(crate) fn board_faces(params: &SynthParams) -> Vec<BoardFace> {
    if !params.models.contains(&crate::model::ModelKind::Board) {
        return Vec::new();
    }
    let scene = super::scene::build_scene(params);
    let distortion = super::distortion_of(params, &scene.world, &scene.road);
    let warp = distortion.local_applier();
    let b = &params.board;
    let turn = b.print_turn_deg.to_radians();
    let plain = (b.levels[0] + b.levels[1]) / 2.0;
    scene
        .targets
        .iter()
        .filter(|t| t.model == crate::model::ModelKind::Board)
        .flat_map(|t| {
            let h = t.heading_deg.to_radians();
            let n = Vector3::new(h.cos(), h.sin(), 0.0);
            let e0 = Vector3::z().cross(&n);
            // The face's second axis: up on a standing board; on one lying
            // flat, away from the road (so that the print's first axis runs
            // along the road either way).
            let e1 = if b.flat { -n } else { Vector3::z() };
            let face = |c: Point, levels: [f64; 2]| {
                let cm = warp(&c);
                let step = 0.1;
                let a = (warp(&(c + e0 * step)) - cm).normalize();
                let up = (warp(&(c + e1 * step)) - cm).normalize();
                BoardFace {
                    centre: cm,
                    normal: a.cross(&up),
                    e: [a, up],
                    half: b.side_m / 2.0,
                    turn: (turn.cos(), turn.sin()),
                    levels,
                    footprint: b.footprint_m,
                }
            };
            let c = Point::from(t.world);
            // The sign beside it (`parts::board_target`): the same face, one
            // intensity.
            let sign = b
                .sign_gap_m
                .map(|g| face(c + e0 * (b.side_m + g), [plain, plain]));
            std::iter::once(face(c, b.levels)).chain(sign)
        })
        .collect()
}

/// The intensity of a return at `p` when it lies on a board's face: the
/// chance its footprint (a Gaussian of `footprint` σ) lands on a bright
/// square, between the two levels, with 5 % noise from the point's hash
/// (the same bytes for the same seed in any thread count).
pub(crate) fn board_intensity(faces: &[BoardFace], p: &Point, hash: u64) -> Option<f32> {
    for f in faces {
        let d = p - f.centre;
        if f.normal.dot(&d).abs() > 0.03 {
            continue;
        }
        let (u, v) = (f.e[0].dot(&d), f.e[1].dot(&d));
        if u.abs() > f.half + 0.002 || v.abs() > f.half + 0.002 {
            continue;
        }
        let (c, s) = f.turn;
        let (d1, d2) = (u * c + v * s, -u * s + v * c);
        let phi = |x: f64| {
            if f.footprint > 0.0 {
                0.5 * (1.0 + erf(x / (f.footprint * std::f64::consts::SQRT_2)))
            } else if x > 0.0 {
                1.0
            } else {
                0.0
            }
        };
        let (s1, s2) = (phi(d1), phi(d2));
        let bright = s1 * s2 + (1.0 - s1) * (1.0 - s2);
        let level = f.levels[0] + (f.levels[1] - f.levels[0]) * bright;
        // A standard normal from the hash's two halves (Box–Muller).
        let u1 = ((hash >> 32) as f64 + 0.5) / 4_294_967_296.0;
        let u2 = ((hash & 0xffff_ffff) as f64 + 0.5) / 4_294_967_296.0;
        let z = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
        return Some((level * (1.0 + 0.05 * z)).max(0.0) as f32);
    }
    None
}

/// The error function (Abramowitz and Stegun 7.1.26, |error| < 1.5e-7):
/// std has none, and a footprint's blur needs no better.
fn erf(x: f64) -> f64 {
    let t = 1.0 / (1.0 + 0.327_591_1 * x.abs());
    let y = 1.0
        - (((((1.061_405_429 * t - 1.453_152_027) * t) + 1.421_413_741) * t - 0.284_496_736) * t
            + 0.254_829_592)
            * t
            * (-x * x).exp();
    y.copysign(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn erf_is_close() {
        for (x, e) in [
            (0.0, 0.0),
            (0.5, 0.520_499_877_8),
            (1.0, 0.842_700_792_9),
            (-2.0, -0.995_322_265),
        ] {
            assert!((erf(x) - e).abs() < 2e-7, "{x}");
        }
    }
}
