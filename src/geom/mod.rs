//! Geometry shared by the stages: planes, their least-squares (SVD) fit and
//! plane RANSAC. The tight crop fits the ground with them, the locator the
//! target's plates. (Rigid transforms live in [`crate::align`].)

pub(crate) mod plane;
pub(crate) mod ransac;

pub(crate) use plane::{Plane, Scatter};
pub(crate) use ransac::{Draw, Ransac};

/// The most values of sorted `v` within any `span`: how many points one
/// surface at one distance holds (the tight crop's "an L, not a T", the
/// doubled-plate check's "a layer along the plate, not across it").
pub(crate) fn densest_run(v: &[f64], span: f64) -> usize {
    let mut best = 0;
    let mut j = 0;
    for i in 0..v.len() {
        while v[i] - v[j] > span {
            j += 1;
        }
        best = best.max(i + 1 - j);
    }
    best
}
