//! The .cgv reader on good, truncated, corrupted and oversized input.

use cgv::codec::quant::Quantizer;
use cgv::container::{self, CodecKind, ContainerError, CorrectionMode, Coverage, Header, Settings, StreamInfo};

fn header() -> Header {
    Header {
        grid: 16,
        seam: container::SEAM_RULE.into(),
        frames: 3,
        fps: 30.0,
        codec: CodecKind::Cgv,
        streams: vec![
            StreamInfo {
                name: "H".into(),
                layer: 1,
                refines: None,
                quant: Quantizer::new(-1.0, 1.0),
                coverage: Coverage::All,
                scaled: false,
            },
            StreamInfo {
                name: "lambda".into(),
                layer: 1,
                refines: None,
                quant: Quantizer::new(0.0, 1.0),
                coverage: Coverage::Key,
                scaled: false,
            },
            StreamInfo {
                name: "H".into(),
                layer: 2,
                refines: Some(0),
                quant: Quantizer::new(-0.1, 0.1),
                coverage: Coverage::All,
                scaled: false,
            },
        ],
        key_frames: vec![0, 2],
        anchors: vec![0, 5, 100, 255],
        solver: "cgv".into(),
        settings: Settings { qp: 20, kbps: None, gop: 30, cabac: true, layers: 2, residual_steps: 8.0 },
        source: Default::default(),
        corrections: CorrectionMode::Scaled,
    }
}

/// A structurally valid file (the payloads are not real H.264).
fn file(h: &Header) -> Vec<u8> {
    let mut out = container::write_header(h).unwrap();
    for f in 0..h.frames {
        let anchors = (0..h.anchors.len()).map(|i| [0, 1, 2].map(|c| (3 * i + c) as f32 + f as f32)).collect();
        let info = container::FrameInfo { predictor: 6, correction_scale: 0.5, anchors };
        out.extend(container::write_chunk(container::TAG_FRAME, 0, f, &info.to_bytes()));
        for s in 0..h.streams.len() {
            if h.stream_has_frame(s, f) {
                out.extend(container::write_chunk(
                    container::TAG_ACCESS_UNIT,
                    s as u16,
                    f,
                    &[0, 0, 0, 1, 9, f as u8, s as u8],
                ));
            }
        }
    }
    out.extend(container::write_chunk(container::TAG_END, 0, h.frames, &[]));
    out
}

#[test]
fn reads_what_it_writes() {
    let h = header();
    let bytes = file(&h);
    let f = container::read(&bytes).unwrap();
    assert_eq!(f.header, h);
    assert_eq!(f.units[0].len(), 3);
    assert!(f.units[1][1].is_empty() && !f.units[1][2].is_empty());
    assert_eq!(f.units[2][1], vec![0, 0, 0, 1, 9, 1, 2]);
    assert_eq!(f.frames[2].anchors[1], [5.0, 6.0, 7.0]);
    assert_eq!((f.frames[1].predictor, f.frames[1].correction_scale), (6, 0.5));
    assert_eq!(h.expected_chunks(), 3 + 2 + 3 + 3);
}

#[test]
fn bad_magic_and_versions() {
    let mut bytes = file(&header());
    bytes[1] = b'X';
    assert_eq!(container::read(&bytes).unwrap_err(), ContainerError::BadMagic);
    assert_eq!(container::read(b"GIF89a").unwrap_err(), ContainerError::BadMagic);
    let mut bytes = file(&header());
    bytes[8] = 3;
    assert_eq!(container::read(&bytes).unwrap_err(), ContainerError::UnsupportedVersion { found: 3 });
    bytes[8] = 0;
    assert!(matches!(container::read(&bytes).unwrap_err(), ContainerError::UnsupportedVersion { found: 0 }));
}

/// A CGV header with motion corrections (format version 2).
fn motion_header() -> Header {
    let mut h = header();
    h.streams.truncate(2);
    for name in ["dx", "dy", "dz"] {
        h.streams.push(StreamInfo {
            name: name.into(),
            layer: 1,
            refines: None,
            quant: Quantizer::new(-0.1, 0.1),
            coverage: Coverage::All,
            scaled: false,
        });
    }
    h.corrections = CorrectionMode::Motion;
    h
}

/// Rewrites the version field of a file and its header CRC.
fn with_version(mut bytes: Vec<u8>, version: u16) -> Vec<u8> {
    bytes[8..10].copy_from_slice(&version.to_le_bytes());
    let len = u32::from_le_bytes([bytes[12], bytes[13], bytes[14], bytes[15]]) as usize;
    let crc = crc32fast::hash(&bytes[8..16 + len]);
    bytes[16 + len..20 + len].copy_from_slice(&crc.to_le_bytes());
    bytes
}

#[test]
fn version_two_only_where_needed_and_never_in_a_version_one_file() {
    // Scaled corrections need nothing new: written as version 1, no new field.
    let bytes = file(&header());
    assert_eq!(u16::from_le_bytes([bytes[8], bytes[9]]), 1);
    assert!(!String::from_utf8_lossy(&bytes).contains("corrections"));
    assert_eq!(container::read(&bytes).unwrap().version, 1);
    // Motion corrections: version 2, read back whole.
    let h = motion_header();
    let bytes = file(&h);
    assert_eq!(u16::from_le_bytes([bytes[8], bytes[9]]), 2);
    let f = container::read(&bytes).unwrap();
    assert_eq!((f.version, &f.header), (2, &h));
    // A file claiming version 1 with a version-2 field is refused by name.
    let e = container::read(&with_version(bytes.clone(), 1)).unwrap_err();
    assert!(matches!(&e, ContainerError::Header(m) if m.contains("version 1") && m.contains("Motion")), "{e}");
    // A version-2 file may hold a header that version 1 could (another writer).
    assert_eq!(container::read(&with_version(file(&header()), 2)).unwrap().version, 2);
    // Motion corrections without all three correction streams, or scaled ones.
    let mut bad = motion_header();
    bad.streams.pop();
    assert!(matches!(container::write_header(&bad).unwrap_err(), ContainerError::Header(_)));
    let mut bad = motion_header();
    bad.streams[2].scaled = true;
    assert!(matches!(container::write_header(&bad).unwrap_err(), ContainerError::Header(_)));
    let mut bad = motion_header();
    bad.codec = CodecKind::Gv;
    assert!(matches!(container::write_header(&bad).unwrap_err(), ContainerError::Header(_)));
}

#[test]
fn every_truncation_is_an_error() {
    let bytes = file(&header());
    for len in 0..bytes.len() {
        let e = container::read(&bytes[..len]).unwrap_err();
        assert!(matches!(e, ContainerError::Truncated { .. } | ContainerError::BadMagic), "length {len}: {e}");
    }
}

#[test]
fn every_flipped_byte_is_an_error() {
    let bytes = file(&header());
    for i in 0..bytes.len() {
        for bit in [0x01u8, 0x80] {
            let mut b = bytes.clone();
            b[i] ^= bit;
            assert!(container::read(&b).is_err(), "flipping bit {bit:#x} of byte {i} went unnoticed");
        }
    }
}

#[test]
fn absurd_sizes_and_counts_are_refused_without_allocating() {
    // A header length of 4 GiB.
    let mut bytes = file(&header());
    bytes[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(matches!(container::read(&bytes).unwrap_err(), ContainerError::TooLarge { what: "header length", .. }));
    // A chunk claiming 4 GiB.
    let h = header();
    let mut bytes = container::write_header(&h).unwrap();
    let mut chunk = container::write_chunk(container::TAG_ACCESS_UNIT, 0, 0, &[1, 2, 3]);
    chunk[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
    bytes.extend(chunk);
    assert!(matches!(container::read(&bytes).unwrap_err(), ContainerError::TooLarge { what: "chunk length", .. }));
    // Headers with impossible values.
    for bad in [
        Header { grid: 1 << 20, ..header() },
        Header { grid: 17, ..header() },
        Header { frames: u32::MAX, ..header() },
        Header { fps: f32::NAN, ..header() },
        Header { key_frames: vec![1, 2], ..header() },
        Header { anchors: vec![0, 1, 2, 256], ..header() },
        Header { anchors: vec![0, 1], ..header() },
        Header { streams: vec![], ..header() },
        Header { seam: "torus".into(), ..header() },
    ] {
        assert!(matches!(container::write_header(&bad).unwrap_err(), ContainerError::Header(_)), "{bad:?}");
    }
    // A valid header promising ten million frames, followed by one frame: an
    // error, after reading only what is there.
    let h = Header { frames: container::MAX_FRAMES, ..header() };
    let mut bytes = container::write_header(&h).unwrap();
    let info = container::FrameInfo { anchors: vec![[0.0; 3]; 4], ..Default::default() };
    bytes.extend(container::write_chunk(container::TAG_FRAME, 0, 0, &info.to_bytes()));
    bytes.extend(container::write_chunk(container::TAG_ACCESS_UNIT, 0, 0, &[1]));
    assert!(matches!(container::read(&bytes).unwrap_err(), ContainerError::Truncated { .. }));
}

#[test]
fn chunks_out_of_order_or_extra_are_errors() {
    let h = header();
    let mut bytes = container::write_header(&h).unwrap();
    bytes.extend(container::write_chunk(container::TAG_ACCESS_UNIT, 1, 0, &[1]));
    assert!(matches!(container::read(&bytes).unwrap_err(), ContainerError::Chunk { .. }));
    let mut bytes = file(&h);
    bytes.extend(container::write_chunk(container::TAG_END, 0, 3, &[]));
    assert!(matches!(container::read(&bytes).unwrap_err(), ContainerError::Chunk { .. }));
    let mut bytes = container::write_header(&h).unwrap();
    bytes.extend(container::write_chunk(*b"JUNK", 0, 0, &[1]));
    assert!(matches!(container::read(&bytes).unwrap_err(), ContainerError::Chunk { .. }));
}

#[test]
fn bad_frame_chunks_are_errors() {
    let h = header();
    let good = container::FrameInfo { predictor: 1, correction_scale: 1.0, anchors: vec![[0.0; 3]; 4] };
    let mut bad_bytes = good.to_bytes();
    bad_bytes.pop();
    let cases: Vec<Vec<u8>> = vec![
        container::FrameInfo { predictor: container::MAX_PREDICTOR + 1, ..good.clone() }.to_bytes(),
        container::FrameInfo { predictor: 3, ..good.clone() }.to_bytes(),
        container::FrameInfo { correction_scale: -1.0, ..good.clone() }.to_bytes(),
        container::FrameInfo { correction_scale: f32::INFINITY, ..good.clone() }.to_bytes(),
        container::FrameInfo { anchors: vec![[f32::NAN, 0.0, 0.0]; 4], ..good.clone() }.to_bytes(),
        container::FrameInfo { anchors: vec![[0.0; 3]; 5], ..good.clone() }.to_bytes(),
        bad_bytes,
    ];
    for payload in cases {
        let mut bytes = container::write_header(&h).unwrap();
        bytes.extend(container::write_chunk(container::TAG_FRAME, 0, 0, &payload));
        bytes.extend(container::write_chunk(container::TAG_ACCESS_UNIT, 0, 0, &[1]));
        let e = container::read(&bytes).unwrap_err();
        assert!(matches!(e, ContainerError::Chunk { .. }), "{payload:?}: {e}");
    }
}

#[test]
fn streaming_reader_sees_frames_as_they_arrive() {
    let h = header();
    let bytes = file(&h);
    let whole = container::read(&bytes).unwrap();
    // Byte by byte: the frame count only grows, and the result is the same file.
    let mut r = container::StreamReader::default();
    let mut seen = vec![];
    for b in &bytes {
        r.push(std::slice::from_ref(b)).unwrap();
        seen.push(r.complete_frames());
    }
    assert!(seen.windows(2).all(|w| w[0] <= w[1]) && seen.contains(&1) && seen.contains(&2));
    assert!(r.is_complete() && r.header() == Some(&h));
    let f = r.finish().unwrap();
    assert_eq!((f.units, f.frames, f.bytes), (whole.units, whole.frames, whole.bytes));
    // Half a file: not complete, and finishing says truncated.
    let mut r = container::StreamReader::default();
    r.push(&bytes[..bytes.len() / 2]).unwrap();
    assert!(!r.is_complete() && r.complete_frames() < 3);
    assert!(matches!(r.finish().unwrap_err(), ContainerError::Truncated { .. }));
    // A flipped byte in the second half is caught when it arrives.
    let mut bad = bytes.clone();
    let k = bytes.len() * 3 / 4;
    bad[k] ^= 0x40;
    let mut r = container::StreamReader::default();
    r.push(&bad[..k - 10]).unwrap();
    assert!(r.push(&bad[k - 10..]).is_err());
}
