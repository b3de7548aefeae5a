//! Checkpoints as a GeoJSON FeatureCollection (RFC 7946: WGS84 longitude,
//! latitude and height; only a WGS84 survey's are written, `super::check`
//! refuses the others). Written with serde_json: the format is a few fixed
//! objects, which a GeoJSON crate would only wrap.

use super::Checkpoint;
use serde_json::{Map, Value, json};

/// The file's text: one Point feature per target at its surveyed position,
/// the measured position and the differences as properties.
pub(super) fn text(rows: &[Checkpoint]) -> String {
    let features: Vec<Value> = rows
        .iter()
        .map(|c| {
            let mut coords = vec![json!(c.surveyed[0]), json!(c.surveyed[1])];
            if let Some(z) = c.surveyed_z {
                coords.push(json!(z));
            }
            let mut p = Map::new();
            p.insert("id".into(), json!(c.id));
            p.insert(
                "role".into(),
                json!(c.role.map(|r| format!("{r:?}").to_lowercase())),
            );
            p.insert("status".into(), json!(c.status));
            p.insert("reason".into(), json!(c.reason));
            p.insert("measured_lon".into(), json!(c.measured.map(|m| m[0])));
            p.insert("measured_lat".into(), json!(c.measured.map(|m| m[1])));
            p.insert("measured_h".into(), json!(c.measured_z));
            let d = c.d.unwrap_or([None; 3]);
            for (k, v) in ["dx_m", "dy_m", "dz_m"].into_iter().zip(d) {
                p.insert(k.into(), json!(v));
            }
            p.insert("error_m".into(), json!(c.error));
            let s = c.sigma.map(|s| s.map(Some)).unwrap_or([None; 3]);
            for (k, v) in ["sigma_x_m", "sigma_y_m", "sigma_z_m"].into_iter().zip(s) {
                p.insert(k.into(), json!(v));
            }
            json!({
                "type": "Feature",
                "id": c.id,
                "geometry": {"type": "Point", "coordinates": coords},
                "properties": Value::Object(p),
            })
        })
        .collect();
    let mut s = serde_json::to_string_pretty(&json!({
        "type": "FeatureCollection",
        "name": "checkpoints",
        "features": features,
    }))
    .unwrap_or_default();
    s.push('\n');
    s
}
