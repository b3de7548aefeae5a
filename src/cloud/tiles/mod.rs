//! Autoware point-cloud maps: a folder of PCD tiles, usually with a metadata
//! YAML that gives each tile's cell of the horizontal grid.
//!
//! Why: Autoware keeps large maps as 20 m (or so) tiles so a vehicle loads
//! only the ones around it; mapgauge does the same for a crop, opening only
//! the tiles within the crop radius of a target. The layout
//! (`pointcloud_divider`'s output, read by Autoware's `map_loader`):
//!
//! ```yaml
//! x_resolution: 20.0
//! y_resolution: 20.0
//! A.pcd: [1200, 2500]   # covers 1200 <= x < 1220, 2500 <= y < 2520
//! B.pcd: [1220, 2500]
//! ```
//!
//! Tiles are looked up beside the metadata, or in a sub-folder of it (Autoware
//! puts `pointcloud_map_metadata.yaml` beside a `pointcloud_map.pcd/`
//! folder; given that tile folder, the metadata beside it is used when all
//! its tiles are in the folder). A folder without metadata is read as every
//! `.pcd` in it, sorted by name.

pub(crate) mod yaml;

use super::{Batch, CloudInfo, Format, PointReader, ReadStats, Scratch};
use crate::{Error, Point, Result};
use std::path::{Path, PathBuf};
use yaml::{Entry, Value};

/// The projector file Autoware keeps beside the map.
pub const PROJECTOR_FILE: &str = "map_projector_info.yaml";

/// One tile of a map.
#[derive(Debug, Clone, PartialEq)]
pub struct Tile {
    /// Where the tile is.
    pub path: PathBuf,
    /// Its cell `[min_x, min_y, max_x, max_y]` (the cell is
    /// `[min, max)`), when a metadata file gives it.
    pub cell: Option<[f64; 4]>,
    /// Line of the metadata that lists it (0 without metadata).
    pub line: u64,
    /// File size in bytes.
    pub bytes: u64,
}

/// A tiled map as found on disk: its metadata (if any) and its tiles in
/// reading order (metadata order, or by name without metadata).
#[derive(Debug, Clone, PartialEq)]
pub struct TiledMap {
    /// The metadata file, when there is one.
    pub metadata: Option<PathBuf>,
    /// Cell size `[x, y]` in metres, from the metadata.
    pub resolution: Option<[f64; 2]>,
    /// The tiles.
    pub tiles: Vec<Tile>,
    /// `map_projector_info.yaml` beside the metadata (or in the folder).
    pub projector: Option<PathBuf>,
}

/// What a tiled reader opened, for reports and benchmarks.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TileStats {
    /// Tiles in the map.
    pub tiles: u64,
    /// Tiles selected to be read (all, unless a region hint dropped some).
    pub selected: u64,
    /// Tiles opened so far.
    pub opened: u64,
    /// Bytes of all tiles.
    pub bytes: u64,
    /// Bytes of the tiles opened so far.
    pub bytes_opened: u64,
    /// The counts are a COPC file's octree nodes (with points), not tiles.
    pub copc: bool,
}

/// Whether `path` names a tiled map: a folder, or a `*metadata*.yaml` file.
pub fn is_tiled(path: &Path) -> bool {
    path.is_dir() || is_metadata_name(path)
}

fn is_metadata_name(path: &Path) -> bool {
    let name = path
        .file_name()
        .and_then(|n| n.to_str())
        .map(|n| n.to_ascii_lowercase())
        .unwrap_or_default();
    name.contains("metadata") && (name.ends_with(".yaml") || name.ends_with(".yml"))
}

/// A metadata key naming a tile: the text itself ends in `.pcd` (a path's
/// extension would also accept `a.pcd/`, which names a folder; found by the
/// `tiles` fuzz target) and holds no NUL.
fn is_tile_name(name: &str) -> bool {
    name.len() > 4
        && !name.contains('\0')
        && name
            .get(name.len() - 4..)
            .is_some_and(|e| e.eq_ignore_ascii_case(".pcd"))
}

fn has_ext(path: &Path, ext: &str) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case(ext))
}

/// Entries of a folder, sorted by name (deterministic whatever the file
/// system's order).
fn sorted_entries(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut v = Vec::new();
    for e in std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))? {
        v.push(e.map_err(|e| Error::io(dir, e))?.path());
    }
    v.sort();
    Ok(v)
}

impl TiledMap {
    /// Finds the map at `path` (a folder or a metadata file) and checks that
    /// every tile is there; no tile is opened.
    pub fn discover(path: &Path) -> Result<TiledMap> {
        let (dir, metadata) = if path.is_dir() {
            let metas: Vec<PathBuf> = sorted_entries(path)?
                .into_iter()
                .filter(|p| p.is_file() && is_metadata_name(p))
                .collect();
            match metas.as_slice() {
                [] => {
                    if let Some(m) = parent_metadata(path) {
                        return Ok(m);
                    }
                    (path.to_path_buf(), None)
                }
                [one] => (path.to_path_buf(), Some(one.clone())),
                more => {
                    let names: Vec<String> = more.iter().map(|p| p.display().to_string()).collect();
                    return Err(Error::Input(format!(
                        "{}: several metadata files ({}): give the one to use with --map",
                        path.display(),
                        names.join(", ")
                    )));
                }
            }
        } else {
            let dir = match path.parent() {
                Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
                _ => PathBuf::from("."),
            };
            (dir, Some(path.to_path_buf()))
        };
        let projector = Some(dir.join(PROJECTOR_FILE)).filter(|p| p.is_file());
        let Some(meta) = metadata else {
            let mut tiles = Vec::new();
            for p in sorted_entries(&dir)? {
                if has_ext(&p, "pcd") && p.is_file() {
                    let bytes = file_size(&p)?;
                    tiles.push(Tile {
                        path: p,
                        cell: None,
                        line: 0,
                        bytes,
                    });
                }
            }
            if tiles.is_empty() {
                return Err(Error::Input(format!(
                    "{}: no .pcd files and no *metadata*.yaml in this folder",
                    dir.display()
                )));
            }
            return Ok(TiledMap {
                metadata: None,
                resolution: None,
                tiles,
                projector,
            });
        };
        let text = std::fs::read(&meta).map_err(|e| Error::io(&meta, e))?;
        let text = String::from_utf8(text)
            .map_err(|_| Error::format(&meta, "not UTF-8 text (a YAML file is expected)"))?;
        let m = parse_metadata(&text).map_err(|(l, msg)| Error::table(&meta, l, msg))?;
        // Autoware keeps the tiles in a sub-folder beside the metadata
        // (`pointcloud_map.pcd/`): a tile is looked for there too.
        let subdirs: Vec<PathBuf> = sorted_entries(&dir)?
            .into_iter()
            .filter(|p| p.is_dir())
            .collect();
        let mut tiles = Vec::with_capacity(m.tiles.len());
        for t in &m.tiles {
            let mut found: Vec<PathBuf> = std::iter::once(&dir)
                .chain(&subdirs)
                .map(|d| d.join(&t.name))
                .filter(|p| p.is_file())
                .collect();
            let path = match found.len() {
                1 => found.remove(0),
                0 => {
                    return Err(Error::table(
                        &meta,
                        t.line,
                        format!(
                            "tile {} is missing (looked in {} and its sub-folders)",
                            t.name,
                            dir.display()
                        ),
                    ));
                }
                _ => {
                    let names: Vec<String> =
                        found.iter().map(|p| p.display().to_string()).collect();
                    return Err(Error::table(
                        &meta,
                        t.line,
                        format!(
                            "tile {} is ambiguous: found as {}",
                            t.name,
                            names.join(" and ")
                        ),
                    ));
                }
            };
            let bytes = file_size(&path)?;
            tiles.push(Tile {
                path,
                cell: Some([
                    t.min[0],
                    t.min[1],
                    t.min[0] + m.resolution[0],
                    t.min[1] + m.resolution[1],
                ]),
                line: t.line,
                bytes,
            });
        }
        Ok(TiledMap {
            metadata: Some(meta),
            resolution: Some(m.resolution),
            tiles,
            projector,
        })
    }

    /// Every file the map consists of, in reading order: the metadata, then
    /// the tiles (what a report hashes).
    pub fn files(&self) -> Vec<&Path> {
        self.metadata
            .iter()
            .map(PathBuf::as_path)
            .chain(self.tiles.iter().map(|t| t.path.as_path()))
            .collect()
    }

    /// Bytes of all tiles.
    pub fn bytes(&self) -> u64 {
        self.tiles.iter().map(|t| t.bytes).sum()
    }
}

/// Autoware's layout seen from the tile folder (`map/pointcloud_map.pcd/`):
/// the one metadata file of the parent folder, when every tile it lists is
/// in `dir`.
fn parent_metadata(dir: &Path) -> Option<TiledMap> {
    let here = dir.canonicalize().ok()?;
    let parent = here.parent()?;
    let metas: Vec<PathBuf> = sorted_entries(parent)
        .ok()?
        .into_iter()
        .filter(|p| p.is_file() && is_metadata_name(p))
        .collect();
    let [meta] = metas.as_slice() else {
        return None;
    };
    let m = TiledMap::discover(meta).ok()?;
    m.tiles
        .iter()
        .all(|t| t.path.canonicalize().is_ok_and(|p| p.starts_with(&here)))
        .then_some(m)
}

fn file_size(p: &Path) -> Result<u64> {
    Ok(std::fs::metadata(p).map_err(|e| Error::io(p, e))?.len())
}

/// A parsed metadata file.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Metadata {
    pub(crate) resolution: [f64; 2],
    pub(crate) tiles: Vec<TileEntry>,
}

#[derive(Debug, Clone, PartialEq)]
pub(crate) struct TileEntry {
    pub(crate) name: String,
    pub(crate) min: [f64; 2],
    pub(crate) line: u64,
}

/// Most tiles a metadata file may list (a 100 km × 100 km map of 20 m
/// tiles has 25 million; this bounds what a corrupt file can ask for).
const MAX_TILES: usize = 50_000_000;

/// Reads the metadata layout; errors carry their line.
pub(crate) fn parse_metadata(text: &str) -> std::result::Result<Metadata, yaml::Fail> {
    let entries = yaml::parse(text)?;
    yaml::check_unique(&entries)?;
    let mut res = [None, None];
    let mut tiles = Vec::new();
    for e in &entries {
        match e.key.as_str() {
            k @ ("x_resolution" | "y_resolution") => {
                let Value::Scalar(s) = &e.value else {
                    return Err((e.line, format!("`{k}` must be a number")));
                };
                let v = yaml::number(e, s)?;
                if v <= 0.0 {
                    return Err((e.line, format!("`{k}` must be positive, got {v}")));
                }
                res[usize::from(k == "y_resolution")] = Some(v);
            }
            name if is_tile_name(name) => {
                tiles.push(TileEntry {
                    name: name.to_string(),
                    min: corner(e)?,
                    line: e.line,
                });
                if tiles.len() > MAX_TILES {
                    return Err((e.line, format!("more than {MAX_TILES} tiles")));
                }
            }
            other => {
                return Err((
                    e.line,
                    format!(
                        "unexpected key `{other}`: a tiled map's metadata has x_resolution, y_resolution and `<file>.pcd: [min_x, min_y]` entries"
                    ),
                ));
            }
        }
    }
    let [Some(x), Some(y)] = res else {
        let missing = if res[0].is_none() {
            "x_resolution"
        } else {
            "y_resolution"
        };
        return Err((0, format!("no `{missing}`")));
    };
    if tiles.is_empty() {
        return Err((0, "no `<file>.pcd: [min_x, min_y]` entries".into()));
    }
    for t in &tiles {
        // A cell's far edge must be a number the grid can tell from its
        // near edge.
        let apart = |lo: f64, size: f64| (lo + size).is_finite() && lo + size > lo;
        if !(apart(t.min[0], x) && apart(t.min[1], y)) {
            return Err((
                t.line,
                format!("`{}`: cell too far out for its size", t.name),
            ));
        }
    }
    Ok(Metadata {
        resolution: [x, y],
        tiles,
    })
}

fn corner(e: &Entry) -> std::result::Result<[f64; 2], yaml::Fail> {
    match &e.value {
        Value::Seq(v) if v.len() == 2 => Ok([yaml::number(e, &v[0])?, yaml::number(e, &v[1])?]),
        _ => Err((e.line, format!("`{}` must be `[min_x, min_y]`", e.key))),
    }
}

/// A metadata file's contents: cell size `[x, y]`, and each tile's file name
/// and cell corner `[min_x, min_y]` in file order.
pub type MetadataTiles = ([f64; 2], Vec<(String, [f64; 2])>);

/// Reads the metadata file at `path` (for fuzzing and tools).
pub fn read_metadata(path: &Path) -> Result<MetadataTiles> {
    let text = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let text = String::from_utf8(text)
        .map_err(|_| Error::format(path, "not UTF-8 text (a YAML file is expected)"))?;
    let m = parse_metadata(&text).map_err(|(l, msg)| Error::table(path, l, msg))?;
    Ok((
        m.resolution,
        m.tiles.into_iter().map(|t| (t.name, t.min)).collect(),
    ))
}

/// Writes `points` as an Autoware tiled map into `dir` (created if missing):
/// one `<ix>_<iy>.pcd` tile per occupied `resolution`-metre cell (cell
/// `floor(x / resolution)`, as `pointcloud_divider` cuts), in `format`, and
/// `pointcloud_map_metadata.yaml`. Tiles are ordered by cell row then
/// column, each with its points in their given order; the returned map
/// lists them in that order, so [`crate::cloud::open`] on `dir` reads exactly
/// [`TiledMap::order_points`] of `points`.
pub fn write_tiles(
    points: &[Point],
    dir: &Path,
    resolution: f64,
    format: super::OutFormat,
) -> Result<TiledMap> {
    let cells = cells_of(points, resolution)?;
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let mut yaml = format!("x_resolution: {resolution:?}\ny_resolution: {resolution:?}\n");
    let mut buf = Vec::new();
    for (&(iy, ix), idx) in &cells {
        let name = format!("{ix}_{iy}.{}", format.extension());
        buf.clear();
        buf.extend(idx.iter().map(|&i| points[i]));
        super::write(&dir.join(&name), format, &buf)?;
        let (x0, y0) = (ix as f64 * resolution, iy as f64 * resolution);
        yaml += &format!("{name}: [{x0:?}, {y0:?}]\n");
    }
    let meta = dir.join("pointcloud_map_metadata.yaml");
    std::fs::write(&meta, yaml).map_err(|e| Error::io(&meta, e))?;
    TiledMap::discover(dir)
}

/// Point indices per cell `(iy, ix)`, in row-then-column order.
fn cells_of(
    points: &[Point],
    resolution: f64,
) -> Result<std::collections::BTreeMap<(i64, i64), Vec<usize>>> {
    if !(resolution.is_finite() && resolution > 0.0) {
        return Err(Error::Param(format!(
            "tile size must be positive, got {resolution}"
        )));
    }
    let mut cells: std::collections::BTreeMap<(i64, i64), Vec<usize>> = Default::default();
    for (i, p) in points.iter().enumerate() {
        let (fx, fy) = ((p.x / resolution).floor(), (p.y / resolution).floor());
        if !(fx.abs() < 1e15 && fy.abs() < 1e15) {
            return Err(Error::Input(format!(
                "point ({}, {}) cannot be put in a {resolution} m tile",
                p.x, p.y
            )));
        }
        cells.entry((fy as i64, fx as i64)).or_default().push(i);
    }
    Ok(cells)
}

impl TiledMap {
    /// `points` in the order [`write_tiles`] stores them (tile by tile): a
    /// single file written in this order reads as the tiles do.
    pub fn order_points(points: &[Point], resolution: f64) -> Result<Vec<Point>> {
        Ok(cells_of(points, resolution)?
            .values()
            .flatten()
            .map(|&i| points[i])
            .collect())
    }
}

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
const MIN_SAMPLE_TILES: usize = 8;

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
        let mut r = super::open(&tile.path)?;
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
fn slack(cell: &[f64; 4]) -> f64 {
    1e-6 * cell.iter().fold(1.0_f64, |m, v| m.max(v.abs()))
}

/// The error for the first point of `pts` outside `tile`'s cell, if any.
fn check_cell(tile: &Tile, meta: Option<&Path>, pts: &[Point]) -> Result<()> {
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
            self.order
                .iter()
                .all(|&t| super::open(&self.map.tiles[t].path).is_ok_and(|r| r.has_intensity()))
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
        let per_point = super::open(&first.path)
            .ok()
            .and_then(|r| r.info().declared_points)
            .filter(|&n| n > 0)
            .map_or(super::BYTES_PER_POINT_GUESS as f64, |n| {
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
struct TileBatch<'a> {
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
        region: &super::Region,
    ) -> Result<&'s [Point]> {
        let pts = self.inner.piece_within(i, scratch, region)?;
        check_cell(self.tile, self.meta, pts)?;
        Ok(pts)
    }
}

/// The batch between two tiles.
struct NoPieces;

impl Batch for NoPieces {
    fn pieces(&self) -> usize {
        0
    }
    fn piece<'s>(&'s self, _: usize, _: &'s mut Scratch) -> Result<&'s [Point]> {
        Ok(&[])
    }
}

#[cfg(test)]
mod tests;
