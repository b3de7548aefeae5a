//! The tiles' metadata YAML: read, checked and written (`pointcloud_divider`'s
//! layout), and a cloud cut into tiles.

use super::*;

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
pub(super) const MAX_TILES: usize = 50_000_000;

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

pub(super) fn corner(e: &Entry) -> std::result::Result<[f64; 2], yaml::Fail> {
    match &e.value {
        Value::Seq(v) if v.len() == 2 => Ok([yaml::number(e, &v[0])?, yaml::number(e, &v[1])?]),
        _ => Err((e.line, format!("`{}` must be `[min_x, min_y]`", e.key))),
    }
}

/// A metadata file's contents: cell size `[x, y]`, and each tile's file name
/// and cell corner `[min_x, min_y]` in file order.
pub(crate) type MetadataTiles = ([f64; 2], Vec<(String, [f64; 2])>);

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
    format: crate::cloud::OutFormat,
) -> Result<TiledMap> {
    let cells = cells_of(points, resolution)?;
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let mut yaml = format!("x_resolution: {resolution:?}\ny_resolution: {resolution:?}\n");
    let mut buf = Vec::new();
    for (&(iy, ix), idx) in &cells {
        let name = format!("{ix}_{iy}.{}", format.extension());
        buf.clear();
        buf.extend(idx.iter().map(|&i| points[i]));
        crate::cloud::write(&dir.join(&name), format, &buf)?;
        let (x0, y0) = (ix as f64 * resolution, iy as f64 * resolution);
        yaml += &format!("{name}: [{x0:?}, {y0:?}]\n");
    }
    let meta = dir.join("pointcloud_map_metadata.yaml");
    std::fs::write(&meta, yaml).map_err(|e| Error::io(&meta, e))?;
    TiledMap::discover(dir)
}

/// Point indices per cell `(iy, ix)`, in row-then-column order.
pub(super) fn cells_of(
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
