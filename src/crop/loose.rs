//! Loose crop: one pass over the map for all targets.
//!
//! A dense grid over the targets' bounding box (cell = crop radius) maps each
//! cell to the targets whose crop region touches it, so a point costs one
//! bounding-box test and a handful of distance tests whatever the number of
//! targets. Blocks from the reader are split across threads and the per-target
//! hits are appended in block order, so the output is identical for any thread
//! count.

use crate::cloud::{Batch, PointReader, Region, Scratch};
use crate::{Error, Point, Result};
use rayon::prelude::*;
use std::sync::Mutex;

#[path = "loose_grid.rs"]
mod grid;
use grid::CentreIndex;

/// The region kept around each expected target position.
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    Default,
    serde::Serialize,
    serde::Deserialize,
    clap::ValueEnum,
)]
#[serde(rename_all = "lowercase")]
pub enum Shape {
    /// Vertical cylinder: horizontal distance < radius, any height (the reference code).
    #[default]
    Cylinder,
    /// Sphere: 3D distance < radius (the paper's text).
    Sphere,
}

/// Loose-crop parameters.
#[derive(Debug, Clone, Copy, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LooseParams {
    /// Crop radius in metres (5 m in the paper).
    pub radius: f64,
    /// Crop shape.
    pub shape: Shape,
    /// Most points [`loose_crop`] keeps per target (0 = all). Beyond it the crop
    /// is thinned uniformly at random (deterministically: a hash of each point
    /// decides), so a dense accumulated map needs memory bounded by the number
    /// of targets, not by the map's density: 500,000 points of a 5 m crop still
    /// put tens of thousands on a 0.6 m target.
    pub max_points: usize,
    /// `eval` of a map held in levels of detail (a COPC octree) finds each
    /// target on the coarse levels near it, then reads every level within a
    /// plate of what it found and locates the target there (`eval.reads`
    /// says what each read cost). The coarse levels are a spatially even but
    /// density-capped sample (untwine and PDAL keep one point per voxel of a
    /// level's grid), so only the search sees them: the located corner comes
    /// from every point near it, and a target the coarse levels do not show
    /// is searched again in every level of its whole crop. `false`: every
    /// level of every crop is read, as `crop` does.
    pub by_level: bool,
    /// Points a coarse read (`by_level`) wants near each target, 1.5× it by
    /// the octree's estimate: with the ground about half of a crop, some
    /// 30 k points above it for the L finder (which looks at 60 k at most),
    /// a point every 3–4 cm over a 5 m crop: enough to find an L, which is
    /// then located in every level near it.
    pub coarse_points: u64,
}

impl Default for LooseParams {
    fn default() -> Self {
        LooseParams {
            radius: 5.0,
            shape: Shape::Cylinder,
            max_points: 500_000,
            by_level: true,
            coarse_points: 40_000,
        }
    }
}

/// A point list thinned to at most `cap` points by halving: a point is kept
/// while a hash of its coordinates lies below a threshold, and the threshold
/// halves whenever the list outgrows `cap`. The kept set depends only on the
/// points (not on their order or on thread count); each point survives with the
/// same probability, 2^-`level`, so the thinning is uniform over the crop.
#[derive(Debug, Clone, Default)]
pub(crate) struct Thinned {
    /// The kept points, in the order they were pushed.
    pub(crate) points: Vec<Point>,
    /// Halvings so far: 0 = every point kept.
    pub(crate) level: u32,
    /// Points offered, kept or not.
    pub(crate) offered: u64,
    cap: usize,
}

impl Thinned {
    /// An empty list that keeps at most `cap` points (0 = no limit).
    pub(crate) fn new(cap: usize) -> Self {
        Thinned {
            cap,
            ..Default::default()
        }
    }

    pub(crate) fn hash(p: &Point) -> u64 {
        // splitmix64 over the coordinates' bit patterns.
        let mut z = p.x.to_bits() ^ p.y.to_bits().rotate_left(21) ^ p.z.to_bits().rotate_left(42);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    fn keeps(level: u32, p: &Point) -> bool {
        level == 0 || Self::hash(p) >> (64 - level.min(63)) == 0
    }

    /// Offers points; keeps those that pass the current threshold.
    pub(crate) fn extend(&mut self, pts: &[Point]) {
        self.offered += pts.len() as u64;
        let level = self.level;
        self.points
            .extend(pts.iter().filter(|p| Self::keeps(level, p)));
        while self.cap > 0 && self.points.len() > self.cap && self.level < 63 {
            self.level += 1;
            let level = self.level;
            self.points.retain(|p| Self::keeps(level, p));
        }
    }
}

/// The points of a map near each target, in the order the map stores them.
#[derive(Debug, Clone, Default)]
pub struct LooseCrop {
    /// One point list per requested centre, in the same order.
    pub points: Vec<Vec<Point>>,
    /// Points inside each crop before thinning (see [`LooseParams::max_points`]).
    pub offered: Vec<u64>,
    /// Points read from the map (finite ones).
    pub map_points: u64,
    /// Points the reader skipped as NaN/infinite.
    pub skipped_nonfinite: u64,
    /// Per crop, whether the reader left levels of detail unread near it
    /// ([`loose_crop_by_level`]): such a crop is no uniform sample of its
    /// disc. Empty when nothing was cut.
    pub levels_cut: Vec<bool>,
}

/// Target ids and points of hits side by side (a pushed (u32, Point) pair is
/// built on the stack and read back with a wider load, which stalls).
#[derive(Default)]
struct Hits {
    ids: Vec<u32>,
    pts: Vec<Point>,
}

/// Hits a segment of a [`Lane`] has room for (768 KiB of points; capacity
/// that is never written is never faulted in).
const SEGMENT: usize = 1 << 15;

/// The hits of one thread in one batch, in segments of fixed capacity: a
/// segment never grows while it is in use (most pieces), so hits are never
/// copied to a larger list, and the segments are reused batch after batch,
/// so their pages are faulted in once.
#[derive(Default)]
struct Lane {
    segments: Vec<Hits>,
    /// Segments in use this batch (the rest are empty, kept for later).
    used: usize,
}

impl Lane {
    fn clear(&mut self) {
        for h in &mut self.segments[..self.used] {
            h.ids.clear();
            h.pts.clear();
        }
        self.used = 0;
    }

    /// The index of a segment with room for `n` more hits: the last one in
    /// use, or the next one (grown to hold `n` if it cannot).
    fn room(&mut self, n: usize) -> usize {
        if let Some(h) = self.used.checked_sub(1).and_then(|i| self.segments.get(i)) {
            let free = |c: usize, l: usize| c - l >= n;
            if free(h.pts.capacity(), h.pts.len()) && free(h.ids.capacity(), h.ids.len()) {
                return self.used - 1;
            }
        }
        if self.used == self.segments.len() {
            self.segments.push(Hits::default());
        }
        let h = &mut self.segments[self.used];
        h.pts.reserve_exact(n.max(SEGMENT));
        h.ids.reserve_exact(n.max(SEGMENT));
        self.used += 1;
        self.used - 1
    }
}

/// Locks `m[own]`, or when it is taken, any free one (a thread that ran a
/// second piece while waiting inside a first, through a reader that waits on
/// rayon, would otherwise wait for itself); waits for `m[own]` only when
/// every one is taken. Returns the index locked.
fn lock_any<T>(m: &[Mutex<T>], own: usize) -> (usize, std::sync::MutexGuard<'_, T>) {
    use std::sync::TryLockError;
    for k in 0..m.len() {
        let i = (own + k) % m.len();
        match m[i].try_lock() {
            Ok(g) => return (i, g),
            Err(TryLockError::Poisoned(e)) => return (i, e.into_inner()),
            Err(TryLockError::WouldBlock) => {}
        }
    }
    (own, m[own].lock().unwrap_or_else(|e| e.into_inner()))
}

/// Where a piece's hits lie: lane, segment, start, end.
type Span = (usize, usize, usize, usize);

/// Streams `reader` once and returns, for every centre (map frame), the points
/// inside its crop region. `progress` is called with the bytes consumed so far.
pub fn loose_crop(
    reader: &mut dyn PointReader,
    centres: &[Point],
    params: &LooseParams,
    progress: impl FnMut(u64),
) -> Result<LooseCrop> {
    thinned(reader, centres, params, None, progress)
}

/// [`loose_crop`] that lets a reader holding its map in levels of detail (a
/// COPC octree) read near each centre only the coarser levels that hold
/// `enough` points there (1.5× it by the reader's estimate), not every level;
/// the crop is thinned to `max_points` as ever. The levels are a spatially
/// even but density-capped sample (one point per voxel of a level's grid in
/// untwine's and PDAL's files), not the uniform thinning: dense surfaces are
/// thinned more than sparse ones. [`LooseCrop::levels_cut`] says which crops
/// were read so; one of no more than `enough` points (the reader's estimate
/// was short) must be read again with [`loose_crop`].
pub fn loose_crop_by_level(
    reader: &mut dyn PointReader,
    centres: &[Point],
    params: &LooseParams,
    enough: u64,
    progress: impl FnMut(u64),
) -> Result<LooseCrop> {
    thinned(reader, centres, params, Some(enough.max(1)), progress)
}

fn thinned(
    reader: &mut dyn PointReader,
    centres: &[Point],
    params: &LooseParams,
    enough: Option<u64>,
    progress: impl FnMut(u64),
) -> Result<LooseCrop> {
    let mut kept = vec![Thinned::new(params.max_points); centres.len()];
    let (map_points, skipped_nonfinite) =
        crop_each(reader, centres, params, enough, progress, |i, p| {
            kept[i].extend(p);
            Ok(())
        })?;
    Ok(LooseCrop {
        offered: kept.iter().map(|k| k.offered).collect(),
        points: kept.into_iter().map(|k| k.points).collect(),
        map_points,
        skipped_nonfinite,
        levels_cut: reader.levels_cut(),
    })
}

/// [`loose_crop`] that hands the points of each crop to `sink(target, points)`
/// as they are found (in map order per target) instead of keeping them, so a
/// caller that writes crops to files needs memory independent of the crops'
/// size. Returns the map's finite and skipped non-finite point counts.
pub fn loose_crop_each(
    reader: &mut dyn PointReader,
    centres: &[Point],
    params: &LooseParams,
    progress: impl FnMut(u64),
    sink: impl FnMut(usize, &[Point]) -> Result<()>,
) -> Result<(u64, u64)> {
    crop_each(reader, centres, params, None, progress, sink)
}

/// [`loose_crop_each`], telling the reader the points per crop kept
/// (`enough`, [`PointReader::hint_enough`]) when they are capped.
fn crop_each(
    reader: &mut dyn PointReader,
    centres: &[Point],
    params: &LooseParams,
    enough: Option<u64>,
    mut progress: impl FnMut(u64),
    sink: impl FnMut(usize, &[Point]) -> Result<()>,
) -> Result<(u64, u64)> {
    if !(params.radius.is_finite() && params.radius > 0.0) {
        return Err(Error::Param(format!(
            "crop radius must be positive, got {}",
            params.radius
        )));
    }
    if centres.is_empty() {
        return Ok((0, 0));
    }
    let within = Within::new(reader, centres, params, enough);
    let mut gens = Generations::new(rayon::current_num_threads() + 1);
    let mut drain = Drain {
        per: vec![Vec::new(); centres.len()],
        sink,
    };
    let mut buf = Vec::new();
    loop {
        let Some(batch) = reader.next_batch(&mut buf)? else {
            break;
        };
        let scanned = scan_batch(&*batch, &within, &mut gens, &mut drain);
        drop(batch);
        scanned?;
        gens.swap();
        progress(reader.bytes_read());
    }
    drain.drain(&mut gens.prev, &gens.prev_spans)?;
    let st = reader.stats();
    Ok((st.points, st.skipped_nonfinite))
}

/// Which crops a point lies in: shared read-only by the pool's threads, so
/// the exact test runs where the piece was decoded, while it is in the cache.
struct Within<'a> {
    centres: &'a [Point],
    grid: CentreIndex,
    /// Handed to the reader so that it drops most of the map before building
    /// points; the exact test still decides.
    region: Option<Region>,
    r2: f64,
    sphere: bool,
}

impl<'a> Within<'a> {
    /// The test for `centres`, with the reader told where they are (a tiled
    /// map then opens only the tiles within reach of a centre) and, when
    /// crops are capped, how many points per crop are kept.
    fn new(
        reader: &mut dyn PointReader,
        centres: &'a [Point],
        params: &LooseParams,
        enough: Option<u64>,
    ) -> Within<'a> {
        let grid = CentreIndex::new(centres, params.radius);
        let discs: Vec<[f64; 2]> = centres.iter().map(|c| [c.x, c.y]).collect();
        reader.hint_discs(&discs, params.radius);
        if let Some(n) = enough {
            reader.hint_enough(n);
        }
        Within {
            centres,
            grid,
            region: Region::discs(&discs, params.radius),
            r2: params.radius * params.radius,
            sphere: params.shape == Shape::Sphere,
        }
    }

    /// Appends each point of `block` to `h` once per crop it lies in. The
    /// whole per-point loop stays in this one function so that the distance
    /// test inlines into it.
    #[inline]
    fn collect(&self, block: &[Point], h: &mut Hits) {
        let (r2, sphere) = (self.r2, self.sphere);
        let inside = |p: &Point, c: &Point| {
            let dx = p.x - c.x;
            let dy = p.y - c.y;
            let mut d2 = dx * dx + dy * dy;
            if sphere {
                let dz = p.z - c.z;
                d2 += dz * dz;
            }
            d2 < r2
        };
        for p in block {
            for &t in self.grid.candidates(p) {
                if inside(p, &self.centres[t as usize]) {
                    h.ids.push(t);
                    h.pts.push(*p);
                }
            }
        }
    }
}

/// Per-thread buffers and two generations of hit lanes: the hits of one
/// batch are handed to `sink` on the calling thread while the pool works on
/// the next, so neither core waits for the writer.
///
/// Each worker thread has its own scratch buffers and, per batch, its own
/// hit lane: a piece appends its hits to the lane of the thread that ran it
/// and records where they lie. Lanes keep their memory across batches, so it
/// is faulted in once, and it is bounded by a batch's hits per thread (one
/// list per piece, as before, grew by copying and grew each list to the most
/// hits its slot ever saw: with 2 x 128 slots that was about half of the
/// crop's page faults).
struct Generations {
    scratch: Vec<Mutex<Scratch>>,
    cur: Vec<Mutex<Lane>>,
    prev: Vec<Mutex<Lane>>,
    /// Per piece of a batch: (lane, segment, start, end) of its hits.
    cur_spans: Vec<Span>,
    prev_spans: Vec<Span>,
}

impl Generations {
    /// `lanes` of each kind: one per worker thread and one shared by any
    /// other thread.
    fn new(lanes: usize) -> Generations {
        Generations {
            scratch: (0..lanes).map(|_| Mutex::default()).collect(),
            cur: (0..lanes).map(|_| Mutex::default()).collect(),
            prev: (0..lanes).map(|_| Mutex::default()).collect(),
            cur_spans: Vec::new(),
            prev_spans: Vec::new(),
        }
    }

    /// The batch just scanned becomes the one to drain.
    fn swap(&mut self) {
        std::mem::swap(&mut self.cur, &mut self.prev);
        std::mem::swap(&mut self.cur_spans, &mut self.prev_spans);
    }
}

/// Hands hits to `sink` in piece order, so the result does not depend on the
/// thread count. A piece's hits usually belong to one target and go to `sink`
/// as they lie, without a copy; a piece that mixes targets (crops
/// overlapping, or two targets near one piece) is sorted out per target
/// first, in order, so that `sink` is never called point by point.
struct Drain<S> {
    per: Vec<Vec<Point>>,
    sink: S,
}

impl<S: FnMut(usize, &[Point]) -> Result<()>> Drain<S> {
    fn drain(&mut self, lanes: &mut [Mutex<Lane>], spans: &[Span]) -> Result<()> {
        let lanes: Vec<&Lane> = lanes
            .iter_mut()
            .map(|m| &*m.get_mut().unwrap_or_else(|e| e.into_inner()))
            .collect();
        for &(lane, seg, a, b) in spans {
            let Some(h) = lanes.get(lane).and_then(|l| l.segments.get(seg)) else {
                continue;
            };
            let (ids, pts) = (&h.ids[a..b], &h.pts[a..b]);
            let Some(&first) = ids.first() else {
                continue;
            };
            if ids.iter().all(|&i| i == first) {
                (self.sink)(first as usize, pts)?;
                continue;
            }
            for (&i, &p) in ids.iter().zip(pts) {
                self.per[i as usize].push(p);
            }
            for (i, v) in self.per.iter_mut().enumerate() {
                if !v.is_empty() {
                    (self.sink)(i, v)?;
                    v.clear();
                }
            }
        }
        Ok(())
    }
}

/// Scans `batch` on the pool into the current lanes while this thread
/// drains the previous batch's. Pieces are read, decoded and tested by the
/// same thread, so each piece's points are used while they are in its
/// cache. The drain's error comes first, then the first piece's.
fn scan_batch<S: FnMut(usize, &[Point]) -> Result<()>>(
    batch: &dyn Batch,
    within: &Within,
    gens: &mut Generations,
    drain: &mut Drain<S>,
) -> Result<()> {
    let n = batch.pieces();
    for l in gens.cur.iter_mut() {
        l.get_mut().unwrap_or_else(|e| e.into_inner()).clear();
    }
    gens.cur_spans.clear();
    gens.cur_spans.resize(n, (0, 0, 0, 0));
    let lanes = gens.cur.len();
    let mut done: Vec<Result<()>> = Vec::new();
    let drained = rayon::in_place_scope(|s| {
        let (cur, spans, done) = (&gens.cur, &mut gens.cur_spans, &mut done);
        let scratch = &gens.scratch;
        s.spawn(move |_| {
            *done = spans
                .par_iter_mut()
                .enumerate()
                .map(|(i, span)| {
                    // The worker's own lane; the last one is shared by
                    // any other thread (none in practice): the locks
                    // keep it correct either way.
                    let own = rayon::current_thread_index().map_or(lanes - 1, |t| t.min(lanes - 1));
                    let (_, mut sc) = lock_any(scratch, own);
                    let (lane, mut l) = lock_any(cur, own);
                    let block = match &within.region {
                        Some(r) => batch.piece_within(i, &mut sc, r),
                        None => batch.piece(i, &mut sc),
                    }?;
                    // Room for every point of the block: more hits only
                    // where crops overlap (then the segment grows).
                    let seg = l.room(block.len());
                    let h = &mut l.segments[seg];
                    let start = h.pts.len();
                    within.collect(block, h);
                    *span = (lane, seg, start, h.pts.len());
                    Ok(())
                })
                .collect();
        });
        drain.drain(&mut gens.prev, &gens.prev_spans)
    });
    drained?;
    done.into_iter().collect::<Result<()>>()
}

#[cfg(test)]
#[path = "loose_tests.rs"]
mod tests;
