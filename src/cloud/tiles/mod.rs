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

mod metadata;
mod reader;
pub(crate) mod yaml;

use super::{Batch, CloudInfo, Format, PointReader, ReadStats, Scratch};
use crate::{Error, Point, Result};
use std::path::{Path, PathBuf};
use yaml::{Entry, Value};

use metadata::TileEntry;
pub(crate) use metadata::parse_metadata;
pub use metadata::{read_metadata, write_tiles};
pub(crate) use reader::open;
/// The projector file Autoware keeps beside the map.
pub(crate) const PROJECTOR_FILE: &str = "map_projector_info.yaml";

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
pub(crate) fn is_tiled(path: &Path) -> bool {
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

/// Where a map given as `path` is: its folder and metadata file (none: every
/// `.pcd` in the folder), or, for a tile folder without metadata whose
/// parent's metadata lists its tiles, that whole map.
enum Located {
    Map(TiledMap),
    In {
        dir: PathBuf,
        metadata: Option<PathBuf>,
    },
}

/// Finds the folder and metadata of the map at `path` (a folder or a
/// metadata file); several metadata files in a folder are an error.
fn locate(path: &Path) -> Result<Located> {
    if !path.is_dir() {
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        return Ok(Located::In {
            dir,
            metadata: Some(path.to_path_buf()),
        });
    }
    let metas: Vec<PathBuf> = sorted_entries(path)?
        .into_iter()
        .filter(|p| p.is_file() && is_metadata_name(p))
        .collect();
    match metas.as_slice() {
        [] => Ok(match parent_metadata(path) {
            Some(m) => Located::Map(m),
            None => Located::In {
                dir: path.to_path_buf(),
                metadata: None,
            },
        }),
        [one] => Ok(Located::In {
            dir: path.to_path_buf(),
            metadata: Some(one.clone()),
        }),
        more => {
            let names: Vec<String> = more.iter().map(|p| p.display().to_string()).collect();
            Err(Error::Input(format!(
                "{}: several metadata files ({}): give the one to use with --map",
                path.display(),
                names.join(", ")
            )))
        }
    }
}

/// A folder without metadata: every `.pcd` in it, by name, with no cells.
fn every_pcd(dir: &Path, projector: Option<PathBuf>) -> Result<TiledMap> {
    let mut tiles = Vec::new();
    for p in sorted_entries(dir)? {
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
    Ok(TiledMap {
        metadata: None,
        resolution: None,
        tiles,
        projector,
    })
}

/// The tiles the metadata `meta` lists, in its order, each with its cell,
/// found in `dir` or a sub-folder of it.
fn listed(dir: &Path, meta: PathBuf, projector: Option<PathBuf>) -> Result<TiledMap> {
    let text = std::fs::read(&meta).map_err(|e| Error::io(&meta, e))?;
    let text = String::from_utf8(text)
        .map_err(|_| Error::format(&meta, "not UTF-8 text (a YAML file is expected)"))?;
    let m = parse_metadata(&text).map_err(|(l, msg)| Error::table(&meta, l, msg))?;
    // Autoware keeps the tiles in a sub-folder beside the metadata
    // (`pointcloud_map.pcd/`): a tile is looked for there too.
    let subdirs: Vec<PathBuf> = sorted_entries(dir)?
        .into_iter()
        .filter(|p| p.is_dir())
        .collect();
    let mut tiles = Vec::with_capacity(m.tiles.len());
    for t in &m.tiles {
        let path = tile_path(dir, &subdirs, &meta, t)?;
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

/// The one file of tile `t` in `dir` or its `subdirs`: missing or found
/// twice is an error at the metadata's line.
fn tile_path(dir: &Path, subdirs: &[PathBuf], meta: &Path, t: &TileEntry) -> Result<PathBuf> {
    let mut found: Vec<PathBuf> = std::iter::once(dir)
        .chain(subdirs.iter().map(PathBuf::as_path))
        .map(|d| d.join(&t.name))
        .filter(|p| p.is_file())
        .collect();
    match found.len() {
        1 => Ok(found.remove(0)),
        0 => Err(Error::table(
            meta,
            t.line,
            format!(
                "tile {} is missing (looked in {} and its sub-folders)",
                t.name,
                dir.display()
            ),
        )),
        _ => {
            let names: Vec<String> = found.iter().map(|p| p.display().to_string()).collect();
            Err(Error::table(
                meta,
                t.line,
                format!(
                    "tile {} is ambiguous: found as {}",
                    t.name,
                    names.join(" and ")
                ),
            ))
        }
    }
}

impl TiledMap {
    /// Finds the map at `path` (a folder or a metadata file) and checks that
    /// every tile is there; no tile is opened.
    pub fn discover(path: &Path) -> Result<TiledMap> {
        let (dir, metadata) = match locate(path)? {
            Located::Map(m) => return Ok(m),
            Located::In { dir, metadata } => (dir, metadata),
        };
        let projector = Some(dir.join(PROJECTOR_FILE)).filter(|p| p.is_file());
        match metadata {
            None => every_pcd(&dir, projector),
            Some(meta) => listed(&dir, meta, projector),
        }
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

#[cfg(test)]
mod tests;
