//! Malformed headers and data: one clear line naming the file (and line).

use super::*;

#[test]
fn header_errors_are_one_clear_line() {
    let dir = tempfile::tempdir().unwrap();
    let pts = sample(3);
    let fields: &[F] = &[
        ("x", 'F', 4, 1),
        ("y", 'F', 4, 1),
        ("z", 'F', 4, 1),
        ("i", 'U', 2, 1),
    ];
    let good =
        String::from_utf8(make(&dir, "good.pcd", fields, 3, 1, "ascii", &pts).pipe_read()).unwrap();
    let cases: &[(&str, &str, &str)] = &[
        (
            "TYPE F F F U",
            "TYPE F F F Q",
            "unknown TYPE 'Q' for field 'i'",
        ),
        (
            "SIZE 4 4 4 2",
            "SIZE 4 2 4 2",
            "field 'y' has TYPE F with SIZE 2",
        ),
        (
            "SIZE 4 4 4 2",
            "SIZE 4 4 4 2 4",
            "SIZE has 5 entries but FIELDS (line 3) has 4",
        ),
        (
            "COUNT 1 1 1 1",
            "COUNT 1 1 1",
            "COUNT has 3 entries but FIELDS (line 3) has 4",
        ),
        ("COUNT 1 1 1 1", "COUNT 1 0 1 1", "COUNT value '0'"),
        (
            "FIELDS x y z i",
            "FIELDS x y q i",
            "no field 'z' in FIELDS x y q i",
        ),
        ("DATA ascii", "DATA zip", "unknown DATA 'zip'"),
        ("DATA ascii\n", "", "header ends without a DATA line"),
        (
            "WIDTH 3",
            "WIDTH 4",
            "WIDTH 4 x HEIGHT 1 does not equal POINTS 3",
        ),
        ("POINTS 3", "POINTS three", "POINTS value 'three'"),
        (
            "POINTS 3",
            "POINTS 4",
            "header declares POINTS 4 but the data ends after 3 points",
        ),
        ("WIDTH 3", "WIDTH 4", "does not equal"),
    ];
    for (i, (from, to, want)) in cases.iter().enumerate() {
        let mut text = replace_header(&good, from, to);
        if *from == "POINTS 3" && *to == "POINTS 4" {
            text = replace_header(&text, "WIDTH 3", "WIDTH 4");
        }
        let p = file(&dir, &format!("bad{i}.pcd"), text.as_bytes());
        let e = err(&p);
        assert!(e.contains(want), "case {i}: got `{e}`, want `{want}`");
        assert!(e.contains(&format!("bad{i}.pcd")), "{e}");
        assert!(!e.contains('\n'), "{e}");
    }
    // Non-UTF-8 header line.
    let mut bytes = b"# .PCD v0.7\nVERSION 0.7\nFIELDS x y \xff z\n".to_vec();
    bytes.extend_from_slice(b"DATA ascii\n");
    let p = file(&dir, "utf.pcd", &bytes);
    assert!(
        err(&p).contains(".pcd:3: header line is not UTF-8"),
        "{}",
        err(&p)
    );
    // A header that never ends (no newline, no DATA, bigger than the limit).
    let mut bytes = b"VERSION 0.7\n# ".to_vec();
    bytes.resize(MAX_HEADER + 100, b'a');
    let p = file(&dir, "endless.pcd", &bytes);
    assert!(err(&p).contains("no DATA line within"), "{}", err(&p));
    // Bad ascii value names line and field.
    let text = replace_header(&good, "\n0.5 -0.25 1 100\n", "\n0.5 oops 1 100\n");
    let p = file(&dir, "badval.pcd", text.as_bytes());
    assert!(
        err(&p).contains(".pcd:13: field 'y' value 'oops' is not a number"),
        "{}",
        err(&p)
    );
    let text = replace_header(&good, "\n0.5 -0.25 1 100\n", "\n0.5 -0.25\n");
    let p = file(&dir, "short.pcd", text.as_bytes());
    assert!(
        err(&p).contains(".pcd:13: expected 4 values, found 2"),
        "{}",
        err(&p)
    );
}

#[test]
fn binary_data_errors() {
    let dir = tempfile::tempdir().unwrap();
    let pts = sample(10);
    // Truncated binary: 10 declared, 7.5 present.
    let full = make(&dir, "full.pcd", PCL_RGB, 10, 1, "binary", &pts).pipe_read();
    let cut = &full[..full.len() - 32 * 2 - 16];
    let p = file(&dir, "cut.pcd", cut);
    let e = err(&p);
    assert!(
        e.contains("declares POINTS 10") && e.contains("(7 whole points)"),
        "{e}"
    );
    // POINTS larger than any file could hold: no allocation, clear error.
    let text = String::from_utf8_lossy(&full[..200]).to_string();
    let head_end = full
        .windows(12)
        .position(|w| w == b"DATA binary\n")
        .unwrap()
        + 12;
    let mut huge = String::from_utf8(full[..head_end].to_vec()).unwrap();
    huge = huge
        .replace("WIDTH 10", "WIDTH 18446744073709551615")
        .replace("POINTS 10", "POINTS 18446744073709551615");
    let p = file(&dir, "huge.pcd", huge.as_bytes());
    assert!(
        err(&p).contains("truncated binary data"),
        "{} {text}",
        err(&p)
    );
    // binary_compressed: sizes disagreeing with the header, truncation, corruption.
    let comp = make(&dir, "comp.pcd", PCL_RGB, 10, 1, "binary_compressed", &pts).pipe_read();
    let head_end = comp
        .windows(23)
        .position(|w| w == b"DATA binary_compressed\n")
        .unwrap()
        + 23;
    let mut wrong = comp.clone();
    wrong[head_end + 4..head_end + 8].copy_from_slice(&1000u32.to_le_bytes());
    let p = file(&dir, "wrongsize.pcd", &wrong);
    assert!(
        err(&p).contains("uncompressed size 1000 does not match POINTS 10 x 32-byte points = 320"),
        "{}",
        err(&p)
    );
    let p = file(&dir, "compcut.pcd", &comp[..comp.len() - 5]);
    assert!(
        err(&p).contains("truncated binary_compressed data"),
        "{}",
        err(&p)
    );
    let mut bad = comp.clone();
    bad[head_end + 8] = 0xff; // a back-reference before the start of the output
    let p = file(&dir, "corrupt.pcd", &bad);
    assert!(
        err(&p).contains("binary_compressed data is corrupt"),
        "{}",
        err(&p)
    );
    let p = file(&dir, "nosizes.pcd", &comp[..head_end + 3]);
    assert!(err(&p).contains("need at least 8"), "{}", err(&p));
}
