//! Locating in every level what the coarse levels showed (issue 29). A map
//! held in levels of detail (a COPC octree) is cropped first in the coarse
//! levels near each target, enough to find it (`crop.coarse_points`);
//! here each target found so is read again in every level within a plate
//! of where it was found, and located there; one the coarse levels did not
//! show, or that every level does not confirm, is searched in every level
//! of its whole crop, as in a map without levels.
//!
//! Why: the coarse levels are a density-capped sample (untwine and PDAL
//! keep one point per voxel of a level's grid), fine for finding an L but
//! not the uniform sample the locator's σ assumes. Reading every level of
//! a 5 m crop is what made eval read a sixth of a 200 M-point COPC file;
//! reading them within a metre of the target is a fiftieth of that.

use super::target::{self, TargetRun};
use super::{Config, others_than};
use crate::cloud::{MapSource, PassRead, RigidMotion};
use crate::crop::{LooseParams, Shape, TightParams};
use crate::model::ModelKind;
use crate::survey::Survey;
use crate::{Point, Result};
use nalgebra::Vector3;
use rayon::prelude::*;

/// How far from where the coarse levels put a target its reference point is
/// searched again in every level (m; the points searched reach a plate
/// further). The coarse levels are a sample of the same points:
/// the corner moves by about its σ (millimetres); 0.3 m is also `layout`'s
/// allowance, beyond which an object is no longer where it was found.
const DETAIL_SEARCH_M: f64 = 0.3;

/// Every level is read this much beyond the search (m): the ground about
/// the plates' feet is seen at full density on every side.
const DETAIL_MARGIN_M: f64 = 0.2;

/// What the detail step needs of the first pass.
pub(super) struct Detail<'a> {
    pub(super) source: MapSource<'a>,
    pub(super) survey: &'a Survey,
    /// The loose crops' parameters (radius and shape about `expected`).
    pub(super) crop: &'a LooseParams,
    pub(super) motion: &'a RigidMotion,
    pub(super) z_range: Option<[f64; 2]>,
    pub(super) cfg: &'a Config,
    /// The last "ups" to try (`more_ups`).
    pub(super) ups: &'a [Vector3<f64>],
    /// Where each target was expected (the crops' centres).
    pub(super) expected: &'a [Point],
}

impl Detail<'_> {
    /// Each target of `found` whose crop held only coarse levels (`coarse`)
    /// located again in every level near where it was found, else searched
    /// in every level of its crop. Boards keep their own crops (read whole
    /// with intensities). Reads are logged as `crops-detail` and
    /// `crops-whole`.
    pub(super) fn run(
        &self,
        found: &mut [TargetRun],
        coarse: &[bool],
        progress: &mut impl FnMut(u64, u64),
        reads: &mut Vec<PassRead>,
    ) -> Result<()> {
        let which: Vec<usize> = (0..found.len())
            .filter(|&i| coarse[i] && self.survey.targets[i].model != ModelKind::Board)
            .collect();
        let (near, mut whole): (Vec<usize>, Vec<usize>) = which
            .into_iter()
            .partition(|&i| found[i].corner().is_some());
        if !near.is_empty() {
            whole.extend(self.in_detail(found, &near, progress, reads)?);
        }
        if !whole.is_empty() {
            whole.sort_unstable();
            self.in_whole(found, &whole, progress, reads)?;
        }
        Ok(())
    }

    /// Targets `near` (found in the coarse levels) located again in every
    /// level within a plate of where they were found; returns those every
    /// level does not confirm there.
    fn in_detail(
        &self,
        found: &mut [TargetRun],
        near: &[usize],
        progress: &mut impl FnMut(u64, u64),
        reads: &mut Vec<PassRead>,
    ) -> Result<Vec<usize>> {
        let centres: Vec<Point> = near.iter().filter_map(|&i| found[i].corner()).collect();
        // The finder looks at points within its search radius of the place:
        // the corner's allowance and the plates beyond it.
        let reach = near.iter().map(|&i| self.reach(i)).fold(0.0, f64::max);
        let params = LooseParams {
            radius: DETAIL_SEARCH_M + reach + DETAIL_MARGIN_M,
            shape: Shape::Cylinder,
            by_level: false,
            ..*self.crop
        };
        let crops = self.read(&centres, &params, "crops-detail", progress, reads)?;
        let located: Vec<(usize, TargetRun, bool)> = near
            .par_iter()
            .zip(centres)
            .zip(crops)
            .map(|((&i, c), (pts, _))| {
                // Its own plates, no wider than the configured search.
                let tight = TightParams {
                    search_radius: (DETAIL_SEARCH_M + self.reach(i))
                        .min(self.cfg.tight.search_radius),
                    ..self.cfg.tight.clone()
                };
                let pts = self.merged(&found[i].loose, pts, &c, params.radius, i);
                let mut r = self.locate(i, c, pts, &tight, &found[i]);
                // Every level confirms it only where the coarse levels put
                // it: another object nearby is not a confirmation.
                let shift = r.corner().map(|d| (d - c).xy().norm());
                let confirmed = shift.is_some_and(|s| s <= DETAIL_SEARCH_M);
                // To the millimetre: 0.3 + 0.6 + 0.2 is 1.0999… in f64.
                r.detail_radius = (params.radius * 1e3).round() / 1e3;
                (i, r, confirmed)
            })
            .collect();
        let mut not = Vec::new();
        for (i, r, confirmed) in located {
            match confirmed {
                true => found[i] = r,
                false => not.push(i),
            }
        }
        Ok(not)
    }

    /// Targets `whole` searched in every level of their whole crops, as in a
    /// map without levels.
    fn in_whole(
        &self,
        found: &mut [TargetRun],
        whole: &[usize],
        progress: &mut impl FnMut(u64, u64),
        reads: &mut Vec<PassRead>,
    ) -> Result<()> {
        let centres: Vec<Point> = whole.iter().map(|&i| self.expected[i]).collect();
        let params = LooseParams {
            by_level: false,
            ..*self.crop
        };
        let crops = self.read(&centres, &params, "crops-whole", progress, reads)?;
        let located: Vec<(usize, TargetRun)> = whole
            .par_iter()
            .zip(crops)
            .map(|(&i, (pts, offered))| {
                let others = others_than(self.expected, i);
                let place = self.place(i, self.expected[i], &others);
                let tight = &self.cfg.tight;
                let mut r = target::locate_target(place, pts, None, tight, self.cfg, found[i].pass);
                r.loose_thinned_from = (offered > r.loose.len() as u64).then_some(offered);
                (i, r)
            })
            .collect();
        for (i, r) in located {
            found[i] = r;
        }
        Ok(())
    }

    /// Every level within `params.radius` of `centres`, the read logged as
    /// `pass`.
    fn read(
        &self,
        centres: &[Point],
        params: &LooseParams,
        pass: &str,
        progress: &mut impl FnMut(u64, u64),
        reads: &mut Vec<PassRead>,
    ) -> Result<super::crops::Crops> {
        let (crops, read) = super::crops::read_near(
            self.source,
            centres,
            params,
            self.motion,
            self.z_range,
            progress,
        )?;
        reads.push(PassRead {
            pass: pass.into(),
            ..read
        });
        Ok(crops)
    }

    /// Where target `i` is looked for: at `at`, among `others`.
    fn place<'p>(&'p self, i: usize, at: Point, others: &'p [Point]) -> target::Place<'p> {
        let t = &self.survey.targets[i];
        target::Place {
            id: &t.id,
            expected: at,
            others,
            more_ups: self.ups,
            model: (t.model, t.size),
            board: None,
        }
    }

    /// How far target `i`'s points reach from its reference point: an L's
    /// plate width, a sphere's diameter.
    fn reach(&self, i: usize) -> f64 {
        let t = &self.survey.targets[i];
        match t.model {
            ModelKind::Sphere => t.size.unwrap_or(self.cfg.sphere.diameter_m),
            _ => target::l_plates(t.size, &self.cfg.tight).0,
        }
    }

    /// The coarse crop (`coarse`) with every level (`every`, read within
    /// `radius` of `at`) in place of its points near `at`: the tight crop's
    /// ground still sees the whole crop. Points of `every` outside target
    /// `i`'s loose crop stay out.
    fn merged(
        &self,
        coarse: &[Point],
        every: Vec<Point>,
        at: &Point,
        radius: f64,
        i: usize,
    ) -> Vec<Point> {
        let r2 = radius * radius;
        let near = |p: &Point| (p.x - at.x).powi(2) + (p.y - at.y).powi(2) < r2;
        let (e, big) = (&self.expected[i], self.crop.radius * self.crop.radius);
        let inside = |p: &Point| match self.crop.shape {
            Shape::Cylinder => (p.x - e.x).powi(2) + (p.y - e.y).powi(2) < big,
            Shape::Sphere => (p - e).norm_squared() < big,
        };
        let mut pts: Vec<Point> = coarse.iter().filter(|p| !near(p)).copied().collect();
        pts.extend(every.into_iter().filter(|p| near(p) && inside(p)));
        pts
    }

    /// Target `i` located in `pts` near `at`, where the coarse levels put
    /// it (`first`: that run, whose place and search it keeps).
    fn locate(
        &self,
        i: usize,
        at: Point,
        pts: Vec<Point>,
        tight: &TightParams,
        first: &TargetRun,
    ) -> TargetRun {
        let others = others_than(self.expected, i);
        let place = self.place(i, at, &others);
        let mut r = target::locate_target(place, pts, None, tight, self.cfg, first.pass);
        r.expected = first.expected;
        r.search_radius = first.search_radius;
        r.waited = first.waited;
        r.loose_thinned_from = first.loose_thinned_from;
        r
    }
}
