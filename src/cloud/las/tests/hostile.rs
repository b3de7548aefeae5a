//! Hostile files (fuzz finds, the hostile-input corpus): refused before a
//! decoder allocates what they declare, and a decoder's panic stays on the
//! reader threads and comes back as the file's error.

use super::*;

/// laz 0.13 indexes out of bounds on this chunk table inside its rayon
/// workers: the panic must happen on reader-named threads (whose panics the
/// quiet hook keeps from a hook that aborts, libFuzzer's: the `las` fuzz
/// target depends on it) and come back as the file's error.
#[test]
fn laz_decoder_panic_stays_on_reader_threads() {
    let seen = decoder_panics();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.las");
    std::fs::write(
        &path,
        include_bytes!("../../../../fuzz/upstream/laz-decoders-index-out-of-bounds.las"),
    )
    .unwrap();
    let e = read(&path).unwrap_err().to_string();
    assert!(e.contains("the decoder failed on malformed data"), "{e}");
    let seen = seen.lock().unwrap_or_else(|e| e.into_inner()).clone();
    assert!(
        !seen.is_empty(),
        "the laz crate no longer panics on this file"
    );
    let reader = Some(crate::cloud::producer::READER_THREAD.to_string());
    assert!(seen.iter().all(|n| *n == reader), "{seen:?}");
}

#[test]
fn lying_layer_sizes_are_refused_before_allocating() {
    // Fuzz find: a COPC node (and its LASzip chunk) declaring layers of
    // gigabytes in 23 KB; the laz crate zero-filled 2 GB before reading.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.copc.laz");
    std::fs::write(
        &path,
        include_bytes!("../../../../tests/corpus/fuzz-copc-layer-sizes.copc.laz"),
    )
    .unwrap();
    // Every chunk of a batch is decoded (the lying one refused before it
    // allocates); the first bad one in file order names the error, the same
    // one on every run (it once depended on which thread failed first).
    for copc in [true, false] {
        let err = || {
            open_with(&path, copc, true)
                .and_then(|mut r| {
                    let mut buf = Vec::new();
                    while r.next_chunk(&mut buf)? {}
                    Ok(())
                })
                .unwrap_err()
                .to_string()
        };
        let e = err();
        assert!(
            e.contains("declared in a chunk of") || e.contains("failed to fill whole buffer"),
            "{copc}: {e}"
        );
        for _ in 0..4 {
            assert_eq!(err(), e, "{copc}");
        }
    }
}

#[test]
fn lying_evlr_length_is_refused_before_allocating() {
    // Fuzz find: an extended VLR declaring 8 GB in a 22 KB file; the las
    // crate allocated it before reading.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.laz");
    std::fs::write(
        &path,
        include_bytes!("../../../../tests/corpus/fuzz-las-evlr-length.copc.laz"),
    )
    .unwrap();
    let e = read(&path).unwrap_err().to_string();
    assert!(
        e.contains("extended VLR at byte") && e.contains("declares"),
        "{e}"
    );
}

/// Every LAS/LAZ input of the fuzz corpus and the hostile-input corpus gives
/// points or an error on both LAZ paths, and a panic inside a decoder only
/// ever happens on reader-named threads (which libFuzzer's hook cannot see).
#[test]
fn fuzz_corpus_gives_errors_not_panics() {
    let seen_all = decoder_panics();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    for d in ["fuzz/corpus/las", "fuzz/upstream", "tests/corpus"] {
        for e in std::fs::read_dir(root.join(d)).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|x| x == "las" || x == "laz") {
                files.push(p);
            }
        }
    }
    assert!(files.len() >= 12, "{files:?}");
    let (mut ok, mut failed) = (0, 0);
    for p in &files {
        for (copc, chunked) in [(true, true), (false, true), (false, false)] {
            match all_of(p, copc, chunked) {
                Ok(_) => ok += 1,
                Err(e) => {
                    failed += 1;
                    assert!(!e.to_string().contains('\n'), "{e}");
                }
            }
        }
    }
    assert!(ok > 0 && failed > 0, "{ok} {failed}");
    let seen = seen_all.lock().unwrap_or_else(|e| e.into_inner()).clone();
    let reader = Some(crate::cloud::producer::READER_THREAD.to_string());
    assert!(seen.iter().all(|n| *n == reader), "{seen:?}");
}
