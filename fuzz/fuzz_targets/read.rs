//! The .cgv reader on arbitrary bytes: it must return Ok or a typed error,
//! never panic, hang or allocate without bound.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let _ = cgv::format::read(data);
    // The streaming entry points too, at every split of the input.
    if let Ok(Some((_, mut offset))) = cgv::format::parse_header(data) {
        while let Ok(Some((_, next))) = cgv::format::parse_chunk(data, offset) {
            offset = next;
        }
    }
});
