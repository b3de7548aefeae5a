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
    /// Multiply z by this instead of by `--scale`: 0.3048006 for heights
    /// in US survey feet over x and y in metres (a compound CRS's vertical
    /// part) [default: `--scale`'s factor].
    #[arg(long, value_name = "FACTOR")]
    scale_z: Option<f64>,
    /// The input's up axis, turned to +z (mapgauge takes +z as up): `y` for
    /// maps written in a y-up convention (Open3D's, Unity's), `-y` for a
    /// camera's y-down one (visual SLAM). A rotation, so the map keeps its
    /// handedness.
    #[arg(long, value_enum, default_value_t = Up::Z, allow_hyphen_values = true)]
    up: Up,
}

/// An input's up axis.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Up {
    #[value(name = "z")]
    Z,
    #[value(name = "-z")]
    MinusZ,
    #[value(name = "y")]
    Y,
    #[value(name = "-y")]
    MinusY,
    #[value(name = "x")]
    X,
    #[value(name = "-x")]
    MinusX,
}

impl Up {
    /// The rotation that takes this axis to +z (a quarter or half turn
    /// about another axis): (x, y, z) to the new x, y, z.
    fn turn(self, p: [f64; 3]) -> [f64; 3] {
        let [x, y, z] = p;
        match self {
            Up::Z => [x, y, z],
            Up::MinusZ => [x, -y, -z],
            Up::Y => [x, -z, y],
            Up::MinusY => [x, z, -y],
            Up::X => [-z, y, x],
            Up::MinusX => [z, y, -x],
        }
    }

    fn name(self) -> &'static str {
        match self {
            Up::Z => "z",
            Up::MinusZ => "-z",
            Up::Y => "y",
            Up::MinusY => "-y",
            Up::X => "x",
            Up::MinusX => "-x",
        }
    }
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
    for (flag, f) in [("--scale", a.scale), ("--scale-z", a.scale_z)] {
        if let Some(s) = f
            && !(s.is_finite() && s > 0.0)
        {
            return Err(Error::Param(format!(
                "{flag} {s}: give a finite factor above 0 (0.001 for a map in millimetres)"
            )));
        }
    }
    let factors = match (a.scale, a.scale_z) {
        (None, None) => None,
        (s, z) => {
            let s = s.unwrap_or(1.0);
            Some([s, s, z.unwrap_or(s)])
        }
    };
    refuse_overwrite(&a.out, &[&a.map])?;
    let mut reader = cloud::open(&a.map)?;
    // Intensity goes through when both ends have it.
    let keep = reader.has_intensity() && format.holds_intensity();
    let mut writer = CloudWriter::create_with(&a.out, format, keep)?;
    let (mut buf, mut inten) = (Vec::new(), Vec::new());
    let scale = |buf: &mut Vec<mapgauge::Point>| {
        if let Some([x, y, z]) = factors {
            for p in buf.iter_mut() {
                *p = mapgauge::Point::new(p.x * x, p.y * y, p.z * z);
            }
        }
        if a.up != Up::Z {
            for p in buf.iter_mut() {
                let [x, y, z] = a.up.turn([p.x, p.y, p.z]);
                *p = mapgauge::Point::new(x, y, z);
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
    let mut scaled = match (a.scale, a.scale_z) {
        (None, None) => String::new(),
        (Some(s), None) => format!(", coordinates × {s}"),
        (None, Some(z)) => format!(", z × {z}"),
        (Some(s), Some(z)) => format!(", x and y × {s}, z × {z}"),
    };
    if a.up != Up::Z {
        scaled += &format!(", turned so its {} is +z", a.up.name());
    }
    outln!("{n} points written to {}{with}{scaled}", a.out.display());
    if st.skipped_nonfinite > 0 {
        errln!("{} non-finite points skipped", st.skipped_nonfinite);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::Up;
    use nalgebra::{Matrix3, Vector3};

    /// Each `--up` is a rotation (determinant +1: no mirror) that takes its
    /// axis to +z.
    #[test]
    fn every_up_is_a_rotation_to_z() {
        for (up, axis) in [
            (Up::Z, [0.0, 0.0, 1.0]),
            (Up::MinusZ, [0.0, 0.0, -1.0]),
            (Up::Y, [0.0, 1.0, 0.0]),
            (Up::MinusY, [0.0, -1.0, 0.0]),
            (Up::X, [1.0, 0.0, 0.0]),
            (Up::MinusX, [-1.0, 0.0, 0.0]),
        ] {
            let col = |p| Vector3::from(up.turn(p));
            let m = Matrix3::from_columns(&[
                col([1.0, 0.0, 0.0]),
                col([0.0, 1.0, 0.0]),
                col([0.0, 0.0, 1.0]),
            ]);
            assert_eq!(m.determinant(), 1.0, "{}", up.name());
            assert_eq!(up.turn(axis), [0.0, 0.0, 1.0], "{}", up.name());
        }
    }
}
