//! Every input in tests/fuzz-regressions (what the fuzzers found, and edge
//! cases that guard the reader and the decoder) gives a value or a typed
//! error, never a panic, through the same paths as the fuzz targets.
#![allow(clippy::unwrap_used, clippy::expect_used)] // tests may stop on any failure

use cgv::codec::FileDecoder;
use cgv::solve::SolverKind;

#[test]
fn regression_inputs_give_values_or_errors() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz-regressions");
    let mut seen = 0;
    let mut decoded = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "md") {
            continue;
        }
        seen += 1;
        let data = std::fs::read(&path).unwrap();
        let Ok(file) = cgv::format::read(&data) else { continue };
        for solver in [SolverKind::Predictive, SolverKind::Paper] {
            let Ok(mut dec) = FileDecoder::new(file.clone(), solver) else { continue };
            for _ in 0..dec.frame_count() {
                if dec.next_frame().is_err() {
                    break;
                }
                decoded += 1;
            }
        }
    }
    assert!(seen >= 6, "{seen} inputs in {}", dir.display());
    // The scrambled access unit reaches the decoder (its file reads).
    assert!(decoded > 0);
}
