//! Version 11: loose vertices, the vertices of the input's tiny parts
//! (an eye, a button, a scrap of a few triangles) that are coded as
//! themselves instead of being resampled on the grid: a part of a few
//! hundred vertices would take a chart, or a tube to the body, whose
//! samples cost more than its own vertices do.
//!
//! The header's `loose` gives their count L; the source mesh says which of
//! its vertices each one is. Every frame chunk then ends with one more
//! length-prefixed unit after the access units, this module's payload:
//! the frame's quantizer step (f32 LE, mesh units), then the 3 L residuals
//! against the decoder's prediction (`crate::codec::loose`), each a
//! zigzag LEB128 integer, deflated (RFC 1951, raw) after the step: most
//! residuals are 0 or ±1, and deflate takes them to a few bits each.

use super::{leb128, ContainerError};

/// Most loose vertices a file may have (a part of at most
/// `mesh::carrier::LOOSE_MAX_VERTICES` vertices each).
pub const MAX_LOOSE_VERTICES: u32 = 1 << 20;

/// Most bytes a residual takes in LEB128 (an i32, zigzag-coded).
const RESIDUAL_BYTES: usize = 5;

/// One frame's loose vertices: residuals times `step` against the prediction.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LooseFrame {
    pub step: f32,
    pub residuals: Vec<[i32; 3]>,
}

impl LooseFrame {
    /// The unit's payload.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut raw = Vec::with_capacity(self.residuals.len() * 3);
        for &r in self.residuals.iter().flatten() {
            let r = i64::from(r);
            leb128::write(&mut raw, ((r << 1) ^ (r >> 63)) as u64);
        }
        let mut out = self.step.to_le_bytes().to_vec();
        out.extend(miniz_oxide::deflate::compress_to_vec(&raw, 9));
        out
    }

    /// Reads a frame's payload of `count` loose vertices (the frame chunk
    /// at byte `offset`, named in errors).
    pub fn parse(payload: &[u8], count: u32, offset: usize) -> Result<LooseFrame, ContainerError> {
        let bad = |msg: String| ContainerError::Chunk { offset, msg: format!("loose vertices: {msg}") };
        let Some((step, packed)) = payload.split_first_chunk::<4>() else {
            return Err(bad(format!("{} bytes, fewer than the step's 4", payload.len())));
        };
        let step = f32::from_le_bytes(*step);
        if !(step.is_finite() && step > 0.0) {
            return Err(bad(format!("step {step} is not a positive number")));
        }
        let limit = count as usize * 3 * RESIDUAL_BYTES;
        let raw = miniz_oxide::inflate::decompress_to_vec_with_limit(packed, limit)
            .map_err(|e| bad(format!("do not inflate within their size ({:?})", e.status)))?;
        let mut at = 0;
        let mut residuals = Vec::with_capacity((count as usize).min(raw.len() / 3));
        for v in 0..count {
            let mut r = [0i32; 3];
            for c in &mut r {
                let z =
                    leb128::read(&raw, &mut at, RESIDUAL_BYTES).ok_or_else(|| bad(format!("stop at vertex {v}")))?;
                let x = (z >> 1) as i64 ^ -((z & 1) as i64);
                *c = i32::try_from(x).map_err(|_| bad(format!("vertex {v}'s residual is out of range")))?;
            }
            residuals.push(r);
        }
        if at != raw.len() {
            return Err(bad(format!("{} bytes after the last residual", raw.len() - at)));
        }
        Ok(LooseFrame { step, residuals })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_and_refuses_what_does_not_fit() {
        let f = LooseFrame { step: 0.5, residuals: vec![[0, 1, -1], [i32::MAX, i32::MIN, 7]] };
        let b = f.to_bytes();
        assert_eq!(LooseFrame::parse(&b, 2, 0).unwrap(), f);
        assert!(LooseFrame::parse(&b, 3, 0).is_err(), "one vertex short");
        assert!(LooseFrame::parse(&b, 1, 0).is_err(), "bytes left over");
        assert!(LooseFrame::parse(&b[..3], 2, 0).is_err(), "no step");
        let mut nan = b.clone();
        nan[..4].copy_from_slice(&f32::NAN.to_le_bytes());
        assert!(LooseFrame::parse(&nan, 2, 0).is_err(), "a NaN step");
    }
}
