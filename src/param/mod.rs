//! Parameterization of a closed genus-0 surface onto the square orbifold of
//! the seamless geometry image ([`crate::grid`]).
//!
//! The square with its border folded at the middle of each side (Praun &
//! Hoppe, "Spherical parametrization and remeshing", SIGGRAPH 2003) is a
//! sphere: a flat one with four cone points of angle π. We map the surface
//! onto it directly, in two steps:
//!
//! 1. **Conformal.** The orbifold harmonic map of Aigerman & Lipman (2015)
//!    with cotangent weights ([`orbifold`]), cones on the extremities
//!    ([`cut`]): as conformal as the cones' positions allow, one sparse
//!    Cholesky solve.
//! 2. **Area.** Conformal maps shrink protrusions exponentially (on samba the
//!    hand at the corner point gets 1e-12 of its share of the square), and no
//!    reweighting of a symmetric energy can undo that, because a harmonic map
//!    of a tube stays conformal inside it. So we then run the stretch
//!    minimization of Yoshizawa, Belyaev & Seidel ("A fast and simple
//!    stretch-minimizing mesh parameterization", SMI 2004), with area
//!    stretch in place of their L2 stretch: divide each half-edge weight by
//!    the area stretch at its far vertex to the power η, re-solve the (now
//!    unsymmetric, but a symmetric one rescaled: `orbifold::OrbifoldSystem::
//!    solve_scaled`) Tutte system, and repeat while the mean |ln area ratio|
//!    decreases. Unsymmetric positive weights keep the orbifold
//!    Tutte guarantee of a bijection. η = 0 (or zero passes) keeps the
//!    conformal map.
//! 3. **Chosen by the grid.** Mean area stretch is not what the codecs pay
//!    for; the grid's resampling error is. The encoder scores the maps the
//!    passes go through by that error and keeps the best, and places the
//!    cones by the same error (`crate::geometry_image`). The passes themselves run in
//!    [`area`], resumable so that cone placements can race.
//!
//! Both the conformal and the final map's distortion are reported.

pub mod area;
pub mod cut;
pub mod distortion;
pub mod orbifold;

use crate::error::Result;
use crate::mesh::Topology;
use cut::Iso;
use distortion::Distortion;
use glam::{DVec2, Vec3};

/// How to parameterize.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ParamOptions {
    /// Stretch-minimization exponent η per pass (0 keeps the map conformal).
    pub area_correction: f64,
    /// Largest number of stretch-minimization passes (it stops earlier when
    /// the stretch stops decreasing).
    pub area_passes: usize,
    /// Cone vertices (top, right, bottom, left) and corner vertex; chosen
    /// automatically when absent.
    pub cones: Option<([u32; 4], u32)>,
    /// Parts of at most this many vertices (other than the largest) are
    /// coded as their own vertices, not on the grid (0: none are;
    /// `crate::mesh::carrier::LOOSE_MAX_VERTICES` by default).
    pub loose_max_vertices: usize,
    /// Where the cut should run, per cone of `cones` (an earlier frame's
    /// cut, [`cut::CutGuide`]); shortest paths when absent.
    #[serde(skip)]
    pub cut_guide: Option<std::sync::Arc<cut::CutGuide>>,
}

impl Default for ParamOptions {
    fn default() -> Self {
        ParamOptions {
            area_correction: 0.5,
            area_passes: 200,
            cones: None,
            loose_max_vertices: crate::mesh::carrier::LOOSE_MAX_VERTICES,
            cut_guide: None,
        }
    }
}

/// Local stretch above which a vertex's weights are treated as this large:
/// beyond it the update only makes the system ill-conditioned.
const STRETCH_CAP: f64 = 1e6;

/// A map from a mesh to the square orbifold.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Parameterization {
    /// Cone vertices at the middles of the top, right, bottom, left sides.
    pub cones: [u32; 4],
    /// The vertex at the square's corners.
    pub corner: u32,
    /// The cut: the path from `corner` to each of `cones`, both ends included.
    #[serde(skip)]
    pub cut_paths: [Vec<u32>; 4],
    /// Position of each vertex's canonical copy in the plane.
    #[serde(skip)]
    pub uv: Vec<DVec2>,
    /// Per face corner, the isometry to the copy that face sees.
    #[serde(skip)]
    pub corner_iso: Vec<[Iso; 3]>,
    /// Distortion of the conformal map (before area correction).
    pub conformal: Distortion,
    /// Distortion of the final map.
    pub distortion: Distortion,
    /// Area-correction passes the final map took.
    pub area_passes: usize,
    /// The score of the final map, where the passes were chosen by one
    /// (see [`parameterize_scored`]).
    pub score: Option<f64>,
    pub options: ParamOptions,
}

impl Parameterization {
    /// The same map turned a quarter (counter-clockwise) about the
    /// square's centre: each place, each corner's copy and each cone's
    /// side turn with it. The grid mesh splits every quad along the same
    /// diagonal, so the turned map lays it the other way across the
    /// surface, which resamples some surfaces better (docs/RESULTS.md,
    /// "Both ways round"; a capture's pieces are turned so,
    /// `crate::features::diagonals`).
    pub fn turned_quarter(&self) -> Parameterization {
        let turn = |u: DVec2| DVec2::new(-u.y, u.x);
        // The top side's cone goes to the left side, the right's to the top.
        let from = |k: usize| (k + 1) % 4;
        Parameterization {
            cones: std::array::from_fn(|k| self.cones[from(k)]),
            cut_paths: std::array::from_fn(|k| self.cut_paths[from(k)].clone()),
            uv: self.uv.iter().map(|&u| turn(u)).collect(),
            corner_iso: self.corner_iso.iter().map(|c| c.map(|i| Iso { s: i.s, t: turn(i.t) })).collect(),
            ..self.clone()
        }
    }

    /// The image of face `f` in the plane: a proper triangle, possibly
    /// reaching outside the square (it wraps across the seam there).
    pub fn face_uv(&self, faces: &[[u32; 3]], f: usize) -> [DVec2; 3] {
        let face = faces[f];
        [0, 1, 2].map(|k| self.corner_iso[f][k].apply(self.uv[face[k] as usize]))
    }
}

/// Parameterizes the surface `topology` with positions `positions` (the
/// reference frame). The surface must be a closed genus-0 manifold.
pub fn parameterize(topology: &Topology, positions: &[Vec3], opts: &ParamOptions) -> Result<Parameterization> {
    parameterize_scored(topology, positions, opts, None)
}

/// Numbers of area-correction passes after which [`parameterize_scored`]
/// scores the map, and after the last pass taken. Sparse where the passes
/// change the map least, since a score (a resampling error) costs as much
/// as several passes.
pub const SCORED_PASSES: [usize; 12] = [5, 10, 15, 20, 30, 40, 60, 80, 100, 130, 160, 200];

/// [`parameterize_scored`] stops the passes once a score is this many times
/// the best one. Measured at N = 128 on the reference frame (RMS surface
/// distance, % of the diagonal, after 5, 10, 15, 20, 30, 40 passes): pcow
/// 0.65, 0.34, 0.125, **0.115**, 0.140, 0.166, rising on to 0.174; the
/// default motion 0.146, 0.063, **0.050**, 0.056, 0.073; horse-gallop 1.53,
/// 0.27, 0.195, 0.190, 0.195, 0.199, and lower again after 89 passes (so a
/// small rise is no reason to stop); samba falls to 0.040 at 130. The
/// passes past a minimum can cost 4x the time of those before it.
pub const SCORE_GIVE_UP: f64 = 1.5;

/// A map's score (lower is better), or an error that ends the
/// parameterization. The second argument is the score above which the map
/// is of no use (it cannot be kept); a score may then stop early and give
/// any figure above it.
pub type Score<'a> = &'a mut dyn FnMut(&Parameterization, f64) -> Result<f64>;

/// [`parameterize`], keeping of the maps that the area-correction passes go
/// through the one that `score` rates best (scored after the passes in
/// [`SCORED_PASSES`] and after the last). Mean area stretch is a proxy: the
/// map that equalizes area best is not the one whose grid resamples the
/// surface best (pcow at N = 128: 0.169 % of the diagonal after the 40 passes
/// of format v5's encodes, 0.119 % after 20, 0.174 % once the stretch stops
/// falling).
pub fn parameterize_scored(
    topology: &Topology,
    positions: &[Vec3],
    opts: &ParamOptions,
    score: Option<Score>,
) -> Result<Parameterization> {
    area::AreaPasses::start(topology, positions, opts)?.finish(score)
}
