//! The whole decoder (container, H.264, dequantization, solvers) on
//! arbitrary bytes. Small files only, so each input stays fast.
#![no_main]

use cgv::codec::{h264, SequenceDecoder};
use cgv::solve::SolverKind;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let Ok(file) = cgv::container::read(data) else { return };
    if file.header.grid > 32 {
        return;
    }
    for solver in [SolverKind::Cgv, SolverKind::Paper] {
        let Ok(mut dec) = SequenceDecoder::new(file.clone(), solver, h264::Decoder::new) else { return };
        for _ in 0..dec.frame_count().min(3) {
            if dec.next_frame().is_err() {
                break;
            }
        }
    }
});
