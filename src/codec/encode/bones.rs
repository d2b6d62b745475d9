//! Step 3b: the bones of a file that predicts with them (format version
//! 13): a skinning decomposition (`crate::skin::ssdr`, Le and Deng 2012)
//! of the grid's motion on the coarse grid the weights are stored on.
//! Only its weights go in the file; each frame's bone transforms, from the
//! decoded random-access point, are fitted in the closed loop
//! (`crate::solve::skinned`).

use super::plan::Plan;
use super::weights_refit::{self, FineMotion};
use super::EncodeOptions;
use crate::error::Result;
use crate::format::skin::{coarse_side, INFLUENCES, MAX_SKIN_SHRINK};
use crate::format::{SkinInfo, SkinWeights};
use crate::grid::{coarse, Grid};
use crate::mesh::FrameSource;
use crate::resample::SampleMap;
use crate::skin::{decompose, BoneTransform, SkinOptions};
use crate::solve::skinned::{SkinnedPredictor, FIT_STRIDE};
use glam::Vec3;
use std::ops::Range;

/// Bones when the options leave it to the encoder (`EncodeOptions::bones`
/// `None`): samba's 32 fit in 0.4 s on the weights' grid.
pub const DEFAULT_BONES: u16 = 32;
/// Frames a motion needs before the encoder gives it bones of its own
/// accord: the weights are a fixed cost (about 5.4 KB for 32 bones, packed), which
/// a short clip does not repay. Measured (N = 128, `cgv eval`, normal
/// codec): wolf's 6 frames and cylinder's 4 came out smallest at 3.0 and
/// 48 bits per vertex per frame with bones, against 1.0 and 16 without,
/// and with higher surface RMS at equal bits; face-poses' 9 frames won at
/// its two highest points and lost its two lowest.
pub const MIN_BONE_FRAMES: usize = 24;

/// The weights' grid is the finest coarse grid at most this many samples
/// a side: 1,024 samples, a few KB deflated, against the 16,384 of N = 128.
pub const SKIN_SIDE: usize = 32;
/// Frames the decomposition looks at, spread over the motion: it fits
/// weights only, which a few hundred frames pin down.
pub const SKIN_FRAMES: usize = 256;
/// SSDR's frames the weights' refit reads at most (`weights_refit`).
pub const REFIT_FRAMES: usize = 48;
/// Sweeps of the weights' refit over the coarse samples.
pub const REFIT_SWEEPS: usize = 3;
/// Alternations of weights and transforms (`SkinOptions::iterations`).
pub const SKIN_ITERATIONS: usize = 10;
/// A rotation-vector unit: 2⁻⁹ rad, which moves a point half the diagonal
/// away 1e-3 of the diagonal. With [`TRANSLATION_STEP`], measured on samba
/// (N = 128, 32 bones, 175 frames, the bones alone): 2⁻¹² rad and 2⁻¹³
/// diagonals gave 0.346 % vertex RMS in 232 bytes a frame, 2⁻⁹ and 2⁻¹⁰
/// 0.348 % in 156, 2⁻⁷ and 2⁻⁸ 0.371 % in 114.
pub const ROTATION_STEP: f32 = 1.0 / 512.0;
/// A translation unit, in diagonals.
pub const TRANSLATION_STEP: f32 = 1.0 / 1024.0;

/// The file's bones: the header's description, its `SKIN` chunk, the
/// units its random-access points carry (version 21: their segment's own
/// weights; empty: the chunk's), and the predictor the encoder's loops use
/// (made from those, as a decoder's).
pub(super) struct Bones {
    pub info: SkinInfo,
    pub weights: SkinWeights,
    pub point_units: Vec<Vec<u8>>,
    pub predictor: SkinnedPredictor,
}

/// How many times the grid is halved for the weights: down to
/// [`SKIN_SIDE`] where the grid allows.
fn skin_shrink(grid: usize) -> u8 {
    (0..=MAX_SKIN_SHRINK).rev().find(|&k| coarse_side(grid, k).is_some_and(|s| s >= SKIN_SIDE.min(grid))).unwrap_or(0)
}

/// The bones for `opts.bones` (none with 0, or without the closed loop).
/// A capture's segments (`src` with frame meshes) each have their own map,
/// so each (of two frames or more) gets its own weights (version 21); else
/// one set fits all.
pub(super) fn fit_bones(
    src: &dyn FrameSource,
    plan: &Plan,
    opts: &EncodeOptions,
    map: &SampleMap,
    diagonal: f32,
    progress: &mut dyn FnMut(&str, usize, usize),
) -> Result<Option<Bones>> {
    let asked = match opts.bones {
        Some(n) => n,
        None if plan.frames >= MIN_BONE_FRAMES => DEFAULT_BONES,
        None => 0,
    };
    if asked == 0 || !plan.closed_loop {
        return Ok(None);
    }
    let shrink = skin_shrink(plan.grid.n);
    let bones = usize::from(asked).min((plan.grid.n >> shrink).pow(2));
    let segments = if src.has_frame_meshes() { &plan.segments[..] } else { &[] };
    let (ranges, own) = weight_segments(segments, plan.frames, |f| plan.is_rap(f));
    let info = SkinInfo {
        bones: bones as u16,
        shrink,
        rotation_step: ROTATION_STEP,
        translation_step: (diagonal * TRANSLATION_STEP).max(f32::MIN_POSITIVE),
        packed: true,
        rest_step: None,
        point_weights: own.iter().any(|&o| o),
    };
    let mut units = Vec::with_capacity(ranges.len());
    for (range, &own) in ranges.iter().zip(&own) {
        if range.start > 0 && !own {
            units.push(None);
            continue;
        }
        let influences = fit_weights(src, range.clone(), (plan.grid, map), (shrink, bones), REFIT_SWEEPS, progress)?;
        units.push(Some(SkinWeights { influences: influences.iter().map(quantize).collect(), ..Default::default() }));
    }
    let weights = units.remove(0).unwrap_or_default();
    // Each random-access point carries its segment's weights, but the
    // first segment's, which are the chunk's.
    let point_units: Vec<Vec<u8>> = (0..plan.frames)
        .filter(|&f| plan.is_rap(f))
        .map(|f| match ranges.iter().rposition(|r| r.start <= f) {
            Some(k) if k > 0 => units[k - 1].as_ref().map_or_else(Vec::new, |w| w.to_bytes(&info)),
            _ => Vec::new(),
        })
        .collect();
    let mut predictor = SkinnedPredictor::new(plan.grid, &info, &weights)?;
    predictor.set_point_units(point_units.clone())?;
    Ok(Some(Bones { info, weights, point_units, predictor }))
}

/// The frames of each segment of a motion of `frames` frames whose later
/// segments start at `segments` (a capture's, each its own map), and
/// whether each after the first gets weights of its own: not where every
/// frame of it is a random-access point (`is_rap`; one frame, say), as
/// bones then predict none of them.
fn weight_segments(segments: &[u32], frames: usize, is_rap: impl Fn(usize) -> bool) -> (Vec<Range<usize>>, Vec<bool>) {
    let starts: Vec<usize> = [0].into_iter().chain(segments.iter().map(|&s| s as usize)).collect();
    let ranges: Vec<Range<usize>> =
        starts.iter().enumerate().map(|(k, &s)| s..starts.get(k + 1).copied().unwrap_or(frames)).collect();
    let own = ranges.iter().map(|r| r.start > 0 && !r.clone().all(&is_rap)).collect();
    (ranges, own)
}

/// The weights of frames `range` on the grid halved `shrink` times: SSDR
/// on that grid, its rest pose the range's first frame, then refitted
/// `sweeps` times for their expansion (`weights_refit`; the encoder's
/// [`REFIT_SWEEPS`], 0: SSDR's weights).
fn fit_weights(
    src: &dyn FrameSource,
    range: Range<usize>,
    (grid, map): (Grid, &SampleMap),
    (shrink, bones): (u8, usize),
    sweeps: usize,
    progress: &mut dyn FnMut(&str, usize, usize),
) -> Result<Vec<[(u16, f32); INFLUENCES]>> {
    let coarse_grid = Grid::new(grid.n >> shrink)?;
    let frames = range.len();
    let count = frames.min(SKIN_FRAMES);
    let every = count.div_ceil(REFIT_FRAMES);
    let stride = if grid.n >= 64 { FIT_STRIDE } else { 1 };
    let samples: Vec<u32> = (0..grid.len() as u32)
        .filter(|&v| (v as usize % grid.n) % stride == 0 && (v as usize / grid.n) % stride == 0)
        .collect();
    let (mut coarse_frames, mut fine) = (Vec::with_capacity(count), Vec::new());
    for k in 0..count {
        let x = map.apply(&src.read_frame(range.start + k * frames / count)?);
        coarse_frames.push(shrink_positions(grid, &x, shrink));
        if k % every == 0 {
            fine.push(samples.iter().map(|&v| x[v as usize]).collect::<Vec<Vec3>>());
        }
        progress("fitting bones", k + 1, count);
    }
    let skin_opts = SkinOptions { bones, iterations: SKIN_ITERATIONS, rest: 0, affine: false };
    let mut skin = decompose(&coarse_frames, &coarse_grid.topology().faces, &skin_opts, &mut |_, _| {})?;
    if sweeps > 0 {
        let transforms: Vec<Vec<BoneTransform>> = skin.transforms.iter().step_by(every).cloned().collect();
        let fine = FineMotion { samples, rest: fine[0].clone(), frames: fine };
        weights_refit::refit(coarse_grid, shrink, &mut skin.influences, &transforms, &fine, sweeps);
    }
    Ok(skin.influences)
}

/// A grid frame's positions on the grid halved `levels` times.
fn shrink_positions(grid: Grid, x: &[Vec3], levels: u8) -> Vec<Vec3> {
    let axis = |c: usize| coarse::shrink(grid, &x.iter().map(|p| p[c]).collect::<Vec<f32>>(), levels);
    let (a, b, c) = (axis(0), axis(1), axis(2));
    a.iter().zip(&b).zip(&c).map(|((&x, &y), &z)| Vec3::new(x, y, z)).collect()
}

/// Weights summing to one as bytes (out of their sum, which stays
/// positive: the largest keeps at least 1).
pub(super) fn quantize(inf: &[(u16, f32); INFLUENCES]) -> [(u8, u8); INFLUENCES] {
    let mut q = inf.map(|(b, w)| (b.min(255) as u8, (w.clamp(0.0, 1.0) * 255.0).round() as u8));
    if q.iter().all(|p| p.1 == 0) {
        let k = (0..INFLUENCES).max_by(|&a, &b| inf[a].1.total_cmp(&inf[b].1)).unwrap_or(0);
        q[k].1 = 1;
    }
    q
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A segment gets weights of its own unless every frame of it is a
    /// random-access point; the first segment's are the chunk's.
    #[test]
    fn segments_whose_frames_are_all_points_keep_the_chunks_weights() {
        let points = |p: &'static [usize]| move |f: usize| p.contains(&f);
        let (ranges, own) = weight_segments(&[4, 7], 8, points(&[0, 4, 7]));
        assert_eq!((ranges, own), (vec![0..4, 4..7, 7..8], vec![false, true, false]));
        // A point every frame: no segment's bones predict anything.
        let (_, own) = weight_segments(&[4], 8, |_| true);
        assert_eq!(own, [false, false]);
        // A two-frame segment whose second frame is a point too.
        let (_, own) = weight_segments(&[2, 4], 6, points(&[0, 2, 3, 4]));
        assert_eq!(own, [false, false, true]);
        let (ranges, own) = weight_segments(&[], 5, |f| f == 0);
        assert_eq!((ranges.len(), ranges[0].clone(), own), (1, 0..5, vec![false]));
    }
}

#[cfg(test)]
mod probe {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::mesh::{open_sequence, Bounds, OpenOptions};

    /// `CGV_PROBE`'s motion at N = 128: its path, the source, its geometry
    /// image and its first frame's diagonal.
    fn probe_input() -> (String, Box<dyn FrameSource>, crate::geometry_image::GeometryImage, f32) {
        let dir = std::env::var("CGV_PROBE").unwrap();
        let src = open_sequence(&dir, &OpenOptions::default()).unwrap();
        let opts = EncodeOptions { grid: 128, ..Default::default() };
        let image = crate::codec::prepare(src.as_ref(), &opts).unwrap();
        let diag = Bounds::of(&src.read_frame(0).unwrap()).diagonal();
        (dir, src, image, diag)
    }

    /// The 32 bones of quantized `inf` on the 128 grid halved `shrink`
    /// times, as a file's header and chunk, and their predictor.
    fn probe_bones(
        inf: &[[(u16, f32); INFLUENCES]],
        shrink: u8,
        diag: f32,
    ) -> (SkinInfo, SkinWeights, SkinnedPredictor) {
        let weights = SkinWeights { influences: inf.iter().map(quantize).collect(), ..Default::default() };
        let info = SkinInfo {
            bones: 32,
            shrink,
            rotation_step: ROTATION_STEP,
            translation_step: diag * TRANSLATION_STEP,
            packed: true,
            rest_step: None,
            point_weights: false,
        };
        let p = SkinnedPredictor::new(Grid::new(128).unwrap(), &info, &weights).unwrap();
        (info, weights, p)
    }

    /// The bones alone on the full grid, with and without the weights'
    /// refit: `CGV_PROBE=/tmp/data/samba cargo test --release --lib probe -- --ignored --nocapture`.
    #[test]
    #[ignore]
    fn bones_alone_on_the_full_grid() {
        let (dir, src, image, diag) = probe_input();
        let grid = Grid::new(128).unwrap();
        let shrink = skin_shrink(128);
        for sweeps in [0, REFIT_SWEEPS] {
            let t0 = std::time::Instant::now();
            let range = 0..src.frame_count();
            let inf =
                fit_weights(src.as_ref(), range, (grid, &image.map), (shrink, 32), sweeps, &mut |_, _, _| {}).unwrap();
            let secs = t0.elapsed().as_secs_f64();
            let (info, weights, mut p) = probe_bones(&inf, shrink, diag);
            let (mut l, mut sum, mut bytes) = (Vec::new(), 0.0, 0);
            for f in 0..src.frame_count() {
                let x = image.map.apply(&src.read_frame(f).unwrap());
                bytes += p.encode(&x).len();
                if f == 0 {
                    l = x.clone();
                } else {
                    l.iter_mut().zip(p.motion().unwrap()).for_each(|(a, d)| *a += d);
                }
                let e: f64 = l.iter().zip(&x).map(|(a, b)| (*a - *b).length_squared() as f64).sum::<f64>();
                sum += (e / x.len() as f64).sqrt() / diag as f64;
                p.commit(&x);
            }
            let n = src.frame_count();
            eprintln!(
                "{dir} sweeps {sweeps}: bones alone {:.4} % vertex RMS, {} B/frame, weights {} B ({} B deflated as v13), fit {secs:.1} s",
                100.0 * sum / n as f64,
                bytes / n,
                weights.to_bytes(&info).len(),
                weights.to_bytes(&SkinInfo { packed: false, ..info }).len(),
            );
        }
    }

    /// What bones fitted on the source vertices would give there, against
    /// today's rebuild from the grid, with the grid uncorrected (X = L),
    /// corrected along its normals (X = L + n n·(T − L)) and exact (X = T):
    /// `CGV_PROBE=/tmp/data/pcow cargo test --release --lib source_vertices -- --ignored --nocapture`.
    #[test]
    #[ignore]
    fn bones_on_the_source_vertices() {
        use crate::resample::triangle_frame;
        let (dir, src, image, diag) = probe_input();
        let grid = Grid::new(128).unwrap();
        let shrink = skin_shrink(128);
        let range = 0..src.frame_count();
        let inf = fit_weights(src.as_ref(), range, (grid, &image.map), (shrink, 32), REFIT_SWEEPS, &mut |_, _, _| {})
            .unwrap();
        let (_, _, mut p) = probe_bones(&inf, shrink, diag);
        let points = image.source_points();
        let faces = grid.topology().faces;
        let n = src.frame_count();
        let x0 = image.map.apply(&src.read_frame(0).unwrap());
        p.commit(&x0);
        let rest = points.apply(&x0);
        let (mut truth_grid, mut skinned, mut moves, mut truth) = (vec![], vec![], vec![], vec![]);
        for f in 1..n {
            let x = image.map.apply(&src.read_frame(f).unwrap());
            p.encode(&x);
            skinned.push(p.skinned().unwrap().to_vec());
            moves.push(p.transforms().unwrap());
            p.commit(&x);
            truth_grid.push(x);
            truth.push(src.read_frame(f).unwrap());
        }
        let src_inf = source_weights(&points, p.influences(), &rest, &moves, &truth);
        let rms = |a: &[Vec3], b: &[Vec3]| {
            (a.iter().zip(b).map(|(p, q)| p.distance_squared(*q) as f64).sum::<f64>() / a.len() as f64).sqrt()
                / diag as f64
        };
        let mut sums = std::collections::BTreeMap::<&str, f64>::new();
        for k in 0..n - 1 {
            let (l, tg, m) = (&skinned[k], &truth_grid[k], &moves[k]);
            let s: Vec<Vec3> = rest
                .iter()
                .zip(&src_inf)
                .map(|(&r, inf)| inf.iter().map(|&(b, w)| w * m[b as usize].apply(r)).sum())
                .collect();
            let normals = crate::mesh::vertex_normals(l, &faces);
            let xn: Vec<Vec3> = l.iter().zip(tg).zip(&normals).map(|((a, t), n)| *a + *n * n.dot(*t - *a)).collect();
            let gl = points.apply(l);
            for (name, x) in [("L", l), ("N", &xn), ("T", tg)] {
                let gx = points.apply(x);
                let tan = |v: usize, d: Vec3| {
                    let nrm = triangle_frame(points.corners[v].map(|i| x[i as usize]))[2];
                    d - nrm * nrm.dot(d)
                };
                let b: Vec<Vec3> = (0..gx.len()).map(|v| s[v] + gx[v] - gl[v]).collect();
                let c: Vec<Vec3> = (0..gx.len()).map(|v| gx[v] + tan(v, s[v] - gl[v])).collect();
                *sums.entry(["today ", name].concat().leak()).or_default() += rms(&gx, &truth[k]);
                *sums.entry(["B ", name].concat().leak()).or_default() += rms(&b, &truth[k]);
                *sums.entry(["C ", name].concat().leak()).or_default() += rms(&c, &truth[k]);
            }
            *sums.entry("A (source skinning alone)").or_default() += rms(&s, &truth[k]);
        }
        for (k, v) in sums {
            eprintln!("{dir}: {k}: {:.4} % vertex RMS", 100.0 * v / (n - 1) as f64);
        }
    }

    /// Each source vertex's weights over the bones of its grid corners
    /// (`full`, the grid's), by SSDR's weight solve with the file's
    /// transforms `moves` of each frame, against the vertices' `truth`.
    fn source_weights(
        points: &crate::resample::SourcePoints,
        full: &[[(u16, f32); INFLUENCES]],
        rest: &[Vec3],
        moves: &[Vec<crate::skin::BoneTransform>],
        truth: &[Vec<Vec3>],
    ) -> Vec<[(u16, f32); INFLUENCES]> {
        (0..rest.len())
            .map(|v| {
                let corners = points.corners[v];
                let mut cand: Vec<u16> =
                    corners.iter().flat_map(|&c| full[c as usize].iter().filter(|i| i.1 > 0.0).map(|i| i.0)).collect();
                cand.sort_unstable();
                cand.dedup();
                crate::skin::nnls::influences(&cand, |c| {
                    let mut eq = crate::skin::nnls::NormalEquations::new(c.len());
                    let mut cols = vec![Vec3::ZERO; c.len()];
                    for (m, t) in moves.iter().zip(truth) {
                        for (col, &b) in cols.iter_mut().zip(c) {
                            *col = m[b as usize].apply(rest[v]);
                        }
                        eq.add(&cols, t[v]);
                    }
                    eq.solve_weights()
                })
                .unwrap_or(full[corners[0] as usize])
            })
            .collect()
    }
}
