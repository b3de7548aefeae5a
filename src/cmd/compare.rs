//! `mapgauge compare A/result.json B/result.json`: is B better than A?

use mapgauge::compare::{self, Comparison};
use mapgauge::record::ResultFile;
use mapgauge::render::{Grid, OutputFormat, TableFormat, mm};
use mapgauge::{Error, Result};
use std::path::PathBuf;

/// Paired differences of two runs on the targets both located, with 95 % intervals.
#[derive(clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct Args {
    /// A's result.json.
    a: PathBuf,
    /// B's result.json.
    b: PathBuf,
    /// Names of A and B, comma-separated [default: each file's parent directory name].
    #[arg(long)]
    names: Option<String>,
    /// Output: text, markdown or json.
    #[arg(long, default_value = "text")]
    format: OutputFormat,
    /// Compare runs scored against different surveys (targets of one id at
    /// other positions) anyway, with a warning [default: refused: their
    /// differences are the surveys', not the maps'].
    #[arg(long)]
    force: bool,
}

fn dir_name(p: &std::path::Path) -> String {
    p.parent()
        .and_then(|d| d.file_name())
        .map(|d| d.to_string_lossy().into_owned())
        .unwrap_or_else(|| p.display().to_string())
}

/// Runs `compare`.
pub fn run(a: Args) -> Result<()> {
    let ra = ResultFile::from_json_file(&a.a)?;
    let rb = ResultFile::from_json_file(&a.b)?;
    let names: [String; 2] = match &a.names {
        Some(n) => {
            let v: Vec<String> = n.split(',').map(|s| s.trim().to_string()).collect();
            match <[String; 2]>::try_from(v) {
                Ok(v) => v,
                Err(v) => {
                    return Err(Error::Param(format!(
                        "--names has {} names for 2 result files",
                        v.len()
                    )));
                }
            }
        }
        None => match [dir_name(&a.a), dir_name(&a.b)] {
            [x, y] if x == y => [a.a.display().to_string(), a.b.display().to_string()],
            v => v,
        },
    };
    // Two sites, or two surveys of one: a paired difference of their errors
    // measures the surveys, and looked like a confident "B is better".
    let elsewhere = mapgauge::render::surveyed_elsewhere(&ra, &rb);
    if !elsewhere.is_empty() {
        let what = format!(
            "`{}` and `{}` were scored against different surveys: targets {} are surveyed at other positions (or in another frame)",
            names[0],
            names[1],
            elsewhere.join(", ")
        );
        if !a.force {
            return Err(Error::Input(format!(
                "{what}; their errors do not compare (--force compares them anyway)"
            )));
        }
        errln!("warning: {what}: the differences below are the surveys' as much as the maps'");
    }
    let c = compare::compare(&ra, &rb, names)?;
    match a.format {
        OutputFormat::Json => {
            let mut v = serde_json::to_value(&c).unwrap_or_default();
            if let Some(o) = v.as_object_mut() {
                o.insert(
                    "verdict_e_abs".into(),
                    compare::verdict(&c, &c.e_abs, "E_abs").into(),
                );
                o.insert(
                    "verdict_e_rel".into(),
                    compare::verdict(&c, &c.e_rel, "E_rel").into(),
                );
                if let Some(v) = compare::scale_verdict(&c) {
                    o.insert("verdict_scale".into(), v.into());
                }
            }
            outln!("{}", serde_json::to_string_pretty(&v).unwrap_or_default());
        }
        OutputFormat::Table(f @ (TableFormat::Text | TableFormat::Markdown)) => {
            out!("{}", text(&c, f))
        }
        OutputFormat::Table(_) => {
            return Err(Error::Param("compare writes text, markdown or json".into()));
        }
    }
    Ok(())
}

fn text(c: &Comparison, f: TableFormat) -> String {
    let [a, b] = &c.names;
    let ci = |d: &compare::Difference| match d.ci95 {
        Some(ci) => format!("[{}, {}]", mm(ci[0]), mm(ci[1])),
        None => "–".into(),
    };
    let head = Grid {
        header: vec![
            "".into(),
            format!("{a} (mm)"),
            format!("{b} (mm)"),
            format!("{b} − {a} (mm)"),
            "95 % CI (mm)".into(),
        ],
        rows: [("E_abs", &c.e_abs), ("E_rel", &c.e_rel)]
            .iter()
            .map(|(k, d)| vec![k.to_string(), mm(d.a), mm(d.b), mm(d.diff), ci(d)])
            .collect(),
        bold: vec![],
        values: Vec::new(),
    };
    let per = Grid {
        header: vec![
            "target".into(),
            format!("{a} (mm)"),
            format!("{b} (mm)"),
            format!("{b} − {a} (mm)"),
        ],
        rows: c
            .targets
            .iter()
            .map(|t| vec![t.id.clone(), mm(t.a), mm(t.b), mm(t.diff)])
            .collect(),
        bold: vec![],
        values: Vec::new(),
    };
    let pairs = Grid {
        header: vec![
            "pair".into(),
            format!("{a} (mm)"),
            format!("{b} (mm)"),
            format!("{b} − {a} (mm)"),
        ],
        rows: c
            .pairs
            .iter()
            .map(|p| {
                vec![
                    format!("{}&{}", p.a_id, p.b_id),
                    mm(p.a),
                    mm(p.b),
                    mm(p.diff),
                ]
            })
            .collect(),
        bold: vec![],
        values: Vec::new(),
    };
    let mut o = String::new();
    for line in [
        compare::verdict(c, &c.e_abs, "E_abs"),
        compare::verdict(c, &c.e_rel, "E_rel"),
    ]
    .into_iter()
    .chain(compare::scale_verdict(c))
    {
        o += &line;
        o += if f == TableFormat::Markdown {
            "  \n"
        } else {
            "\n"
        };
    }
    o += &format!(
        "\nOn the {} targets both located (paired bootstrap over targets, 95 %):\n\n",
        c.targets.len()
    );
    o += &head.render(f);
    o += "\n";
    o += &per.render(f);
    if !c.pairs.is_empty() {
        o += "\n";
        o += &pairs.render(f);
    }
    o
}
