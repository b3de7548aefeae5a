//! Checks a run's `result.json` against the `truth.json` of the synthetic scene it
//! measured, corner by corner. The accuracy metrics alone cannot catch a located
//! corner that is off by a constant: the rigid alignment absorbs it. So every
//! located corner (map frame) is compared with the true one, in x, y and z.
//!
//! z convention: mapgauge reports a corner's z as the mean height of its plate
//! inliers; truth.json's `map` z is the plates' centre height (halfway between
//! bottom and top edge) carried into the map frame. The two agree to the extent
//! that the LiDAR hits spread evenly over the plate height, hence a looser bound.

use serde_json::Value;
use std::path::Path;

/// What a run must achieve against its truth (millimetres).
#[derive(Debug, Clone, Copy)]
pub struct Limits {
    /// Every target's horizontal localisation error.
    pub each_mm: f64,
    /// The median horizontal localisation error.
    pub median_mm: f64,
    /// Length of the mean horizontal error vector: a constant offset of every
    /// corner, which the alignment (hence E_abs, E_rel) cannot see.
    pub bias_mm: f64,
    /// Every target's |z − truth z| (see the module doc for the convention).
    pub z_mm: f64,
    /// |E_abs − truth| and |E_rel − truth|.
    pub metrics_mm: f64,
}

/// The limits README.md's "Accuracy and speed" claims; `.ci/run` holds the demo
/// to them.
/// to them. (The demo, seed 1: 2.2–5.7 mm per target, median 2.9 mm.)
pub const README: Limits = Limits {
    each_mm: 10.0,
    median_mm: 5.0,
    bias_mm: 5.0,
    z_mm: 80.0,
    metrics_mm: 5.0,
};

/// One located corner minus its true position (mm, map frame).
#[derive(Debug, Clone)]
pub struct CornerError {
    pub id: String,
    pub dx: f64,
    pub dy: f64,
    pub dz: f64,
}

impl CornerError {
    pub fn horizontal(&self) -> f64 {
        self.dx.hypot(self.dy)
    }
}

/// A run and its scene's truth, read from their files.
pub struct Run {
    pub result: Value,
    pub truth: Value,
}

impl Run {
    pub fn read(result_json: &Path, truth_json: &Path) -> Run {
        let read = |p: &Path| -> Value {
            let bytes = std::fs::read(p).unwrap_or_else(|e| panic!("read {}: {e}", p.display()));
            serde_json::from_slice(&bytes).unwrap_or_else(|e| panic!("parse {}: {e}", p.display()))
        };
        Run {
            result: read(result_json),
            truth: read(truth_json),
        }
    }

    /// Every located corner's error against the truth; Err lists the targets
    /// that were not found (or that the truth does not know).
    pub fn corner_errors(&self) -> Result<Vec<CornerError>, String> {
        let truth = self.truth["targets"]
            .as_array()
            .expect("truth.json targets");
        let targets = self.result["targets"]
            .as_array()
            .expect("result.json targets");
        if targets.len() != truth.len() {
            return Err(format!(
                "{} targets in result.json, {} in truth.json",
                targets.len(),
                truth.len()
            ));
        }
        let mut out = Vec::new();
        let mut missing = Vec::new();
        for t in targets {
            let id = t["id"].as_str().expect("target id").to_string();
            if t["status"] != "ok" {
                missing.push(format!("{id} ({})", t["reason"]));
                continue;
            }
            let Some(tt) = truth.iter().find(|x| x["id"] == t["id"]) else {
                missing.push(format!("{id} (not in truth.json)"));
                continue;
            };
            // A levelled map's positions are in the levelled frame; the truth
            // is in the map's own: compare there. (A level map's
            // `corner_in_map` is its position as is; the position itself is
            // read then, which a test's shifted copy moves.)
            let levelled = self.result["eval"]["frame"]["levelling"]["tilt_deg"]
                .as_f64()
                .is_some_and(|t| t > 0.0);
            let in_map = self.result["eval"]["targets"]
                .as_array()
                .and_then(|v| v.iter().find(|d| d["id"] == t["id"]))
                .map(|d| d["corner_in_map"].clone())
                .filter(|c| c.is_array() && levelled);
            let got = |k: &str| match &in_map {
                Some(c) => c[["x", "y", "z"].iter().position(|n| *n == k).unwrap_or(0)]
                    .as_f64()
                    .expect("corner_in_map"),
                None => t["map"][k].as_f64().expect("located corner"),
            };
            let want = |i: usize| tt["map"][i].as_f64().expect("true corner");
            out.push(CornerError {
                id,
                dx: (got("x") - want(0)) * 1000.0,
                dy: (got("y") - want(1)) * 1000.0,
                dz: (got("z") - want(2)) * 1000.0,
            });
        }
        if missing.is_empty() {
            Ok(out)
        } else {
            Err(format!("not found: {}", missing.join(", ")))
        }
    }

    /// (measured, truth) for `absolute` or `relative` mean error (m).
    fn metric(&self, which: &str) -> (f64, f64) {
        (
            self.result[which]["mean"].as_f64().expect("result mean"),
            self.truth["expected"][which]["mean"]
                .as_f64()
                .expect("truth mean"),
        )
    }

    /// One line per target and the summary, for the test log.
    pub fn describe(&self) -> String {
        let mut s = String::new();
        match self.corner_errors() {
            Ok(errs) => {
                for e in &errs {
                    s += &format!(
                        "  target {:<4} dx {:+6.2} dy {:+6.2} horiz {:5.2} dz {:+6.2} mm\n",
                        e.id,
                        e.dx,
                        e.dy,
                        e.horizontal(),
                        e.dz
                    );
                }
            }
            Err(e) => s += &format!("  {e}\n"),
        }
        let (a, at) = self.metric("absolute");
        let (r, rt) = self.metric("relative");
        s += &format!("  E_abs {a:.4} (truth {at:.4}), E_rel {r:.4} (truth {rt:.4})");
        s
    }

    /// Every target found and within `lim`; Err says which bound failed and by how much.
    pub fn check(&self, lim: &Limits) -> Result<(), String> {
        let errs = self.corner_errors()?;
        let mut fails = Vec::new();
        for e in &errs {
            if e.horizontal() > lim.each_mm {
                fails.push(format!(
                    "target {}: horizontal error {:.1} mm > {} mm",
                    e.id,
                    e.horizontal(),
                    lim.each_mm
                ));
            }
            if e.dz.abs() > lim.z_mm {
                fails.push(format!(
                    "target {}: z error {:+.1} mm, limit ±{} mm",
                    e.id, e.dz, lim.z_mm
                ));
            }
        }
        let mut h: Vec<f64> = errs.iter().map(CornerError::horizontal).collect();
        h.sort_by(f64::total_cmp);
        let median = h[h.len() / 2];
        if median > lim.median_mm {
            fails.push(format!(
                "median horizontal error {median:.1} mm > {} mm",
                lim.median_mm
            ));
        }
        let n = errs.len() as f64;
        let (bx, by) = (
            errs.iter().map(|e| e.dx).sum::<f64>() / n,
            errs.iter().map(|e| e.dy).sum::<f64>() / n,
        );
        if bx.hypot(by) > lim.bias_mm {
            fails.push(format!(
                "mean error vector ({bx:+.1}, {by:+.1}) mm, length > {} mm: every corner is off the same way",
                lim.bias_mm
            ));
        }
        for which in ["absolute", "relative"] {
            let (got, want) = self.metric(which);
            if (got - want).abs() * 1000.0 > lim.metrics_mm {
                fails.push(format!(
                    "{which} mean {got:.4} m vs truth {want:.4} m: off by more than {} mm",
                    lim.metrics_mm
                ));
            }
        }
        if fails.is_empty() {
            Ok(())
        } else {
            Err(fails.join("; "))
        }
    }

    /// This run with every located corner moved by (dx, dy) metres in the map
    /// frame: what a constant bias in the locator would produce.
    pub fn shifted(&self, dx: f64, dy: f64) -> Run {
        let mut result = self.result.clone();
        for t in result["targets"].as_array_mut().expect("targets") {
            if t["status"] == "ok" {
                for (k, d) in [("x", dx), ("y", dy)] {
                    let v = t["map"][k].as_f64().expect("corner") + d;
                    t["map"][k] = Value::from(v);
                }
            }
        }
        Run {
            result,
            truth: self.truth.clone(),
        }
    }
}
