//! Crops that keep each point's intensity: what a checkerboard board is
//! told by. The loose crop carries coordinates only (every other model is
//! geometry), so boards get a pass of their own, about the places where a
//! board is expected (`eval`) or where map-wide detection saw an object of
//! a board's size (`detect`).

use crate::cloud::{MapSource, PassRead, RigidMotion};
use crate::frame::grid::TileMap;
use crate::{Point, Result};

/// A crop's points and their intensities, or why the map has none to give.
pub type IntensityCrop = std::result::Result<(Vec<Point>, Vec<f32>), String>;

/// The crops within `radius` (horizontally) of `centres` (`None`: no crop
/// wanted there), with intensities, in one pass over `source` read through
/// `motion`. Each crop keeps at most about `max_points` (a coordinate-hash
/// sample beyond, halved as it fills), so memory stays bounded however dense
/// the map. Points with a NaN or infinite intensity are left out (they say
/// nothing of a print). A map without intensity gives every wanted crop the
/// reason; `PassRead` is `None` when nothing was read.
pub fn crops_with_intensity(
    source: MapSource,
    centres: &[Option<Point>],
    radius: f64,
    max_points: usize,
    motion: &RigidMotion,
    z_range: Option<[f64; 2]>,
) -> Result<(Vec<Option<IntensityCrop>>, Option<PassRead>)> {
    let at: Vec<(usize, Point)> = centres
        .iter()
        .enumerate()
        .filter_map(|(i, c)| c.map(|c| (i, c)))
        .collect();
    let mut out: Vec<Option<IntensityCrop>> = vec![None; centres.len()];
    if at.is_empty() {
        return Ok((out, None));
    }
    let mut reader = source.open_moved_within(Some(motion), z_range)?;
    if !reader.has_intensity() {
        let why = match source {
            MapSource::Points(_) => "a map handed over in memory has no intensity".to_string(),
            MapSource::File(p) => format!(
                "{} has no intensity mapgauge reads: the file holds no intensity field \
                 (mapgauge reads one from PCD `intensity` or `i`, PLY `intensity` or \
                 `scalar_intensity`, LAS, LAZ, COPC, E57, PTS, XYZ/CSV with a header \
                 naming an intensity column, and tiled maps of those)",
                p.display()
            ),
        };
        for &(i, _) in &at {
            out[i] = Some(Err(why.clone()));
        }
        return Ok((out, None));
    }
    let discs: Vec<[f64; 2]> = at.iter().map(|(_, c)| [c.x, c.y]).collect();
    reader.hint_discs(&discs, radius);
    let index = DiscIndex::new(&discs, radius);
    let r2 = radius * radius;
    // Per crop: points, intensities, and the hash level kept (a point is
    // kept while its hash's top `level` bits are zero).
    let mut kept: Vec<(Vec<Point>, Vec<f32>, u32)> = vec![(Vec::new(), Vec::new(), 0); at.len()];
    let (mut buf, mut inten) = (Vec::new(), Vec::new());
    let hash = |p: &Point| super::point_hash(p);
    while reader.next_chunk_intensity(&mut buf, &mut inten)? {
        for (p, &v) in buf.iter().zip(&inten) {
            if !v.is_finite() {
                continue;
            }
            for &k in index.near(p) {
                let c = &at[k].1;
                let (dx, dy) = (p.x - c.x, p.y - c.y);
                if dx * dx + dy * dy >= r2 {
                    continue;
                }
                let (pts, iv, level) = &mut kept[k];
                if *level > 0 && hash(p) >> (64 - (*level).min(63)) != 0 {
                    continue;
                }
                pts.push(*p);
                iv.push(v);
                if pts.len() > 2 * max_points {
                    *level += 1;
                    let l = *level;
                    let mut j = 0;
                    for i in 0..pts.len() {
                        if hash(&pts[i]) >> (64 - l.min(63)) == 0 {
                            pts[j] = pts[i];
                            iv[j] = iv[i];
                            j += 1;
                        }
                    }
                    pts.truncate(j);
                    iv.truncate(j);
                }
            }
        }
    }
    let read = PassRead::of("board-crops", reader.as_ref());
    for ((i, _), (pts, iv, _)) in at.into_iter().zip(kept) {
        out[i] = Some(Ok((pts, iv)));
    }
    Ok((out, Some(read)))
}

/// The discs that may hold a point, by square cells a disc's diameter wide:
/// map-wide detection asks for hundreds of crops, and testing every point
/// against every disc would cost points × discs. Each cell lists the discs
/// (in ascending order, so each crop gets its points in reading order as
/// before) whose bounding square meets it. A few discs (a survey's boards)
/// are each tested instead: cheaper than a lookup.
struct DiscIndex {
    cell: f64,
    cells: TileMap<(i64, i64), Vec<usize>>,
    /// Every disc, when there are few enough to test each.
    all: Option<Vec<usize>>,
}

/// Discs up to this many are tested each, not looked up.
const FEW_DISCS: usize = 8;

impl DiscIndex {
    fn new(discs: &[[f64; 2]], radius: f64) -> Self {
        let cell = (2.0 * radius).max(1e-3);
        if discs.len() <= FEW_DISCS {
            return DiscIndex {
                cell,
                cells: TileMap::default(),
                all: Some((0..discs.len()).collect()),
            };
        }
        let mut cells: TileMap<(i64, i64), Vec<usize>> = TileMap::default();
        for (k, c) in discs.iter().enumerate() {
            let lo = [
                ((c[0] - radius) / cell).floor() as i64,
                ((c[1] - radius) / cell).floor() as i64,
            ];
            let hi = [
                ((c[0] + radius) / cell).floor() as i64,
                ((c[1] + radius) / cell).floor() as i64,
            ];
            for x in lo[0]..=hi[0] {
                for y in lo[1]..=hi[1] {
                    cells.entry((x, y)).or_default().push(k);
                }
            }
        }
        DiscIndex {
            cell,
            cells,
            all: None,
        }
    }

    fn near(&self, p: &Point) -> &[usize] {
        if let Some(all) = &self.all {
            return all;
        }
        let key = (
            (p.x / self.cell).floor() as i64,
            (p.y / self.cell).floor() as i64,
        );
        self.cells.get(&key).map_or(&[], |v| v.as_slice())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The index hands every disc that holds a point to the test (the
    /// crops equal those of testing every disc), for discs near and far,
    /// overlapping, and at negative coordinates.
    #[test]
    fn the_index_misses_no_disc() {
        let mut discs = vec![[0.0, 0.0], [1.1, 0.3], [-5.5, 7.25], [300.2, -40.0]];
        // More than a few: looked up by cell.
        discs.extend((0..FEW_DISCS).map(|i| [1e3 + 10.0 * i as f64, -7.5]));
        let r = 1.3;
        let index = DiscIndex::new(&discs, r);
        assert!(index.all.is_none());
        let mut s = 7u64;
        for _ in 0..20_000 {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let k = (s >> 33) as usize % discs.len();
            let u = ((s >> 11) & 0xffff) as f64 / 65536.0 - 0.5;
            let w = ((s >> 27) & 0xffff) as f64 / 65536.0 - 0.5;
            let p = Point::new(discs[k][0] + 4.0 * u, discs[k][1] + 4.0 * w, 0.0);
            let near = index.near(&p);
            assert!(near.is_sorted());
            for (j, c) in discs.iter().enumerate() {
                let inside = (p.x - c[0]).powi(2) + (p.y - c[1]).powi(2) < r * r;
                assert!(!inside || near.contains(&j), "{p:?} in disc {j}");
            }
        }
    }
}
