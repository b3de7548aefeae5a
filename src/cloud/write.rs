//! PLY and PCD writers, atomic (temporary sibling, then rename).
//!
//! Both formats put the point count in the header, but crops are streamed and
//! their size is only known at the end. The header is therefore written with a
//! fixed length up front and rewritten in place by `finish`: the count's width
//! varies, so a comment line absorbs the difference with trailing spaces
//! (comments are ignored by every reader, unlike padded numbers, which some
//! parsers reject). Points go to `.NAME.tmp-PID-N` beside the target and the
//! file is renamed into place only when complete; dropping an unfinished
//! writer removes the temporary file.

use super::Sink;
use crate::{Error, Point, Result};
use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Distinguishes temporary files of writers in the same process.
static TMP_SEQ: AtomicU64 = AtomicU64::new(0);
/// Widest decimal u64: the header is sized for it.
const COUNT_WIDTH: usize = 20;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    /// Binary little-endian PLY, double x y z, and float intensity when
    /// the writer was created with intensity.
    Ply {
        intensity: bool,
    },
    Pcd,
    PcdAscii,
    /// Binary PCD with float (f32) x, y, z.
    PcdF32,
    /// Binary PCD, float x y z intensity (LIO-SAM's `PointXYZI`).
    PcdXyzi,
    /// Binary PCD, float x y z intensity normal_x normal_y normal_z curvature
    /// (FAST-LIO2's `PointXYZINormal`; normals and curvature written as 0, as
    /// FAST-LIO2 saves its maps).
    PcdFastlio,
    /// Binary little-endian PLY, float x y z, and float intensity when the
    /// writer was created with intensity (GLIM's maps).
    PlyF32 {
        intensity: bool,
    },
    /// `x y z` text lines (micrometres), plus intensity when the writer was
    /// created with intensity, under a header line naming the columns then
    /// (`x y z intensity`: a headerless fourth column may be anything, and
    /// mapgauge's own reader, PDAL's and pandas' take the names from it);
    /// no header without.
    Xyz {
        intensity: bool,
    },
}

impl Kind {
    /// Float32 values per record, or `None` for the double and ascii kinds.
    fn f32_fields(self) -> Option<usize> {
        match self {
            Kind::PcdF32 | Kind::PlyF32 { intensity: false } => Some(3),
            Kind::PcdXyzi | Kind::PlyF32 { intensity: true } => Some(4),
            Kind::PcdFastlio => Some(8),
            Kind::Ply { .. } | Kind::Pcd | Kind::PcdAscii | Kind::Xyz { .. } => None,
        }
    }
}

/// Largest coordinate magnitude written as f32. Coordinates are written as
/// they are (the map's own frame, no offset, as SLAM tools write them): f32
/// has a 24-bit significand, so a value in [2^k, 2^(k+1)) m is rounded to a
/// multiple of 2^(k-23) m, by at most half that: ≤ 4 µm within 128 m of the
/// origin, ≤ 0.03 mm within 1 024 m, ≤ 0.25 mm within 8 192 m and < 1 mm
/// below 2^15 m. Beyond, a point would move by a millimetre or more: refused.
pub(super) const F32_LIMIT: f64 = 32768.0;

/// The header for `n` points; `pad` trailing spaces go on the comment line.
fn header(kind: Kind, n: u64, pad: usize) -> Vec<u8> {
    let pad = " ".repeat(pad);
    let s = match kind {
        Kind::Ply { intensity } => format!(
            "ply\nformat binary_little_endian 1.0\ncomment written by mapgauge{pad}\n\
             element vertex {n}\nproperty double x\nproperty double y\nproperty double z\n{}end_header\n",
            if intensity {
                "property float intensity\n"
            } else {
                ""
            }
        ),
        Kind::Pcd => pcd_header(n, &pad, 8, "binary"),
        Kind::PcdAscii => pcd_header(n, &pad, 8, "ascii"),
        Kind::PcdF32 => pcd_header(n, &pad, 4, "binary"),
        Kind::PcdXyzi => pcd_f32_header(n, &pad, &["x", "y", "z", "intensity"]),
        // Nothing to fix up: the same line whatever the count.
        Kind::Xyz { intensity: true } => "x y z intensity\n".into(),
        Kind::Xyz { intensity: false } => String::new(),
        Kind::PcdFastlio => pcd_f32_header(
            n,
            &pad,
            &[
                "x",
                "y",
                "z",
                "intensity",
                "normal_x",
                "normal_y",
                "normal_z",
                "curvature",
            ],
        ),
        Kind::PlyF32 { intensity } => format!(
            "ply\nformat binary_little_endian 1.0\ncomment written by mapgauge{pad}\n\
             element vertex {n}\nproperty float x\nproperty float y\nproperty float z\n{}end_header\n",
            if intensity {
                "property float intensity\n"
            } else {
                ""
            }
        ),
    };
    s.into_bytes()
}

/// A binary PCD header with the float32 `fields` (x, y, z first).
fn pcd_f32_header(n: u64, pad: &str, fields: &[&str]) -> String {
    let k = fields.len();
    format!(
        "# .PCD v0.7 - Point Cloud Data file format{pad}\nVERSION 0.7\nFIELDS {}\n\
         SIZE {}\nTYPE {}\nCOUNT {}\nWIDTH {n}\nHEIGHT 1\n\
         VIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA binary\n",
        fields.join(" "),
        vec!["4"; k].join(" "),
        vec!["F"; k].join(" "),
        vec!["1"; k].join(" "),
    )
}

/// A PCD header with `size`-byte float x, y, z.
fn pcd_header(n: u64, pad: &str, size: u8, data: &str) -> String {
    format!(
        "# .PCD v0.7 - Point Cloud Data file format{pad}\nVERSION 0.7\nFIELDS x y z\n\
         SIZE {size} {size} {size}\nTYPE F F F\nCOUNT 1 1 1\nWIDTH {n}\nHEIGHT 1\n\
         VIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA {data}\n"
    )
}

/// The header for `n` points, padded to the length reserved at creation.
fn fixed_header(kind: Kind, n: u64) -> Vec<u8> {
    let digits = n.to_string().len();
    let per_count = if matches!(kind, Kind::Ply { .. } | Kind::PlyF32 { .. }) {
        1
    } else {
        2
    };
    header(kind, n, (COUNT_WIDTH - digits) * per_count)
}

/// Bytes a [`XyzSink`] buffers: a block of [`SINK_BLOCK`] binary points is
/// larger and goes to the file directly (no second copy); smaller writes (the
/// crop hands its hits over piece by piece) gather here. Small, because the
/// crop keeps one sink per target open and every buffer's pages are faulted
/// in (1 MiB each was a quarter of a crop's page faults).
const SINK_BUF: usize = 64 << 10;

/// Points converted to bytes at a time (96 KiB of double PLY).
const SINK_BLOCK: usize = 1 << 12;

/// A binary x, y, z (f64, little endian) writer for PLY or PCD.
struct XyzSink {
    kind: Kind,
    dest: PathBuf,
    /// `Some` until finished; removed on drop otherwise.
    tmp: Option<PathBuf>,
    out: Option<BufWriter<File>>,
    count: u64,
    scratch: Vec<u8>,
}

impl XyzSink {
    fn create(path: &Path, kind: Kind) -> Result<XyzSink> {
        let name = path.file_name().ok_or_else(|| {
            Error::Param(format!("{}: output path has no file name", path.display()))
        })?;
        let tmp_name = format!(
            ".{}.tmp-{}-{}",
            name.to_string_lossy(),
            std::process::id(),
            TMP_SEQ.fetch_add(1, Ordering::Relaxed)
        );
        let tmp = path.with_file_name(tmp_name);
        let file = File::options()
            .write(true)
            .create_new(true)
            .open(&tmp)
            .map_err(|e| Error::io(&tmp, e))?;
        let mut sink = XyzSink {
            kind,
            dest: path.to_path_buf(),
            tmp: Some(tmp.clone()),
            out: Some(BufWriter::with_capacity(SINK_BUF, file)),
            count: 0,
            scratch: Vec::new(),
        };
        let head = fixed_header(kind, 0);
        sink.out_mut()?
            .write_all(&head)
            .map_err(|e| Error::io(&tmp, e))?;
        Ok(sink)
    }

    fn out_mut(&mut self) -> Result<&mut BufWriter<File>> {
        self.out.as_mut().ok_or_else(|| {
            Error::Input(format!("{}: writer already finished", self.dest.display()))
        })
    }

    fn tmp_path(&self) -> PathBuf {
        self.tmp.clone().unwrap_or_else(|| self.dest.clone())
    }
}

impl Sink for XyzSink {
    fn write(&mut self, points: &[Point], intensity: Option<&[f32]>) -> Result<()> {
        if let Some(i) = intensity
            && i.len() != points.len()
        {
            return Err(Error::Input(format!(
                "{}: {} intensities for {} points",
                self.dest.display(),
                i.len(),
                points.len()
            )));
        }
        for (b, block) in points.chunks(SINK_BLOCK).enumerate() {
            // Binary records overwrite every byte of `scratch[..len]`: it is
            // grown (zero-filled) once, never cleared, so no block pays a
            // memset (3 % of a crop's instructions when it did).
            let len = if let Kind::PcdAscii | Kind::Xyz { .. } = self.kind {
                self.scratch.clear();
                let inten = intensity
                    .filter(|_| self.kind == Kind::Xyz { intensity: true })
                    .map(|i| &i[b * SINK_BLOCK..b * SINK_BLOCK + block.len()]);
                for (j, p) in block.iter().enumerate() {
                    let _ = write!(self.scratch, "{:.6} {:.6} {:.6}", p.x, p.y, p.z);
                    if self.kind == (Kind::Xyz { intensity: true }) {
                        // Shortest text that reads back as the same f32.
                        let _ = write!(self.scratch, " {}", inten.map_or(0.0, |i| i[j]));
                    }
                    self.scratch.push(b'\n');
                }
                self.scratch.len()
            } else if let Some(k) = self.kind.f32_fields() {
                let inten = intensity.map(|i| &i[b * SINK_BLOCK..b * SINK_BLOCK + block.len()]);
                let rec = 4 * k;
                let len = rec * block.len();
                if self.scratch.len() < len {
                    self.scratch.resize(len, 0);
                }
                for (j, (r, p)) in self.scratch[..len]
                    .chunks_exact_mut(rec)
                    .zip(block)
                    .enumerate()
                {
                    for (c, v) in [p.x, p.y, p.z].into_iter().enumerate() {
                        if v.is_finite() && v.abs() >= F32_LIMIT {
                            return Err(f32_refusal(&self.dest, self.count + j as u64, v));
                        }
                        r[4 * c..4 * c + 4].copy_from_slice(&(v as f32).to_le_bytes());
                    }
                    if k > 3 {
                        // Intensity (0 when the source has none); the rest
                        // (FAST-LIO2's normals and curvature) is 0.
                        let v = inten.map_or(0.0, |i| i[j]);
                        r[12..16].copy_from_slice(&v.to_le_bytes());
                        r[16..].fill(0);
                    }
                }
                // `count` advances per block, so a refusal names the right point.
                self.count += block.len() as u64;
                len
            } else if self.kind == (Kind::Ply { intensity: true }) {
                let inten = intensity.map(|i| &i[b * SINK_BLOCK..b * SINK_BLOCK + block.len()]);
                let len = 28 * block.len();
                if self.scratch.len() < len {
                    self.scratch.resize(len, 0);
                }
                for (j, (r, p)) in self.scratch[..len]
                    .chunks_exact_mut(28)
                    .zip(block)
                    .enumerate()
                {
                    r[..8].copy_from_slice(&p.x.to_le_bytes());
                    r[8..16].copy_from_slice(&p.y.to_le_bytes());
                    r[16..24].copy_from_slice(&p.z.to_le_bytes());
                    r[24..].copy_from_slice(&inten.map_or(0.0, |i| i[j]).to_le_bytes());
                }
                len
            } else {
                // Filled record by record: the crop writer's inner loop (a
                // push per coordinate cost a capacity check each).
                let len = 24 * block.len();
                if self.scratch.len() < len {
                    self.scratch.resize(len, 0);
                }
                for (r, p) in self.scratch[..len].chunks_exact_mut(24).zip(block) {
                    r[..8].copy_from_slice(&p.x.to_le_bytes());
                    r[8..16].copy_from_slice(&p.y.to_le_bytes());
                    r[16..].copy_from_slice(&p.z.to_le_bytes());
                }
                len
            };
            let scratch = std::mem::take(&mut self.scratch);
            let res = self.out_mut()?.write_all(&scratch[..len]);
            self.scratch = scratch;
            res.map_err(|e| Error::io(self.tmp_path(), e))?;
        }
        if self.kind.f32_fields().is_none() {
            self.count += points.len() as u64;
        }
        Ok(())
    }

    fn finish(mut self: Box<Self>) -> Result<u64> {
        let tmp = self.tmp_path();
        let out = self.out.take().ok_or_else(|| {
            Error::Input(format!("{}: writer already finished", self.dest.display()))
        })?;
        let mut file = out
            .into_inner()
            .map_err(|e| Error::io(&tmp, e.into_error()))?;
        let head = fixed_header(self.kind, self.count);
        file.seek(SeekFrom::Start(0))
            .map_err(|e| Error::io(&tmp, e))?;
        file.write_all(&head).map_err(|e| Error::io(&tmp, e))?;
        drop(file);
        std::fs::rename(&tmp, &self.dest).map_err(|e| Error::io(&self.dest, e))?;
        self.tmp = None;
        Ok(self.count)
    }
}

impl Drop for XyzSink {
    fn drop(&mut self) {
        if let Some(tmp) = self.tmp.take() {
            drop(self.out.take());
            let _ = std::fs::remove_file(tmp);
        }
    }
}

/// Starts a binary PLY writer (double x y z, plus float intensity if
/// `intensity`).
pub(super) fn ply_sink(path: &Path, intensity: bool) -> Result<Box<dyn Sink>> {
    Ok(Box::new(XyzSink::create(path, Kind::Ply { intensity })?))
}

/// Starts a binary PCD writer.
pub(super) fn pcd_sink(path: &Path) -> Result<Box<dyn Sink>> {
    Ok(Box::new(XyzSink::create(path, Kind::Pcd)?))
}

/// Starts a binary float32 PCD writer (coordinates within ±[`F32_LIMIT`]).
pub(super) fn pcd_f32_sink(path: &Path) -> Result<Box<dyn Sink>> {
    Ok(Box::new(XyzSink::create(path, Kind::PcdF32)?))
}

/// Starts a binary PCD writer of float x y z intensity (LIO-SAM).
pub(super) fn pcd_xyzi_sink(path: &Path) -> Result<Box<dyn Sink>> {
    Ok(Box::new(XyzSink::create(path, Kind::PcdXyzi)?))
}

/// Starts a binary PCD writer of FAST-LIO2's eight floats.
pub(super) fn pcd_fastlio_sink(path: &Path) -> Result<Box<dyn Sink>> {
    Ok(Box::new(XyzSink::create(path, Kind::PcdFastlio)?))
}

/// Starts an XYZ text writer (x y z, plus intensity if `intensity`).
pub(super) fn xyz_sink(path: &Path, intensity: bool) -> Result<Box<dyn Sink>> {
    Ok(Box::new(XyzSink::create(path, Kind::Xyz { intensity })?))
}

/// Starts a binary float PLY writer (x y z, plus intensity if `intensity`).
pub(super) fn ply_f32_sink(path: &Path, intensity: bool) -> Result<Box<dyn Sink>> {
    Ok(Box::new(XyzSink::create(path, Kind::PlyF32 { intensity })?))
}

/// Why a coordinate cannot be written as f32: the error it would carry.
fn f32_refusal(dest: &Path, point: u64, v: f64) -> Error {
    let err = (v - f64::from(v as f32)).abs();
    let ulp = 2f64.powi(v.abs().log2().floor() as i32 - 23);
    Error::Input(format!(
        "{}: point {point} has a coordinate of {v} m, which float32 PCD cannot hold to the millimetre \
         (f32 keeps ~7 significant digits: spacing {ulp} m here, this one would move {err:.4} m; \
         the limit is ±{F32_LIMIT} m); write a double format (--format pcd or ply) or move the map to a local frame first",
        dest.display()
    ))
}

/// Starts an ascii PCD writer (coordinates to the micrometre).
pub(super) fn pcd_ascii_sink(path: &Path) -> Result<Box<dyn Sink>> {
    Ok(Box::new(XyzSink::create(path, Kind::PcdAscii)?))
}

/// Uncompressed bytes per LZF block written by the binary_compressed writer.
const LZF_BLOCK: usize = 1 << 20;

/// A binary_compressed PCD writer. The format stores all x, then all y, then
/// all z (then all intensities, as float32, when asked for), LZF-compressed
/// as one stream behind the header, so the columns are spooled to temporary
/// files while points arrive and compressed at `finish`, 1 MiB at a time
/// (LZF blocks compressed separately concatenate into one valid stream):
/// memory stays bounded.
struct PcdCompressedSink {
    dest: PathBuf,
    tmp: PathBuf,
    /// The column files being written, one writer each in `cols`, kept
    /// apart so that a `finish` failing part way (after `cols` was taken)
    /// still leaves none behind.
    spooled: Vec<PathBuf>,
    cols: Vec<BufWriter<File>>,
    /// Whether the fourth column is the intensity.
    intensity: bool,
    count: u64,
    finished: bool,
}

/// The binary_compressed header: double x, y, z, and a float intensity.
fn compressed_header(n: u64, intensity: bool) -> String {
    if intensity {
        format!(
            "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z intensity\n\
             SIZE 8 8 8 4\nTYPE F F F F\nCOUNT 1 1 1 1\nWIDTH {n}\nHEIGHT 1\n\
             VIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA binary_compressed\n"
        )
    } else {
        pcd_header(n, "", 8, "binary_compressed")
    }
}

/// Starts a binary_compressed PCD writer, with an intensity column when
/// `intensity` (points written without one get NaN there).
pub(super) fn pcd_compressed_sink(path: &Path, intensity: bool) -> Result<Box<dyn Sink>> {
    let name = path
        .file_name()
        .ok_or_else(|| Error::Param(format!("{}: output path has no file name", path.display())))?;
    let seq = TMP_SEQ.fetch_add(1, Ordering::Relaxed);
    let tmp_name = |what: &str| {
        path.with_file_name(format!(
            ".{}.tmp-{}-{seq}{what}",
            name.to_string_lossy(),
            std::process::id()
        ))
    };
    let mut sink = PcdCompressedSink {
        dest: path.to_path_buf(),
        tmp: tmp_name(""),
        cols: Vec::new(),
        spooled: Vec::new(),
        intensity,
        count: 0,
        finished: false,
    };
    let names: &[&str] = if intensity {
        &["x", "y", "z", "i"]
    } else {
        &["x", "y", "z"]
    };
    for c in names {
        let p = tmp_name(&format!(".{c}"));
        let f = File::options()
            .write(true)
            .create_new(true)
            .open(&p)
            .map_err(|e| Error::io(&p, e))?;
        sink.spooled.push(p);
        sink.cols.push(BufWriter::with_capacity(1 << 20, f));
    }
    Ok(Box::new(sink))
}

impl Sink for PcdCompressedSink {
    fn write(&mut self, points: &[Point], intensity: Option<&[f32]>) -> Result<()> {
        if let Some(i) = intensity
            && i.len() != points.len()
        {
            return Err(Error::Param(format!(
                "{}: {} intensities for {} points",
                self.dest.display(),
                i.len(),
                points.len()
            )));
        }
        for (c, (w, p)) in self.cols.iter_mut().zip(&self.spooled).enumerate() {
            if c == 3 {
                for k in 0..points.len() {
                    let v = intensity.map_or(f32::NAN, |i| i[k]);
                    w.write_all(&v.to_le_bytes()).map_err(|e| Error::io(p, e))?;
                }
                continue;
            }
            for q in points {
                w.write_all(&q[c].to_le_bytes())
                    .map_err(|e| Error::io(p, e))?;
            }
        }
        self.count += points.len() as u64;
        Ok(())
    }

    fn finish(mut self: Box<Self>) -> Result<u64> {
        let per_point = if self.intensity { 28 } else { 24 };
        let raw = self.count * per_point;
        let Ok(raw32) = u32::try_from(raw) else {
            return Err(Error::Input(format!(
                "{}: {} points do not fit in a binary_compressed PCD (its sizes are 32-bit: at most {} double x, y, z points{})",
                self.dest.display(),
                self.count,
                u32::MAX as u64 / per_point,
                if self.intensity {
                    " with intensity"
                } else {
                    ""
                }
            )));
        };
        let tmp = self.tmp.clone();
        let file = File::options()
            .write(true)
            .create_new(true)
            .open(&tmp)
            .map_err(|e| Error::io(&tmp, e))?;
        let mut out = BufWriter::with_capacity(1 << 20, file);
        let io = |e| Error::io(&tmp, e);
        out.write_all(compressed_header(self.count, self.intensity).as_bytes())
            .map_err(io)?;
        out.write_all(&[0u8; 8]).map_err(io)?;
        let mut comp: u64 = 0;
        let mut block = vec![0u8; LZF_BLOCK];
        let paths = self.spooled.clone();
        for (p, w) in paths.iter().zip(std::mem::take(&mut self.cols)) {
            let mut f = w.into_inner().map_err(|e| Error::io(&p, e.into_error()))?;
            f.seek(SeekFrom::Start(0)).map_err(|e| Error::io(&p, e))?;
            drop(f);
            let mut f = File::open(&p).map_err(|e| Error::io(&p, e))?;
            loop {
                let n = read_full(&mut f, &mut block).map_err(|e| Error::io(&p, e))?;
                if n == 0 {
                    break;
                }
                let packed = lzf_block(&block[..n]);
                out.write_all(&packed).map_err(io)?;
                comp += packed.len() as u64;
            }
            let _ = std::fs::remove_file(&p);
        }
        let comp32 = u32::try_from(comp).map_err(|_| {
            Error::Input(format!(
                "{}: compressed data exceeds the format's 4 GiB limit",
                self.dest.display()
            ))
        })?;
        let mut file = out.into_inner().map_err(|e| io(e.into_error()))?;
        let head = compressed_header(self.count, self.intensity).len() as u64;
        file.seek(SeekFrom::Start(head)).map_err(io)?;
        file.write_all(&comp32.to_le_bytes()).map_err(io)?;
        file.write_all(&raw32.to_le_bytes()).map_err(io)?;
        drop(file);
        std::fs::rename(&tmp, &self.dest).map_err(|e| Error::io(&self.dest, e))?;
        self.finished = true;
        Ok(self.count)
    }
}

impl Drop for PcdCompressedSink {
    fn drop(&mut self) {
        self.cols.clear();
        for p in &self.spooled {
            let _ = std::fs::remove_file(p);
        }
        if !self.finished {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// Reads until `buf` is full or the file ends; returns the bytes read.
fn read_full(f: &mut File, buf: &mut [u8]) -> std::io::Result<usize> {
    use std::io::Read;
    let mut n = 0;
    while n < buf.len() {
        match f.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}

/// LZF-compresses one block; incompressible data becomes literal runs.
pub(super) fn lzf_block(data: &[u8]) -> Vec<u8> {
    match lzf::compress(data) {
        Ok(v) => v,
        Err(_) => {
            let mut v = Vec::with_capacity(data.len() + data.len() / 32 + 1);
            for run in data.chunks(32) {
                v.push((run.len() - 1) as u8);
                v.extend_from_slice(run);
            }
            v
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_length_is_fixed_for_every_count() {
        for kind in [
            Kind::Ply { intensity: false },
            Kind::Ply { intensity: true },
            Kind::Pcd,
            Kind::PcdAscii,
            Kind::PcdF32,
            Kind::PcdXyzi,
            Kind::PcdFastlio,
            Kind::PlyF32 { intensity: false },
            Kind::PlyF32 { intensity: true },
            Kind::Xyz { intensity: true },
        ] {
            let len = fixed_header(kind, 0).len();
            for n in [1, 9, 10, 12345, u64::MAX / 3, u64::MAX] {
                assert_eq!(fixed_header(kind, n).len(), len, "{kind:?} {n}");
            }
        }
    }
}
