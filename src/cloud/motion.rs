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
    // No `hint_discs`: the hint is in the moved frame, and a tilted map's
    // points move sideways with their height, which no tile tells before it
    // is read; every tile is read.
    fn tile_stats(&self) -> Option<super::TileStats> {
        self.inner.tile_stats()
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
    fn moved_reader_moves_every_point() {
        let pts: Vec<Point> = (0..200_000)
            .map(|i| Point::new(i as f64 * 0.01, 1.0, 2.0))
            .collect();
        let m = RigidMotion::levelling(Point::origin(), &Vector3::new(0.1, 0.0, 1.0).normalize());
        let mut r = Moved {
            inner: Box::new(super::super::MemoryReader::new(&pts)),
            motion: m,
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
