//! The bone count for an error: the fewest bones of a ladder whose
//! decomposition (`super::ssdr`, Le and Deng 2012) is within a vertex RMS
//! target. SSDR's error falls with the bone count, slowly past a body's
//! parts (horse-gallop, rigid: 10 bones 0.75 %, 30 bones 0.14 % of the
//! diagonal), and each count is its own fit (the clustering that seeds it
//! depends on the count), so counts are tried from the fewest up and the
//! first within the target is kept.

use super::errors::measure;
use super::ssdr::{decompose, SkinOptions};
use super::Skinning;
use crate::error::{Error, Result};
use glam::Vec3;

/// The bone counts tried, fewest first.
pub const LADDER: [usize; 7] = [8, 12, 16, 24, 32, 48, 64];

/// One count tried: its bones and vertex RMS (mean over frames, relative
/// to each frame's diagonal).
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct Tried {
    pub bones: usize,
    pub vertex_rms: f64,
}

/// The decomposition with the fewest bones of [`LADDER`] (at most one a
/// vertex) whose vertex RMS is at most `target` (a fraction of the
/// diagonal), or the one with the most bones when none is; every count
/// tried, and whether the target was met. `report(bones)` before each fit.
pub fn fewest_bones_within(
    frames: &[Vec<Vec3>],
    faces: &[[u32; 3]],
    target: f64,
    opts: &SkinOptions,
    diagonal: &dyn Fn(usize) -> f64,
    report: &mut dyn FnMut(usize),
) -> Result<(Skinning, Vec<Tried>, bool)> {
    if !(target.is_finite() && target > 0.0) {
        return Err(Error::Argument(format!("a target error of {target}: give a positive fraction of the diagonal")));
    }
    let vertices = frames.first().map_or(0, Vec::len);
    let mut tried = Vec::new();
    let mut last = None;
    for bones in LADDER.into_iter().filter(|&b| b <= vertices) {
        report(bones);
        let skin = decompose(frames, faces, &SkinOptions { bones, ..opts.clone() }, &mut |_, _| {})?;
        let vertex_rms = measure(frames, faces, &skin, 0, diagonal)?.vertex_rms;
        tried.push(Tried { bones, vertex_rms });
        if vertex_rms <= target {
            return Ok((skin, tried, true));
        }
        last = Some(skin);
    }
    let skin = last.ok_or_else(|| Error::Argument(format!("{vertices} vertices: too few for {} bones", LADDER[0])))?;
    Ok((skin, tried, false))
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    /// A bar of vertices whose right part swings: one bone cannot follow
    /// it, eight can; a target below what 64 bones reach is reported unmet
    /// with the most bones tried.
    #[test]
    fn the_fewest_bones_within_the_target_are_kept() {
        let rest: Vec<Vec3> =
            (0..400).map(|k| Vec3::new((k % 40) as f32 / 40.0, (k / 40) as f32 / 40.0, 0.0)).collect();
        let frames: Vec<Vec<Vec3>> = (0..6)
            .map(|t| {
                let turn = glam::Mat3::from_rotation_z(0.15 * t as f32);
                rest.iter().map(|&p| if p.x > 0.5 { turn * (p - Vec3::X * 0.5) + Vec3::X * 0.5 } else { p }).collect()
            })
            .collect();
        let diagonal = |_: usize| 1.0;
        let opts = SkinOptions { iterations: 4, ..Default::default() };
        let mut asked = Vec::new();
        let (skin, tried, met) =
            fewest_bones_within(&frames, &[], 0.01, &opts, &diagonal, &mut |b| asked.push(b)).unwrap();
        assert!(met && skin.bones == 8 && tried.len() == 1 && asked == [8], "{tried:?}");
        let (skin, tried, met) = fewest_bones_within(&frames, &[], 1e-9, &opts, &diagonal, &mut |_| {}).unwrap();
        assert!(!met && skin.bones == 64 && tried.len() == LADDER.len(), "{tried:?}");
        assert!(tried.windows(2).all(|w| w[1].vertex_rms <= w[0].vertex_rms * 1.5), "{tried:?}");
        assert!(fewest_bones_within(&frames, &[], -1.0, &opts, &diagonal, &mut |_| {}).is_err());
    }
}
