//! Quality gates: `E_abs<=0.05`, judged on a result with its uncertainty.
//!
//! A gate passes when even the unlucky end of its statistic's 95 % interval
//! meets the threshold, fails when even the lucky end misses it, and is
//! undecided otherwise: five targets measure a map's error to a few
//! millimetres, and a number 1 mm under a threshold with an interval 8 mm
//! wide has not shown that the map meets it. The [`Policy`] says what an
//! undecided (or failed) gate does to the exit code.
//!
//! The interval is the envelope of the two the result carries (the
//! localisation's Monte Carlo and the bootstrap over targets, see
//! `docs/uncertainty.md`): a release gate asks whether the map would pass
//! if measured again with other targets, so both kinds of doubt count.
//! Statistics without an interval (maxima, RMSE_V, found) are judged on
//! their value, and the verdict says so (`basis`).
//!
//! ```
//! use mapgauge::gate::{Gate, Verdict};
//! let g: Gate = "E_abs <= 5cm".parse()?;
//! assert_eq!(g.threshold, 0.05);
//! // 18 mm, its interval 12–26 mm: well inside 5 cm.
//! assert_eq!(g.verdict(Some(0.018), Some([0.012, 0.026])), Verdict::Pass);
//! // Inside 2 cm on its value, not for the whole interval.
//! let g: Gate = "E_abs<=0.02".parse()?;
//! assert_eq!(g.verdict(Some(0.018), Some([0.012, 0.026])), Verdict::Undecided);
//! # Ok::<(), mapgauge::Error>(())
//! ```

use crate::record::ResultFile;
use crate::{Error, Result};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// A statistic of a result that a gate can hold to a threshold.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Statistic {
    /// Mean absolute error (m).
    EAbs,
    /// Mean relative (pair) error (m).
    ERel,
    /// Largest absolute error (m).
    MaxAbs,
    /// Median absolute error (m).
    MedianAbs,
    /// Largest pair error (m).
    MaxRel,
    /// Mean leave-one-out error (m).
    ELoo,
    /// ASPRS RMSE_H (m).
    RmseH,
    /// ASPRS RMSE_V (m), when heights were fitted.
    RmseV,
    /// ASPRS RMSE_3D (m), when heights were fitted.
    Rmse3d,
    /// NSSDA horizontal accuracy at 95 % (m).
    NssdaH,
    /// NSSDA vertical accuracy at 95 % (m).
    NssdaV,
    /// The map's scale error, absolute (ppm).
    ScalePpm,
    /// Fraction of the surveyed targets located (0–1): scored, or excluded
    /// as a gross error (found, and its error judged), as the summary's
    /// "Found" counts them.
    Found,
}

/// Every statistic, with its name as written in gates and results.
const NAMES: [(Statistic, &str); 13] = [
    (Statistic::EAbs, "E_abs"),
    (Statistic::ERel, "E_rel"),
    (Statistic::MaxAbs, "max_abs"),
    (Statistic::MedianAbs, "median_abs"),
    (Statistic::MaxRel, "max_rel"),
    (Statistic::ELoo, "E_loo"),
    (Statistic::RmseH, "RMSE_H"),
    (Statistic::RmseV, "RMSE_V"),
    (Statistic::Rmse3d, "RMSE_3D"),
    (Statistic::NssdaH, "NSSDA_H"),
    (Statistic::NssdaV, "NSSDA_V"),
    (Statistic::ScalePpm, "scale_ppm"),
    (Statistic::Found, "found"),
];

/// What the threshold's number is in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Unit {
    Metres,
    Ppm,
    Fraction,
}

impl Statistic {
    /// The name gates and `result.json` use (`E_abs`, `RMSE_H`, `found`…).
    pub fn name(self) -> &'static str {
        NAMES.iter().find(|(s, _)| *s == self).map_or("?", |n| n.1)
    }
    /// Case and underscores do not matter: `e_abs`, `EABS`, `E_abs`.
    fn parse(s: &str) -> Option<Statistic> {
        let key = |n: &str| n.to_ascii_lowercase().replace(['_', '-'], "");
        NAMES.iter().find(|(_, n)| key(n) == key(s)).map(|n| n.0)
    }
    /// Whether the statistic is of errors after the fit (which a fit on
    /// too few targets takes up), not of pair distances or counts.
    fn from_fit(self) -> bool {
        !matches!(
            self,
            Statistic::ERel | Statistic::MaxRel | Statistic::ScalePpm | Statistic::Found
        )
    }
    fn unit(self) -> Unit {
        match self {
            Statistic::ScalePpm => Unit::Ppm,
            Statistic::Found => Unit::Fraction,
            _ => Unit::Metres,
        }
    }
    /// The statistic's value in `r`, and its 95 % interval when the result
    /// has one; `Err` says why it is not there.
    pub fn read(self, r: &ResultFile) -> std::result::Result<(f64, Option<[f64; 2]>), String> {
        let a = &r.asprs;
        let folded = a.survey_sigma_h.is_some();
        let rmse_h_ci = (!folded)
            .then(|| envelope(&[a.ci95_measurement, a.ci95_targets]))
            .flatten();
        let heights = "not computed: the alignment does not fit heights (use rigid2d+z or rigid3d)";
        Ok(match self {
            Statistic::EAbs => (
                r.absolute.mean,
                envelope(&[
                    r.absolute.ci95_measurement.flatten(),
                    r.absolute.ci95_targets.flatten(),
                ]),
            ),
            Statistic::ERel => (
                r.relative.mean,
                envelope(&[r.relative.ci95_measurement, r.relative.ci95_targets]),
            ),
            Statistic::MaxAbs => (r.absolute.max, None),
            Statistic::MedianAbs => (r.absolute.median, None),
            Statistic::MaxRel => (r.relative.max, None),
            Statistic::ELoo => match &r.leave_one_out {
                Some(h) => (h.summary.mean, None),
                None => {
                    return Err("not computed: leave-one-out needs 3 or more scored targets".into());
                }
            },
            Statistic::RmseH => (a.rmse_h, rmse_h_ci),
            Statistic::RmseV => (a.rmse_v.ok_or(heights)?, None),
            Statistic::Rmse3d => (a.rmse_3d.ok_or(heights)?, None),
            Statistic::NssdaH => (
                a.nssda_horizontal_95,
                rmse_h_ci.map(|[lo, hi]| [lo * NSSDA_H, hi * NSSDA_H]),
            ),
            Statistic::NssdaV => (a.nssda_vertical_95.ok_or(heights)?, None),
            Statistic::ScalePpm => match &r.scale {
                Some(s) => {
                    let [lo, hi] = s.ci95_ppm;
                    let abs_lo = if lo <= 0.0 && hi >= 0.0 {
                        0.0
                    } else {
                        lo.abs().min(hi.abs())
                    };
                    (s.ppm.abs(), Some([abs_lo, lo.abs().max(hi.abs())]))
                }
                None => return Err("not computed: the scale needs 3 or more targets".into()),
            },
            Statistic::Found => {
                let (found, _) = r.found();
                (found as f64 / r.targets.len().max(1) as f64, None)
            }
        })
    }
}

/// NSSDA's horizontal factor (RMSE_H to 95 %, circular errors).
const NSSDA_H: f64 = 1.7308;

/// The widest interval of those given: both kinds of doubt together.
fn envelope(cis: &[Option<[f64; 2]>]) -> Option<[f64; 2]> {
    cis.iter()
        .flatten()
        .copied()
        .reduce(|a, b| [a[0].min(b[0]), a[1].max(b[1])])
}

/// A gate's comparison.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Op {
    /// `<=`
    Le,
    /// `<`
    Lt,
    /// `>=`
    Ge,
    /// `>`
    Gt,
}

impl Op {
    /// As written: `<=`, `<`, `>=`, `>`.
    pub fn symbol(self) -> &'static str {
        match self {
            Op::Le => "<=",
            Op::Lt => "<",
            Op::Ge => ">=",
            Op::Gt => ">",
        }
    }
    fn holds(self, v: f64, t: f64) -> bool {
        match self {
            Op::Le => v <= t,
            Op::Lt => v < t,
            Op::Ge => v >= t,
            Op::Gt => v > t,
        }
    }
    /// The interval's end that must meet the threshold for a pass: the
    /// upper for an upper bound, the lower for a lower bound.
    fn unlucky(self, [lo, hi]: [f64; 2]) -> (f64, f64) {
        match self {
            Op::Le | Op::Lt => (hi, lo),
            Op::Ge | Op::Gt => (lo, hi),
        }
    }
}

/// A quality gate: a statistic, a comparison and a threshold (metres for
/// lengths, ppm for the scale, a fraction for `found`).
#[derive(Debug, Clone, PartialEq)]
pub struct Gate {
    /// The statistic held to the threshold.
    pub statistic: Statistic,
    /// The comparison.
    pub op: Op,
    /// The threshold, in the statistic's unit (m, ppm, fraction).
    pub threshold: f64,
}

/// What a gate says of a result.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Verdict {
    /// Met by the whole 95 % interval (or by the value, without one).
    Pass,
    /// Missed by the whole interval (or by the value).
    Fail,
    /// The interval straddles the threshold, or the statistic was not computed.
    Undecided,
}

impl Verdict {
    /// `pass`, `fail`, `undecided`.
    pub fn word(self) -> &'static str {
        match self {
            Verdict::Pass => "pass",
            Verdict::Fail => "fail",
            Verdict::Undecided => "undecided",
        }
    }
}

impl Gate {
    /// The uncertainty-aware verdict on a value and its 95 % interval; with
    /// no interval, on the value; with no value, undecided.
    pub fn verdict(&self, value: Option<f64>, ci95: Option<[f64; 2]>) -> Verdict {
        let Some(v) = value else {
            return Verdict::Undecided;
        };
        let ci = ci95.map_or([v, v], |[lo, hi]| [lo.min(v), hi.max(v)]);
        let (unlucky, lucky) = self.op.unlucky(ci);
        if self.op.holds(unlucky, self.threshold) {
            Verdict::Pass
        } else if !self.op.holds(lucky, self.threshold) {
            Verdict::Fail
        } else {
            Verdict::Undecided
        }
    }
    /// The gate judged on `r`.
    pub fn judge(&self, r: &ResultFile) -> GateVerdict {
        let read = self.statistic.read(r);
        let (value, ci95, note) = match read {
            Ok((v, ci)) => (Some(v), ci, None),
            Err(why) => (None, None, Some(why)),
        };
        let mut verdict = self.verdict(value, ci95);
        // A fit on fewer targets than an interval needs takes up the map's
        // error (two targets under rigid2d leave one coordinate of doubt):
        // its errors pass any threshold, so they are not judged.
        // Only a pass is in doubt (a fit can only make errors smaller), and
        // only for what a fit makes: pair distances and `found` take none.
        let scored = r.absolute.n;
        let too_few = self.statistic.from_fit()
            && matches!(self.op, Op::Le | Op::Lt)
            && r.alignment.method != "none"
            && value.is_some_and(|v| self.op.holds(v, self.threshold))
            && scored < crate::accuracy::intervals::MIN_TARGETS;
        let note = if too_few {
            verdict = Verdict::Undecided;
            Some(format!(
                "not judged: only {scored} target(s) scored, and a fit on so few takes up the map's error (4 or more)"
            ))
        } else {
            note
        };
        GateVerdict {
            gate: self.to_string(),
            statistic: self.statistic.name().to_string(),
            op: self.op.symbol().to_string(),
            threshold: self.threshold,
            value,
            ci95,
            basis: match (value, ci95) {
                _ if too_few => "too_few",
                (None, _) => "missing",
                (Some(_), Some(_)) => "ci95",
                (Some(_), None) => "value",
            }
            .to_string(),
            verdict,
            on_value: value.map(|v| {
                if self.op.holds(v, self.threshold) {
                    Verdict::Pass
                } else {
                    Verdict::Fail
                }
            }),
            note,
        }
    }
}

impl fmt::Display for Gate {
    /// `E_abs<=0.05`: the canonical form (metres, ppm, fraction).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}{}{}",
            self.statistic.name(),
            self.op.symbol(),
            self.threshold
        )
    }
}

impl FromStr for Gate {
    type Err = Error;
    /// `STAT OP NUMBER[UNIT]`: `E_abs<=0.05`, `max_abs < 10cm`, `found>=90%`,
    /// `scale_ppm<=200`. Lengths take `m` (the default), `cm` or `mm`.
    fn from_str(s: &str) -> Result<Gate> {
        let bad = |why: &str| {
            Error::Param(format!(
                "gate `{s}`: {why} (write STATISTIC OP NUMBER, e.g. `E_abs<=0.05`, `max_abs<10cm`, `found>=0.9`; statistics: {})",
                NAMES.map(|n| n.1).join(", ")
            ))
        };
        let at = s
            .find(['<', '>'])
            .ok_or_else(|| bad("no comparison (<=, <, >=, >)"))?;
        let (name, rest) = s.split_at(at);
        let (op, number) = match rest.get(..2) {
            Some("<=") => (Op::Le, &rest[2..]),
            Some(">=") => (Op::Ge, &rest[2..]),
            _ if rest.starts_with('<') => (Op::Lt, &rest[1..]),
            _ => (Op::Gt, &rest[1..]),
        };
        if name.trim_end().ends_with(['=', '!']) {
            return Err(bad("the comparison is written `<=`, `<`, `>=` or `>`"));
        }
        let statistic = Statistic::parse(name.trim()).ok_or_else(|| bad("unknown statistic"))?;
        let threshold = threshold(number.trim(), statistic.unit()).map_err(|w| bad(&w))?;
        Ok(Gate {
            statistic,
            op,
            threshold,
        })
    }
}

/// A threshold in the statistic's unit from `0.05`, `1e-2`, `5cm`, `50 mm`,
/// `90%`. Scaled by division, so `95%` is exactly 95/100 (the value `found`
/// takes with 19 of 20): a product like 95 × 0.01 lands one bit above it.
fn threshold(s: &str, unit: Unit) -> std::result::Result<f64, String> {
    let units: &[(&str, f64)] = match unit {
        Unit::Metres => &[("mm", 1000.0), ("cm", 100.0), ("m", 1.0)],
        Unit::Ppm => &[("ppm", 1.0)],
        Unit::Fraction => &[("%", 100.0)],
    };
    let given = units
        .iter()
        .find_map(|(u, d)| s.strip_suffix(u).map(|n| (n, *d)));
    let (num, div) = given.unwrap_or((s, 1.0));
    let v: f64 = num.trim().parse().map_err(|_| {
        if num
            .trim()
            .ends_with(|c: char| c.is_ascii_alphabetic() || c == '%')
        {
            format!("`{s}`: not a number with a unit this statistic takes")
        } else {
            format!("`{}` is not a number", num.trim())
        }
    })?;
    let t = v / div;
    if !t.is_finite() || t < 0.0 {
        return Err("the threshold must be a finite number ≥ 0".into());
    }
    // `E_abs<=5` is a 5 m gate every map passes: a unit was meant (1 m and
    // under are read as written).
    if unit == Unit::Metres && given.is_none() && t > 1.0 {
        return Err(format!(
            "`{s}` would be {t} m: give its unit (`{s}cm`, `{s}mm`, or `{s}m` if metres are meant)"
        ));
    }
    if unit == Unit::Fraction && t > 1.0 {
        return Err("`found` is a fraction of the surveyed targets, 0–1 (or 0–100 %)".into());
    }
    Ok(t)
}

impl Serialize for Gate {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.serialize_str(&self.to_string())
    }
}

impl<'de> Deserialize<'de> for Gate {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Gate, D::Error> {
        let s = String::deserialize(d)?;
        s.parse().map_err(serde::de::Error::custom)
    }
}

/// One gate's verdict as `result.json` holds it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GateVerdict {
    /// The gate, canonical (`E_abs<=0.05`).
    pub gate: String,
    /// Statistic name.
    pub statistic: String,
    /// `<=`, `<`, `>=` or `>`.
    pub op: String,
    /// Threshold (m, ppm or fraction).
    pub threshold: f64,
    /// The statistic's value; `null` when not computed.
    pub value: Option<f64>,
    /// Its 95 % interval (both kinds together); `null` when it has none.
    pub ci95: Option<[f64; 2]>,
    /// What the verdict rests on: `ci95`, `value` (no interval) or `missing`.
    pub basis: String,
    /// `pass`, `fail` or `undecided`.
    pub verdict: Verdict,
    /// The verdict on the value alone (what `--gate-policy point` uses);
    /// `null` when the statistic was not computed.
    pub on_value: Option<Verdict>,
    /// Why the statistic is missing.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

/// What failed and undecided gates do to a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Policy {
    /// A failed gate fails the run (exit 1); an undecided one too, with its own exit code (3).
    #[default]
    Strict,
    /// Each gate on its value alone, the interval ignored: a value that
    /// misses (or a statistic not computed) fails the run (exit 1).
    Point,
    /// Verdicts are written and printed; the exit code does not depend on them.
    ReportOnly,
}

impl Policy {
    /// `strict`, `point`, `report-only`.
    pub fn name(self) -> &'static str {
        match self {
            Policy::Strict => "strict",
            Policy::Point => "point",
            Policy::ReportOnly => "report-only",
        }
    }
}

/// The run's verdict over all its gates under a policy.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Outcome {
    /// Every gate passed (or the policy reports only).
    Pass,
    /// A gate failed.
    Fail,
    /// No gate failed and one or more were undecided (strict).
    Undecided,
}

impl Outcome {
    /// The process exit code: 0 pass, 1 fail, 3 undecided.
    pub fn exit_code(self) -> u8 {
        match self {
            Outcome::Pass => 0,
            Outcome::Fail => 1,
            Outcome::Undecided => 3,
        }
    }
}

/// What the gates decided, as `result.json`'s `gate_outcome` holds it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct GateOutcome {
    /// The policy the outcome was decided under.
    pub policy: Policy,
    /// The run's outcome under it.
    pub outcome: Outcome,
    /// The exit code `mapgauge` gives it (0 pass, 1 fail, 3 undecided).
    pub exit_code: u8,
    /// Gates that passed, failed and were undecided (the verdicts with
    /// their intervals, whatever the policy).
    pub counts: [usize; 3],
}

/// Judges every gate on `r`, decides the outcome under `policy`, and
/// records both in `r` (`gates`, `gate_outcome`). No gates, no change.
pub fn judge(gates: &[Gate], policy: Policy, r: &mut ResultFile) -> Option<GateOutcome> {
    if gates.is_empty() {
        return None;
    }
    let verdicts: Vec<GateVerdict> = gates.iter().map(|g| g.judge(r)).collect();
    let n = |w: Verdict| verdicts.iter().filter(|v| v.verdict == w).count();
    let counts = [n(Verdict::Pass), n(Verdict::Fail), n(Verdict::Undecided)];
    let outcome = match policy {
        Policy::ReportOnly => Outcome::Pass,
        Policy::Point if verdicts.iter().all(|v| v.on_value == Some(Verdict::Pass)) => {
            Outcome::Pass
        }
        Policy::Point => Outcome::Fail,
        Policy::Strict if counts[1] > 0 => Outcome::Fail,
        Policy::Strict if counts[2] > 0 => Outcome::Undecided,
        Policy::Strict => Outcome::Pass,
    };
    let o = GateOutcome {
        policy,
        outcome,
        exit_code: outcome.exit_code(),
        counts,
    };
    r.gates = verdicts;
    r.gate_outcome = Some(o);
    Some(o)
}

/// The gates section of the TOML configuration:
///
/// ```toml
/// [gates]
/// policy = "strict"
/// checks = ["E_abs<=0.05", "max_abs<=0.10", "found>=0.9"]
/// ```
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GateConfig {
    /// What failed and undecided gates do (`strict`, `point`, `report-only`).
    pub policy: Policy,
    /// The gates; `--gate` flags replace them.
    pub checks: Vec<Gate>,
}

#[cfg(test)]
pub(crate) mod tests;
