//! The gates' verdicts as people read them (the terminal summary's first
//! lines, stderr, the report's header) and as CI reads them (JUnit XML).

use super::numbers::{fixed, mm};
use crate::gate::{GateVerdict, Outcome, Policy, Verdict};
use crate::record::ResultFile;
use std::fmt::Write as _;

/// A value of a gate's statistic in its reading unit: mm, ppm or %.
fn amount(statistic: &str, v: f64) -> String {
    match statistic {
        "found" => format!("{} %", fixed(v * 100.0, 0)),
        "scale_ppm" => format!("{} ppm", fixed(v, 0)),
        _ => format!("{} mm", mm(v)),
    }
}

/// The interval in the same unit, `[lo, hi]`.
fn interval(statistic: &str, [lo, hi]: [f64; 2]) -> String {
    match statistic {
        "found" => format!("[{}, {}] %", fixed(lo * 100.0, 0), fixed(hi * 100.0, 0)),
        "scale_ppm" => format!("[{}, {}] ppm", fixed(lo, 0), fixed(hi, 0)),
        _ => format!("[{}, {}] mm", mm(lo), mm(hi)),
    }
}

/// What one gate saw: `18.8 mm, 95 % [14.1, 23.5] mm`.
pub(crate) fn evidence(v: &GateVerdict) -> String {
    match (v.value, v.ci95) {
        (None, _) => v.note.clone().unwrap_or_else(|| "not computed".into()),
        (Some(x), _) if v.basis == "too_few" => format!(
            "{} ({})",
            amount(&v.statistic, x),
            v.note.as_deref().unwrap_or("too few targets")
        ),
        (Some(x), Some(ci)) => format!(
            "{}, 95 % {}",
            amount(&v.statistic, x),
            interval(&v.statistic, ci)
        ),
        (Some(x), None) => format!(
            "{} (no interval: judged on the value)",
            amount(&v.statistic, x)
        ),
    }
}

/// The headline of the gates: `gates (strict): FAIL, exit 1 — 1 passed, …`.
pub(crate) fn headline(r: &ResultFile) -> Option<String> {
    let o = r.gate_outcome?;
    let word = match (o.policy, o.outcome) {
        (Policy::ReportOnly, _) => "REPORTED",
        (_, Outcome::Pass) => "PASS",
        (_, Outcome::Fail) => "FAIL",
        (_, Outcome::Undecided) => "UNDECIDED",
    };
    let [p, f, u] = o.counts;
    Some(format!(
        "gates ({}): {word}, exit {} — {p} passed, {f} failed, {u} undecided",
        o.policy.name(),
        o.exit_code
    ))
}

/// The gates' lines, the headline first and one per gate (none without
/// gates): what the terminal summary opens with.
pub fn gate_lines(r: &ResultFile) -> Vec<String> {
    let Some(head) = headline(r) else {
        return Vec::new();
    };
    let width = r.gates.iter().map(|g| g.gate.len()).max().unwrap_or(0);
    let point = r.gate_outcome.is_some_and(|o| o.policy == Policy::Point);
    let mut out = vec![head];
    for g in &r.gates {
        let mut line = format!(
            "  {:<9}  {:<width$}  {}",
            g.verdict.word(),
            g.gate,
            evidence(g)
        );
        if g.verdict == Verdict::Undecided
            && let Some(on) = g.on_value
        {
            let _ = write!(
                line,
                "; on its value alone it would {}{}",
                on.word(),
                if point {
                    " (--gate-policy point: it does)"
                } else {
                    ""
                }
            );
        }
        out.push(line);
    }
    out
}

/// `s` safe inside XML text and attributes: HTML's escaping, and the
/// characters XML 1.0 forbids (control characters but tab and line ends,
/// U+FFFE, U+FFFF) as spaces.
fn xml(s: &str) -> String {
    let clean: String = s
        .chars()
        .map(|c| {
            let banned = (c.is_control() && !matches!(c, '\t' | '\n' | '\r'))
                || matches!(c, '\u{FFFE}' | '\u{FFFF}');
            if banned { ' ' } else { c }
        })
        .collect();
    super::escape(&clean)
}

/// One JUnit test case: passed (`None`), failed or skipped with a message.
enum Case {
    Pass(String),
    Fail(String),
    Skip(String),
}

/// A `<testsuite>` of `cases` (name, class, outcome).
fn suite(o: &mut String, name: &str, cases: &[(String, Case)]) {
    let fails = cases
        .iter()
        .filter(|c| matches!(c.1, Case::Fail(_)))
        .count();
    let skips = cases
        .iter()
        .filter(|c| matches!(c.1, Case::Skip(_)))
        .count();
    let _ = writeln!(
        o,
        "  <testsuite name=\"{}\" tests=\"{}\" failures=\"{fails}\" errors=\"0\" skipped=\"{skips}\">",
        xml(name),
        cases.len()
    );
    for (case, outcome) in cases {
        let _ = write!(
            o,
            "    <testcase classname=\"{}\" name=\"{}\" time=\"0\">",
            xml(name),
            xml(case)
        );
        match outcome {
            Case::Pass(out) => {
                let _ = write!(o, "<system-out>{}</system-out>", xml(out));
            }
            Case::Fail(msg) => {
                let _ = write!(o, "<failure message=\"{0}\">{0}</failure>", xml(msg));
            }
            Case::Skip(msg) => {
                let _ = write!(o, "<skipped message=\"{}\"/>", xml(msg));
            }
        }
        o.push_str("</testcase>\n");
    }
    o.push_str("  </testsuite>\n");
}

/// The result as JUnit XML, for CI test reports: a suite of the gates (a
/// gate fails as its policy makes it fail the run; under `report-only` its
/// verdict is a skip message) and a suite of the targets (a target not
/// found, set aside or mapped twice fails with its reason).
pub fn junit_xml(r: &ResultFile, name: &str) -> String {
    let policy = r.gate_outcome.map(|o| o.policy).unwrap_or_default();
    let gates: Vec<(String, Case)> = r
        .gates
        .iter()
        .map(|g| {
            let said = format!("{}: {}", g.verdict.word(), evidence(g));
            let fails = match policy {
                Policy::Strict => g.verdict != Verdict::Pass,
                Policy::Point => g.on_value != Some(Verdict::Pass),
                Policy::ReportOnly => false,
            };
            let case = if policy == Policy::ReportOnly && g.verdict != Verdict::Pass {
                Case::Skip(format!("report only: {said}"))
            } else if fails {
                Case::Fail(said)
            } else {
                Case::Pass(said)
            };
            (g.gate.clone(), case)
        })
        .collect();
    let targets: Vec<(String, Case)> = r
        .targets
        .iter()
        .map(|t| {
            let case = if t.status == "ok" {
                Case::Pass(match t.abs_error {
                    Some(e) => format!("located; absolute error {} mm", mm(e)),
                    None => "located".into(),
                })
            } else {
                Case::Fail(format!(
                    "{}: {}",
                    t.status,
                    t.reason.as_deref().unwrap_or("no reason given")
                ))
            };
            (format!("target {}", t.id), case)
        })
        .collect();
    let mut o = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    let n = gates.len() + targets.len();
    let fails = gates
        .iter()
        .chain(&targets)
        .filter(|c| matches!(c.1, Case::Fail(_)))
        .count();
    let _ = writeln!(
        o,
        "<testsuites name=\"{}\" tests=\"{n}\" failures=\"{fails}\" errors=\"0\">",
        xml(name)
    );
    if !gates.is_empty() {
        suite(&mut o, &format!("{name}: gates"), &gates);
    }
    suite(&mut o, &format!("{name}: targets"), &targets);
    o.push_str("</testsuites>\n");
    o
}

/// JUnit XML for a run that could not produce a result: one test case in
/// error with the reason, so a CI test report shows why rather than nothing.
pub fn junit_error(name: &str, error: &str) -> String {
    format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<testsuites name=\"{0}\" tests=\"1\" failures=\"0\" errors=\"1\">\n  <testsuite name=\"{0}\" tests=\"1\" failures=\"0\" errors=\"1\" skipped=\"0\">\n    <testcase classname=\"{0}\" name=\"evaluation\" time=\"0\"><error message=\"{1}\">{1}</error></testcase>\n  </testsuite>\n</testsuites>\n",
        xml(name),
        xml(error)
    )
}

#[cfg(test)]
mod tests;
