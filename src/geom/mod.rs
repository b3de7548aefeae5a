//! Geometry shared by the stages: planes, their least-squares (SVD) fit and
//! plane RANSAC. The tight crop fits the ground with them, the locator the
//! target's plates. (Rigid transforms live in [`crate::align`].)

pub(crate) mod plane;
pub(crate) mod ransac;

pub(crate) use plane::{Plane, Scatter};
pub(crate) use ransac::{Draw, Ransac};
