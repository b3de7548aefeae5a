//! What a new user runs into first (issue 19): surveys as spreadsheets write
//! them, loose crops handed to `locate`, outputs that name files, flags that
//! take negative numbers, and messages that name the remedy.

use crate::util::{bin, stderr, stdout_ok, tempdir};
use std::path::Path;

fn scene(dir: &Path) -> (std::path::PathBuf, std::path::PathBuf) {
    let scene = dir.join("scene");
    stdout_ok(
        bin()
            .args(["synth", "--points", "1000000", "--out"])
            .arg(&scene),
    );
    (scene.join("map.ply"), scene.join("survey.csv"))
}

#[test]
fn crop_tight_then_locate_works_and_a_loose_crop_is_named() {
    let d = tempdir();
    let (map, survey) = scene(d.path());
    let loose = d.path().join("loose");
    stdout_ok(
        bin()
            .args(["crop", "--map"])
            .arg(&map)
            .arg("--survey")
            .arg(&survey)
            .arg("--out")
            .arg(&loose),
    );
    let o = bin()
        .arg("locate")
        .arg(loose.join("1.ply"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("looks like a loose crop") && stderr(&o).contains("crop --tight"),
        "{}",
        stderr(&o)
    );
    let o = bin()
        .args(["eval", "--map"])
        .arg(&map)
        .arg("--survey")
        .arg(&survey)
        .arg("--crops")
        .arg(&loose)
        .output()
        .unwrap();
    assert!(
        stderr(&o).contains("looks like a loose crop") && !stderr(&o).contains("--init"),
        "{}",
        stderr(&o)
    );
    let tight = d.path().join("tight");
    stdout_ok(
        bin()
            .args(["crop", "--tight", "--map"])
            .arg(&map)
            .arg("--survey")
            .arg(&survey)
            .arg("--out")
            .arg(&tight),
    );
    let out = stdout_ok(
        bin()
            .arg("locate")
            .args((1..=5).map(|i| tight.join(format!("{i}.ply")))),
    );
    assert_eq!(
        out.lines().filter(|l| l.ends_with(" ok")).count(),
        5,
        "{out}"
    );
    let json = stdout_ok(
        bin()
            .args(["eval", "--format", "json", "--map"])
            .arg(&map)
            .arg("--survey")
            .arg(&survey)
            .arg("--crops")
            .arg(&tight),
    );
    assert!(!json.contains("not_found"), "{json}");
}

#[test]
fn surveys_with_semicolons_tabs_or_no_header() {
    let d = tempdir();
    let est = d.path().join("est.csv");
    std::fs::write(&est, "id,x,y\n1,0,0\n2,10,0\n3,0,10\n").unwrap();
    for (name, text) in [
        ("semi.csv", "id;x;y\n1;0;0\n2;10;0.01\n3;0;10\n"),
        (
            "tab.csv",
            "# a comment\nid\tx\ty\n1\t0\t0\n2\t10\t0.01\n3\t0\t10\n",
        ),
    ] {
        let p = d.path().join(name);
        std::fs::write(&p, text).unwrap();
        let json = stdout_ok(
            bin()
                .args(["errors", "--format", "json", "--survey"])
                .arg(&p)
                .arg("--estimates")
                .arg(&est),
        );
        assert!(json.contains("\"n\": 3"), "{name}: {json}");
    }
    let p = d.path().join("nohead.csv");
    std::fs::write(&p, "1,0,0\n2,10,0\n").unwrap();
    let o = bin()
        .args(["errors", "--survey"])
        .arg(&p)
        .arg("--estimates")
        .arg(&est)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(
        e.starts_with(&format!("error: {}:1: no header line", p.display()))
            && e.contains("id,x,y,z"),
        "{e}"
    );
}

#[test]
fn messages_name_the_remedy() {
    let d = tempdir();
    let a = d.path().join("a.csv");
    let b = d.path().join("b.csv");
    std::fs::write(&a, "id,x,y\n1,0,0\n2,10,0\n3,0,10\n").unwrap();
    std::fs::write(&b, "id,x,y\nT1,0,0\nT2,10,0\n").unwrap();
    let o = bin()
        .args(["errors", "--survey"])
        .arg(&a)
        .arg("--estimates")
        .arg(&b)
        .output()
        .unwrap();
    assert!(
        stderr(&o).contains("the ids differ (survey: 1, 2, 3; estimates: T1, T2)"),
        "{}",
        stderr(&o)
    );
    // --out naming a file: refused before any work, the file untouched.
    let f = d.path().join("file");
    std::fs::write(&f, "keep").unwrap();
    let o = bin()
        .args(["errors", "--survey"])
        .arg(&a)
        .arg("--estimates")
        .arg(&a)
        .arg("--out")
        .arg(&f)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("exists and is not a directory"),
        "{}",
        stderr(&o)
    );
    assert_eq!(std::fs::read_to_string(&f).unwrap(), "keep");
    // --origin with a local survey is refused, not ignored.
    let o = bin()
        .args(["errors", "--origin", "37.5,127.0", "--survey"])
        .arg(&a)
        .arg("--estimates")
        .arg(&a)
        .output()
        .unwrap();
    assert!(
        stderr(&o).contains("--origin applies to WGS84"),
        "{}",
        stderr(&o)
    );
    // List flags: negative numbers without `=`; a wrong count is a usage error.
    let (map, survey) = scene(d.path());
    let o = bin()
        .args(["eval", "--init", "-26.7,96,30", "--print-config"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        String::from_utf8_lossy(&o.stdout).contains("init = [\n    -26.7,")
            || String::from_utf8_lossy(&o.stdout).contains("init = [-26.7"),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    let o = bin()
        .args(["eval", "--init", "1,2", "--map"])
        .arg(&map)
        .arg("--survey")
        .arg(&survey)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("expected 3 comma-separated numbers"),
        "{}",
        stderr(&o)
    );
    let o = bin()
        .args(["eval", "--format", "yaml", "--map"])
        .arg(&map)
        .arg("--survey")
        .arg(&survey)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    // One surveyed target: the message says the survey is the problem.
    let one = d.path().join("one.csv");
    let first = std::fs::read_to_string(&survey).unwrap();
    let two_lines: String = first.lines().take(2).map(|l| format!("{l}\n")).collect();
    std::fs::write(&one, two_lines).unwrap();
    let o = bin()
        .args(["eval", "--map"])
        .arg(&map)
        .arg("--survey")
        .arg(&one)
        .output()
        .unwrap();
    let e = stderr(&o);
    assert!(
        e.contains("The survey has 1 target(s)") && !e.contains("; ."),
        "{e}"
    );
}
