//! Driving the road: how many scans the requested points take, and the
//! passes that cast them, batch by batch, handing each scan's points to the
//! sink in scan order whatever the thread count.

use super::geometry::World;
use super::lidar::{self, Pose, Road};
use super::{BATCH, BATCH_POINTS, LabelledSink, PointLabel, SynthParams};
use crate::{Point, Result};
use nalgebra::Vector3;
use rayon::prelude::*;

/// The plan of a drive along the road, and what it casts each scan with.
pub(super) struct Drive<'a, W> {
    world: &'a World,
    road: &'a Road,
    params: &'a SynthParams,
    /// Objects 0..n_targets of the world are the targets (their labels).
    n_targets: usize,
    labelled: bool,
    /// Into the map's local frame (see `Truth`).
    warp: &'a W,
    per_scan: u64,
    /// Stations along the road, one scan each.
    pub(super) n_scans: u64,
    spacing: f64,
    batch_scans: u64,
}

/// What the passes have handed the sink so far: the points, and the pose of
/// every scan (the route the truth records).
pub(super) struct Driven {
    pub(super) total: u64,
    pub(super) path: Vec<Pose>,
}

impl<'a, W: Fn(&Point) -> Point + Sync> Drive<'a, W> {
    /// Spaces the scans evenly along the road so that they return about
    /// `params.points` points.
    pub(super) fn plan(
        params: &'a SynthParams,
        world: &'a World,
        road: &'a Road,
        n_targets: usize,
        labelled: bool,
        warp: &'a W,
    ) -> Self {
        let lidar = &params.lidar;
        let dx_rev = lidar.speed_mps / lidar.rate_hz;
        let usable = (road.length() - dx_rev).max(0.0);
        let per_scan = probe_per_scan(params, world, road, usable);
        let n_scans = params.points.div_ceil(per_scan).max(1);
        Drive {
            world,
            road,
            params,
            n_targets,
            labelled,
            warp,
            per_scan,
            n_scans,
            spacing: usable / n_scans as f64,
            batch_scans: (BATCH_POINTS / per_scan).clamp(1, BATCH),
        }
    }

    /// An empty record of the passes, its route sized for this drive.
    pub(super) fn driven(&self) -> Driven {
        Driven {
            total: 0,
            path: Vec::with_capacity(self.n_scans.min(1 << 24) as usize),
        }
    }

    fn station(&self, i: u64) -> f64 {
        self.road.x0 + (i as f64 + 0.5) * self.spacing
    }

    /// One pass over stations `from..n_scans`: scan `index_base + i` at
    /// station i, its points warped and then displaced by `shift`, handed to
    /// the sink in scan order; returns per object the returns it saw.
    pub(super) fn pass(
        &self,
        (from, index_base): (u64, u64),
        shift: Vector3<f64>,
        sink: &mut LabelledSink,
        driven: &mut Driven,
    ) -> Result<Vec<u64>> {
        let mut seen = vec![0u64; self.world.objects.len()];
        let mut first = from;
        while first < self.n_scans {
            let last = (first + self.batch_scans).min(self.n_scans);
            let batch: Vec<(Vec<Point>, Vec<PointLabel>, Vec<u64>)> = (first..last)
                .into_par_iter()
                .map(|i| self.scan(i, index_base, shift))
                .collect();
            for (i, (pts, labels, cnt)) in (first..last).zip(batch) {
                sink(&pts, &labels)?;
                driven.total += pts.len() as u64;
                for (a, b) in seen.iter_mut().zip(cnt) {
                    *a += b;
                }
                let (world, road) = (self.world, self.road);
                let pose = lidar::pose_at(world, road, &self.params.lidar, self.station(i));
                driven.path.push(pose);
            }
            first = last;
        }
        Ok(seen)
    }

    /// Scan `index_base + i` at station i: its points (warped, shifted), what
    /// each is a return from, and per object the returns.
    fn scan(&self, i: u64, index_base: u64, shift: Vector3<f64>) -> ScanOut {
        let per_scan = self.per_scan as usize;
        let mut out = Vec::with_capacity(per_scan + per_scan / 4);
        let mut cnt = vec![0u64; self.world.objects.len()];
        let mut hits = Vec::new();
        lidar::scan(
            self.world,
            self.road,
            &self.params.lidar,
            self.params.seed,
            index_base + i,
            self.station(i),
            &mut out,
            &mut cnt,
            self.labelled.then_some(&mut hits),
        );
        let labels = labels_of(hits, self.n_targets);
        for p in out.iter_mut() {
            *p = (self.warp)(p);
        }
        if shift != Vector3::zeros() {
            for p in out.iter_mut() {
                *p += shift;
            }
        }
        (out, labels, cnt)
    }
}

/// A scan's points, their labels and the returns per object.
type ScanOut = (Vec<Point>, Vec<PointLabel>, Vec<u64>);

/// The labels of a scan's hits (object, primitive); world objects hold the
/// targets first (index = target), their plates as primitives 0 and 1.
fn labels_of(hits: Vec<(Option<u32>, u32)>, n_targets: usize) -> Vec<PointLabel> {
    hits.into_iter()
        .map(|(object, prim)| match object {
            None => PointLabel::Ground,
            Some(o) if (o as usize) < n_targets => match prim {
                0 | 1 => PointLabel::Plate {
                    target: o,
                    plate: prim as u8,
                },
                _ => PointLabel::TargetOther { target: o },
            },
            Some(_) => PointLabel::Other,
        })
        .collect()
}

/// Returns per scan, estimated from three probe scans along the road (at a
/// quarter, half and three quarters of the `usable` length): the scan count
/// follows from it.
fn probe_per_scan(params: &SynthParams, world: &World, road: &Road, usable: f64) -> u64 {
    let n_obj = world.objects.len();
    let probe: u64 = [0.25, 0.5, 0.75]
        .par_iter()
        .map(|f| {
            let mut out = Vec::new();
            let mut cnt = vec![0; n_obj];
            lidar::scan(
                world,
                road,
                &params.lidar,
                params.seed,
                u64::MAX,
                road.x0 + f * usable,
                &mut out,
                &mut cnt,
                None,
            );
            out.len() as u64
        })
        .sum();
    (probe / 3).max(1)
}
