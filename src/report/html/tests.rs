use super::super::{Provenance, Report};
use super::*;
use crate::Point;
use crate::accuracy::Dim;
use crate::accuracy::{ScoreOptions, score};
use crate::survey::{Estimate, EstimateStatus, Survey, SurveyFrame, SurveyTarget};

/// A result with 4 targets at tens of metres, the fourth not found.
pub(crate) fn result(ids: &[&str]) -> crate::record::ResultFile {
    let pos = [(0.0, 0.0), (30.0, 1.0), (12.0, 25.0), (-14.0, 18.0)];
    let targets: Vec<SurveyTarget> = ids
        .iter()
        .zip(pos)
        .enumerate()
        .map(|(i, (id, p))| SurveyTarget {
            id: id.to_string(),
            position: Point::new(p.0, p.1, 0.0),
            has_z: false,
            role: None,
            antenna_height: 0.0,
            model: Default::default(),
            size: None,
            line: i as u64 + 2,
        })
        .collect();
    let survey = Survey {
        targets,
        frame: SurveyFrame::Local,
        origin: None,
        exchanged: None,
    };
    let est: Vec<Estimate> = survey
        .targets
        .iter()
        .enumerate()
        .map(|(i, t)| Estimate {
            id: t.id.clone(),
            status: if i == 3 {
                EstimateStatus::NotFound {
                    reason: "too few points <here> & there".into(),
                }
            } else {
                EstimateStatus::Found(
                    t.position + nalgebra::Vector3::new(0.01 * i as f64, -0.02, 0.0),
                )
            },
            has_z: false,
        })
        .collect();
    let opts = ScoreOptions {
        method: Default::default(),
        dim: Dim::D2,
        survey_sigma: None,
        vertical: None,
        threshold: None,
    };
    crate::record::ResultFile::from_accuracy(&score(&survey, &est, &opts).unwrap(), &survey)
}

#[test]
fn report_page_is_self_contained() {
    let r = result(&["<t&1>", "2", "3", "4"]);
    let mut prov = Provenance::new(Some(7), Some("[locate]\nseed = 7\n".into()));
    prov.date_utc = "2026-01-01 00:00:00 UTC".into();
    let rep = Report::from_result(&r, prov);
    let figs = rep.figures();
    assert_eq!(figs.len(), 3 + 4);
    let html = rep.html();
    // One panel per target, one figure each plus overview, relative and
    // the errors' CDF.
    assert_eq!(html.matches("<div class=\"target").count(), 4);
    assert_eq!(html.matches("<svg ").count(), 7);
    assert!(html.contains("<meta name=\"mapgauge-figures\" content=\"7\">"));
    assert_eq!(html.matches("class=\"target failed\"").count(), 1);
    // Ids and reasons are escaped everywhere.
    assert!(!html.contains("<t&1>"), "raw id in the page");
    assert!(html.contains("&lt;t&amp;1&gt;"));
    assert!(html.contains("too few points &lt;here&gt; &amp; there"));
    // No network: `http` appears only in SVG namespace declarations.
    let http = html.matches("http").count();
    let ns = html.matches("xmlns=\"http://www.w3.org/2000/svg\"").count();
    assert_eq!(http, ns, "external reference in the page");
    assert!(!html.contains("<script") && !html.contains("<link") && !html.contains("url("));
    crate::report::tests::check_xmlish(&html[html.find("<html").unwrap()..]);
    for f in &figs {
        crate::report::tests::check_xmlish(&svg::render(f));
    }
    assert!(html.contains("2026-01-01 00:00:00 UTC") && html.contains("seed = 7"));
}

/// Past 6 targets the paper's one-row tables (66 pair columns at 12)
/// give way to a pair matrix and a column, and the targets table to mm.
#[test]
fn many_targets_get_tables_that_fit() {
    let ids: Vec<String> = (1..=12).map(|i| i.to_string()).collect();
    let targets: Vec<SurveyTarget> = ids
        .iter()
        .enumerate()
        .map(|(i, id)| SurveyTarget {
            id: id.clone(),
            position: Point::new(10.0 * i as f64, (i % 3) as f64 * 7.0, 0.0),
            has_z: false,
            role: None,
            antenna_height: 0.0,
            model: Default::default(),
            size: None,
            line: i as u64 + 2,
        })
        .collect();
    let survey = Survey {
        targets,
        frame: SurveyFrame::Local,
        origin: None,
        exchanged: None,
    };
    let est: Vec<Estimate> = survey
        .targets
        .iter()
        .enumerate()
        .map(|(i, t)| Estimate {
            id: t.id.clone(),
            status: EstimateStatus::Found(
                t.position + nalgebra::Vector3::new(0.002 * (i % 4) as f64, 0.001, 0.0),
            ),
            has_z: false,
        })
        .collect();
    let r = crate::record::ResultFile::from_accuracy(
        &score(&survey, &est, &ScoreOptions::default()).unwrap(),
        &survey,
    );
    let rep = Report::from_result(&r, Provenance::new(None, None));
    let html = rep.html();
    let tables = &html[html.find("<section id=\"tables\">").unwrap()..];
    assert!(!tables.contains("t1 &amp; t2"), "no 66-column Table I");
    assert!(tables.contains("Relative error of every pair (mm, 2D)"));
    // The matrix: 11 rows (t1..t11) under a header t2..t12.
    let matrix = &tables[..tables.find("Absolute error").unwrap()];
    assert_eq!(matrix.matches("<tr>").count(), 1 + 11);
    assert!(matrix.contains("<th>t12</th>") && !matrix.contains("<th>t1</th>"));
    assert!(
        !tables.contains("survey_x"),
        "coordinates stay in targets.csv"
    );
    assert!(tables.contains("z is not fitted by a 2D alignment"));
    // A few targets keep the paper's layout.
    let few = result(&["1", "2", "3", "4"]);
    let html = Report::from_result(&few, Provenance::new(None, None)).html();
    assert!(html.contains("t1 &amp; t2") && html.contains("the paper's Table I"));
}

#[test]
fn escape_all_specials() {
    assert_eq!(
        escape("<a href='x'>&\"</a>"),
        "&lt;a href=&#39;x&#39;&gt;&amp;&quot;&lt;/a&gt;"
    );
}
