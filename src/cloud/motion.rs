//! A rigid rotation applied to every point as it streams: how a tilted map is
//! read in its levelled frame without a copy. The rotation is about an origin
//! near the map, so the large coordinates of a georeferenced map are
//! subtracted before they are multiplied.

use super::{Batch, CloudInfo, PointReader, ReadStats, Scratch};
use crate::{Point, Result};
use nalgebra::{Rotation3, Vector3};

/// `p ↦ origin + R·(p − origin)`: a rotation about a point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidMotion {
    /// The fixed point of the rotation (map frame).
    pub origin: Point,
    /// The rotation.
    pub rotation: Rotation3<f64>,
}

impl RigidMotion {
    /// The identity about `origin`.
    pub fn identity_at(origin: Point) -> Self {
        RigidMotion {
            origin,
            rotation: Rotation3::identity(),
        }
    }

    /// The rotation that turns `up` (any unit vector) into +z, about `origin`.
    pub fn levelling(origin: Point, up: &Vector3<f64>) -> Self {
        let rotation =
            Rotation3::rotation_between(up, &Vector3::z()).unwrap_or_else(Rotation3::identity);
        RigidMotion { origin, rotation }
    }

    /// Whether this moves nothing.
    pub fn is_identity(&self) -> bool {
        self.rotation == Rotation3::identity()
    }

    /// A point moved.
    #[inline]
    pub fn apply(&self, p: &Point) -> Point {
        self.origin + self.rotation * (p - self.origin)
    }

    /// A point moved back.
    pub fn invert(&self, p: &Point) -> Point {
        self.origin + self.rotation.inverse() * (p - self.origin)
    }

    /// This motion followed by `more`, a rotation about the same origin.
    pub fn then(&self, more: &Rotation3<f64>) -> RigidMotion {
        RigidMotion {
            origin: self.origin,
            rotation: more * self.rotation,
        }
    }

    /// Discs in the unmoved frame that hold every point with z in `z` whose
    /// moved position lies within `radius` (horizontally) of a centre:
    /// `(centres, radius)`. A tilted map's points move sideways by their
    /// height times the tangent of the tilt, so the disc grows by that over
    /// the map's height range. `None` when the range or radius is not finite,
    /// or the motion tips the map more than 60° (not a levelling): then
    /// nothing can be left unread.
    pub fn discs_back(
        &self,
        centres: &[[f64; 2]],
        radius: f64,
        z: [f64; 2],
    ) -> Option<(Vec<[f64; 2]>, f64)> {
        // p - o = T (q - o) with T = R⁻¹. Eliminating the moved height q_z
        // through p_z: p_xy - o_xy = K (q_xy - o_xy) + k (p_z - o_z), with
        // K = A - b aᵀ / g and k = b / g for T's blocks [[A, b], [aᵀ, g]].
        let t = self.rotation.inverse().into_inner();
        let g = t[(2, 2)];
        if !(g > 0.5 && radius.is_finite() && z.iter().all(|v| v.is_finite()) && z[0] <= z[1]) {
            return None;
        }
        let k = [t[(0, 2)] / g, t[(1, 2)] / g];
        let kk = |i: usize, j: usize| t[(i, j)] - k[i] * t[(2, j)];
        let m = [[kk(0, 0), kk(0, 1)], [kk(1, 0), kk(1, 1)]];
        // ‖K‖₂: the square root of KᵀK's largest eigenvalue.
        let p = m[0][0] * m[0][0] + m[1][0] * m[1][0];
        let q = m[0][0] * m[0][1] + m[1][0] * m[1][1];
        let s = m[0][1] * m[0][1] + m[1][1] * m[1][1];
        let norm = ((p + s) / 2.0 + (((p - s) / 2.0).powi(2) + q * q).sqrt()).sqrt();
        let o = self.origin;
        let mid = (z[0] + z[1]) / 2.0 - o.z;
        let half = (z[1] - z[0]) / 2.0;
        let back = centres
            .iter()
            .map(|c| {
                let d = [c[0] - o.x, c[1] - o.y];
                [
                    o.x + m[0][0] * d[0] + m[0][1] * d[1] + k[0] * mid,
                    o.y + m[1][0] * d[0] + m[1][1] * d[1] + k[1] * mid,
                ]
            })
            .collect();
        // A millimetre and a part in 10⁹ beyond what the algebra gives, for
        // its rounding: the reader still gets a superset, as a hint must be.
        let r = (norm * radius + k[0].hypot(k[1]) * half) * (1.0 + 1e-9) + 1e-3;
        Some((back, r))
    }

    /// Tilt of the motion's rotation: the angle between +z and where it goes (degrees).
    pub fn tilt_deg(&self) -> f64 {
        (self.rotation * Vector3::z())
            .angle(&Vector3::z())
            .to_degrees()
    }
}

/// A reader whose points come out moved by a [`RigidMotion`].
pub(crate) struct Moved<'r> {
    pub(crate) inner: Box<dyn PointReader + 'r>,
    pub(crate) motion: RigidMotion,
    /// The map's z range (unmoved frame), when known: what lets a hint be
    /// turned back into the inner reader's frame.
    pub(crate) z_range: Option<[f64; 2]>,
}

impl PointReader for Moved<'_> {
    fn info(&self) -> &CloudInfo {
        self.inner.info()
    }
    fn next_chunk(&mut self, buf: &mut Vec<Point>) -> Result<bool> {
        let more = self.inner.next_chunk(buf)?;
        for p in buf.iter_mut() {
            *p = self.motion.apply(p);
        }
        Ok(more)
    }
    fn stats(&self) -> ReadStats {
        self.inner.stats()
    }
    fn bytes_read(&self) -> u64 {
        self.inner.bytes_read()
    }
    fn has_intensity(&self) -> bool {
        self.inner.has_intensity()
    }
    fn next_chunk_intensity(
        &mut self,
        buf: &mut Vec<Point>,
        intensity: &mut Vec<f32>,
    ) -> Result<bool> {
        let more = self.inner.next_chunk_intensity(buf, intensity)?;
        for p in buf.iter_mut() {
            *p = self.motion.apply(p);
        }
        Ok(more)
    }
    /// The hint is in the moved frame; a tilted map's points move sideways
    /// with their height, which no tile or COPC node tells before it is read.
    /// With the map's z range the discs are turned back and widened by the
    /// most any point can move ([`RigidMotion::discs_back`]); without it
    /// every part of the map is read.
    fn hint_discs(&mut self, centres: &[[f64; 2]], radius: f64) {
        if let Some((back, r)) = self
            .z_range
            .and_then(|z| self.motion.discs_back(centres, radius, z))
        {
            self.inner.hint_discs(&back, r);
        }
    }
    /// Passed on when the discs were (a reader given no discs ignores it).
    fn hint_enough(&mut self, points: u64) {
        self.inner.hint_enough(points);
    }
    fn levels_cut(&self) -> Vec<bool> {
        self.inner.levels_cut()
    }
    fn tile_stats(&self) -> Option<super::TileStats> {
        self.inner.tile_stats()
    }
    fn hint_sample(&mut self, points: u64) {
        self.inner.hint_sample(points);
    }
    fn sampled(&self) -> Option<u64> {
        self.inner.sampled()
    }
    fn float32_coords(&self) -> bool {
        self.inner.float32_coords()
    }
    fn next_batch<'a>(
        &'a mut self,
        buf: &'a mut Vec<Point>,
    ) -> Result<Option<Box<dyn Batch + 'a>>> {
        let motion = self.motion;
        Ok(self
            .inner
            .next_batch(buf)?
            .map(|inner| Box::new(MovedBatch { inner, motion }) as Box<dyn Batch + 'a>))
    }
}

struct MovedBatch<'a> {
    inner: Box<dyn Batch + 'a>,
    motion: RigidMotion,
}

impl Batch for MovedBatch<'_> {
    fn pieces(&self) -> usize {
        self.inner.pieces()
    }
    // The region hint is in the moved frame, which the inner reader does not
    // know: every point is decoded and moved (correct, a little slower).
    fn piece<'s>(&'s self, i: usize, scratch: &'s mut Scratch) -> Result<&'s [Point]> {
        let mut out = std::mem::take(&mut scratch.moved);
        out.clear();
        {
            let pts = self.inner.piece(i, scratch)?;
            out.extend(pts.iter().map(|p| self.motion.apply(p)));
        }
        scratch.moved = out;
        Ok(&scratch.moved)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levelling_turns_up_into_z_and_back() {
        let up = Vector3::new(0.05, -0.08, 1.0).normalize();
        let m = RigidMotion::levelling(Point::new(1000.0, 2000.0, 50.0), &up);
        let p = Point::new(1000.0, 2000.0, 50.0) + up * 3.0;
        let q = m.apply(&p);
        assert!((q - Point::new(1000.0, 2000.0, 53.0)).norm() < 1e-9);
        assert!((m.invert(&q) - p).norm() < 1e-9);
        assert!((m.tilt_deg() - up.angle(&Vector3::z()).to_degrees()).abs() < 1e-9);
    }

    #[test]
    fn discs_turned_back_hold_every_point_that_moves_into_a_disc() {
        let mut s = 11u64;
        let mut u = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        for (tilt, az) in [(0.0, 0.0), (3.0, 40.0), (8.0, 200.0), (25.0, 300.0)] {
            let (t, a) = (f64::to_radians(tilt), f64::to_radians(az));
            let up = Vector3::new(t.sin() * a.cos(), t.sin() * a.sin(), t.cos());
            let o = Point::new(512_000.0, 4_100_000.0, 80.0);
            let m = RigidMotion::levelling(o, &up);
            let centres = [[o.x + 35.0, o.y - 60.0], [o.x - 120.0, o.y + 14.0]];
            let z = [60.0, 140.0];
            let (back, r) = m.discs_back(&centres, 5.0, z).unwrap();
            if tilt == 0.0 {
                assert!(
                    (r - 5.0).abs() < 2e-3 && back[0] == centres[0],
                    "{back:?} {r}"
                );
            }
            let mut worst: f64 = 0.0;
            for _ in 0..20_000 {
                // A point of the map (z in range) that moves to within 5 m of
                // a centre: pick the moved x, y, then solve for the height.
                let c = centres[(u() * 2.0) as usize % 2];
                let (ang, d) = (u() * std::f64::consts::TAU, 5.0 * u().sqrt());
                let pz = z[0] + (z[1] - z[0]) * u();
                let (qx, qy) = (c[0] + d * ang.cos(), c[1] + d * ang.sin());
                // p = invert(q): its z is linear in q's height h.
                let at = |h: f64| m.invert(&Point::new(qx, qy, h));
                let (p0, p1) = (at(0.0), at(1.0));
                let p = at((pz - p0.z) / (p1.z - p0.z));
                assert!((p.z - pz).abs() < 1e-6);
                let inside = back
                    .iter()
                    .map(|b| (p.x - b[0]).hypot(p.y - b[1]))
                    .fold(f64::INFINITY, f64::min);
                assert!(inside <= r, "tilt {tilt}: {inside} > {r}");
                worst = worst.max(inside / r);
            }
            // Tight: the far rim is reached (the disc is not just huge).
            assert!(worst > 0.9, "tilt {tilt}: {worst}");
        }
        let flat = RigidMotion::identity_at(Point::origin());
        assert!(
            flat.discs_back(&[[0.0, 0.0]], 5.0, [0.0, f64::NAN])
                .is_none()
        );
        let over = RigidMotion::levelling(Point::origin(), &Vector3::x());
        assert!(over.discs_back(&[[0.0, 0.0]], 5.0, [0.0, 1.0]).is_none());
    }

    #[test]
    fn moved_reader_moves_every_point() {
        let pts: Vec<Point> = (0..200_000)
            .map(|i| Point::new(i as f64 * 0.01, 1.0, 2.0))
            .collect();
        let m = RigidMotion::levelling(Point::origin(), &Vector3::new(0.1, 0.0, 1.0).normalize());
        let mut r = Moved {
            inner: Box::new(super::super::MemoryReader::new(&pts)),
            motion: m,
            z_range: None,
        };
        let mut buf = Vec::new();
        let mut got = Vec::new();
        while let Some(b) = r.next_batch(&mut buf).unwrap() {
            let mut s = Scratch::default();
            for i in 0..b.pieces() {
                got.extend_from_slice(b.piece(i, &mut s).unwrap());
            }
        }
        assert_eq!(got.len(), pts.len());
        assert!((got[777] - m.apply(&pts[777])).norm() < 1e-12);
    }
}
