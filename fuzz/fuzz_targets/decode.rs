//! The whole decoder (container, H.264, dequantization, solvers, the
//! source mesh's vertices) on
//! arbitrary bytes. Small files only, so each input stays fast.
#![no_main]

use cgv::codec::FileDecoder;
use cgv::solve::SolverKind;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let Ok(file) = cgv::format::read(data) else { return };
    if file.header.grid > 32 {
        return;
    }
    for solver in [SolverKind::Predictive, SolverKind::Paper] {
        let Ok(mut dec) = FileDecoder::new(file.clone(), solver) else { return };
        let source = dec.source_mesh();
        for _ in 0..dec.frame_count().min(3) {
            let Ok((x, _)) = dec.next_frame() else { break };
            if let Some(s) = &source {
                let _ = s.vertices(&x, dec.loose(), dec.at_vertices());
            }
        }
    }
});
