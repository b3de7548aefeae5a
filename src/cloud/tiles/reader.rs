//! Reading a tiled map: the tiles near the crop's region opened one after
//! another, as one stream of points, each tile's points checked against
//! its cell.

use super::*;

/// Opens a tiled map for streaming.
pub(crate) fn open(path: &Path) -> Result<Box<dyn PointReader>> {
    Ok(Box::new(TiledReader::new(TiledMap::discover(path)?)))
}

/// Streams the tiles one after the other (each through its own reader, so
/// each keeps its format's parallel path).
pub(crate) struct TiledReader {
    map: TiledMap,
    /// Indices of the tiles to read, in order.
    order: Vec<usize>,
    next: usize,
    cur: Option<(Box<dyn PointReader>, usize)>,
    /// The current tile's reader has said it is exhausted.
    ended: bool,
    done: ReadStats,
    done_bytes: u64,
    info: CloudInfo,
    counts: TileStats,
    /// Reading has begun: a region hint comes too late.
    started: bool,
    /// Whether every tile to read has an intensity field (looked up once).
    intensity: std::sync::OnceLock<bool>,
    /// A sample's points per byte of tile, handed to each tile's reader when
    /// too few tiles are left out (`hint_sample`), and whether some tile or
    /// tile reader left part of the map unread.
    sample_each: Option<f64>,
    sampled: bool,
    /// Some tile opened stores float32 coordinates.
    float32: bool,
}

/// A sample of a tiled map reads whole tiles when it can leave out enough of
/// them and still keep this many, spread over the map; with fewer, each
/// tile is sampled by its own reader.
pub(super) const MIN_SAMPLE_TILES: usize = 8;

impl TiledReader {
    pub(crate) fn new(map: TiledMap) -> Self {
        let bytes = map.bytes();
        let n = map.tiles.len() as u64;
        TiledReader {
            order: (0..map.tiles.len()).collect(),
            map,
            next: 0,
            cur: None,
            ended: false,
            done: ReadStats::default(),
            done_bytes: 0,
            info: CloudInfo {
                format: Format::Pcd,
                declared_points: None,
                file_bytes: bytes,
            },
            counts: TileStats {
                tiles: n,
                selected: n,
                bytes,
                ..TileStats::default()
            },
            started: false,
            intensity: std::sync::OnceLock::new(),
            sample_each: None,
            sampled: false,
            float32: false,
        }
    }

    /// Closes the current tile (its counters kept) and opens the next one;
    /// false when none is left.
    fn advance(&mut self) -> Result<bool> {
        self.started = true;
        if let Some((r, _)) = self.cur.take() {
            let s = r.stats();
            self.done.points += s.points;
            self.done.skipped_nonfinite += s.skipped_nonfinite;
            self.done_bytes += r.bytes_read();
        }
        self.ended = false;
        let Some(&t) = self.order.get(self.next) else {
            return Ok(false);
        };
        self.next += 1;
        let tile = &self.map.tiles[t];
        let mut r = crate::cloud::open(&tile.path)?;
        if let Some(per_byte) = self.sample_each {
            r.hint_sample(((tile.bytes as f64 * per_byte).ceil() as u64).max(1));
            self.sampled |= r.sampled().is_some();
        }
        self.counts.opened += 1;
        self.counts.bytes_opened += tile.bytes;
        self.float32 |= r.float32_coords();
        self.cur = Some((r, t));
        Ok(true)
    }
}

/// How far outside its cell a tile's point may lie: float32 tiles round
/// coordinates by half an ulp (6e-8 of them), so a point written at the cell's
/// edge may read a hair beyond it.
pub(super) fn slack(cell: &[f64; 4]) -> f64 {
    1e-6 * cell.iter().fold(1.0_f64, |m, v| m.max(v.abs()))
}

/// The error for the first point of `pts` outside `tile`'s cell, if any.
pub(super) fn check_cell(tile: &Tile, meta: Option<&Path>, pts: &[Point]) -> Result<()> {
    let Some(c) = &tile.cell else {
        return Ok(());
    };
    let s = slack(c);
    let (x0, y0, x1, y1) = (c[0] - s, c[1] - s, c[2] + s, c[3] + s);
    if let Some(p) = pts
        .iter()
        .find(|p| !(p.x >= x0 && p.x <= x1 && p.y >= y0 && p.y <= y1))
    {
        let meta = meta.map(|m| m.display().to_string()).unwrap_or_default();
        return Err(Error::format(
            &tile.path,
            format!(
                "point ({}, {}) lies outside the tile's cell x [{}, {}), y [{}, {}) given in {meta}:{}: the metadata does not describe this tile (move the metadata aside to read every .pcd in the folder)",
                p.x, p.y, c[0], c[2], c[1], c[3], tile.line
            ),
        ));
    }
    Ok(())
}

impl PointReader for TiledReader {
    fn info(&self) -> &CloudInfo {
        &self.info
    }

    fn has_intensity(&self) -> bool {
        // Every tile to read must have it; known only from their headers.
        *self.intensity.get_or_init(|| {
            self.order.iter().all(|&t| {
                crate::cloud::open(&self.map.tiles[t].path).is_ok_and(|r| r.has_intensity())
            })
        })
    }

    fn next_chunk_intensity(
        &mut self,
        buf: &mut Vec<Point>,
        intensity: &mut Vec<f32>,
    ) -> Result<bool> {
        loop {
            if (self.cur.is_none() || self.ended) && !self.advance()? {
                buf.clear();
                intensity.clear();
                return Ok(false);
            }
            let Some((r, t)) = self.cur.as_mut() else {
                return Ok(false);
            };
            if r.next_chunk_intensity(buf, intensity)? {
                check_cell(&self.map.tiles[*t], self.map.metadata.as_deref(), buf)?;
                if !self.has_intensity() {
                    // Some tile lacks it: none is given (the trait's promise).
                    intensity.clear();
                }
                return Ok(true);
            }
            self.ended = true;
        }
    }

    fn next_chunk(&mut self, buf: &mut Vec<Point>) -> Result<bool> {
        loop {
            if (self.cur.is_none() || self.ended) && !self.advance()? {
                buf.clear();
                return Ok(false);
            }
            let Some((r, t)) = self.cur.as_mut() else {
                return Ok(false);
            };
            if r.next_chunk(buf)? {
                check_cell(&self.map.tiles[*t], self.map.metadata.as_deref(), buf)?;
                return Ok(true);
            }
            self.ended = true;
        }
    }

    fn stats(&self) -> ReadStats {
        let mut s = self.done;
        if let Some((r, _)) = &self.cur {
            let c = r.stats();
            s.points += c.points;
            s.skipped_nonfinite += c.skipped_nonfinite;
        }
        s
    }

    fn bytes_read(&self) -> u64 {
        self.done_bytes + self.cur.as_ref().map_or(0, |(r, _)| r.bytes_read())
    }

    fn next_batch<'a>(
        &'a mut self,
        buf: &'a mut Vec<Point>,
    ) -> Result<Option<Box<dyn Batch + 'a>>> {
        if (self.cur.is_none() || self.ended) && !self.advance()? {
            return Ok(None);
        }
        let TiledReader {
            cur, ended, map, ..
        } = self;
        let Some((r, t)) = cur.as_mut() else {
            return Ok(None);
        };
        let (tile, meta) = (&map.tiles[*t], map.metadata.as_deref());
        match r.next_batch(buf)? {
            Some(inner) => Ok(Some(Box::new(TileBatch { inner, tile, meta }))),
            // The next call opens the next tile; a batch of no pieces keeps
            // the caller reading.
            None => {
                *ended = true;
                Ok(Some(Box::new(NoPieces)))
            }
        }
    }

    fn hint_discs(&mut self, centres: &[[f64; 2]], radius: f64) {
        if self.started
            || !(radius.is_finite() && radius >= 0.0)
            || centres.iter().flatten().any(|v| !v.is_finite())
        {
            return;
        }
        let near = |c: &[f64; 4]| {
            let s = slack(c);
            centres.iter().any(|p| {
                let dx = (c[0] - s - p[0]).max(p[0] - c[2] - s).max(0.0);
                let dy = (c[1] - s - p[1]).max(p[1] - c[3] - s).max(0.0);
                dx * dx + dy * dy <= radius * radius
            })
        };
        let tiles = &self.map.tiles;
        self.order
            .retain(|&t| tiles[t].cell.as_ref().is_none_or(near));
        self.counts.selected = self.order.len() as u64;
        self.info.file_bytes = self.order.iter().map(|&t| tiles[t].bytes).sum();
    }

    fn tile_stats(&self) -> Option<TileStats> {
        Some(self.counts)
    }

    /// Every k-th tile in reading order (row by row under a metadata file),
    /// so the sample spans the map; each tile whole, as its ground is. With
    /// too few tiles to leave enough out, each tile's reader samples it.
    fn hint_sample(&mut self, points: u64) {
        if self.started || points == 0 {
            return;
        }
        let tiles = &self.map.tiles;
        let bytes: u64 = self.order.iter().map(|&t| tiles[t].bytes).sum();
        // Bytes a point takes, from the biggest tile's header (where the
        // header's own bytes count least); a guess when it declares no count.
        let Some(&big) = self
            .order
            .iter()
            .max_by_key(|&&t| (tiles[t].bytes, usize::MAX - t))
        else {
            return;
        };
        let first = &tiles[big];
        let per_point = crate::cloud::open(&first.path)
            .ok()
            .and_then(|r| r.info().declared_points)
            .filter(|&n| n > 0)
            .map_or(crate::cloud::BYTES_PER_POINT_GUESS as f64, |n| {
                first.bytes as f64 / n as f64
            });
        let want = points as f64 * per_point;
        if want >= bytes as f64 {
            return;
        }
        let every = ((bytes as f64 / want) as usize).min(self.order.len() / MIN_SAMPLE_TILES);
        if every >= 2 {
            self.order = self.order.iter().copied().step_by(every).collect();
            self.counts.selected = self.order.len() as u64;
            self.info.file_bytes = self.order.iter().map(|&t| tiles[t].bytes).sum();
            self.sampled = true;
        } else {
            self.sample_each = Some(points as f64 / bytes as f64);
        }
    }

    /// Whether any tile opened so far stores float32 coordinates.
    fn float32_coords(&self) -> bool {
        self.float32
    }

    fn sampled(&self) -> Option<u64> {
        let current = self
            .cur
            .as_ref()
            .is_some_and(|(r, _)| r.sampled().is_some());
        (self.sampled || current).then_some(self.counts.bytes_opened)
    }
}

/// A tile's batch: its points checked against the tile's cell.
pub(super) struct TileBatch<'a> {
    inner: Box<dyn Batch + 'a>,
    tile: &'a Tile,
    meta: Option<&'a Path>,
}

impl Batch for TileBatch<'_> {
    fn pieces(&self) -> usize {
        self.inner.pieces()
    }
    fn piece<'s>(&'s self, i: usize, scratch: &'s mut Scratch) -> Result<&'s [Point]> {
        let pts = self.inner.piece(i, scratch)?;
        check_cell(self.tile, self.meta, pts)?;
        Ok(pts)
    }
    fn piece_within<'s>(
        &'s self,
        i: usize,
        scratch: &'s mut Scratch,
        region: &crate::cloud::Region,
    ) -> Result<&'s [Point]> {
        let pts = self.inner.piece_within(i, scratch, region)?;
        check_cell(self.tile, self.meta, pts)?;
        Ok(pts)
    }
}

/// The batch between two tiles.
pub(super) struct NoPieces;

impl Batch for NoPieces {
    fn pieces(&self) -> usize {
        0
    }
    fn piece<'s>(&'s self, _: usize, _: &'s mut Scratch) -> Result<&'s [Point]> {
        Ok(&[])
    }
}
