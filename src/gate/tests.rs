use super::*;
use crate::Point;
use crate::accuracy::{ScoreOptions, score};
use crate::survey::{Estimate, Survey};

fn gate(s: &str) -> Gate {
    s.parse().unwrap_or_else(|e| panic!("{s}: {e}"))
}

#[test]
fn parses_names_ops_and_units() {
    let g = gate("E_abs<=0.05");
    assert_eq!(
        (g.statistic, g.op, g.threshold),
        (Statistic::EAbs, Op::Le, 0.05)
    );
    let g = gate(" max_abs < 10cm ");
    assert_eq!((g.statistic, g.op), (Statistic::MaxAbs, Op::Lt));
    assert!((g.threshold - 0.10).abs() < 1e-12);
    assert!((gate("rmse_h<=25 mm").threshold - 0.025).abs() < 1e-12);
    assert_eq!(gate("FOUND>=90%").threshold, 0.9);
    assert_eq!(gate("found>0.5").op, Op::Gt);
    assert_eq!(gate("scale_ppm<=200ppm").threshold, 200.0);
    // Exactly the fraction a count gives: 19 of 20 meets 95 %, 7 of 10 meets 70 %.
    assert_eq!(gate("found>=95%").threshold, 19.0 / 20.0);
    assert_eq!(gate("found>=70%").threshold, 7.0 / 10.0);
    assert_eq!(
        gate("found>=95%").verdict(Some(19.0 / 20.0), None),
        Verdict::Pass
    );
    assert_eq!(gate("max_abs<=57cm").threshold, 0.57);
    assert_eq!(gate("E_abs<=1e-2").threshold, 0.01);
    assert_eq!(gate("found>=95%").to_string(), "found>=0.95");
    assert_eq!(gate("E_abs<=0.05").to_string(), "E_abs<=0.05");
    // The canonical form reads back as the same gate.
    let g = gate("nssda_h <= 4cm");
    assert_eq!(gate(&g.to_string()), g);
}

#[test]
fn refuses_what_it_cannot_read() {
    for bad in [
        "E_abs=0.05",
        "E_abs<=",
        "E_abs<=abc",
        "E_abs<=-1",
        "E_abs<=5%",
        "found>=1.5",
        "found>=0.9cm",
        "speed<=3",
        "E_abs<=NaN",
    ] {
        let e = bad.parse::<Gate>().expect_err(bad).to_string();
        assert!(e.contains(bad) && e.contains("E_abs<=0.05"), "{bad}: {e}");
    }
    // A new user's slips: the operator written backwards, a length
    // without its unit that would be metres (a 5 m gate every map passes).
    let e = "E_abs=<5cm".parse::<Gate>().unwrap_err().to_string();
    assert!(e.contains("the comparison is written `<=`"), "{e}");
    let e = "E_abs<=5".parse::<Gate>().unwrap_err().to_string();
    assert!(e.contains("would be 5 m: give its unit"), "{e}");
    assert_eq!(gate("E_abs<=5m").threshold, 5.0);
    assert_eq!(gate("E_abs<=0.5").threshold, 0.5);
}

/// A fit on two or three targets takes up the map's error: a strict gate
/// on its errors passed at 3 mm where the map was 20 mm off. Undecided,
/// saying why; `found` is still judged.
#[test]
fn a_result_of_too_few_targets_is_not_judged() {
    let truth = [(0.0, 0.0), (50.0, 5.0), (100.0, -3.0)];
    let survey = Survey::local(&truth.map(|(x, y)| (x, y, 0.0)), false);
    let estimates: Vec<Estimate> = truth
        .iter()
        .enumerate()
        .map(|(i, &(x, y))| {
            Estimate::found(
                format!("t{}", i + 1),
                Point::new(x + 0.02, y - 0.01 * i as f64, 0.0),
            )
        })
        .collect();
    let acc = score(&survey, &estimates, &ScoreOptions::default()).expect("score");
    let mut r = ResultFile::from_accuracy(&acc, &survey);
    let gates = [
        gate("E_abs<=5cm"),
        gate("max_abs<=5cm"),
        gate("found>=1"),
        gate("E_abs<=0.1mm"),
        gate("max_rel<=5cm"),
    ];
    let o = judge(&gates, Policy::Strict, &mut r).expect("gates");
    let words: Vec<&str> = r.gates.iter().map(|v| v.verdict.word()).collect();
    // A miss stays a fail (a fit only makes errors smaller); pair
    // distances take no fit.
    assert_eq!(words, ["undecided", "undecided", "pass", "fail", "pass"]);
    assert_eq!(r.gates[0].basis, "too_few");
    assert!(
        r.gates[0]
            .note
            .as_deref()
            .is_some_and(|n| n.contains("only 3 target(s) scored"))
    );
    assert_eq!(o.exit_code, 1);
    assert_eq!(
        judge(&gates[..3], Policy::Strict, &mut r).map(|o| o.exit_code),
        Some(3)
    );
    // On its values, as the point policy asks.
    assert_eq!(
        judge(&gates[..3], Policy::Point, &mut r).map(|o| o.exit_code),
        Some(0)
    );
}

#[test]
fn the_whole_interval_decides() {
    let le = gate("E_abs<=0.02");
    let ci = Some([0.012, 0.026]);
    assert_eq!(le.verdict(Some(0.018), ci), Verdict::Undecided);
    assert_eq!(le.verdict(Some(0.018), Some([0.015, 0.019])), Verdict::Pass);
    assert_eq!(le.verdict(Some(0.024), Some([0.021, 0.03])), Verdict::Fail);
    // No interval: the value decides; no value: undecided.
    assert_eq!(le.verdict(Some(0.019), None), Verdict::Pass);
    assert_eq!(le.verdict(Some(0.021), None), Verdict::Fail);
    assert_eq!(le.verdict(None, None), Verdict::Undecided);
    // A lower bound looks at the other end.
    let ge = gate("found>=0.5");
    assert_eq!(ge.verdict(Some(0.6), Some([0.55, 0.7])), Verdict::Pass);
    assert_eq!(ge.verdict(Some(0.6), Some([0.45, 0.7])), Verdict::Undecided);
    assert_eq!(ge.verdict(Some(0.4), Some([0.3, 0.45])), Verdict::Fail);
    // Strict comparisons at the threshold itself.
    assert_eq!(gate("E_abs<0.02").verdict(Some(0.02), None), Verdict::Fail);
    assert_eq!(gate("E_abs<=0.02").verdict(Some(0.02), None), Verdict::Pass);
    // An interval that does not hold its value is widened to hold it.
    assert_eq!(
        le.verdict(Some(0.021), Some([0.01, 0.019])),
        Verdict::Undecided
    );
}

/// Six targets 30–60 m apart, the map off by a few millimetres each.
pub(crate) fn result() -> ResultFile {
    let truth = [
        (0.0, 0.0),
        (30.0, 0.0),
        (30.0, 40.0),
        (0.0, 40.0),
        (15.0, 60.0),
        (50.0, 20.0),
    ];
    let off = [
        (3.0, -2.0),
        (-4.0, 1.0),
        (2.0, 5.0),
        (-1.0, -3.0),
        (6.0, 0.0),
        (-2.0, 2.0),
    ];
    let survey = Survey::local(&truth.map(|(x, y)| (x, y, 0.0)), false);
    let estimates: Vec<Estimate> = truth
        .iter()
        .zip(off)
        .enumerate()
        .map(|(i, (&(x, y), (dx, dy)))| {
            Estimate::found(
                format!("t{}", i + 1),
                Point::new(x + dx / 1e3, y + dy / 1e3, 0.0),
            )
        })
        .collect();
    let acc = score(&survey, &estimates, &ScoreOptions::default()).expect("score");
    ResultFile::from_accuracy(&acc, &survey)
}

#[test]
fn judges_a_result_and_records_the_verdicts() {
    let mut r = result();
    let ci = r
        .absolute
        .ci95_targets
        .flatten()
        .expect("a bootstrap interval with 6 targets");
    let e = r.absolute.mean;
    assert!(ci[0] < e && e < ci[1], "{ci:?} {e}");
    let gates = [
        gate(&format!("E_abs<={}", ci[1] * 1.01)),
        gate(&format!("E_abs<={}", ci[0] * 0.99)),
        gate(&format!("E_abs<={}", e * 1.001)),
        gate("found>=1"),
        gate("RMSE_V<=0.01"),
    ];
    let o = judge(&gates, Policy::Strict, &mut r).expect("gates");
    let words: Vec<&str> = r.gates.iter().map(|v| v.verdict.word()).collect();
    assert_eq!(words, ["pass", "fail", "undecided", "pass", "undecided"]);
    assert_eq!(r.gates[2].on_value, Some(Verdict::Pass));
    assert_eq!(r.gates[3].basis, "value");
    assert_eq!(r.gates[0].basis, "ci95");
    assert!(
        r.gates[4]
            .note
            .as_deref()
            .is_some_and(|n| n.contains("heights"))
    );
    assert_eq!(
        (o.outcome, o.exit_code, o.counts),
        (Outcome::Fail, 1, [2, 1, 2])
    );
    // The same gates under the other policies.
    assert_eq!(
        judge(&gates, Policy::Point, &mut r).map(|o| o.outcome),
        Some(Outcome::Fail)
    );
    assert_eq!(
        judge(&gates[2..4], Policy::Point, &mut r).map(|o| o.outcome),
        Some(Outcome::Pass)
    );
    assert_eq!(
        judge(&gates[2..4], Policy::Strict, &mut r).map(|o| o.exit_code),
        Some(3)
    );
    assert_eq!(
        judge(&gates, Policy::ReportOnly, &mut r).map(|o| o.exit_code),
        Some(0)
    );
    // They travel through result.json.
    let back: ResultFile = serde_json::from_str(&r.to_json()).expect("read back");
    assert_eq!(back.gates, r.gates);
    assert_eq!(back.gate_outcome, r.gate_outcome);
    // No gates: nothing recorded, and result.json as before.
    let mut plain = result();
    assert!(judge(&[], Policy::Strict, &mut plain).is_none());
    assert!(!plain.to_json().contains("gate"));
}

#[test]
fn the_config_table_reads_its_gates() {
    let c: GateConfig =
        toml::from_str("policy = \"report-only\"\nchecks = [\"E_abs<=5cm\", \"found>=0.9\"]")
            .expect("toml");
    assert_eq!(c.policy, Policy::ReportOnly);
    assert_eq!(c.checks, [gate("E_abs<=0.05"), gate("found>=0.9")]);
    let e = toml::from_str::<GateConfig>("checks = [\"E_abs=5\"]").expect_err("bad gate");
    assert!(e.to_string().contains("E_abs=5"), "{e}");
}
