//! A sparse 2D grid of cells over a map of any extent: tiles of 64 × 64 cells
//! are allocated where points fall, so memory follows the site's area, not its
//! number of points, and a point costs one tile lookup (cached: a map's points
//! arrive in scan order, mostly in the tile of the previous one).

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// A multiply-rotate hash for tile keys: SipHash (std's default, built to
/// resist crafted keys) was a third of a whole-map pass, and tile keys come
/// from coordinates, not from an adversary choosing hash collisions.
#[derive(Default)]
pub(crate) struct TileHasher(u64);

impl Hasher for TileHasher {
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(b as u64);
        }
    }
    fn write_i64(&mut self, i: i64) {
        self.write_u64(i as u64);
    }
    fn write_u64(&mut self, i: u64) {
        self.0 = (self.0.rotate_left(5) ^ i).wrapping_mul(0x517c_c1b7_2722_0a95);
    }
    fn finish(&self) -> u64 {
        self.0
    }
}

/// A hash map keyed by tile or cell.
pub(crate) type TileMap<K, V> = HashMap<K, V, BuildHasherDefault<TileHasher>>;

/// Cells per tile side.
const TILE: i64 = 64;

/// A sparse grid of `T` cells of side `cell` metres, keyed from `origin`.
#[derive(Debug, Clone)]
pub(crate) struct CellGrid<T> {
    pub(crate) cell: f64,
    pub(crate) origin: [f64; 2],
    empty: T,
    index: TileMap<(i64, i64), usize>,
    tiles: Vec<((i64, i64), Box<[T]>)>,
    last: Option<((i64, i64), usize)>,
    /// Calls of [`CellGrid::entry`]: a pass's points, to tell a map whose
    /// points are spread too thin to be one in metres.
    touched: u64,
    /// The tiles' key range (min x, min y, max x, max y).
    span: [i64; 4],
}

/// A grid of at least this many tiles (a square kilometre and more) whose
/// points average fewer than
/// [`THIN_PER_TILE`] a tile is [`CellGrid::spread_thin`]. A map's points
/// sample surfaces at centimetres to a metre (thousands to millions in a
/// 32 m square); a map in millimetres read as metres puts each point in a
/// square of its own, and a tile (16 KiB) for each would exhaust memory.
pub(crate) const THIN_TILES: usize = 1024;
/// See [`THIN_TILES`].
pub(crate) const THIN_PER_TILE: u64 = 8;
/// A thin grid must span this many tiles (64 km) to be judged early...
const THIN_SPAN_TILES: i64 = 2000;
/// ... or hold this many (256 MiB of tiles; 16.8 km² of squares).
const THIN_TILES_ANYWHERE: usize = 16384;

/// Farthest distance from the origin accepted (metres): a point beyond (more
/// than the Earth's radius away, however the first point fell) is not part
/// of any site and is left out.
const FAR: f64 = 1e7;

impl<T: Copy> CellGrid<T> {
    pub(crate) fn new(cell: f64, origin: [f64; 2], empty: T) -> Self {
        CellGrid {
            cell,
            origin,
            empty,
            index: TileMap::default(),
            tiles: Vec::new(),
            last: None,
            touched: 0,
            span: [i64::MAX, i64::MAX, i64::MIN, i64::MIN],
        }
    }

    fn widen(&mut self, t: (i64, i64)) {
        self.span = [
            self.span[0].min(t.0),
            self.span[1].min(t.1),
            self.span[2].max(t.0),
            self.span[3].max(t.1),
        ];
    }

    /// Whether the points seen are spread too thin for a map in metres:
    /// a thousand tiles or more with a few points each ([`THIN_TILES`]). A pass
    /// stops filling a grid once it is, so its memory stays bounded.
    pub(crate) fn spread_thin(&self) -> bool {
        let n = self.tiles.len();
        if n < THIN_TILES || self.touched >= THIN_PER_TILE * n as u64 {
            return false;
        }
        // Judged early (a few thousand points: memory must not wait), a
        // map stored in hashed or voxel order looks thin too until its
        // squares fill; so thin only over an extent no such map spans (a
        // map in millimetres of anything over 64 m does), or at a size that
        // bounds the grid's memory (256 MiB).
        let span = (self.span[2] - self.span[0]).max(self.span[3] - self.span[1]);
        span >= THIN_SPAN_TILES || n >= THIN_TILES_ANYWHERE
    }

    /// The cell holding (x, y), or `None` when absurdly far from the origin.
    #[inline]
    pub(crate) fn key(&self, x: f64, y: f64) -> Option<(i64, i64)> {
        let (dx, dy) = (x - self.origin[0], y - self.origin[1]);
        (dx.abs() < FAR && dy.abs() < FAR).then(|| {
            (
                (dx / self.cell).floor() as i64,
                (dy / self.cell).floor() as i64,
            )
        })
    }

    /// Centre of cell `k`.
    pub(crate) fn centre(&self, k: (i64, i64)) -> [f64; 2] {
        [
            self.origin[0] + (k.0 as f64 + 0.5) * self.cell,
            self.origin[1] + (k.1 as f64 + 0.5) * self.cell,
        ]
    }

    fn split(k: (i64, i64)) -> ((i64, i64), usize) {
        let t = (k.0.div_euclid(TILE), k.1.div_euclid(TILE));
        let i = (k.1.rem_euclid(TILE) * TILE + k.0.rem_euclid(TILE)) as usize;
        (t, i)
    }

    /// The cell `k`, created empty when new.
    #[inline]
    pub(crate) fn entry(&mut self, k: (i64, i64)) -> &mut T {
        self.touched += 1;
        let (t, i) = Self::split(k);
        let slot = match self.last {
            Some((lt, s)) if lt == t => s,
            _ => {
                let s = match self.index.get(&t) {
                    Some(&s) => s,
                    None => {
                        self.widen(t);
                        self.tiles
                            .push((t, vec![self.empty; (TILE * TILE) as usize].into()));
                        self.index.insert(t, self.tiles.len() - 1);
                        self.tiles.len() - 1
                    }
                };
                self.last = Some((t, s));
                s
            }
        };
        &mut self.tiles[slot].1[i]
    }

    /// The cell `k`, if its tile exists.
    pub(crate) fn get(&self, k: (i64, i64)) -> Option<&T> {
        let (t, i) = Self::split(k);
        self.index.get(&t).map(|&s| &self.tiles[s].1[i])
    }

    /// Every cell of every tile with its key, tiles in key order (deterministic
    /// whatever order the tiles were made in).
    pub(crate) fn cells(&self) -> impl Iterator<Item = ((i64, i64), &T)> {
        let mut order: Vec<usize> = (0..self.tiles.len()).collect();
        order.sort_by_key(|&s| self.tiles[s].0);
        order.into_iter().flat_map(move |s| {
            let (t, cells) = &self.tiles[s];
            cells.iter().enumerate().map(move |(i, c)| {
                let i = i as i64;
                ((t.0 * TILE + i % TILE, t.1 * TILE + i / TILE), c)
            })
        })
    }

    /// Merges `other` (same cell and origin) cell by cell.
    pub(crate) fn merge(&mut self, other: CellGrid<T>, f: impl Fn(&mut T, &T)) {
        self.touched += other.touched;
        for (t, cells) in other.tiles {
            match self.index.get(&t) {
                Some(&s) => {
                    for (a, b) in self.tiles[s].1.iter_mut().zip(cells.iter()) {
                        f(a, b);
                    }
                }
                None => {
                    self.widen(t);
                    self.tiles.push((t, cells));
                    self.index.insert(t, self.tiles.len() - 1);
                }
            }
        }
        self.last = None;
    }

    /// The extent (m) across the tiles made so far, along x and y.
    pub(crate) fn extent(&self) -> [f64; 2] {
        if self.tiles.is_empty() {
            return [0.0; 2];
        }
        let side = TILE as f64 * self.cell;
        [
            (self.span[2] - self.span[0] + 1) as f64 * side,
            (self.span[3] - self.span[1] + 1) as f64 * side,
        ]
    }

    /// Bytes held by the tiles (for the memory bound).
    pub(crate) fn bytes(&self) -> usize {
        self.tiles.len() * (TILE * TILE) as usize * std::mem::size_of::<T>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_round_trip_across_negative_tiles() {
        let mut g = CellGrid::new(0.5, [100.0, -50.0], 0u32);
        for (x, y) in [(100.1, -50.1), (60.0, -90.0), (140.0, 0.0), (100.1, -50.2)] {
            let k = g.key(x, y).unwrap();
            *g.entry(k) += 1;
        }
        let k = g.key(100.1, -50.1).unwrap();
        assert_eq!(*g.get(k).unwrap(), 2);
        let c = g.centre(k);
        assert!((c[0] - 100.25).abs() < 1e-12 && (c[1] + 50.25).abs() < 1e-12);
        let total: u32 = g.cells().map(|(_, &c)| c).sum();
        assert_eq!(total, 4);
        assert!(g.key(1e300, 0.0).is_none());
    }
}
