//! The .cgv reader on good, truncated, corrupted and oversized input.
#![allow(clippy::unwrap_used, clippy::expect_used)] // tests may stop on any failure

mod common;

use cgv::format::quant::Quantizer;
use cgv::format::{
    self, CodecKind, ContainerError, CorrectionMode, Coverage, Header, PredictorCode, Settings, SolverKind, StreamInfo,
    StreamName,
};

fn header() -> Header {
    Header {
        grid: 16,
        seam: format::SEAM_RULE.into(),
        frames: 3,
        fps: 30.0,
        codec: CodecKind::Cgv,
        streams: vec![
            StreamInfo {
                name: StreamName::H,
                layer: 1,
                refines: None,
                quant: Quantizer::new(-1.0, 1.0),
                coverage: Coverage::All,
                scaled: false,
                shrink: 0,
            },
            StreamInfo {
                name: StreamName::Lambda,
                layer: 1,
                refines: None,
                quant: Quantizer::new(0.0, 1.0),
                coverage: Coverage::Key,
                scaled: false,
                shrink: 0,
            },
            StreamInfo {
                name: StreamName::H,
                layer: 2,
                refines: Some(0),
                quant: Quantizer::new(-0.1, 0.1),
                coverage: Coverage::All,
                scaled: false,
                shrink: 0,
            },
        ],
        key_frames: vec![0, 2],
        anchors: vec![0, 5, 100, 255],
        solver: SolverKind::Predictive,
        settings: Settings { qp: 20, kbps: None, gop: 30, cabac: true, layers: 2, residual_steps: 8.0 },
        source: Default::default(),
        corrections: CorrectionMode::Scaled,
        max_lag: 0,
        source_mesh: None,
        appearance: None,
        random_access: None,
        skin: None,
        segments: Vec::new(),
        frame_meshes: false,
        vertex_residual: None,
    }
}

/// A valid predictor code from its bytes.
fn code(byte: u8, lag: u8) -> PredictorCode {
    PredictorCode::from_bytes(byte, lag).unwrap()
}

fn frame_info(h: &Header, f: u32) -> format::FrameInfo {
    let anchors = (0..h.anchors.len()).map(|i| [0, 1, 2].map(|c| (3 * i + c) as f32 + f as f32)).collect();
    // A file with random-access points carries a seed origin at each.
    let seed_origin = h.has_seed_origin(f).then_some([1.0, 2.0, f as f32]);
    // A file with loose vertices carries their residuals in every frame.
    let loose = h.loose_vertices().map(|n| {
        format::LooseFrame { step: 0.25, residuals: (0..n as i32).map(|k| [k, -k, f as i32]).collect() }.to_bytes()
    });
    format::FrameInfo {
        predictor: code(6, 0),
        filter: 0,
        relax: 0,
        correction_scale: 0.5,
        anchors,
        seed_origin,
        loose,
        bones: None,
        mesh: None,
        residual: None,
    }
}

/// Not real H.264: the reader does not look inside.
fn unit(f: u32, s: usize) -> Vec<u8> {
    vec![0, 0, 0, 1, 9, f as u8, s as u8]
}

/// A structurally valid file of this writer's version: one chunk per frame.
fn file(h: &Header) -> Vec<u8> {
    let mut out = format::write_header(h).unwrap();
    for f in 0..h.frames {
        let units: Vec<Vec<u8>> =
            (0..h.streams.len()).filter(|&s| h.stream_has_frame(s, f)).map(|s| unit(f, s)).collect();
        let refs: Vec<&[u8]> = units.iter().map(Vec::as_slice).collect();
        out.extend(format::write_frame(f, &frame_info(h, f), &refs));
    }
    out.extend(format::write_chunk(format::TAG_END, 0, h.frames, &[]));
    out
}

/// The prefix of a version-1 file.
fn header_v1(h: &Header) -> Vec<u8> {
    with_version(format::write_header(h).unwrap(), 1)
}

/// A structurally valid version-1 file: a chunk per access unit.
fn file_v1(h: &Header) -> Vec<u8> {
    let mut out = header_v1(h);
    for f in 0..h.frames {
        out.extend(format::write_chunk(format::TAG_FRAME, 0, f, &frame_info(h, f).to_bytes()));
        for s in 0..h.streams.len() {
            if h.stream_has_frame(s, f) {
                out.extend(format::write_chunk(format::TAG_ACCESS_UNIT, s as u16, f, &unit(f, s)));
            }
        }
    }
    out.extend(format::write_chunk(format::TAG_END, 0, h.frames, &[]));
    out
}

#[test]
fn reads_what_it_writes_in_both_layouts() {
    let h = header();
    let (v1, v2) = (file_v1(&h), file(&h));
    // Versions 2 to 6 save 20 bytes per access unit but the frame's first.
    assert_eq!(v1.len() - v2.len(), (h.expected_chunks() as usize - 3) * 20 - 8);
    let a = format::read(&v1).unwrap();
    let f = format::read(&v2).unwrap();
    assert_eq!((a.version, f.version), (1, format::VERSION));
    for version in 2..=5 {
        assert_eq!(format::read(&with_version(v2.clone(), version)).unwrap().header, h);
    }
    assert_eq!((&a.header, &a.units, &a.frames), (&f.header, &f.units, &f.frames));
    assert_eq!(f.header, h);
    assert_eq!(f.units[0].len(), 3);
    assert!(f.units[1][1].is_empty() && !f.units[1][2].is_empty());
    assert_eq!(f.units[2][1], vec![0, 0, 0, 1, 9, 1, 2]);
    assert_eq!(f.frames[2].anchors[1], [5.0, 6.0, 7.0]);
    assert_eq!((f.frames[1].predictor.to_byte(), f.frames[1].correction_scale), (6, 0.5));
    assert_eq!(h.expected_chunks(), 3 + 2 + 3 + 3);
}

#[test]
fn bad_magic_and_versions() {
    let mut bytes = file(&header());
    bytes[1] = b'X';
    assert_eq!(format::read(&bytes).unwrap_err(), ContainerError::BadMagic);
    assert_eq!(format::read(b"GIF89a").unwrap_err(), ContainerError::BadMagic);
    let mut bytes = file(&header());
    bytes[8] = 22;
    assert_eq!(format::VERSION, 21);
    assert_eq!(format::read(&bytes).unwrap_err(), ContainerError::UnsupportedVersion { found: 22 });
    bytes[8] = 0;
    assert!(matches!(format::read(&bytes).unwrap_err(), ContainerError::UnsupportedVersion { found: 0 }));
}

/// A CGV header with motion corrections (format version 2).
fn motion_header() -> Header {
    let mut h = header();
    h.streams.truncate(2);
    for name in format::stream::CORRECTION {
        h.streams.push(StreamInfo {
            name,
            layer: 1,
            refines: None,
            quant: Quantizer::new(-0.1, 0.1),
            coverage: Coverage::All,
            scaled: false,
            shrink: 0,
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
fn motion_corrections_only_in_version_two() {
    // Scaled corrections add no header field.
    let bytes = file(&header());
    assert_eq!(u16::from_le_bytes([bytes[8], bytes[9]]), format::VERSION);
    assert!(!String::from_utf8_lossy(&bytes).contains("corrections"));
    // Motion corrections: read back whole.
    let h = motion_header();
    let f = format::read(&file(&h)).unwrap();
    assert_eq!((f.version, &f.header), (format::VERSION, &h));
    assert_eq!(format::read(&with_version(file(&h), 2)).unwrap().header, h);
    // A version-1 file with the version-2 field is refused by name.
    let e = format::read(&file_v1(&h)).unwrap_err();
    assert!(matches!(&e, ContainerError::Header(m) if m.contains("version 1") && m.contains("Motion")), "{e}");
    // Motion corrections without all three correction streams, or scaled ones.
    let mut bad = motion_header();
    bad.streams.pop();
    assert!(matches!(format::write_header(&bad).unwrap_err(), ContainerError::Header(_)));
    let mut bad = motion_header();
    bad.streams[2].scaled = true;
    assert!(matches!(format::write_header(&bad).unwrap_err(), ContainerError::Header(_)));
    let mut bad = motion_header();
    bad.codec = CodecKind::Gv;
    assert!(matches!(format::write_header(&bad).unwrap_err(), ContainerError::Header(_)));
}

#[test]
fn only_motion_files_leave_out_h_and_lambda_from_version_three() {
    let mut h = motion_header();
    h.streams.retain(|s| s.name != StreamName::H && s.name != StreamName::Lambda);
    let f = format::read(&file(&h)).unwrap();
    assert_eq!((f.version, &f.header, h.min_version()), (format::VERSION, &h, 3));
    assert_eq!(format::read(&with_version(file(&h), 3)).unwrap().header, h);
    // The same header in a version-2 file is refused by name.
    let e = format::read(&with_version(file(&h), 2)).unwrap_err();
    assert!(matches!(&e, ContainerError::Header(m) if m.contains("version 2") && m.contains("dx dy dz")), "{e}");
    // Scaled corrections still need H and lambda.
    let mut bad = h.clone();
    bad.corrections = CorrectionMode::Scaled;
    let e = format::write_header(&bad).unwrap_err();
    assert!(matches!(&e, ContainerError::Header(m) if m.contains("H and lambda")), "{e}");
    let mut bad = header();
    bad.streams.retain(|s| s.name != StreamName::Lambda);
    assert!(matches!(format::write_header(&bad).unwrap_err(), ContainerError::Header(_)));
}

#[test]
fn cycle_predictions_from_version_four() {
    let mut h = motion_header();
    h.frames = 6;
    h.max_lag = 3;
    // Frame f predicts with lag f - 1 (the longest its past allows) up to 3.
    let mut bytes = format::write_header(&h).unwrap();
    for f in 0..h.frames {
        let lag = (f as u8).saturating_sub(1).min(3);
        let info =
            format::FrameInfo { predictor: if lag >= 2 { code(3, lag) } else { code(1, 0) }, ..frame_info(&h, f) };
        let units: Vec<Vec<u8>> =
            (0..h.streams.len()).filter(|&s| h.stream_has_frame(s, f)).map(|s| unit(f, s)).collect();
        bytes.extend(format::write_frame(f, &info, &units.iter().map(Vec::as_slice).collect::<Vec<_>>()));
    }
    bytes.extend(format::write_chunk(format::TAG_END, 0, h.frames, &[]));
    let f = format::read(&bytes).unwrap();
    assert_eq!((f.version, h.min_version()), (format::VERSION, 4));
    assert_eq!(
        f.frames.iter().map(|i| (i.predictor.to_byte(), i.predictor.lag)).collect::<Vec<_>>(),
        [(1, 0), (1, 0), (1, 0), (3, 2), (3, 3), (3, 3)]
    );
    // The same file as version 3 is refused by name.
    let e = format::read(&with_version(bytes, 3)).unwrap_err();
    assert!(matches!(&e, ContainerError::Header(m) if m.contains("version 3") && m.contains("max_lag: 3")), "{e}");
    // A lag the header does not allow, one that reaches before frame 0,
    // and a lag below 2 (lag 1 is the velocity predictor).
    for (frame, lag) in [(5, 4), (2, 2), (3, 1)] {
        let mut bytes = format::write_header(&h).unwrap();
        for f in 0..=frame {
            let info = match f == frame {
                true => format::FrameInfo { predictor: PredictorCode { lag, ..code(3, 2) }, ..frame_info(&h, f) },
                false => format::FrameInfo { predictor: code(1, 0), ..frame_info(&h, f) },
            };
            let units: Vec<Vec<u8>> =
                (0..h.streams.len()).filter(|&s| h.stream_has_frame(s, f)).map(|s| unit(f, s)).collect();
            bytes.extend(format::write_frame(f, &info, &units.iter().map(Vec::as_slice).collect::<Vec<_>>()));
        }
        let e = format::read(&bytes).unwrap_err();
        assert!(
            matches!(&e, ContainerError::Chunk { msg, .. } if msg.contains(&format!("unknown predictor [3, {lag}, 0, 0] at frame {frame}"))),
            "{e}"
        );
    }
    // Cycle predictions need correction streams.
    let mut bad = header();
    bad.streams.retain(|s| s.name != StreamName::Dx && s.name != StreamName::Dy && s.name != StreamName::Dz);
    assert!(format::write_header(&bad).is_ok());
    bad.max_lag = 2;
    let e = format::write_header(&bad).unwrap_err();
    assert!(matches!(&e, ContainerError::Header(m) if m.contains("max_lag")), "{e}");
}

/// A motion file whose frame `f` asks for `filter(f)` averaging passes.
fn filtered_file(h: &Header, filter: impl Fn(u32) -> u8) -> Vec<u8> {
    let mut bytes = format::write_header(h).unwrap();
    for f in 0..h.frames {
        let info = format::FrameInfo { predictor: code(1, 0), filter: filter(f), ..frame_info(h, f) };
        let units: Vec<Vec<u8>> =
            (0..h.streams.len()).filter(|&s| h.stream_has_frame(s, f)).map(|s| unit(f, s)).collect();
        bytes.extend(format::write_frame(f, &info, &units.iter().map(Vec::as_slice).collect::<Vec<_>>()));
    }
    bytes.extend(format::write_chunk(format::TAG_END, 0, h.frames, &[]));
    bytes
}

#[test]
fn correction_filters_from_version_five() {
    let h = motion_header();
    let bytes = filtered_file(&h, |f| [0, 1, format::MAX_FILTER][f as usize % 3]);
    let f = format::read(&bytes).unwrap();
    assert_eq!(f.version, format::VERSION);
    assert_eq!(format::read(&with_version(bytes.clone(), 5)).unwrap().frames, f.frames);
    assert_eq!(f.frames.iter().map(|i| i.filter).collect::<Vec<_>>(), [0, 1, format::MAX_FILTER]);
    // A version-4 reader's file had the byte reserved: a filter there is
    // refused by name, no filter still reads.
    let e = format::read(&with_version(bytes, 4)).unwrap_err();
    assert!(
        matches!(&e, ContainerError::Chunk { msg, .. } if msg.contains("[1, 0, 1, 0] at frame 1") && msg.contains("version 4")),
        "{e}"
    );
    assert!(format::read(&with_version(filtered_file(&h, |_| 0), 4)).is_ok());
    // More passes than the format allows.
    let e = format::read(&filtered_file(&h, |f| if f == 2 { format::MAX_FILTER + 1 } else { 0 })).unwrap_err();
    assert!(matches!(&e, ContainerError::Chunk { msg, .. } if msg.contains("at frame 2")), "{e}");
}

#[test]
fn every_truncation_is_an_error() {
    for bytes in [file(&header()), file_v1(&header())] {
        for len in 0..bytes.len() {
            let e = format::read(&bytes[..len]).unwrap_err();
            assert!(matches!(e, ContainerError::Truncated { .. } | ContainerError::BadMagic), "length {len}: {e}");
        }
    }
}

#[test]
fn every_flipped_byte_is_an_error() {
    for bytes in [file(&header()), file_v1(&header())] {
        for i in 0..bytes.len() {
            for bit in [0x01u8, 0x80] {
                let mut b = bytes.clone();
                b[i] ^= bit;
                assert!(format::read(&b).is_err(), "flipping bit {bit:#x} of byte {i} went unnoticed");
            }
        }
    }
}

#[test]
fn absurd_sizes_and_counts_are_refused_without_allocating() {
    // A header length of 4 GiB.
    let mut bytes = file(&header());
    bytes[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(matches!(format::read(&bytes).unwrap_err(), ContainerError::TooLarge { what: "header length", .. }));
    // A chunk claiming 4 GiB.
    let h = header();
    let mut bytes = format::write_header(&h).unwrap();
    let mut chunk = format::write_chunk(format::TAG_ACCESS_UNIT, 0, 0, &[1, 2, 3]);
    chunk[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
    bytes.extend(chunk);
    assert!(matches!(format::read(&bytes).unwrap_err(), ContainerError::TooLarge { what: "chunk length", .. }));
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
        assert!(matches!(format::write_header(&bad).unwrap_err(), ContainerError::Header(_)), "{bad:?}");
    }
    // A valid header promising ten million frames, followed by one frame: an
    // error, after reading only what is there.
    let h = Header { frames: format::MAX_FRAMES, ..header() };
    let mut bytes = format::write_header(&h).unwrap();
    let info = format::FrameInfo { anchors: vec![[0.0; 3]; 4], ..Default::default() };
    bytes.extend(format::write_frame(0, &info, &[&[1], &[2], &[3]]));
    assert!(matches!(format::read(&bytes).unwrap_err(), ContainerError::Truncated { .. }));
    // An access unit length of 2^28 - 1 inside a small frame chunk.
    let mut bytes = format::write_header(&header()).unwrap();
    let mut payload = frame_info(&header(), 0).to_bytes();
    payload.extend([0xff, 0xff, 0xff, 0x7f, 1, 2, 3]);
    bytes.extend(format::write_chunk(format::TAG_FRAME, 0, 0, &payload));
    let e = format::read(&bytes).unwrap_err();
    assert!(matches!(&e, ContainerError::Chunk { msg, .. } if msg.contains("overruns")), "{e}");
}

#[test]
fn chunks_out_of_order_or_extra_are_errors() {
    let h = header();
    let mut bytes = header_v1(&h);
    bytes.extend(format::write_chunk(format::TAG_ACCESS_UNIT, 1, 0, &[1]));
    assert!(matches!(format::read(&bytes).unwrap_err(), ContainerError::Chunk { .. }));
    for mut bytes in [file(&h), file_v1(&h)] {
        bytes.extend(format::write_chunk(format::TAG_END, 0, 3, &[]));
        assert!(matches!(format::read(&bytes).unwrap_err(), ContainerError::Chunk { .. }));
    }
    let mut bytes = format::write_header(&h).unwrap();
    bytes.extend(format::write_chunk(*b"JUNK", 0, 0, &[1]));
    assert!(matches!(format::read(&bytes).unwrap_err(), ContainerError::Chunk { .. }));
    // Version 2: no access unit chunks, and frames in order.
    let mut bytes = format::write_header(&h).unwrap();
    bytes.extend(format::write_chunk(format::TAG_ACCESS_UNIT, 0, 0, &[1]));
    assert!(matches!(format::read(&bytes).unwrap_err(), ContainerError::Chunk { .. }));
    let mut bytes = format::write_header(&h).unwrap();
    bytes.extend(format::write_frame(1, &frame_info(&h, 1), &[&[1], &[2]]));
    assert!(matches!(format::read(&bytes).unwrap_err(), ContainerError::Chunk { .. }));
}

#[test]
fn bad_frame_chunks_are_errors() {
    let h = header();
    let good = format::FrameInfo {
        predictor: code(1, 0),
        filter: 0,
        relax: 0,
        correction_scale: 1.0,
        anchors: vec![[0.0; 3]; 4],
        seed_origin: None,
        loose: None,
        bones: None,
        mesh: None,
        residual: None,
    };
    let mut bad_bytes = good.to_bytes();
    bad_bytes.pop();
    // The byte after the filter, reserved before version 9 (relaxation).
    let mut reserved = good.to_bytes();
    reserved[3] = 1;
    let cases: Vec<Vec<u8>> = vec![
        {
            let mut b = good.to_bytes();
            b[0] = format::MAX_PREDICTOR + 1;
            b
        },
        format::FrameInfo { predictor: PredictorCode { lag: 0, ..code(3, 2) }, ..good.clone() }.to_bytes(),
        // A skinned prediction in a file without bones (version 13), and
        // the skinned bit beside another extrapolation.
        {
            let mut b = good.to_bytes();
            b[0] = format::predictor::SKINNED_BIT;
            b
        },
        {
            let mut b = good.to_bytes();
            b[0] = format::predictor::SKINNED_BIT | 1;
            b
        },
        // A cycle prediction in a file whose header allows no lag, and a lag
        // on another predictor.
        format::FrameInfo { predictor: code(3, 2), ..good.clone() }.to_bytes(),
        format::FrameInfo { predictor: PredictorCode { lag: 2, ..code(1, 0) }, ..good.clone() }.to_bytes(),
        // A filter in a version-1 file, and more passes than any version allows.
        format::FrameInfo { filter: 1, ..good.clone() }.to_bytes(),
        format::FrameInfo { filter: format::MAX_FILTER + 1, ..good.clone() }.to_bytes(),
        reserved,
        format::FrameInfo { correction_scale: -1.0, ..good.clone() }.to_bytes(),
        format::FrameInfo { correction_scale: f32::INFINITY, ..good.clone() }.to_bytes(),
        format::FrameInfo { anchors: vec![[f32::NAN, 0.0, 0.0]; 4], ..good.clone() }.to_bytes(),
        format::FrameInfo { anchors: vec![[0.0; 3]; 5], ..good.clone() }.to_bytes(),
        bad_bytes,
    ];
    for payload in &cases {
        let mut bytes = header_v1(&h);
        bytes.extend(format::write_chunk(format::TAG_FRAME, 0, 0, payload));
        bytes.extend(format::write_chunk(format::TAG_ACCESS_UNIT, 0, 0, &[1]));
        let e = format::read(&bytes).unwrap_err();
        assert!(matches!(e, ContainerError::Chunk { .. }), "{payload:?}: {e}");
    }
    // Version 2 and later: the same side data, then the frame's three access units
    // (frame 0 has streams 0, 1 and 2), or too few, too many, bad lengths.
    let units = |side: &[u8], rest: &[u8]| [side, rest].concat();
    let good_units: &[u8] = &[1, 7, 1, 8, 1, 9];
    let mut v2: Vec<Vec<u8>> = cases[..cases.len() - 1].iter().map(|c| units(c, good_units)).collect();
    v2.push(units(&good.to_bytes(), &[1, 7, 1, 8]));
    v2.push(units(&good.to_bytes(), &[1, 7, 1, 8, 1, 9, 0]));
    v2.push(units(&good.to_bytes(), &[1, 7, 1, 8, 5, 9]));
    v2.push(units(&good.to_bytes(), &[1, 7, 1, 8, 0x80, 0x80, 0x80, 0x80, 0x01]));
    v2.push(good.to_bytes()[..10].to_vec());
    for payload in v2 {
        // As version 4, whose filter byte was reserved.
        let mut bytes = with_version(format::write_header(&h).unwrap(), 4);
        bytes.extend(format::write_chunk(format::TAG_FRAME, 0, 0, &payload));
        let e = format::read(&bytes).unwrap_err();
        assert!(matches!(e, ContainerError::Chunk { .. }), "{payload:?}: {e}");
    }
    let mut ok = format::write_header(&h).unwrap();
    ok.extend(format::write_chunk(format::TAG_FRAME, 0, 0, &units(&good.to_bytes(), good_units)));
    assert!(matches!(format::read(&ok).unwrap_err(), ContainerError::Truncated { .. }));
}

#[test]
fn streaming_reader_sees_frames_as_they_arrive() {
    let h = header();
    for bytes in [file(&h), file_v1(&h)] {
        streams_byte_by_byte(&h, &bytes);
    }
}

fn streams_byte_by_byte(h: &Header, bytes: &[u8]) {
    let whole = format::read(bytes).unwrap();
    // Byte by byte: the frame count only grows, and the result is the same file.
    let mut r = format::StreamReader::default();
    let mut seen = vec![];
    for b in bytes {
        r.push(std::slice::from_ref(b)).unwrap();
        seen.push(r.complete_frames());
    }
    assert!(seen.windows(2).all(|w| w[0] <= w[1]) && seen.contains(&1) && seen.contains(&2));
    assert!(r.is_complete() && r.header() == Some(h));
    let f = r.finish().unwrap();
    assert_eq!((f.units, f.frames, f.bytes), (whole.units, whole.frames, whole.bytes));
    // Half a file: not complete, and finishing says truncated.
    let mut r = format::StreamReader::default();
    r.push(&bytes[..bytes.len() / 2]).unwrap();
    assert!(!r.is_complete() && r.complete_frames() < 3);
    assert!(matches!(r.finish().unwrap_err(), ContainerError::Truncated { .. }));
    // A flipped byte in the second half is caught when it arrives.
    let mut bad = bytes.to_vec();
    let k = bytes.len() * 3 / 4;
    bad[k] ^= 0x40;
    let mut r = format::StreamReader::default();
    r.push(&bad[..k - 10]).unwrap();
    assert!(r.push(&bad[k - 10..]).is_err());
}

/// A tetrahedron as a file carries it.
fn source_mesh() -> format::SourceMesh {
    format::SourceMesh {
        faces: vec![[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]],
        places: vec![[0, 0], [u32::MAX, 0], [0, u32::MAX], [1 << 31, 3 << 30]],
        offsets: None,
        loose_of: Vec::new(),
        loose_anchors: Vec::new(),
    }
}

/// `h`'s file with `chunk` right after the header (and `h` saying a source
/// mesh of `info` is there).
fn file_with_source(h: &Header, info: format::SourceMeshInfo, chunk: Vec<u8>) -> Vec<u8> {
    let h = Header { source_mesh: Some(info), ..h.clone() };
    let plain = file(&h);
    let header_len = format::parse_header(&plain).unwrap().unwrap().1;
    [&plain[..header_len], &chunk, &plain[header_len..]].concat()
}

/// `mesh` as versions 6 to 11 describe it (no walk).
fn plain_info(mesh: &format::SourceMesh) -> format::SourceMeshInfo {
    format::SourceMeshInfo { walk: false, around: false, ..mesh.info() }
}

/// `mesh`'s chunk as versions 6 to 11 write it.
fn plain_chunk(mesh: &format::SourceMesh) -> Vec<u8> {
    format::write_chunk(format::TAG_SOURCE_MESH, 0, 0, &mesh.to_bytes_plain())
}

/// Version 16: a header with frame meshes needs version 16, and cannot
/// also have one source mesh; a frame without its mesh unit is refused.
#[test]
fn frame_meshes_need_version_16_and_no_source_mesh() {
    let mesh = source_mesh();
    let h = Header { frame_meshes: true, ..header() };
    assert_eq!(h.min_version(), 16);
    let both = Header { source_mesh: Some(mesh.info()), ..h.clone() };
    assert!(format::write_header(&both).unwrap_err().to_string().contains("frame meshes"));
    // The frames of `file` have no mesh unit: the first is refused by name.
    let err = format::read(&file(&h)).unwrap_err().to_string();
    assert!(err.contains("frame 0's mesh"), "{err}");
}

#[test]
fn version_six_carries_the_source_mesh() {
    let (h, mesh) = (header(), source_mesh());
    let bytes = file_with_source(&h, plain_info(&mesh), plain_chunk(&mesh));
    let f = format::read(&bytes).unwrap();
    assert_eq!((f.version, f.header.min_version()), (format::VERSION, 6));
    assert_eq!(f.source_mesh.as_ref(), Some(&mesh));
    assert_eq!(f.frames.len(), h.frames as usize);
    // Byte by byte, as a stream: the same file.
    let mut r = format::StreamReader::default();
    for b in &bytes {
        r.push(std::slice::from_ref(b)).unwrap();
    }
    assert_eq!(r.finish().unwrap().source_mesh, Some(mesh.clone()));
    // A version-5 reader's file cannot hold it.
    let e = format::read(&with_version(bytes, 5)).unwrap_err();
    assert!(matches!(&e, ContainerError::Header(m) if m.contains("version 5")), "{e}");
    // Files without it are as before.
    assert!(format::read(&file(&h)).unwrap().source_mesh.is_none());
}

/// A sheet of `n` x `n` quads, two faces each, in a scrambled order, with
/// places on the grid (16 low bits zero, as the encoder leaves them) and
/// small offsets.
fn larger_source_mesh(n: u32) -> format::SourceMesh {
    let (_, mut faces) = common::sheet(n as usize);
    // Scrambled as a scan's faces come: by a hash of their first vertex.
    faces.sort_by_key(|f| (f[0] * 7919 + f[1]) % 1021);
    let step = 65535 / n;
    let places = (0..(n + 1) * (n + 1)).map(|v| [((v % (n + 1)) * step) << 16, ((v / (n + 1)) * step + v % 3) << 16]);
    let places = places.collect();
    let offsets: Vec<[f32; 3]> = (0..(n + 1) * (n + 1)).map(|v| [0.0, 0.0, (v % 7) as f32 * 1e-3]).collect();
    format::SourceMesh {
        faces,
        places,
        offsets: format::Offsets::quantize(&offsets, 1e-4),
        loose_of: Vec::new(),
        loose_anchors: Vec::new(),
    }
}

/// `faces` with each face's rotation kept, in a canonical order.
fn face_set(faces: &[[u32; 3]]) -> Vec<[u32; 3]> {
    let mut f = faces.to_vec();
    f.sort();
    f
}

#[test]
fn version_twelve_codes_faces_as_a_walk_and_places_from_predictions() {
    let h = header();
    // Version 12's references, and version 20's (next new vertex, neighbours).
    for (around, version) in [(false, 12), (true, 20)] {
        for mesh in [source_mesh(), larger_source_mesh(24)] {
            let info = format::SourceMeshInfo { around, ..mesh.info() };
            let chunk = format::write_chunk(format::TAG_SOURCE_MESH, 0, 0, &mesh.to_bytes_with(around));
            let bytes = file_with_source(&h, info, chunk);
            let f = format::read(&bytes).unwrap();
            assert_eq!((f.version, f.header.min_version()), (format::VERSION, version));
            let back = f.source_mesh.unwrap();
            // Every face with its vertices in their order, perhaps in another
            // order of faces; every vertex's place and offset exactly.
            assert_eq!(face_set(&back.faces), face_set(&mesh.faces));
            assert_eq!((&back.places, &back.offsets), (&mesh.places, &mesh.offsets));
            // A file of the version before cannot hold it.
            let e = format::read(&with_version(bytes, version - 1)).unwrap_err();
            let before = format!("version {}", version - 1);
            assert!(matches!(&e, ContainerError::Header(m) if m.contains(&before)), "{e}");
        }
    }
    // Smaller than versions 6 to 11 stored it: scrambled faces walked, places predicted.
    let mesh = larger_source_mesh(24);
    let (walked, plain) = (mesh.to_bytes().len(), mesh.to_bytes_plain().len());
    assert!(walked * 2 < plain, "{walked} against {plain}");
}

#[test]
fn broken_version_twelve_source_meshes_are_errors_never_panics() {
    let h = header();
    let mesh = larger_source_mesh(6);
    let info = mesh.info();
    let raw = miniz_oxide::inflate::decompress_to_vec(&mesh.to_bytes()).unwrap();
    let chunk = |raw: &[u8]| {
        let deflated = miniz_oxide::deflate::compress_to_vec(raw, 6);
        format::write_chunk(format::TAG_SOURCE_MESH, 0, 0, &deflated)
    };
    // Cut anywhere: an error naming the source mesh.
    for cut in 0..raw.len() {
        let e = format::read(&file_with_source(&h, info, chunk(&raw[..cut]))).unwrap_err();
        assert!(matches!(&e, ContainerError::Chunk { msg, .. } if msg.contains("source mesh")), "{cut}: {e}");
    }
    // Any byte changed: an error, or a mesh whose every index is in range.
    for i in 0..raw.len() {
        for b in [0u8, 1, 2, 17, 48, 0x7f, 0x80, 0xff] {
            let mut c = raw.clone();
            c[i] = b;
            if let Ok(f) = format::read(&file_with_source(&h, info, chunk(&c))) {
                let m = f.source_mesh.unwrap();
                assert!(m.faces.iter().flatten().all(|&v| v < info.vertices) && m.places.len() == mesh.places.len());
            }
        }
    }
    // An order or a place shift this reader does not know.
    for (at, b, want) in [(0, 2, "face order 2"), (1, 17, "place shift 17")] {
        let mut c = raw.clone();
        c[at] = b;
        let e = format::read(&file_with_source(&h, info, chunk(&c))).unwrap_err();
        assert!(e.to_string().contains(want), "{e}");
    }
}

#[test]
fn bad_source_meshes_are_errors() {
    let (h, mesh) = (header(), source_mesh());
    let info = plain_info(&mesh);
    let chunk = |payload: &[u8]| format::write_chunk(format::TAG_SOURCE_MESH, 0, 0, payload);
    let deflate = |raw: &[u8]| miniz_oxide::deflate::compress_to_vec(raw, 6);
    let mut past_end = source_mesh();
    past_end.faces[2][1] = 4;
    let cases: Vec<(&str, Vec<u8>)> = vec![
        // The header says a source mesh, the frame chunk comes first.
        ("expected the source mesh", file_with_source(&h, info, Vec::new())),
        ("uses vertex 4", file_with_source(&h, info, plain_chunk(&past_end))),
        ("does not inflate", file_with_source(&h, info, chunk(&[1, 2, 3, 4]))),
        // More bytes than the counts allow (a deflate bomb): refused while inflating.
        ("does not inflate", file_with_source(&h, info, chunk(&deflate(&vec![0u8; 1 << 20])))),
        // Counts that disagree with the payload.
        ("vertex places", file_with_source(&h, format::SourceMeshInfo { vertices: 5, ..info }, plain_chunk(&mesh))),
        ("vertex places", file_with_source(&h, format::SourceMeshInfo { faces: 5, ..info }, plain_chunk(&mesh))),
    ];
    for (want, bytes) in cases {
        let e = format::read(&bytes).unwrap_err();
        assert!(matches!(&e, ContainerError::Chunk { msg, .. } if msg.contains(want)), "{want}: {e}");
    }
    // Counts past the limits, in the header itself.
    for info in [
        format::SourceMeshInfo { vertices: 2, faces: 1, offset_step: None, loose: None, walk: false, around: false },
        format::SourceMeshInfo { vertices: 3, faces: 0, offset_step: None, loose: None, walk: false, around: false },
        format::SourceMeshInfo {
            vertices: 3,
            faces: 1,
            offset_step: Some(0.0),
            loose: None,
            walk: false,
            around: false,
        },
        format::SourceMeshInfo {
            vertices: 3,
            faces: 1,
            offset_step: Some(f32::NAN),
            loose: None,
            walk: false,
            around: false,
        },
    ] {
        let e = format::write_header(&Header { source_mesh: Some(info), ..h.clone() }).unwrap_err();
        assert!(matches!(&e, ContainerError::Header(m) if m.contains("source mesh")), "{e}");
    }
}

#[test]
fn version_seven_carries_vertex_offsets() {
    let h = header();
    let mesh = format::SourceMesh {
        offsets: format::Offsets::quantize(&[[0.5, -0.25, 0.0], [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0; 3]], 1e-6),
        ..source_mesh()
    };
    let offsets = mesh.offsets.as_ref().unwrap();
    assert_eq!(offsets.values[2], [-32767, 0, 0]);
    assert!((offsets.get(0)[0] - 0.5).abs() < 1e-4);
    let bytes = file_with_source(&h, plain_info(&mesh), plain_chunk(&mesh));
    let f = format::read(&bytes).unwrap();
    assert_eq!((f.version, f.header.min_version()), (format::VERSION, 7));
    assert_eq!(f.source_mesh.as_ref(), Some(&mesh));
    // A version-6 file cannot hold them.
    let e = format::read(&with_version(bytes, 6)).unwrap_err();
    assert!(matches!(&e, ContainerError::Header(m) if m.contains("version 6")), "{e}");
    // The header saying offsets that the chunk lacks (or the other way round).
    let plain = source_mesh();
    let with_step = format::SourceMeshInfo { offset_step: Some(1.0), ..plain_info(&plain) };
    for (info, m) in [(with_step, &plain), (plain_info(&plain), &mesh)] {
        let e = format::read(&file_with_source(&h, info, plain_chunk(m))).unwrap_err();
        assert!(matches!(&e, ContainerError::Chunk { msg, .. } if msg.contains("offsets")), "{e}");
    }
    // No offsets to keep: none written.
    assert!(format::Offsets::quantize(&[[0.0; 3]; 4], 1e-6).is_none());
    // A coarse finest step wins over the largest offset's.
    assert_eq!(format::Offsets::quantize(&[[1.0, 0.0, 0.0]], 0.01).unwrap().values[0], [100, 0, 0]);
}

/// The tetrahedron's look: a UV per vertex and a (not decoded) PNG.
fn look() -> format::Appearance {
    format::Appearance {
        uvs: vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.5, 0.5]],
        base_color: [1.0, 0.5, 0.25, 1.0],
        texture: Some(("image/png".into(), b"\x89PNG\r\n\x1a\n-not-decoded".to_vec())),
    }
}

/// `h`'s file with the tetrahedron and `chunk` as its appearance chunk.
fn file_with_look(h: &Header, info: format::AppearanceInfo, chunk: Vec<u8>) -> Vec<u8> {
    let mesh = source_mesh();
    let h = Header { appearance: Some(info), ..h.clone() };
    file_with_source(&h, plain_info(&mesh), [plain_chunk(&mesh), chunk].concat())
}

#[test]
fn version_eight_carries_the_look() {
    let (h, look) = (header(), look());
    let bytes = file_with_look(&h, look.info(), format::write_appearance(&look));
    let f = format::read(&bytes).unwrap();
    assert_eq!((f.version, f.header.min_version()), (format::VERSION, 8));
    assert_eq!(f.appearance.as_ref(), Some(&look));
    let mut r = format::StreamReader::default();
    for c in bytes.chunks(7) {
        r.push(c).unwrap();
    }
    assert_eq!(r.finish().unwrap().appearance, Some(look.clone()));
    let e = format::read(&with_version(bytes, 7)).unwrap_err();
    assert!(matches!(&e, ContainerError::Header(m) if m.contains("version 7")), "{e}");
    // Without a texture, too.
    let plain = format::Appearance { texture: None, ..look };
    let f = format::read(&file_with_look(&h, plain.info(), format::write_appearance(&plain))).unwrap();
    assert_eq!(f.appearance, Some(plain));
}

#[test]
fn bad_looks_are_errors() {
    let (h, look) = (header(), look());
    let info = look.info();
    let chunk = |payload: &[u8]| format::write_chunk(format::TAG_APPEARANCE, 0, 0, payload);
    let good = look.to_bytes();
    let mut nan = look.clone();
    nan.uvs[2][1] = f32::NAN;
    let three = format::Appearance { uvs: look.uvs[..3].to_vec(), ..look.clone() };
    let cases: Vec<(&str, Vec<u8>)> = vec![
        ("expected the appearance", file_with_look(&h, info.clone(), Vec::new())),
        ("texture image", file_with_look(&h, info.clone(), chunk(&good[..good.len() - 1]))),
        ("texture image", file_with_look(&h, info.clone(), chunk(&[&good[..], b"x"].concat()))),
        ("not finite", file_with_look(&h, info.clone(), format::write_appearance(&nan))),
        ("texture coordinates", file_with_look(&h, info.clone(), format::write_appearance(&three))),
        ("cut short", file_with_look(&h, info.clone(), chunk(&[0x80]))),
    ];
    for (want, bytes) in cases {
        let e = format::read(&bytes).unwrap_err();
        assert!(matches!(&e, ContainerError::Chunk { msg, .. } if msg.contains(want)), "{want}: {e}");
    }
    // What the header itself may not say.
    let gif = format::AppearanceInfo {
        texture: Some(format::TextureInfo { mime: "image/gif".into(), bytes: 3 }),
        ..info.clone()
    };
    let bright = format::AppearanceInfo { base_color: [2.0, 0.0, 0.0, 1.0], ..info.clone() };
    for (want, h) in [
        ("image/gif", Header { appearance: Some(gif), source_mesh: Some(source_mesh().info()), ..h.clone() }),
        ("base colour", Header { appearance: Some(bright), source_mesh: Some(source_mesh().info()), ..h.clone() }),
        ("needs a source mesh", Header { appearance: Some(info), ..h.clone() }),
    ] {
        let e = format::write_header(&h).unwrap_err();
        assert!(matches!(&e, ContainerError::Header(m) if m.contains(want)), "{want}: {e}");
    }
}

#[test]
fn a_normal_correction_and_shrunk_streams_need_version_nine() {
    // dx, dy, dz at half size beside a full-size dn: read back whole, and
    // only as version 9.
    let mut h = Header { grid: 32, ..motion_header() };
    h.streams.iter_mut().filter(|s| s.name.is_correction()).for_each(|s| s.shrink = 1);
    let mut dn = h.streams[2].clone();
    (dn.name, dn.shrink) = (StreamName::Dn, 0);
    h.streams.push(dn);
    let bytes = file(&h);
    let f = format::read(&bytes).unwrap();
    assert_eq!((f.version, h.min_version(), &f.header), (format::VERSION, 9, &h));
    assert_eq!(format::read(&with_version(bytes.clone(), 9)).unwrap().header, h);
    assert_eq!(f.header.correction_streams().unwrap().len(), 4);
    assert_eq!(f.header.streams[2].size(32), 16);
    assert!(String::from_utf8_lossy(&bytes).contains("\"shrink\":1"));
    let e = format::read(&with_version(bytes, 8)).unwrap_err();
    assert!(matches!(&e, ContainerError::Header(m) if m.contains("version 9")), "{e}");
    // A world-axes file says nothing of either.
    assert!(!String::from_utf8_lossy(&file(&motion_header())).contains("shrink"));

    let refused = |h: &Header, what: &str| {
        let e = format::write_header(h).unwrap_err();
        assert!(matches!(&e, ContainerError::Header(m) if m.contains(what)), "{e}");
    };
    // Shrunk without dn, or a stream that is not a correction.
    let mut bad = motion_header();
    bad.streams[2].shrink = 1;
    refused(&bad, "only dx, dy, dz beside dn");
    let mut bad = h.clone();
    bad.streams[0].shrink = 1;
    refused(&bad, "only dx, dy, dz beside dn");
    // Below H.264's 16 samples a side: N = 32 halved twice is 8.
    let mut bad = h.clone();
    bad.streams[2..5].iter_mut().for_each(|s| s.shrink = 2);
    refused(&bad, "at least 16");
    // dx, dy, dz of different sizes, or dn without them.
    let mut bad = h.clone();
    bad.grid = 64;
    bad.anchors.clear();
    bad.streams[2].shrink = 2;
    refused(&bad, "all three the same size");
    let mut bad = h.clone();
    bad.streams.retain(|s| s.name.axis().is_none() || !s.name.is_correction());
    refused(&bad, "with or without dn");
}

/// A motion header with a seed stream (`first`) and random-access points
/// every 3 of 7 frames (format version 10), each a key frame.
fn random_access_header() -> Header {
    let mut h = motion_header();
    h.frames = 7;
    h.max_lag = 3;
    h.key_frames = vec![0, 2, 3, 6];
    h.random_access = Some(3);
    h.streams.push(StreamInfo {
        name: StreamName::SeedX,
        layer: 1,
        refines: None,
        quant: Quantizer::new(-1.0, 1.0),
        coverage: Coverage::First,
        scaled: false,
        shrink: 0,
    });
    h
}

/// A file of `h` whose frames predict with `predictor(f)`, with the
/// random-access index if `h` has points (offsets as written unless `lie`
/// changes them).
fn file_with_points(h: &Header, predictor: impl Fn(u32) -> PredictorCode, lie: impl Fn(&mut Vec<u64>)) -> Vec<u8> {
    let mut out = format::write_header(h).unwrap();
    let mut index = Vec::new();
    for f in 0..h.frames {
        if h.is_random_access_point(f) {
            index.push(out.len() as u64);
        }
        let info = format::FrameInfo { predictor: predictor(f), ..frame_info(h, f) };
        let units: Vec<Vec<u8>> =
            (0..h.streams.len()).filter(|&s| h.stream_has_frame(s, f)).map(|s| unit(f, s)).collect();
        out.extend(format::write_frame(f, &info, &units.iter().map(Vec::as_slice).collect::<Vec<_>>()));
    }
    lie(&mut index);
    if h.random_access.is_some() {
        out.extend(format::write_index(&index));
    }
    out.extend(format::write_chunk(format::TAG_END, 0, h.frames, &[]));
    out
}

#[test]
fn loose_vertices_from_version_eleven() {
    // The tetrahedron's last two vertices are loose vertices 1 and 0,
    // following grid samples 3 and 7.
    let with =
        |loose_of: Vec<u32>, loose_anchors: Vec<u32>| format::SourceMesh { loose_of, loose_anchors, ..source_mesh() };
    let (h, mesh) = (header(), with(vec![0, 0, 2, 1], vec![3, 7]));
    assert_eq!(plain_info(&mesh).loose, Some(2));
    let bytes = file_with_source(&h, plain_info(&mesh), plain_chunk(&mesh));
    let f = format::read(&bytes).unwrap();
    assert_eq!((f.version, f.header.min_version(), f.header.loose_vertices()), (format::VERSION, 11, Some(2)));
    assert_eq!(f.source_mesh.as_ref(), Some(&mesh));
    for (k, info) in f.frames.iter().enumerate() {
        let l = format::LooseFrame::parse(info.loose.as_ref().unwrap(), 2, 0).unwrap();
        assert_eq!((l.step, &l.residuals), (0.25, &vec![[0, 0, k as i32], [1, -1, k as i32]]));
    }
    streams_byte_by_byte(&f.header, &bytes);
    // A version-10 file cannot have them.
    let e = format::read(&with_version(bytes.clone(), 10)).unwrap_err();
    assert!(matches!(&e, ContainerError::Header(m) if m.contains("version 10")), "{e}");
    // Every truncation is caught.
    for len in 0..bytes.len() {
        assert!(format::read(&bytes[..len]).is_err(), "length {len}");
    }
    // The header and the mesh must agree on the loose vertices: a count
    // past the mesh's, a vertex naming one past the count, one unnamed, an
    // anchor missing.
    for loose in [Some(0), Some(5)] {
        assert!(format::SourceMeshInfo { loose, ..plain_info(&mesh) }.validate().is_err(), "{loose:?}");
    }
    for bad in [with(vec![0, 0, 3, 1], vec![3, 7]), with(vec![0, 0, 1, 1], vec![3, 7]), with(vec![0, 0, 2, 1], vec![3])]
    {
        let e = format::read(&file_with_source(&h, plain_info(&mesh), plain_chunk(&bad))).unwrap_err();
        assert!(matches!(&e, ContainerError::Chunk { msg, .. } if msg.contains("loose")), "{e}");
    }
    // Frames without the loose unit the header promises.
    let no_loose =
        Header { source_mesh: Some(format::SourceMeshInfo { loose: None, ..plain_info(&mesh) }), ..h.clone() };
    let frames = file(&no_loose);
    let frames = &frames[format::parse_header(&frames).unwrap().unwrap().1..];
    let prefix = &bytes[..format::parse_header(&bytes).unwrap().unwrap().1];
    let without = [prefix, &plain_chunk(&mesh), frames].concat();
    let e = format::read(&without).unwrap_err();
    assert!(matches!(&e, ContainerError::Chunk { msg, .. } if msg.contains("loose")), "{e}");
}

#[test]
fn random_access_points_and_their_index_from_version_ten() {
    let h = random_access_header();
    let bytes = file_with_points(&h, |_| code(1, 0), |_| {});
    let f = format::read(&bytes).unwrap();
    assert_eq!((f.version, h.min_version(), h.random_access_points()), (format::VERSION, 10, 3));
    // The seed has a picture at each point (0, 3, 6) and nowhere else.
    let seed = h.stream(StreamName::SeedX).unwrap();
    assert_eq!(f.units[seed].iter().map(|u| !u.is_empty()).collect::<Vec<_>>(), [1, 0, 0, 1, 0, 0, 1].map(|b| b == 1));
    assert_eq!((h.random_access_point(5), h.random_access_point(6)), (3, 6));
    // The index the reader checked: each offset is its point's frame chunk,
    // and a player holding the header finds it in the file's tail.
    assert_eq!(f.index.len(), 3);
    for (k, &o) in f.index.iter().enumerate() {
        let o = o as usize;
        assert_eq!(&bytes[o..o + 4], b"FRAM");
        assert_eq!(u32::from_le_bytes(bytes[o + 8..o + 12].try_into().unwrap()), 3 * k as u32);
    }
    let tail = &bytes[bytes.len() - format::index_tail_bytes(&h) as usize..];
    assert_eq!(format::parse_index_tail(&h, tail).unwrap(), f.index);
    assert!(format::parse_index_tail(&h, &tail[1..]).is_err());
    streams_byte_by_byte(&h, &bytes);
    // A version-9 file cannot have them.
    let e = format::read(&with_version(bytes.clone(), 9)).unwrap_err();
    assert!(matches!(&e, ContainerError::Header(m) if m.contains("version 10")), "{e}");
    // Every truncation and flipped byte is caught.
    for len in 0..bytes.len() {
        assert!(format::read(&bytes[..len]).is_err(), "length {len}");
    }
    for i in 0..bytes.len() {
        let mut b = bytes.clone();
        b[i] ^= 0x10;
        assert!(format::read(&b).is_err(), "flipping byte {i} went unnoticed");
    }
}

#[test]
fn a_wrong_or_missing_index_and_bad_points_are_refused() {
    let h = random_access_header();
    // An index whose offsets (CRC and all) do not match the chunks.
    for lie in [|i: &mut Vec<u64>| i[1] += 1, |i: &mut Vec<u64>| i.truncate(2), |i: &mut Vec<u64>| i.push(1 << 40)] {
        let e = format::read(&file_with_points(&h, |_| code(1, 0), lie)).unwrap_err();
        assert!(matches!(&e, ContainerError::Chunk { msg, .. } if msg.contains("random-access index")), "{e}");
    }
    // No index before the end chunk.
    let mut bytes = file(&h);
    let e = format::read(&bytes).unwrap_err();
    assert!(matches!(&e, ContainerError::Chunk { msg, .. } if msg.contains("the random-access index")), "{e}");
    // A point that is not a key frame, and an interval of 0.
    let mut bad = h.clone();
    bad.key_frames = vec![0, 2, 6];
    let e = format::write_header(&bad).unwrap_err();
    assert!(matches!(&e, ContainerError::Header(m) if m.contains("point 3 is not a key frame")), "{e}");
    bad.random_access = Some(0);
    assert!(format::write_header(&bad).is_err());
    // Segments (version 15): increasing frames past 0, each a key frame,
    // in a file with points.
    for (segments, points) in [(vec![0], Some(3)), (vec![5, 4], Some(3)), (vec![2], Some(3)), (vec![4], None)] {
        let mut bad = h.clone();
        bad.key_frames = vec![0, 3, 4, 5, 6];
        (bad.segments, bad.random_access) = (segments, points);
        assert!(format::write_header(&bad).is_err(), "{:?} {:?}", bad.segments, bad.random_access);
    }
    // A segment at 4 between the points 3 and 6: four offsets, and the
    // reader finds each (a lie about the new one is caught).
    let mut seg = h.clone();
    (seg.key_frames, seg.segments) = (vec![0, 2, 3, 4, 6], vec![4]);
    let f = format::read(&file_with_points(&seg, |_| code(1, 0), |_| {})).unwrap();
    assert_eq!((f.header.min_version(), f.index.len(), f.header.point_frame(2)), (15, 4, Some(4)));
    assert!(format::read(&file_with_points(&seg, |_| code(1, 0), |i| i[2] += 1)).is_err());
    // A cycle prediction may not reach back past the last point: at frame
    // 5 (point 3) lag 2 would read frame 2's velocity.
    let lagged = |at: u32, lag: u8| move |f: u32| if f == at { code(3, lag) } else { code(1, 0) };
    bytes = file_with_points(&h, lagged(5, 2), |_| {});
    let e = format::read(&bytes).unwrap_err();
    assert!(matches!(&e, ContainerError::Chunk { msg, .. } if msg.contains("[3, 2, 0, 0] at frame 5")), "{e}");
    assert!(format::read(&file_with_points(&h, lagged(2, 2), |_| {})).is_err());
    // Without points, the same lag at frame 5 reads.
    let mut plain = h.clone();
    plain.random_access = None;
    assert!(format::read(&file_with_points(&plain, lagged(5, 2), |_| {})).is_ok());
}

#[test]
fn a_file_with_a_segment_read_in_pieces_from_its_points() {
    // Points 0, 3, 4 (the segment) and 6: the segment's point is fetched
    // first, then the rest, as a page seeking there would.
    let mut h = random_access_header();
    (h.key_frames, h.segments) = (vec![0, 2, 3, 4, 6], vec![4]);
    let bytes = file_with_points(&h, |_| code(1, 0), |_| {});
    let whole = format::read(&bytes).unwrap();
    let idx: Vec<usize> = whole.index.iter().map(|&o| o as usize).collect();
    let tail = &bytes[bytes.len() - format::index_tail_bytes(&h) as usize..];
    let mut r = format::StreamReader::default();
    r.push(&bytes[..idx[0]]).unwrap();
    r.set_index(format::parse_index_tail(&h, tail).unwrap()).unwrap();
    r.jump(2).unwrap();
    r.push(&bytes[idx[2]..idx[3]]).unwrap();
    assert_eq!((0..7).map(|f| r.frame_arrived(f)).collect::<Vec<_>>(), [0, 0, 0, 0, 1, 1, 0].map(|b| b == 1));
    r.jump(0).unwrap();
    r.push(&bytes[idx[0]..idx[2]]).unwrap();
    r.jump(3).unwrap();
    r.push(&bytes[idx[3]..]).unwrap();
    assert!(r.is_complete() && r.complete_frames() == 7);
    assert_eq!(r.finish().unwrap().frames, whole.frames);
}

#[test]
fn a_version_ten_file_read_in_pieces_from_its_points() {
    // As a page fetching by range requests: the header, the index from the
    // tail, then point 2's frames, then the rest from point 0.
    let h = random_access_header();
    let bytes = file_with_points(&h, |_| code(1, 0), |_| {});
    let whole = format::read(&bytes).unwrap();
    let idx: Vec<usize> = whole.index.iter().map(|&o| o as usize).collect();
    let tail = &bytes[bytes.len() - format::index_tail_bytes(&h) as usize..];
    let mut r = format::StreamReader::default();
    r.push(&bytes[..idx[0] + 5]).unwrap();
    assert!(r.jump(2).is_err(), "a jump needs the index first");
    r.set_index(format::parse_index_tail(&h, tail).unwrap()).unwrap();
    r.jump(2).unwrap();
    r.push(&bytes[idx[2]..]).unwrap();
    assert_eq!((0..7).map(|f| r.frame_arrived(f)).collect::<Vec<_>>(), [0, 0, 0, 0, 0, 0, 1].map(|b| b == 1));
    assert!(!r.is_complete() && r.complete_frames() == 0);
    r.jump(0).unwrap();
    r.push(&bytes[idx[0]..idx[1] + 3]).unwrap();
    r.jump(1).unwrap();
    r.push(&bytes[idx[1]..idx[2]]).unwrap();
    assert!(r.is_complete() && r.complete_frames() == 7);
    let f = r.finish().unwrap();
    assert_eq!((f.units, f.frames, &f.index), (whole.units, whole.frames, &whole.index));
    // An index that lies about a point is caught when the next point (or
    // the file's own index) arrives somewhere else.
    let mut r = format::StreamReader::default();
    r.push(&bytes[..idx[0]]).unwrap();
    let mut lie = whole.index.clone();
    lie[1] += 1;
    r.set_index(lie).unwrap();
    r.jump(1).unwrap();
    let e = r.push(&bytes[idx[1]..]).unwrap_err();
    assert!(
        matches!(&e, ContainerError::Chunk { msg, .. } if msg.contains("the random-access point the index names of frame 6")),
        "{e}"
    );
    // And one that disagrees with the points already read is refused.
    let mut r = format::StreamReader::default();
    r.push(&bytes[..idx[1] + 1]).unwrap();
    let mut lie = whole.index.clone();
    lie[0] -= 1;
    assert!(r.set_index(lie).is_err());
}

/// A chunk as (tag, frame, payload).
type RawChunk = ([u8; 4], u32, Vec<u8>);

/// A bones fixture's prefix and chunks.
fn bones_chunks(fixture: &str) -> (Vec<u8>, Vec<RawChunk>) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures").join(fixture);
    let bytes = std::fs::read(path).unwrap();
    let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let prefix = bytes[..20 + len].to_vec();
    let mut chunks = Vec::new();
    let mut at = prefix.len();
    while let Some((c, next)) = format::parse_chunk(&bytes, at).unwrap() {
        chunks.push((c.tag, c.frame, c.payload.to_vec()));
        at = next;
    }
    (prefix, chunks)
}

/// The file of these chunks, its random-access index (points at 0, 3, 6)
/// rewritten for where the frames now lie.
fn bones_file(prefix: &[u8], chunks: &[RawChunk]) -> Vec<u8> {
    let mut out = prefix.to_vec();
    let mut points = Vec::new();
    for (tag, frame, payload) in chunks {
        if tag == b"FRAM" && frame % 3 == 0 {
            points.push(out.len() as u64);
        }
        match tag {
            b"RIDX" => out.extend(format::write_index(&points)),
            _ => out.extend(format::write_chunk(*tag, 0, *frame, payload)),
        }
    }
    out
}

/// Versions 13's, 14's and 17's parts, each broken on its own: the skin weights
/// missing, truncated or naming a bone past the count, a frame's bones
/// unit missing or overlong, and the file declared as the version before.
/// Each is a typed error; the intact file reads.
#[test]
fn broken_bones_are_errors() {
    broken_bones_of("v13/walk-bones.cgv");
    broken_bones_of("v14/walk-bones-packed.cgv");
    broken_bones_of("v17/walk-skinned.cgv");
}

fn broken_bones_of(fixture: &str) {
    let (prefix, chunks) = bones_chunks(fixture);
    assert!(format::read(&bones_file(&prefix, &chunks)).is_ok());
    let skin = chunks.iter().position(|c| &c.0 == b"SKIN").expect("a SKIN chunk");
    let frame1 = chunks.iter().position(|c| &c.0 == b"FRAM" && c.1 == 1).unwrap();
    let h = format::read(&bones_file(&prefix, &chunks)).unwrap().header;
    let info = h.skin.unwrap();
    let side = h.grid as usize >> info.shrink;
    let weights = format::SkinWeights::parse(&chunks[skin].2, &info, h.skin_samples(), 0).unwrap();
    let mut bad_bone = weights.clone();
    bad_bone.influences[side][0] = (info.bones as u8, 10);
    // Frame 1's side data, its access units' lengths and units, then the bones unit.
    let frame = |f: &mut Vec<u8>, unit: &[u8]| {
        let h = &h;
        let mut at = h.side_data_len(1);
        for s in 0..h.streams.len() {
            if h.stream_has_frame(s, 1) {
                let mut n = 0usize;
                let mut shift = 0;
                loop {
                    let b = f[at];
                    at += 1;
                    n |= ((b & 0x7f) as usize) << shift;
                    shift += 7;
                    if b & 0x80 == 0 {
                        break;
                    }
                }
                at += n;
            }
        }
        f.truncate(at);
        // The unit's LEB128 length (under 2^14).
        match unit.len() {
            n if n < 128 => f.push(n as u8),
            n => f.extend([(n & 0x7f) as u8 | 0x80, (n >> 7) as u8]),
        }
        f.extend_from_slice(unit);
    };
    let too_long = format::BoneMotions::max_bytes(info.bones, info.packed) + 1;
    let too_long_says = format!("bones: a unit of {too_long}");
    type Break<'a> = Box<dyn Fn(&mut Vec<RawChunk>) + 'a>;
    let cases: Vec<(&str, &str, Break)> = vec![
        ("no skin chunk", "skin weights", Box::new(move |c| drop(c.remove(skin)))),
        (
            "truncated weights",
            "skin weights",
            Box::new(move |c| {
                let n = c[skin].2.len() / 2;
                c[skin].2.truncate(n)
            }),
        ),
        ("a bone past the count", "names a bone past", Box::new(move |c| c[skin].2 = bad_bone.to_bytes(&info))),
        ("no bones at frame 1", "bones: a unit of 0 bytes", Box::new(move |c| frame(&mut c[frame1].2, &[]))),
        ("a bones unit too long", &too_long_says, Box::new(move |c| frame(&mut c[frame1].2, &vec![7; too_long]))),
    ];
    for (what, says, break_it) in cases {
        let mut c = chunks.clone();
        break_it(&mut c);
        let Err(e) = format::read(&bones_file(&prefix, &c)) else { panic!("{fixture}, {what}: read") };
        assert!(matches!(e, ContainerError::Chunk { .. }) && e.to_string().contains(says), "{fixture}, {what}: {e}");
    }
    // Bones the reader cannot check alone (they are differences): a unit
    // that does not hold the bones' numbers is the decoder's error.
    let mut c = chunks.clone();
    let short = if info.packed { vec![0x11, 0xff] } else { miniz_oxide::deflate::compress_to_vec(&[1, 2, 3], 9) };
    frame(&mut c[frame1].2, &short);
    let file = format::read(&bones_file(&prefix, &c)).unwrap();
    let mut dec = cgv::codec::FileDecoder::new(file, cgv::solve::SolverKind::Predictive).unwrap();
    dec.next_frame().unwrap();
    let e = dec.next_frame().unwrap_err().to_string();
    assert!(e.contains("frame 1") && e.contains("bone"), "{e}");
    // The version before cannot hold it.
    assert!(format::read(&bones_file(&version_before(&prefix), &chunks)).is_err());
}

/// Version 21's weights at a random-access point (frame 3), broken: a
/// unit that is no weights, one naming a bone past the count, one past
/// the most a point's unit may hold, each a typed error naming it; weights
/// at frame 3 of a file whose header does not allow them; and the file
/// declared as version 20. The intact file reads, frame 3's unit holding
/// weights and frame 0's none.
#[test]
fn broken_weights_at_a_point_are_errors() {
    let (prefix, chunks) = bones_chunks("v21/walk-capture-bones.cgv");
    let file = format::read(&bones_file(&prefix, &chunks)).unwrap();
    let (h, info) = (&file.header, file.header.skin.unwrap());
    assert!(info.point_weights && h.min_version() == 21 && h.is_random_access_point(3), "{h:?}");
    assert_eq!(file.frames[0].bones.as_deref(), Some(&[][..]));
    let own = file.frames[3].bones.clone().unwrap();
    let mut weights = format::SkinWeights::parse(&own, &info, h.skin_samples(), 0).unwrap();
    weights.influences[0][0] = (info.bones as u8, 9);
    let most = info.point_unit_bytes(h.skin_samples());
    // Frame 3's chunk with its bones unit (the last unit) replaced.
    let frame3 = chunks.iter().position(|c| &c.0 == b"FRAM" && c.1 == 3).unwrap();
    let with_unit = |c: &mut Vec<RawChunk>, unit: &[u8]| {
        let p = &mut c[frame3].2;
        p.truncate(p.len() - own.len() - leb_len(own.len()));
        let mut n = unit.len();
        while n >= 128 {
            p.push((n & 0x7f) as u8 | 0x80);
            n >>= 7;
        }
        p.push(n as u8);
        p.extend_from_slice(unit);
    };
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        ("no weights", vec![1, 2, 3], "skin weights"),
        ("a bone past the count", weights.to_bytes(&info), "names a bone past"),
        ("too long", vec![0; most + 1], "bones: a unit of"),
    ];
    for (what, unit, says) in cases {
        let mut c = chunks.clone();
        with_unit(&mut c, &unit);
        let Err(e) = format::read(&bones_file(&prefix, &c)) else { panic!("{what}: read") };
        assert!(matches!(e, ContainerError::Chunk { .. }) && e.to_string().contains(says), "{what}: {e}");
    }
    let e = format::read(&bones_file(&version_before(&prefix), &chunks)).unwrap_err().to_string();
    assert!(e.contains("21"), "{e}");
}

/// Bytes of `n`'s LEB128.
fn leb_len(mut n: usize) -> usize {
    let mut k = 1;
    while n >= 128 {
        n >>= 7;
        k += 1;
    }
    k
}

/// A file's prefix (magic, version, header, CRC) declaring the version
/// before its own.
fn version_before(prefix: &[u8]) -> Vec<u8> {
    let mut old = prefix.to_vec();
    old[8] -= 1;
    let crc = crc32fast::hash(&old[8..old.len() - 4]);
    let n = old.len();
    old[n - 4..].copy_from_slice(&crc.to_le_bytes());
    old
}

/// Version 18's vertex residual, broken in each of its parts: a unit with
/// an unknown mode, counts for another mesh, a cut word, a unit missing;
/// and the file declared as version 17. Each is a typed error naming it.
#[test]
fn broken_vertex_residuals_are_errors() {
    let (prefix, chunks) = bones_chunks("v18/walk-skinned-residual.cgv");
    let file = format::read(&bones_file(&prefix, &chunks)).unwrap();
    let frame1 = chunks.iter().position(|c| &c.0 == b"FRAM" && c.1 == 1).unwrap();
    let unit = file.frames[1].residual.clone().expect("frame 1's residual");
    // The unit ends the frame chunk, after its LEB128 length.
    let with_unit = |c: &mut Vec<RawChunk>, new: &[u8]| {
        let p = &mut c[frame1].2;
        let len_bytes = |n: usize| {
            if n < 128 {
                1
            } else if n < 1 << 14 {
                2
            } else {
                3
            }
        };
        p.truncate(p.len() - unit.len() - len_bytes(unit.len()));
        let mut n = new.len();
        loop {
            let b = (n & 0x7f) as u8;
            n >>= 7;
            p.push(if n > 0 { b | 0x80 } else { b });
            if n == 0 {
                break;
            }
        }
        p.extend_from_slice(new);
    };
    let mut moded = unit.clone();
    moded[0] = 7;
    let mut recounted = unit.clone();
    recounted[3] ^= 1;
    let mut spatial = unit.clone();
    spatial[0] = 2;
    let cases: [(&str, Vec<u8>, &str); 5] = [
        ("an unknown mode", moded, "unknown mode 7"),
        ("a spatial unit (version 19) where the header allows none", spatial, "unknown mode 2"),
        ("counts for another mesh", recounted, "counts sum to"),
        ("a cut word", unit[..unit.len() - 1].to_vec(), "whole 32-bit words"),
        ("no unit", Vec::new(), "an empty unit"),
    ];
    for (what, new, says) in cases {
        let mut c = chunks.clone();
        with_unit(&mut c, &new);
        let Err(e) = format::read(&bones_file(&prefix, &c)) else { panic!("{what}: read") };
        assert!(e.to_string().contains("vertex residual") && e.to_string().contains(says), "{what}: {e}");
    }
    let e = format::read(&bones_file(&version_before(&prefix), &chunks)).unwrap_err().to_string();
    assert!(e.contains("version 18"), "{e}");
}

/// Version 19's spatial units need a version 19 header.
#[test]
fn a_spatial_residual_declared_as_version_18_is_an_error() {
    let (prefix, chunks) = bones_chunks("v19/walk-normal-spatial.cgv");
    assert!(format::read(&bones_file(&prefix, &chunks)).is_ok());
    let e = format::read(&bones_file(&version_before(&prefix), &chunks)).unwrap_err().to_string();
    assert!(e.contains("version 19"), "{e}");
}

/// Version 20: a file without streams (the vertices codec's) needs a
/// version 20 header; a header without streams needs the residual's
/// origin; and such a file cut anywhere, or with any byte flipped, is an
/// error, never a panic.
#[test]
fn a_file_without_streams_is_checked_like_any_other() {
    let (prefix, chunks) = bones_chunks("v20/walk-vertices.cgv");
    let whole = bones_file(&prefix, &chunks);
    let file = format::read(&whole).unwrap();
    let e = format::read(&bones_file(&version_before(&prefix), &chunks)).unwrap_err().to_string();
    assert!(e.contains("version 20"), "{e}");
    let mut h = file.header.clone();
    h.vertex_residual = h.vertex_residual.map(|r| format::vertex_residual::VertexResidualInfo { origin: None, ..r });
    let e = h.validate().unwrap_err().to_string();
    assert!(e.contains("0 streams"), "{e}");
    // Beside a stream, the origin would leave the grid unused: refused.
    let mut h = file.header.clone();
    h.streams = header().streams;
    assert!(h.validate().unwrap_err().to_string().contains("origin"));
    for cut in (0..whole.len()).step_by(89) {
        assert!(format::read(&whole[..cut]).is_err(), "cut at {cut}");
    }
    let mut flipped = whole.clone();
    for i in (0..flipped.len()).step_by(61) {
        flipped[i] ^= 0x20;
        let _ = format::read(&flipped);
        flipped[i] ^= 0x20;
    }
}
