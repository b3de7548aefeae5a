use super::*;
use crate::gate::{Gate, GateVerdict};

fn verdict(
    gate: &str,
    value: Option<f64>,
    ci95: Option<[f64; 2]>,
    verdict: Verdict,
) -> GateVerdict {
    let g: Gate = gate.parse().expect("gate");
    GateVerdict {
        gate: g.to_string(),
        statistic: g.statistic.name().into(),
        op: g.op.symbol().into(),
        threshold: g.threshold,
        value,
        ci95,
        basis: if ci95.is_some() { "ci95" } else { "value" }.into(),
        verdict,
        on_value: value.map(|_| Verdict::Pass),
        note: None,
    }
}

#[test]
fn xml_text_is_escaped_and_control_characters_dropped() {
    assert_eq!(
        xml("a<b & \"c\" 'd'>"),
        "a&lt;b &amp; &quot;c&quot; &#39;d&#39;&gt;"
    );
    assert_eq!(xml("x\u{1}y\tz\u{FFFF}"), "x y\tz ");
}

#[test]
fn evidence_speaks_in_the_statistics_units() {
    let v = verdict(
        "E_abs<=0.02",
        Some(0.0188),
        Some([0.0141, 0.0235]),
        Verdict::Undecided,
    );
    assert_eq!(evidence(&v), "18.8 mm, 95 % [14.1, 23.5] mm");
    let v = verdict("found>=0.9", Some(0.8), None, Verdict::Fail);
    assert_eq!(evidence(&v), "80 % (no interval: judged on the value)");
    let v = verdict(
        "scale_ppm<=200",
        Some(493.4),
        Some([279.0, 707.0]),
        Verdict::Fail,
    );
    assert_eq!(evidence(&v), "493 ppm, 95 % [279, 707] ppm");
}

#[test]
fn junit_counts_what_fails_under_each_policy() {
    use crate::gate::{GateOutcome, Outcome};
    let gates = vec![
        verdict("E_abs<=0.05", Some(0.02), Some([0.01, 0.03]), Verdict::Pass),
        verdict(
            "E_abs<=0.02",
            Some(0.019),
            Some([0.01, 0.03]),
            Verdict::Undecided,
        ),
    ];
    let xml_of = |policy| {
        let mut r = crate::gate::tests::result();
        r.gates = gates.clone();
        r.gate_outcome = Some(GateOutcome {
            policy,
            outcome: Outcome::Pass,
            exit_code: 0,
            counts: [1, 0, 1],
        });
        junit_xml(&r, "run")
    };
    let strict = xml_of(Policy::Strict);
    assert!(
        strict.contains("name=\"run: gates\" tests=\"2\" failures=\"1\""),
        "{strict}"
    );
    assert!(
        strict.contains("<failure message=\"undecided: 19.0 mm, 95 % [10.0, 30.0] mm\">"),
        "{strict}"
    );
    // On its value the undecided gate passes: `point` fails nothing.
    let point = xml_of(Policy::Point);
    assert!(
        point.contains("name=\"run: gates\" tests=\"2\" failures=\"0\""),
        "{point}"
    );
    let report = xml_of(Policy::ReportOnly);
    assert!(
        report.contains("skipped=\"1\"")
            && report.contains("<skipped message=\"report only: undecided"),
        "{report}"
    );
}
