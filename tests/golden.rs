//! Byte-for-byte check of what mapgauge prints and writes, against the files in
//! `tests/golden/`: the demo and three `synth` scenes through `eval`, `errors`,
//! `table`, `crop` and `locate`. A refactor must leave every byte alone (issue
//! 14); a change that means to alter an output re-blesses them and says so:
//!
//! ```sh
//! MAPGAUGE_BLESS=1 cargo test --release --test golden
//! git diff --stat tests/golden
//! ```
//!
//! Temporary paths are written as `<TMP>`, and the few lines that report
//! elapsed time have their digits masked; nothing else is normalised. Binary
//! outputs (crops, PNG figures) are compared by SHA-256 (`binary.sha256`).

use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};
use std::process::Command;

fn bin() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_mapgauge"));
    c.env("SOURCE_DATE_EPOCH", "1700000000")
        .env("RAYON_NUM_THREADS", "2");
    c
}

/// One case's outputs, compared with (or blessed into) `tests/golden/<case>/`.
struct Golden {
    case: String,
    tmp: PathBuf,
    text: Vec<(String, String)>,
    binary: Vec<(String, String)>,
}

impl Golden {
    fn new(case: &str, tmp: &Path) -> Golden {
        Golden {
            case: case.into(),
            tmp: tmp.to_path_buf(),
            text: Vec::new(),
            binary: Vec::new(),
        }
    }

    fn normalise(&self, s: &str) -> String {
        let tmp = self.tmp.display().to_string();
        s.replace(&tmp, "<TMP>")
            .lines()
            .map(|l| {
                // Elapsed times are the one thing that may differ between runs.
                let timed = l.starts_with("time:")
                    || l.starts_with("report written to")
                    || l.contains("figure files written to")
                    || (l.starts_with("demo:") && l.contains(" s"))
                    || (l.starts_with("synth:") && l.contains(" s"));
                if timed {
                    l.chars()
                        .map(|c| if c.is_ascii_digit() { '#' } else { c })
                        .collect::<String>()
                } else {
                    l.to_string()
                }
            })
            .collect::<Vec<_>>()
            .join("\n")
            + "\n"
    }

    /// Runs a command, keeps its stdout and stderr under `name`, returns stdout.
    fn run(&mut self, name: &str, args: &[&str]) -> String {
        let out = bin().args(args).output().unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout).to_string();
        let stderr = String::from_utf8_lossy(&out.stderr).to_string();
        let code = out.status.code().unwrap_or(-1);
        let text = format!(
            "exit {code}\n--- stdout\n{}--- stderr\n{}",
            self.normalise(&stdout),
            self.normalise(&stderr)
        );
        self.text.push((format!("{name}.out"), text));
        stdout
    }

    fn text_file(&mut self, name: &str, path: &Path) {
        let s = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let s = self.normalise(&s);
        self.text.push((name.into(), s));
    }

    /// Every file under `dir` (sorted): text files whole, others by SHA-256.
    fn tree(&mut self, prefix: &str, dir: &Path) {
        let mut files = Vec::new();
        collect(dir, &mut files);
        files.sort();
        for f in files {
            let rel = f.strip_prefix(dir).unwrap().display().to_string();
            let name = format!("{prefix}/{rel}");
            let ext = f.extension().and_then(|e| e.to_str()).unwrap_or("");
            if ["json", "csv", "html", "svg", "md", "tex", "txt"].contains(&ext) {
                self.text_file(&name.replace('/', "__"), &f);
            } else {
                let bytes = std::fs::read(&f).unwrap();
                let digest = Sha256::digest(&bytes);
                let hex: String = digest.iter().map(|b| format!("{b:02x}")).collect();
                self.binary.push((name, hex));
            }
        }
    }

    fn check(self) {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/golden")
            .join(&self.case);
        let mut files = self.text;
        let manifest: String = self
            .binary
            .iter()
            .map(|(n, h)| format!("{h}  {n}\n"))
            .collect();
        files.push(("binary.sha256".into(), manifest));
        if std::env::var_os("MAPGAUGE_BLESS").is_some() {
            let _ = std::fs::remove_dir_all(&dir);
            std::fs::create_dir_all(&dir).unwrap();
            for (n, s) in &files {
                std::fs::write(dir.join(n), s).unwrap();
            }
            return;
        }
        let mut bad = Vec::new();
        let mut expected_names: Vec<String> = std::fs::read_dir(&dir)
            .unwrap_or_else(|e| panic!("{}: {e} (bless with MAPGAUGE_BLESS=1)", dir.display()))
            .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
            .collect();
        expected_names.sort();
        let mut got_names: Vec<String> = files.iter().map(|f| f.0.clone()).collect();
        got_names.sort();
        if expected_names != got_names {
            bad.push(format!(
                "file set differs:\n  golden {expected_names:?}\n  now    {got_names:?}"
            ));
        }
        for (n, s) in &files {
            let want = std::fs::read_to_string(dir.join(n)).unwrap_or_default();
            if &want != s {
                let line = want
                    .lines()
                    .zip(s.lines())
                    .position(|(a, b)| a != b)
                    .unwrap_or(want.lines().count().min(s.lines().count()));
                bad.push(format!(
                    "{}/{n} differs from line {}:\n  golden: {}\n  now:    {}",
                    self.case,
                    line + 1,
                    want.lines().nth(line).unwrap_or("<end>"),
                    s.lines().nth(line).unwrap_or("<end>")
                ));
            }
        }
        assert!(bad.is_empty(), "{}", bad.join("\n"));
    }
}

fn collect(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            collect(&p, out);
        } else {
            out.push(p);
        }
    }
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn demo_is_unchanged() {
    let tmp = tempfile::tempdir().unwrap();
    let mut g = Golden::new("demo", tmp.path());
    let out = tmp.path().join("demo");
    g.run("demo", &["demo", "--out", s(&out)]);
    g.tree("eval", &out.join("eval"));
    g.check();
}

/// Clutter, a bush touching a target, eight targets; every output format and
/// every file `eval` can write.
#[test]
fn cluttered_scene_is_unchanged() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let mut g = Golden::new("cluttered", t);
    let scene = t.join("scene");
    g.run(
        "synth",
        &[
            "synth",
            "--out",
            s(&scene),
            "--seed",
            "3",
            "--targets",
            "8",
            "--points",
            "700000",
            "--format",
            "pcd",
            "--near-clutter-m",
            "1.5",
            "--bush-touching",
        ],
    );
    let map = scene.join("map.pcd");
    let survey = scene.join("survey.csv");
    let ev = t.join("eval");
    g.run(
        "eval",
        &[
            "eval",
            "--map",
            s(&map),
            "--survey",
            s(&survey),
            "--out",
            s(&ev),
            "--save-crops",
            "--plots",
            s(&t.join("plots")),
            "--seed",
            "7",
        ],
    );
    g.tree("eval", &ev);
    g.tree("plots", &t.join("plots"));
    for f in ["json", "markdown", "latex", "csv", "html"] {
        g.run(
            &format!("eval-{f}"),
            &[
                "eval",
                "--map",
                s(&map),
                "--survey",
                s(&survey),
                "--seed",
                "7",
                "--format",
                f,
            ],
        );
    }
    g.run(
        "eval-print-config",
        &[
            "eval",
            "--print-config",
            "--plate-size",
            "0.6,0.5",
            "--radius",
            "4",
        ],
    );
    // Hand-made crops: the tight crops eval saved.
    g.run(
        "eval-crops",
        &[
            "eval",
            "--map",
            s(&map),
            "--survey",
            s(&survey),
            "--crops",
            s(&ev.join("crops/tight")),
            "--seed",
            "7",
        ],
    );
    let tight: Vec<String> = (1..=8)
        .map(|i| s(&ev.join(format!("crops/tight/{i}.ply"))).to_string())
        .filter(|p| Path::new(p).exists())
        .collect();
    let mut args = vec!["locate", "--seed", "5"];
    args.extend(tight.iter().map(|x| x.as_str()));
    g.run("locate", &args);
    let crops = t.join("crops");
    g.run(
        "crop",
        &[
            "crop",
            "--map",
            s(&map),
            "--survey",
            s(&survey),
            "--out",
            s(&crops),
        ],
    );
    g.tree("crop", &crops);
    g.check();
}

/// A tilted, rotated, offset LAS map with heights: 3D errors, a z-fitting
/// alignment, the survey sigma, and a second eval's tables across runs.
#[test]
fn tilted_scene_is_unchanged() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let mut g = Golden::new("tilted", t);
    let scene = t.join("scene");
    g.run(
        "synth",
        &[
            "synth",
            "--out",
            s(&scene),
            "--seed",
            "11",
            "--targets",
            "6",
            "--points",
            "600000",
            "--format",
            "las",
            "--tilt-deg",
            "1.5",
            "--yaw-deg",
            "2",
            "--offset-m",
            "2,-1.5,0.4",
            "--slope-deg",
            "3",
            "--survey-noise-m",
            "0.01",
        ],
    );
    let map = scene.join("map.las");
    let survey = scene.join("survey.csv");
    let a = t.join("a");
    let b = t.join("b");
    g.run(
        "eval-3d",
        &[
            "eval",
            "--map",
            s(&map),
            "--survey",
            s(&survey),
            "--out",
            s(&a),
            "--align",
            "rigid2d+z",
            "--dim",
            "3d",
            "--survey-sigma",
            "0.01,0.02",
        ],
    );
    g.tree("a", &a);
    g.run(
        "eval-robust",
        &[
            "eval",
            "--map",
            s(&map),
            "--survey",
            s(&survey),
            "--out",
            s(&b),
            "--align",
            "robust2d",
            "--no-report",
            "--shape",
            "sphere",
        ],
    );
    g.tree("b", &b);
    for f in ["markdown", "latex", "csv", "html", "json", "text"] {
        g.run(
            &format!("table-{f}"),
            &[
                "table",
                s(&a.join("result.json")),
                s(&b.join("result.json")),
                "--names",
                "A,B",
                "--format",
                f,
            ],
        );
    }
    g.check();
}

/// `errors` on positions: the paper's sequence 5, a WGS84 survey of the synth
/// scene with roles, and a run with too few targets.
#[test]
fn errors_are_unchanged() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let mut g = Golden::new("errors", t);
    let scene = t.join("scene");
    g.run(
        "synth",
        &[
            "synth",
            "--out",
            s(&scene),
            "--seed",
            "5",
            "--targets",
            "7",
            "--points",
            "400000",
        ],
    );
    let ev = t.join("eval");
    g.run(
        "eval",
        &[
            "eval",
            "--map",
            s(&scene.join("map.ply")),
            "--survey",
            s(&scene.join("survey.csv")),
            "--out",
            s(&ev),
            "--no-report",
        ],
    );
    // Estimates from that run, and a survey with roles.
    let est = t.join("est.csv");
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(ev.join("result.json")).unwrap()).unwrap();
    let mut e = String::from("id,x,y,z\n");
    let mut sv = String::from("id,x,y,z,role\n");
    for (i, tg) in r["targets"].as_array().unwrap().iter().enumerate() {
        let id = tg["id"].as_str().unwrap();
        if let Some(m) = tg["map"].as_object() {
            e += &format!("{id},{},{},{}\n", m["x"], m["y"], m["z"]);
        }
        let sp = &tg["survey"];
        let role = if i % 3 == 2 { "check" } else { "control" };
        sv += &format!(
            "{id},{},{},{},{role}\n",
            sp["x"],
            sp["y"],
            sp["z"],
            role = role
        );
    }
    std::fs::write(&est, e).unwrap();
    let roles = t.join("roles.csv");
    std::fs::write(&roles, sv).unwrap();
    for f in ["table", "json", "csv", "markdown", "latex"] {
        g.run(
            &format!("errors-{f}"),
            &[
                "errors",
                "--survey",
                s(&roles),
                "--estimates",
                s(&est),
                "--format",
                f,
            ],
        );
    }
    g.run(
        "errors-llh",
        &[
            "errors",
            "--survey",
            s(&scene.join("survey_llh.csv")),
            "--estimates",
            s(&est),
            "--align",
            "similarity2d",
            "--out",
            s(&t.join("llh")),
        ],
    );
    g.tree("llh", &t.join("llh"));
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    g.run(
        "errors-paper",
        &[
            "errors",
            "--survey",
            s(&data.join("paper_seq5_survey.csv")),
            "--estimates",
            s(&data.join("paper_seq5_estimates.csv")),
            "--align",
            "robust2d",
        ],
    );
    let one = t.join("one.csv");
    std::fs::write(&one, "id,x,y\n1,0,0\n").unwrap();
    g.run(
        "errors-too-few",
        &["errors", "--survey", s(&one), "--estimates", s(&one)],
    );
    g.check();
}
