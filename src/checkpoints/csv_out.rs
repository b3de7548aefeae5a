//! Checkpoints as CSV: one row per target, the CRS named in a column (CSV
//! has no header block to hold it).

use super::{Checkpoint, Crs};
use crate::{Error, Result};

/// The CSV file's bytes. Columns: id, role, status, reason, crs, the
/// surveyed and measured positions (`lon`/`lat`/`h` for WGS84, else
/// `x`/`y`/`z`), dx/dy/dz (m), error (m), sigma_x/y/z (m).
pub(super) fn bytes(crs: &Crs, rows: &[Checkpoint]) -> Result<Vec<u8>> {
    let axes = match crs {
        Crs::Wgs84 => ["lon", "lat", "h"],
        _ => ["x", "y", "z"],
    };
    let mut header = vec![
        "id".to_string(),
        "role".into(),
        "status".into(),
        "reason".into(),
        "crs".into(),
    ];
    for side in ["surveyed", "measured"] {
        header.extend(axes.iter().map(|a| format!("{side}_{a}")));
    }
    header.extend(
        [
            "dx_m",
            "dy_m",
            "dz_m",
            "error_m",
            "sigma_x_m",
            "sigma_y_m",
            "sigma_z_m",
        ]
        .map(String::from),
    );
    let mut w = csv::Writer::from_writer(Vec::new());
    let err = |e: csv::Error| Error::Input(format!("checkpoints CSV: {e}"));
    w.write_record(&header).map_err(err)?;
    // Degrees to 1e-9 (0.1 mm), metres to 0.1 µm: nothing the numbers hold is lost.
    let deg = matches!(crs, Crs::Wgs84);
    let xy = |v: f64| {
        if deg {
            format!("{v:.10}")
        } else {
            format!("{v:.6}")
        }
    };
    let m = |v: Option<f64>| v.map(|v| format!("{v:.7}")).unwrap_or_default();
    for c in rows {
        let mut row = vec![
            c.id.clone(),
            c.role
                .map(|r| format!("{r:?}").to_lowercase())
                .unwrap_or_default(),
            c.status.clone(),
            c.reason.clone().unwrap_or_default(),
            crs.label(),
            xy(c.surveyed[0]),
            xy(c.surveyed[1]),
            m(c.surveyed_z),
        ];
        match c.measured {
            Some(p) => row.extend([xy(p[0]), xy(p[1]), m(c.measured_z)]),
            None => row.extend([String::new(), String::new(), String::new()]),
        }
        let d = c.d.unwrap_or([None; 3]);
        row.extend(d.iter().map(|v| m(*v)));
        row.push(m(c.error));
        let s = c.sigma.map(|s| s.map(Some)).unwrap_or([None; 3]);
        row.extend(s.iter().map(|v| m(*v)));
        w.write_record(&row).map_err(err)?;
    }
    w.into_inner()
        .map_err(|e| Error::Input(format!("checkpoints CSV: {e}")))
}
