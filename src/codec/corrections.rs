//! The closed loop's corrections: how a frame's decoded correction
//! pictures become a displacement of the predicted grid, and what the
//! encoder puts in the pictures for the displacement it wants. One piece
//! of code for both sides, so the encoder corrects what the decoder has.
//!
//! **Layout.** Up to version 8 the three pictures are the correction's
//! x, y, z at full size (`dx`, `dy`, `dz`). From version 9 they may be on
//! a grid halved `shrink` times, with a fourth picture, `dn`, at full size:
//! what they leave of the correction, along the predicted surface's normal.
//! This is the paper's split made to pay: the normal part moves the
//! surface, the extrinsic geometry that H carries (Guskov et al. 2000,
//! "Normal meshes": one scalar per sample suffices for a surface; V-DMC
//! codes displacements in such a frame), while the rest, mostly tangential,
//! only slides samples along the surface and is smooth (on samba, 2 x 2
//! means keep 94 % of its energy). The coarse part stays in x, y, z rather
//! than the surface's own frame because a rigid move of a thin limb is a
//! constant in x, y, z but oscillates around it in (normal, tangent,
//! bitangent), which H.264 pays for: coding (dn, dt, db) instead lost at
//! every rate (samba, N = 128, 60 frames: 3.1 % surface RMS against 0.58 %
//! at the lowest point). The normal is the prediction's, which the decoder
//! has before any correction arrives.
//!
//! **Filter** (format version 5): `filter` averaging passes over the
//! correction, as a video codec's in-loop deblocking filter. At the lowest
//! rates H.264 keeps little of a correction but its block edges, and in
//! motion mode they never cancel: each frame adds the difference of two
//! decoded pictures, whose block noise the coarse corrections cannot take
//! back, so it piles up in the decoded surface (samba, N = 256,
//! 67 kbit/s: smoothness 24.5 against GV's 22.9). The encoder chooses the
//! filter per frame ([`FILTER_CHOICES`]), so a correction whose detail is
//! real keeps it.

use crate::format::{CorrectionMode, Header};
use crate::grid::{coarse, Grid, Stencils};
use glam::Vec3;
use std::collections::VecDeque;
use std::sync::{Arc, Mutex};

/// The filters (averaging passes) the encoder tries on each frame's
/// correction; it keeps the one that lands closest to the true frame.
pub const FILTER_CHOICES: [u8; 4] = [0, 1, 2, 4];

/// Most relaxation passes the encoder tries on a frame (the format allows
/// up to `format::MAX_RELAX`): on samba at N = 128 one fixed pass every
/// frame cut the worst spacing drift at 72 kbit/s from 46 % to 23 %, four
/// did no better.
pub const RELAX_CHOICES: u8 = 2;

/// One frame's correction pictures' values: x, y, z (each on the grid
/// halved [`Layout::shrink`] times), then the normal picture if the layout
/// has one.
pub type Pictures = Vec<Vec<f32>>;

/// What the correction pictures are.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    /// How many times the x, y, z pictures' grid is halved.
    pub shrink: u8,
    /// A fourth picture, `dn`, at full size: what the x, y, z pictures
    /// leave of the correction, along the predicted surface's normal.
    pub normal: bool,
}

impl Layout {
    /// x, y, z at full size (format versions 1 to 8).
    pub const WORLD: Layout = Layout { shrink: 0, normal: false };

    /// The layout of a header's correction streams (world axes without any).
    pub fn of(h: &Header) -> Layout {
        let Some(names) = h.correction_streams() else { return Layout::WORLD };
        let shrink = h.stream(names[0]).map_or(0, |s| h.streams[s].shrink);
        Layout { shrink, normal: names.len() == 4 }
    }
}

/// The unit normals of the surface `x` after [`NORMAL_SMOOTHING`]
/// averaging passes: x_u × x_v from central differences, normalized; the
/// z axis where that is zero.
pub fn smoothed_normals(st: &Stencils, x: &[Vec3]) -> Vec<Vec3> {
    let s = st.smooth(x.to_vec(), NORMAL_SMOOTHING);
    (0..x.len())
        .map(|v| {
            let (xu, xv) = st.tangents(&s, v);
            let n = xu.cross(xv).normalize_or_zero();
            if n == Vec3::ZERO {
                Vec3::Z
            } else {
                n
            }
        })
        .collect()
}

/// Averaging passes over the prediction before its normals are taken: the
/// decoded surface's coding noise, differentiated, would make the normal
/// picture of a smooth correction noisy (samba, N = 128, scaled, surface
/// frame at full size: 0.37 % surface RMS at 50 KB with 0 passes, 0.26 %
/// with 4, 0.20 % with 16).
pub const NORMAL_SMOOTHING: usize = 16;

/// The corrections' state: the layout, and in motion mode the previous
/// frame's decoded pictures.
#[derive(Debug, Clone)]
pub struct Corrections {
    mode: CorrectionMode,
    layout: Layout,
    st: Stencils,
    prev: Option<Pictures>,
    normals: NormalCache,
}

/// The smoothed normals of the last few surfaces, shared by clones. The
/// encoder takes a frame's prediction's normals four times (normal
/// picture, filter choice, relaxation choice, the decoder's step) and each
/// relaxed surface's twice; at N = 256 that was a third of its time. A
/// surface is known by its values, so what comes out is the same.
#[derive(Debug, Clone, Default)]
struct NormalCache(Arc<Mutex<VecDeque<Surface>>>);

/// A surface and its smoothed normals.
type Surface = (Vec<Vec3>, Vec<Vec3>);

/// Surfaces the cache keeps: a prediction and its two relaxations.
const NORMAL_CACHE: usize = 3;

impl NormalCache {
    fn normals(&self, st: &Stencils, x: &[Vec3]) -> Vec<Vec3> {
        let hit = |c: &VecDeque<Surface>| c.iter().find(|(k, _)| k.as_slice() == x).map(|e| e.1.clone());
        if let Some(n) = self.0.lock().ok().and_then(|c| hit(&c)) {
            return n;
        }
        let n = smoothed_normals(st, x);
        if let Ok(mut c) = self.0.lock() {
            c.push_front((x.to_vec(), n.clone()));
            c.truncate(NORMAL_CACHE);
        }
        n
    }
}

impl Corrections {
    pub fn new(mode: CorrectionMode, layout: Layout, st: Stencils) -> Corrections {
        Corrections { mode, layout, st, prev: None, normals: NormalCache::default() }
    }

    /// The corrections of a file with this header.
    pub fn of(h: &Header, st: Stencils) -> Corrections {
        Corrections::new(h.corrections, Layout::of(h), st)
    }

    /// Picture `c`'s values this frame adds: in motion mode the difference
    /// from the previous frame's.
    fn delta(&self, decoded: &[Vec<f32>], c: usize) -> Vec<f32> {
        match (self.mode, &self.prev) {
            (CorrectionMode::Motion, Some(prev)) => decoded[c].iter().zip(&prev[c]).map(|(d, q)| d - q).collect(),
            _ => decoded[c].clone(),
        }
    }

    /// The displacement the x, y, z pictures carry, on the full grid.
    fn world_increment(&self, decoded: &[Vec<f32>]) -> Vec<Vec3> {
        let coarse = Grid { n: self.st.grid.n >> self.layout.shrink };
        let [x, y, z] = [0, 1, 2].map(|c| coarse::expand(coarse, &self.delta(decoded, c), self.layout.shrink));
        (0..self.st.grid.len()).map(|v| Vec3::new(x[v], y[v], z[v])).collect()
    }

    /// The displacement this frame's decoded pictures carry for the
    /// prediction `x` (already scaled in scaled mode), unfiltered.
    fn increment(&self, x: &[Vec3], decoded: &Pictures) -> Vec<Vec3> {
        let mut inc = self.world_increment(decoded);
        if self.layout.normal {
            let dn = self.delta(decoded, 3);
            let normals = self.normals.normals(&self.st, x);
            inc.iter_mut().zip(&normals).zip(&dn).for_each(|((d, n), a)| *d += *n * *a);
        }
        inc
    }

    /// Adds this frame's correction, after `filter` averaging passes, to
    /// the prediction `x`, then relaxes it `relax` times ([`Self::relax`]).
    pub fn apply(&mut self, x: &mut [Vec3], decoded: Pictures, (filter, relax): (u8, u8)) {
        let inc = self.st.smooth(self.increment(x, &decoded), filter as usize);
        x.iter_mut().zip(&inc).for_each(|(p, d)| *p += *d);
        for _ in 0..relax {
            self.relax(x);
        }
        self.record(decoded);
    }

    /// One pass of tangential relaxation (format version 9): each sample
    /// moves by half of the fine part of its Laplacian's tangential
    /// component, against it. With x, y, z coded coarse, nothing corrects
    /// the fine tangential error that coding noise leaves, and it piles up
    /// over a long motion (samba, N = 128, 72 kbit/s: samples 46 % off their
    /// spacing by the worst frame). On the true grid the tangential
    /// Laplacian is smooth (the metric's Christoffel terms, `grid::stencil`),
    /// so its fine part is that error; the coarse part (the same means and
    /// doubling as the x, y, z pictures) is left to them. The normals are
    /// [`smoothed_normals`]. The encoder chooses the passes per frame.
    pub fn relax(&self, x: &mut [Vec3]) {
        let (st, k) = (&self.st, self.layout.shrink);
        let normals = self.normals.normals(st, x);
        let t: Vec<Vec3> = (0..x.len())
            .map(|v| {
                let l = st.laplacian(x, v);
                l - normals[v] * normals[v].dot(l)
            })
            .collect();
        let coarse = Grid { n: st.grid.n >> k };
        let [a, b, c] = [0, 1, 2].map(|i| {
            let f: Vec<f32> = t.iter().map(|v| v[i]).collect();
            coarse::expand(coarse, &coarse::shrink(st.grid, &f, k), k)
        });
        for (v, p) in x.iter_mut().enumerate() {
            *p -= (t[v] - Vec3::new(a[v], b[v], c[v])) * 0.5;
        }
    }

    /// The encoder's choice of relaxation passes for the corrected frame
    /// `x`: of 0 ..= [`RELAX_CHOICES`], the count that lands closest to
    /// `truth` (none without a normal picture, where x, y, z at full size
    /// leave no fine tangential error uncorrected).
    pub fn best_relax(&self, x: &[Vec3], truth: &[Vec3]) -> u8 {
        if !self.layout.normal {
            return 0;
        }
        let mut y = x.to_vec();
        let distance = |y: &[Vec3]| -> f64 { y.iter().zip(truth).map(|(p, t)| p.distance_squared(*t) as f64).sum() };
        let mut best = (distance(&y), 0);
        for r in 1..=RELAX_CHOICES {
            self.relax(&mut y);
            let e = distance(&y);
            if e < best.0 {
                best = (e, r);
            }
        }
        best.1
    }

    /// Forgets the previous pictures, as at frame 0 (a random-access point).
    pub fn reset(&mut self) {
        self.prev = None;
    }

    /// Records a frame's pictures as decoded without applying them (the
    /// encoder's uncoded loop, which commits the true frame instead).
    pub fn record(&mut self, decoded: Pictures) {
        if self.mode == CorrectionMode::Motion {
            self.prev = Some(decoded);
        }
    }

    /// The encoder's choice of filter for this frame: of
    /// [`FILTER_CHOICES`], the one with which the pictures `decoded`
    /// bring the prediction `x` closest to `truth` (the smallest on a tie).
    pub fn best_filter(&self, x: &[Vec3], decoded: &Pictures, truth: &[Vec3]) -> u8 {
        let mut inc = self.increment(x, decoded);
        let mut done = 0;
        let mut best = (f64::INFINITY, 0);
        for f in FILTER_CHOICES {
            inc = self.st.smooth(inc, (f - done) as usize);
            done = f;
            let e: f64 = x.iter().zip(&inc).zip(truth).map(|((p, d), t)| (*p + *d).distance_squared(*t) as f64).sum();
            if e < best.0 {
                best = (e, f);
            }
        }
        best.1
    }

    /// What picture `c` carries for the values `v` it should add: scaled,
    /// over the frame's `scale`; motion, plus what it held before.
    fn carried(&self, c: usize, mut v: Vec<f32>, scale: f32) -> Vec<f32> {
        match (self.mode, &self.prev) {
            (CorrectionMode::Scaled, _) => v.iter_mut().for_each(|e| *e /= scale),
            (CorrectionMode::Motion, Some(prev)) => v.iter_mut().zip(&prev[c]).for_each(|(e, q)| *e += *q),
            (CorrectionMode::Motion, None) => {}
        }
        v
    }

    /// The encoder's side of [`apply`](Self::apply), first step: what the
    /// x, y, z pictures carry for the correction `err` (means of its
    /// components over the coarse grid's blocks).
    pub fn world_pictures(&self, err: &[Vec3], scale: f32) -> Pictures {
        let k = self.layout.shrink;
        (0..3)
            .map(|c| {
                let full: Vec<f32> = err.iter().map(|e| e[c]).collect();
                self.carried(c, coarse::shrink(self.st.grid, &full, k), scale)
            })
            .collect()
    }

    /// Second step, with a normal picture: what it carries for `err` once
    /// the x, y, z pictures as decoded (`world`, scaled) have added theirs
    /// to the prediction `x`: the rest of `err` along the normal.
    pub fn normal_picture(&self, x: &[Vec3], err: &[Vec3], world: &[Vec<f32>], scale: f32) -> Vec<f32> {
        let moved = self.world_increment(world);
        let normals = self.normals.normals(&self.st, x);
        let left = err.iter().zip(&moved).zip(&normals).map(|((e, m), n)| (*e - *m).dot(*n)).collect();
        self.carried(3, left, scale)
    }
}
