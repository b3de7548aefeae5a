//! `mapgauge convert`: rewrite a map in another format (streamed).

use mapgauge::cloud::{self, CloudWriter, OutFormat};
use mapgauge::record::refuse_overwrite;
use mapgauge::{Error, Result};
use std::path::PathBuf;

/// Convert a map to another format, streaming (memory does not grow with the map).
#[derive(clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct Args {
    /// Input map (PCD, PLY, LAS/LAZ, E57, PTS, XYZ; recognised from its content),
    /// or an Autoware tiled map (a folder of PCD tiles or its `*metadata*.yaml`).
    #[arg(long)]
    map: PathBuf,
    /// Output file.
    #[arg(long)]
    out: PathBuf,
    /// Output format [default: from the output's extension: .ply, .pcd (binary), .las, .laz, .xyz].
    /// `pcd-f32` is for readers that misread double PCD (Open3D 0.20); it and
    /// the other float32 layouts refuse coordinates beyond ±32 768 m, where
    /// f32 rounds by over 1 mm. The input's intensity (binary PCD, binary PLY,
    /// LAS, LAZ, COPC, E57) is kept by `ply`, `pcd-xyzi`, `pcd-fastlio`, `ply-f32`,
    /// `xyz` (under an `x y z intensity` header line), `las` and `laz` (the
    /// last two as whole numbers 0–65535).
    #[arg(long, visible_alias = "to", value_enum)]
    format: Option<OutFormat>,
    /// Multiply every coordinate by this: 0.001 turns a map written in
    /// millimetres into metres, which mapgauge reads [default: 1, as stored].
    #[arg(long, value_name = "FACTOR")]
    scale: Option<f64>,
}

/// Runs `convert`.
pub fn run(a: Args) -> Result<()> {
    let format = match a.format {
        Some(f) => f,
        None => {
            let ext = a
                .out
                .extension()
                .and_then(|e| e.to_str())
                .map(str::to_ascii_lowercase)
                .unwrap_or_default();
            match ext.as_str() {
                "ply" => OutFormat::Ply,
                "pcd" => OutFormat::Pcd,
                "las" => OutFormat::Las,
                "laz" => OutFormat::Laz,
                "xyz" => OutFormat::Xyz,
                _ => {
                    return Err(Error::Param(format!(
                        "{}: cannot tell the output format from the extension; give --format",
                        a.out.display()
                    )));
                }
            }
        }
    };
    if let Some(s) = a.scale
        && !(s.is_finite() && s > 0.0)
    {
        return Err(Error::Param(format!(
            "--scale {s}: give a finite factor above 0 (0.001 for a map in millimetres)"
        )));
    }
    refuse_overwrite(&a.out, &[&a.map])?;
    let mut reader = cloud::open(&a.map)?;
    // Intensity goes through when both ends have it.
    let keep = reader.has_intensity() && format.holds_intensity();
    let mut writer = CloudWriter::create_with(&a.out, format, keep)?;
    let (mut buf, mut inten) = (Vec::new(), Vec::new());
    let scale = |buf: &mut Vec<mapgauge::Point>| {
        if let Some(s) = a.scale {
            for p in buf.iter_mut() {
                p.coords *= s;
            }
        }
    };
    if keep {
        while reader.next_chunk_intensity(&mut buf, &mut inten)? {
            scale(&mut buf);
            writer.write_intensity(&buf, &inten)?;
        }
    } else {
        while reader.next_chunk(&mut buf)? {
            scale(&mut buf);
            writer.write(&buf)?;
        }
    }
    let n = writer.finish()?;
    let st = reader.stats();
    let with = if keep { " with intensity" } else { "" };
    let scaled = a
        .scale
        .map_or(String::new(), |s| format!(", coordinates × {s}"));
    outln!("{n} points written to {}{with}{scaled}", a.out.display());
    if st.skipped_nonfinite > 0 {
        errln!("{} non-finite points skipped", st.skipped_nonfinite);
    }
    Ok(())
}
