//! Step 3c (format version 17): bones on the source mesh's own vertices,
//! what they miss coded as a geometry video. As MPEG-4 FAMC codes a mesh's
//! skinning and the residual (Mamou, Zaharia and Prêteux 2009), with SSDR's
//! decomposition (Le and Deng 2012, `crate::skin::ssdr`): rigid bones and
//! four weights a vertex fitted to the motion. The file carries the
//! weights and the rest pose once (`SKIN`), each frame's transforms from
//! that rest pose (`crate::solve::skinned`'s unit, fitted here to the true
//! frame), and the residual x − L(x) resampled on the grid as GV's x, y, z
//! streams; the decoder adds the residual, read at each vertex's place, to
//! the skinning (`SourceMeshDecoder::vertices`). Unlike the grid's bones
//! (version 13) nothing runs on the decoded past: every frame is the
//! skinning of the file's rest pose plus its own residual, so the grid's
//! resampling floor bounds only the residual, not the body.

use super::bones::{quantize, ROTATION_STEP, TRANSLATION_STEP};
use super::plan::Plan;
use crate::error::{Error, Result};
use crate::format::skin::Motion;
use crate::format::{SkinInfo, SkinWeights};
use crate::mesh::{Frame, FrameSource, Topology};
use crate::skin::INFLUENCES;
use crate::skin::{decompose, SkinOptions, Skinning};
use crate::solve::skinned::SkinnedPredictor;
use glam::Vec3;
use std::hash::{Hash, Hasher};
use std::path::Path;
use std::sync::{Arc, Mutex};

/// A rest coordinate's unit, in diagonals: 1e-5 (a 16-bit grid would be
/// 1.5e-5), far below any error the residual video reaches.
pub const REST_STEP: f32 = 1e-5;
/// Frames the decomposition reads at most, spread over the motion (the
/// weights; each frame's transforms are fitted on their own).
pub const VERTEX_SKIN_FRAMES: usize = 256;

/// `--grid auto` for the skinned codec: the smallest of 32, 64, 128 and
/// 256 with a sample for each vertex of the mesh. The grid codes only what
/// the bones miss, read at the vertices' places; more samples than
/// vertices cost bits and add nothing (pcow's 2,904 vertices, 24 bones:
/// 0.239 % vertex RMS at 1.45 bits/v/f on N = 64, 0.265 % at 1.44 on 128).
pub fn skinned_grid(vertices: usize) -> usize {
    [32, 64, 128].into_iter().find(|n| n * n >= vertices).unwrap_or(256)
}

/// The skinned codec's bones when the options leave it to the encoder: one
/// for each 150 vertices, in steps of 8, from 32 to 48. Measured (`cgv eval
/// --codecs skinned --kbps ...`, all frames, BD-rate on vertex RMS): samba
/// (9,971 vertices) 48 bones −15 % against 32 and 64 another −11 %, 16
/// +46 %; horse-gallop (8,431) 48 against 30 −9 %, 56 −4 % but its
/// smallest file 0.93 bits/v/f against 0.68 and worse below 1 bit (each
/// frame's motions cost more there than the residual they save: hence 48
/// at most); pcow (2,904) 32 against 24 −10 % (worse at its smallest
/// file), 16 +27 %. The rate sets the weights' precision instead
/// ([`COARSE_WEIGHTS_QP`]): fewer bones lower the smallest file less and
/// lose more (horse-gallop at QP 51: 16 bones 0.291 % at 0.59 bits/v/f,
/// 48 with coarse weights 0.128 % at 0.56).
pub fn skinned_bones(vertices: usize) -> u16 {
    ((vertices / 150).clamp(32, 48) / 8 * 8) as u16
}

/// From this QP on, a constant-QP file stores its weights coarse
/// ([`weight_bytes`]); with a bitrate, where the fine-weighted file at
/// this QP is over the budget (`budget.rs`). Measured (48 bones, all
/// frames, vertex RMS on the input's vertices, bits/v/f less the mesh
/// line): horse-gallop at QP 42 0.613 bits, 0.098 % against fine 0.919,
/// 0.095 % (−33 % bits at equal error from QP 36 on), samba at QP 39
/// 0.486, 0.140 % against 0.591, 0.123 % (−11 %), but at QP 33 samba's
/// coarse weights cost 9 % more at equal error and horse-gallop's gained
/// nothing at QP 30: where the residual is fine, so must the skinning be.
pub const COARSE_WEIGHTS_QP: u8 = 39;
/// Coarse weights: an influence under 5 % is dropped and the rest kept in
/// 32 levels, which deflate codes in about half the bits.
const COARSE_DROP: f32 = 0.05;
const COARSE_LEVELS: f32 = 32.0;

/// A vertex's influences as the file's bytes: 255 levels, or coarse, where
/// the residual video is coarse enough that the skinning's finer detail
/// would not show (the decoder divides by their sum either way, so the
/// format is the same).
fn weight_bytes(inf: &[(u16, f32); INFLUENCES], coarse: bool) -> [(u8, u8); INFLUENCES] {
    let kept = inf.map(|(b, w)| (b, if w < COARSE_DROP { 0.0 } else { w }));
    let sum: f32 = kept.iter().map(|p| p.1).sum();
    if !coarse || sum <= 0.0 {
        return quantize(inf);
    }
    quantize(&kept.map(|(b, w)| (b, (w / sum * COARSE_LEVELS).round() / COARSE_LEVELS)))
}

/// The bones of a file with bones on its vertices.
pub(super) struct VertexBones {
    pub info: SkinInfo,
    pub weights: SkinWeights,
    /// Each frame's bones unit.
    pub units: Vec<Vec<u8>>,
    /// Each frame's motions (as the units code them), and the predictor
    /// that skins the rest pose with them, as a decoder's.
    motions: Vec<Vec<Motion>>,
    predictor: SkinnedPredictor,
    /// For each source vertex, a stored vertex that is it (a textured
    /// input's stored mesh splits vertices along its UV seams).
    stored_of: Vec<u32>,
}

/// The stored vertices' source vertices (`welded`; each its own without
/// an appearance).
fn welded(src: &dyn FrameSource) -> Vec<u32> {
    match src.appearance() {
        Some(a) => a.welded.clone(),
        None => (0..src.topology().vertex_count as u32).collect(),
    }
}

/// The last decomposition made, by a hash of what it read: a budget's
/// passes and a target error's search encode one motion 5 to 12 times,
/// and the decomposition was most of each (samba's 48 bones: 3.4 s). The
/// decomposition is deterministic, so the same frames, faces and options
/// give the same bones.
static LAST: Mutex<Option<(u64, Arc<Skinning>)>> = Mutex::new(None);

/// [`decompose`], or the last one where it read the same.
fn decomposition(
    frames: &[Frame],
    faces: &[[u32; 3]],
    opts: &SkinOptions,
    progress: &mut dyn FnMut(&str, usize, usize),
) -> Result<Arc<Skinning>> {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    (opts.bones, opts.iterations, opts.rest, opts.affine, faces).hash(&mut h);
    frames.iter().flatten().for_each(|p| p.to_array().map(f32::to_bits).hash(&mut h));
    let key = h.finish();
    if let Some((_, skin)) = LAST.lock().ok().and_then(|l| l.clone()).filter(|l| l.0 == key) {
        return Ok(skin);
    }
    let iterations = opts.iterations;
    let skin = Arc::new(decompose(frames, faces, opts, &mut |it, _| progress("bones", it, iterations))?);
    if let Ok(mut last) = LAST.lock() {
        *last = Some((key, skin.clone()));
    }
    Ok(skin)
}

/// Fits `bones` bones to `src` and each frame's transforms; their
/// weights stored `coarse` or not ([`weight_bytes`]).
pub(super) fn fit(
    src: &dyn FrameSource,
    plan: &Plan,
    (bones, coarse): (u16, bool),
    diagonal: f32,
    progress: &mut dyn FnMut(&str, usize, usize),
) -> Result<VertexBones> {
    let n = plan.frames;
    let picks: Vec<usize> = (0..n.min(VERTEX_SKIN_FRAMES)).map(|k| k * n / n.min(VERTEX_SKIN_FRAMES)).collect();
    let frames = picks.iter().map(|&f| src.read_frame(f)).collect::<Result<Vec<Frame>>>()?;
    let opts = SkinOptions { bones: usize::from(bones), ..Default::default() };
    let skin = decomposition(&frames, &src.topology().faces, &opts, progress)?;
    drop(frames);
    // Each frame's transforms from the decomposition's where it read that
    // frame.
    let from = |f: usize| picks.binary_search(&f).ok().and_then(|k| skin.transforms.get(k));
    let welded = welded(src);
    // A mesh far from the origin gets coarser rest steps rather than
    // numbers past i32.
    let farthest = skin.rest.iter().map(|p| p.abs().max_element()).fold(0.0f32, f32::max);
    let step = (diagonal * REST_STEP).max(farthest / 2.0e9);
    let at = |v: &u32| skin.rest.get(*v as usize).copied().unwrap_or_default();
    let bytes = |inf: &[(u16, f32); INFLUENCES]| weight_bytes(inf, coarse);
    let influence = |v: &u32| skin.influences.get(*v as usize).map_or([(0, 255), (0, 0), (0, 0), (0, 0)], bytes);
    let weights = SkinWeights {
        influences: welded.iter().map(influence).collect(),
        rest: welded.iter().map(|v| (at(v) / step).round().to_array().map(|x| x.clamp(-2.1e9, 2.1e9) as i32)).collect(),
    };
    let info = SkinInfo {
        bones,
        shrink: 0,
        rotation_step: ROTATION_STEP,
        translation_step: diagonal * TRANSLATION_STEP,
        packed: true,
        rest_step: Some(step),
        point_weights: false,
    };
    let mut predictor = SkinnedPredictor::on_vertices(&info, &weights)?;
    let (mut units, mut motions) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for f in 0..n {
        if f > 0 && plan.is_rap(f) {
            predictor.reset();
        }
        let x = src.read_frame(f)?;
        let truth: Vec<Vec3> = welded.iter().map(|&v| x[v as usize]).collect();
        units.push(predictor.encode_from(&truth, from(f).map(Vec::as_slice)));
        motions.push(predictor.motions().to_vec());
        progress("bone motions", f + 1, n);
    }
    let count = src.topology().vertex_count;
    let stored_of = src.appearance().map_or_else(|| (0..count as u32).collect(), |a| a.stored_of(count));
    Ok(VertexBones { info, weights, units, motions, predictor, stored_of })
}

/// What the bones miss of each frame of `src`, x − L(x): the motion the
/// grid codes (a source with the same connectivity, appearance and rate).
pub(super) struct Residual<'a> {
    pub src: &'a dyn FrameSource,
    pub bones: &'a VertexBones,
}

impl FrameSource for Residual<'_> {
    fn label(&self) -> &Path {
        self.src.label()
    }
    fn frame_count(&self) -> usize {
        self.src.frame_count()
    }
    fn fps(&self) -> f32 {
        self.src.fps()
    }
    fn topology(&self) -> &Topology {
        self.src.topology()
    }
    fn read_frame(&self, i: usize) -> Result<Frame> {
        let b = self.bones;
        let skinned = b.motions.get(i).and_then(|m| b.predictor.skin_with(m));
        let skinned = skinned.ok_or_else(|| Error::Argument(format!("no bone motions for frame {i}")))?;
        let x = self.src.read_frame(i)?;
        Ok(x.iter().zip(&b.stored_of).map(|(p, &k)| *p - skinned[k as usize]).collect())
    }
    fn kind(&self) -> &'static str {
        self.src.kind()
    }
    fn appearance(&self) -> Option<&crate::mesh::Appearance> {
        self.src.appearance()
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::{decomposition, skinned_bones, skinned_grid, weight_bytes, Frame};
    use crate::skin::SkinOptions;
    use glam::Vec3;
    use std::sync::Arc;

    /// A budget's passes fit the same motion again: the second fit is the
    /// first one's, a changed frame a new one.
    #[test]
    fn the_same_frames_reuse_the_last_decomposition() {
        let sheet = |bend: f32| -> Frame {
            (0..16).map(|i| Vec3::new((i % 4) as f32, (i / 4) as f32, bend * ((i % 4) as f32).powi(2))).collect()
        };
        let faces: Vec<[u32; 3]> = (0..3u32)
            .flat_map(|y| {
                (0..3u32).flat_map(move |x| {
                    let v = y * 4 + x;
                    [[v, v + 1, v + 5], [v, v + 5, v + 4]]
                })
            })
            .collect();
        let opts = SkinOptions { bones: 2, iterations: 2, ..Default::default() };
        let frames = vec![sheet(0.0), sheet(0.1), sheet(0.2)];
        let first = decomposition(&frames, &faces, &opts, &mut |_, _, _| {}).unwrap();
        let again = decomposition(&frames, &faces, &opts, &mut |_, _, _| {}).unwrap();
        assert!(Arc::ptr_eq(&first, &again));
        let other = vec![sheet(0.0), sheet(0.1), sheet(0.3)];
        let new = decomposition(&other, &faces, &opts, &mut |_, _, _| {}).unwrap();
        assert!(!Arc::ptr_eq(&first, &new));
    }

    #[test]
    fn coarse_weights_drop_small_influences_and_keep_32_levels() {
        let inf = [(3, 0.62), (7, 0.31), (1, 0.04), (9, 0.03)];
        assert_eq!(weight_bytes(&inf, false), [(3, 158), (7, 79), (1, 10), (9, 8)]);
        let coarse = weight_bytes(&inf, true);
        // 0.62 / 0.93 and 0.31 / 0.93 in 32nds: 21 and 11, as bytes.
        assert_eq!(coarse, [(3, 167), (7, 88), (1, 0), (9, 0)]);
        // One bone whole stays whole.
        assert_eq!(weight_bytes(&[(5, 1.0), (0, 0.0), (0, 0.0), (0, 0.0)], true)[0], (5, 255));
    }

    #[test]
    fn the_skinned_bones_follow_the_vertices() {
        let bones = [100, 2904, 6274, 8431, 9971, 50_000].map(skinned_bones);
        assert_eq!(bones, [32, 32, 40, 48, 48, 48]);
    }

    #[test]
    fn the_skinned_grid_has_a_sample_for_each_vertex() {
        let sizes = [500, 2904, 4096, 4097, 8431, 9971, 16385, 1_000_000].map(skinned_grid);
        assert_eq!(sizes, [32, 64, 64, 128, 128, 128, 256, 256]);
    }
}

#[cfg(test)]
mod probe {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::mesh::{open_sequence, Bounds, OpenOptions};

    /// The bones alone, as the decomposition fitted them and as the file
    /// codes them: `CGV_PROBE=/tmp/data/pcow CGV_BONES=24 cargo test
    /// --release --lib vertex_bones_alone -- --ignored --nocapture`.
    #[test]
    #[ignore]
    fn vertex_bones_alone() {
        let dir = std::env::var("CGV_PROBE").unwrap();
        let bones: u16 = std::env::var("CGV_BONES").ok().and_then(|b| b.parse().ok()).unwrap_or(32);
        let src = open_sequence(&dir, &OpenOptions::default()).unwrap();
        let diag = Bounds::of(&src.read_frame(0).unwrap()).diagonal();
        let opts = crate::codec::EncodeOptions { random_access: 0.0, ..Default::default() };
        let plan = Plan::new(&opts, src.frame_count(), src.fps()).unwrap();
        let b = fit(src.as_ref(), &plan, (bones, false), diag, &mut |_, _, _| {}).unwrap();
        let mut sum = 0.0;
        for f in 0..plan.frames {
            let x = src.read_frame(f).unwrap();
            let s = b.predictor.skin_with(&b.motions[f]).unwrap();
            let e: f64 = x.iter().zip(&s).map(|(a, c)| a.distance_squared(*c) as f64).sum::<f64>() / x.len() as f64;
            sum += e.sqrt() / diag as f64;
        }
        let unit: usize = b.units.iter().map(Vec::len).sum();
        eprintln!(
            "{dir}: {bones} bones as coded: {:.4} % vertex RMS, {} B/frame",
            100.0 * sum / plan.frames as f64,
            unit / plan.frames
        );
    }
}
