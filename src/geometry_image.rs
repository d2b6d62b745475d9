//! A motion's geometry image: the reference frame parameterized onto the
//! seamless grid ([`crate::param`]) and every grid sample located on the
//! surface ([`crate::resample`]), the map chosen by what its grid makes of
//! the surface. Of the maps the area-correction passes go through
//! ([`parameterize_scored`]), keep the one whose grid mesh lies closest to
//! the reference frame's surface (the symmetric RMS distance of
//! [`metrics::surface`](crate::metrics::surface)).
//!
//! This is the resampling error every codec starts from (the uncompressed
//! grid's), so it bounds the surface error of the best encode. Measured on
//! the reference frame, at N = 128, mean over 8 frames of the sequence
//! (`cgv remesh` reports the same figure): horse-gallop 0.285 % of the
//! diagonal after format v5's fixed 40 passes, 0.208 % after 200; pcow
//! 0.169 % after 40, 0.119 % after 20, 0.174 % after 200; samba 0.056 %
//! after 40, 0.046 % after 200. No fixed count suits all three.
//!
//! The same score places the cones. `cut::choose_cones` puts them on the
//! first four extremities (farthest-point sampling of geodesic distance), but
//! which four matters more than the passes do: on horse-gallop leaving out
//! the fourth extremity for the fifth cuts the resampling error 4x. So every
//! four of the first five race through the passes, and the losers drop out
//! early ([`RACE_MARGIN`], [`RACE_DECIDE`]): about twice the time of one
//! placement's passes instead of five times.

use crate::error::{Error, Result};
use crate::format::{Offsets, SourceMesh};
use crate::grid::Grid;
use crate::mesh::carrier::Carrier;
use crate::mesh::Topology;
use crate::metrics::surface;
use crate::param::area::AreaPasses;
use crate::param::{cut, ParamOptions, Parameterization, SCORED_PASSES};
use crate::resample::{SampleMap, SourcePoints};
use glam::Vec3;
use rayon::prelude::*;
use std::path::Path;

/// The reference frame's parameterization and the grid's sample map: what
/// every encode of one motion at one grid size shares.
#[derive(Debug, Clone)]
pub struct GeometryImage {
    /// The closed genus-0 surface parameterized: the input itself when it
    /// is one, else the input closed up ([`Carrier`]).
    pub carrier: Carrier,
    pub param: Parameterization,
    pub map: SampleMap,
    /// Each input vertex's place on the grid, quantized as a file stores
    /// it: its place in the parameterization, or a nearby one that
    /// [`fit_places`](Self::fit_places) found to follow the motion better.
    pub places: Vec<[u32; 2]>,
    /// How many places `fit_places` moved.
    pub places_moved: usize,
    /// Each input vertex's offset from the grid mesh of the reference
    /// frame (format version 7), quantized as a file carries it.
    pub offsets: Option<Offsets>,
    /// Each loose vertex's anchor (format version 11): the grid sample
    /// nearest it on the reference frame, whose motion it follows.
    pub loose_anchors: Vec<u32>,
    /// Time spent parameterizing (the cone race and the area passes).
    pub seconds_parameterize: f64,
    /// Time spent locating the samples.
    pub seconds_locate: f64,
}

impl GeometryImage {
    /// The geometry image of the mesh `topology` whose reference frame is
    /// `reference` (from the file `label`, named in errors) on `grid`.
    pub fn build(
        label: &Path,
        topology: &Topology,
        reference: &[Vec3],
        grid: Grid,
        opts: &ParamOptions,
    ) -> Result<GeometryImage> {
        if topology.vertex_count == grid.len() && is_part_of(&topology.faces, &grid.topology().faces) {
            return GeometryImage::on_its_own_grid(label, topology, reference, grid, opts);
        }
        let t = std::time::Instant::now();
        let mut carrier = Carrier::build_with(label, topology, reference, opts.loose_max_vertices)?;
        let mut param = parameterize_carrier(&carrier, topology, reference, grid, opts);
        // A carrier too coarse for its cone paths gets finer, twice at most.
        for _ in 0..SUBDIVISIONS {
            if param.is_ok() {
                break;
            }
            carrier.subdivide();
            param = parameterize_carrier(&carrier, topology, reference, grid, opts);
        }
        let param = param?;
        let seconds_parameterize = t.elapsed().as_secs_f64();
        let t = std::time::Instant::now();
        let map = SampleMap::on_carrier(grid, &carrier, &param)?;
        let places = crate::resample::carrier_places(&carrier, &param);
        let mut image = GeometryImage::assemble(grid, (carrier, param, map), places, reference);
        (image.seconds_parameterize, image.seconds_locate) = (seconds_parameterize, t.elapsed().as_secs_f64());
        Ok(image)
    }

    /// The image of a map: each input vertex's place and its offset from
    /// the grid on `reference`, and each loose vertex's nearest sample there.
    fn assemble(
        grid: Grid,
        (carrier, param, map): (Carrier, Parameterization, SampleMap),
        places: Vec<[u32; 2]>,
        reference: &[Vec3],
    ) -> GeometryImage {
        let on_grid = map.apply(reference);
        let offsets = offsets_of(grid, &places, &carrier.loose, reference, &on_grid);
        let loose: Vec<Vec3> = carrier.loose.iter().map(|&v| reference[v as usize]).collect();
        let loose_anchors = nearest_samples(&loose, &on_grid);
        GeometryImage {
            carrier,
            param,
            map,
            places,
            places_moved: 0,
            offsets,
            loose_anchors,
            seconds_parameterize: 0.0,
            seconds_locate: 0.0,
        }
    }

    /// A motion already on `grid`'s own mesh, or on part of it (a
    /// registered capture, `crate::features::register`, whose faces over
    /// holes are left out, or a grid mesh of this size) is its own
    /// geometry image: each sample its vertex, no map to find and nothing
    /// lost to resampling. The parameterization reported is the grid's own
    /// layout (each vertex at its sample, the cones at the sides' middles);
    /// it has no per-corner isometries, which only locating samples needs.
    fn on_its_own_grid(
        label: &Path,
        topology: &Topology,
        reference: &[Vec3],
        grid: Grid,
        opts: &ParamOptions,
    ) -> Result<GeometryImage> {
        let carrier = Carrier::build_with(label, topology, reference, 0)?;
        let map = SampleMap::identity_on(grid, &topology.faces);
        let places: Vec<[u32; 2]> = (0..grid.len() as u32).map(|s| crate::resample::sample_place(grid, s)).collect();
        let n = grid.n as u32;
        let at = |k: usize| (k as f64 + 0.5) * 2.0 / grid.n as f64 - 1.0;
        let param = Parameterization {
            cones: [(n / 2, n - 1), (n - 1, n / 2), (n / 2, 0), (0, n / 2)].map(|(i, j)| j * n + i),
            corner: 0,
            cut_paths: Default::default(),
            uv: (0..grid.len()).map(|s| glam::DVec2::new(at(s % grid.n), at(s / grid.n))).collect(),
            corner_iso: Vec::new(),
            conformal: Default::default(),
            distortion: Default::default(),
            area_passes: 0,
            score: Some(0.0),
            options: opts.clone(),
        };
        // Built with no loose parts: every vertex is on the grid.
        Ok(GeometryImage::assemble(grid, (carrier, param, map), places, reference))
    }

    /// Moves input vertices' places where a nearby one rebuilds them
    /// closer over the motion ([`crate::place_fit`]), judged on up to
    /// [`FIT_FRAMES`] frames of `src` spread over it (alternately choosing
    /// and checking), and measures the offsets again. `reference` is the
    /// frame the image was built on. A motion of fewer than three frames
    /// keeps every place.
    pub fn fit_places(&mut self, src: &dyn crate::mesh::FrameSource, reference: usize) -> Result<()> {
        use crate::place_fit::{fit_places, FitFrame};
        let t = std::time::Instant::now();
        let n = src.frame_count();
        let mut picked: Vec<usize> = (0..FIT_FRAMES).map(|k| k * n / FIT_FRAMES).filter(|&i| i != reference).collect();
        picked.dedup();
        if picked.len() < 2 {
            return Ok(());
        }
        let inputs = picked.iter().map(|&i| src.read_frame(i)).collect::<Result<Vec<_>>>()?;
        let grids: Vec<Vec<Vec3>> = inputs.iter().map(|f| self.map.apply(f)).collect();
        let every_other = |first: usize| -> Vec<FitFrame> {
            inputs.iter().zip(&grids).skip(first).step_by(2).map(|(i, g)| FitFrame { grid: g, input: i }).collect()
        };
        let (choosing, checking) = (every_other(0), every_other(1));
        let reference_frame = src.read_frame(reference)?;
        let reference_grid = self.map.apply(&reference_frame);
        let mut fixed: Vec<bool> = self.carrier.carrier_of.iter().map(|&c| c == crate::mesh::adjacency::NONE).collect();
        for &v in &self.carrier.loose {
            fixed[v as usize] = true;
        }
        let grid = self.map.grid;
        let places = fit_places(grid, &self.places, &fixed, (&reference_frame, &reference_grid), &choosing, &checking);
        self.places_moved = places.iter().zip(&self.places).filter(|(a, b)| a != b).count();
        self.places = places;
        self.offsets = offsets_of(grid, &self.places, &self.carrier.loose, &reference_frame, &reference_grid);
        self.seconds_locate += t.elapsed().as_secs_f64();
        Ok(())
    }

    /// The input's mesh as a version-7 file carries it: `topology`'s faces,
    /// each vertex's place on this image and its offset from there.
    pub fn source_mesh(&self, topology: &Topology) -> SourceMesh {
        SourceMesh {
            faces: topology.faces.clone(),
            places: self.places.clone(),
            offsets: self.offsets.clone(),
            loose_of: self.loose_of(topology.vertex_count),
            loose_anchors: self.loose_anchors.clone(),
        }
    }

    /// Each of the input's `vertices` vertices' loose vertex plus one, 0
    /// where the grid rebuilds it (empty without loose vertices).
    pub fn loose_of(&self, vertices: usize) -> Vec<u32> {
        if self.carrier.loose.is_empty() {
            return Vec::new();
        }
        let mut of = vec![0; vertices];
        for (k, &v) in self.carrier.loose.iter().enumerate() {
            of[v as usize] = k as u32 + 1;
        }
        of
    }

    /// [`source_mesh`](Self::source_mesh) over the input's stored vertices
    /// when it has an appearance (each with its welded vertex's place and
    /// offset), so that the decoded mesh keeps its UV seams.
    pub fn source_mesh_as_stored(&self, topology: &Topology, look: Option<&crate::mesh::Appearance>) -> SourceMesh {
        let mesh = self.source_mesh(topology);
        let Some(a) = look else { return mesh };
        let at = |w: &u32| mesh.places.get(*w as usize).copied().unwrap_or_default();
        let offsets = mesh.offsets.as_ref().map(|o| Offsets {
            step: o.step,
            values: a.welded.iter().map(|w| o.values.get(*w as usize).copied().unwrap_or_default()).collect(),
        });
        let loose_of = if mesh.loose_of.is_empty() {
            Vec::new()
        } else {
            a.welded.iter().map(|w| mesh.loose_of.get(*w as usize).copied().unwrap_or(0)).collect()
        };
        let places = a.welded.iter().map(at).collect();
        SourceMesh { faces: a.faces.clone(), places, offsets, loose_of, loose_anchors: mesh.loose_anchors }
    }

    /// The faces of the surface a decoder shows, over the grid's samples
    /// followed by the loose vertices ([`surface_vertices`]): the grid
    /// mesh's faces that lie on the input, and the loose parts' own faces
    /// (of `topology`, the input's).
    pub fn surface_faces(&self, topology: &Topology) -> Vec<[u32; 3]> {
        let mut faces = self.map.surface_faces();
        let loose_of = self.loose_of(topology.vertex_count);
        let n = self.map.grid.len() as u32;
        let at = |v: u32| loose_of.get(v as usize).copied().filter(|&k| k > 0).map(|k| n + k - 1);
        faces.extend(topology.faces.iter().filter_map(|f| Some([at(f[0])?, at(f[1])?, at(f[2])?])));
        faces
    }

    /// Where each input vertex lies on the grid mesh, and its offset: the
    /// decoder's rule.
    pub fn source_points(&self) -> SourcePoints {
        SourcePoints::from_places(self.map.grid, &self.places).with_offsets(self.offsets.as_ref())
    }

    /// Both times together.
    pub fn seconds(&self) -> f64 {
        self.seconds_parameterize + self.seconds_locate
    }
}

/// For each point, the sample of `grid` nearest it (ties to the lower
/// index): a scan of every sample, once per file, for a few tiny parts'
/// vertices.
fn nearest_samples(points: &[Vec3], grid: &[Vec3]) -> Vec<u32> {
    points
        .iter()
        .map(|p| {
            let d = |i: &usize| grid[*i].distance_squared(*p);
            (0..grid.len()).min_by(|a, b| d(a).total_cmp(&d(b)).then(a.cmp(b))).unwrap_or(0) as u32
        })
        .collect()
}

/// The vertices of [`GeometryImage::surface_faces`]: a decoded grid frame
/// and the loose vertices decoded with it.
pub fn surface_vertices(grid_frame: &[Vec3], loose: &[Vec3]) -> Vec<Vec3> {
    grid_frame.iter().chain(loose).copied().collect()
}

/// [`parameterize_carrier`] of a closed genus-0 input, its own carrier.
pub fn parameterize_for_grid(
    topology: &Topology,
    reference: &[Vec3],
    grid: Grid,
    opts: &ParamOptions,
) -> Result<Parameterization> {
    let carrier = Carrier::build(Path::new("input"), topology, reference)?;
    parameterize_carrier(&carrier, topology, reference, grid, opts)
}

/// [`crate::param::parameterize`] of the carrier of `source` (whose first
/// frame is `reference`), keeping of the area-correction passes the map
/// whose `grid` resamples the input's surface with the lowest symmetric
/// RMS surface distance (reported in [`Parameterization::score`], in the
/// mesh's units).
pub fn parameterize_carrier(
    carrier: &Carrier,
    source: &Topology,
    reference: &[Vec3],
    grid: Grid,
    opts: &ParamOptions,
) -> Result<Parameterization> {
    // The loose parts are coded as themselves: the grid is scored on the rest.
    let source = &carrier.on_grid(source);
    let target = surface::Target::new(reference, &source.faces)?;
    let input = (source, reference);
    let mut p = choose_map(carrier, input, grid, opts, &target)?;
    // The kept map's own figure, measured whole: it is what the encoder
    // reports as the grid's floor and what `--grid auto` decides by.
    if p.score.is_some() {
        p.score = Some(grid_score(&p, (grid, carrier), input, &target, (f64::INFINITY, 1))?);
    }
    Ok(p)
}

/// The race of cone placements and their passes, ranked on a subsample
/// ([`SCORE_EVERY`]).
fn choose_map(
    carrier: &Carrier,
    input: (&Topology, &[Vec3]),
    grid: Grid,
    opts: &ParamOptions,
    target: &surface::Target,
) -> Result<Parameterization> {
    let reference = input.1;
    // A copy for each caller (it only reads): `&mut { score }` below.
    let score = |p: &Parameterization, above: f64| grid_score(p, (grid, carrier), input, target, (above, SCORE_EVERY));
    let positions = carrier.positions(reference);
    let (topology, reference) = (&carrier.topology, &positions[..]);
    let nv = topology.vertex_count;
    if opts.cones.is_some() || nv < 5 || reference.len() != nv {
        // Given cones, or a mesh that parameterize_scored rejects with the reason.
        return AreaPasses::start_with(topology, reference, Some(&carrier.real), opts)?.finish(Some(&mut { score }));
    }
    let (mut racers, mut first_error) = start_racers(carrier, reference, opts);
    // The race: all run in step to each scored pass count from RACE_FROM
    // on, but those of RACE_DEFERRED. One drops out when its best score is
    // past RACE_MARGIN times the leader's, or did not fall since the last
    // count (it has stopped, or its passes are not helping it: leading it
    // back would cost what racing saves). At RACE_DECIDE the leader alone
    // goes on.
    for &stop in
        SCORED_PASSES.iter().filter(|&&s| (RACE_FROM..=RACE_DECIDE).contains(&s) && !RACE_DEFERRED.contains(&s))
    {
        if racers.len() < 2 {
            break;
        }
        let advanced = advance_all(racers, stop, &score);
        let mut running = Vec::with_capacity(advanced.len());
        for (result, r, before) in advanced {
            match result {
                Ok(()) => running.push((r, before)),
                Err(err) => {
                    first_error.get_or_insert(err);
                }
            }
        }
        let lead = running.iter().filter_map(|(r, _)| r.score()).fold(f64::INFINITY, f64::min);
        // The first to reach the lead leads (ties go to the earlier start).
        let Some(i) = running.iter().position(|(r, _)| r.score() == Some(lead)) else {
            racers = running.into_iter().map(|(r, _)| r).collect();
            break;
        };
        let (leader, _) = running.remove(i);
        racers = vec![leader];
        if stop < RACE_DECIDE {
            racers.extend(running.into_iter().filter_map(|(r, before)| {
                let s = r.score()?;
                let fell = before.is_none_or(|b| s < b);
                (fell && s <= RACE_MARGIN * lead).then_some(r)
            }));
        }
    }
    match racers.into_iter().next() {
        Some(leader) => finish_leader(leader, &score),
        // Every placement failed (there are always CONE_CANDIDATES of them,
        // so there is an error to report).
        None => Err(first_error.unwrap_or_else(|| Error::Numerical("no cone placement could be cut".into()))),
    }
}

/// The racers: each four of the first [`CONE_CANDIDATES`] extremities of
/// the carrier (positions `reference`; the first four are what
/// `cut::choose_cones` picks, and start first, so they win ties), the
/// corner farthest from them, each with its conformal map solved (on its
/// own core; rayon keeps the order). Some cannot be cut apart (two cones
/// whose paths must cross): they drop out, and the first such error is
/// returned beside the others.
fn start_racers(carrier: &Carrier, reference: &[Vec3], opts: &ParamOptions) -> (Vec<AreaPasses>, Option<Error>) {
    let (topology, nv) = (&carrier.topology, carrier.topology.vertex_count);
    let pos: Vec<glam::DVec3> = reference.iter().map(|p| p.as_dvec3()).collect();
    let graph = cut::Graph::new(nv, &topology.faces, &pos);
    let e = cut::extremities(&graph, nv, CONE_CANDIDATES);
    let started: Vec<Result<AreaPasses>> = fours(e.len())
        .into_par_iter()
        .map(|c| {
            let cones = c.map(|i| e[i]);
            let corner = cut::corner_for(&graph, nv, &cones);
            let o = ParamOptions { cones: Some((cones, corner)), ..opts.clone() };
            Ok(AreaPasses::start_with(topology, reference, Some(&carrier.real), &o)?
                .score_from(RACE_FROM)
                .defer(&RACE_DEFERRED))
        })
        .collect();
    let (mut racers, mut first_error) = (Vec::new(), None);
    for r in started {
        match r {
            Ok(r) => racers.push(r),
            Err(err) => {
                first_error.get_or_insert(err);
            }
        }
    }
    (racers, first_error)
}

/// Runs every racer's passes to `stop`, [`SEGMENT`] passes at a time, those furthest
/// behind first, one on each core: three racers on two cores then finish
/// together instead of the third alone after the other two. They share
/// nothing but the scoring target, read only, and each racer's passes run
/// in their order, so the maps do not depend on the schedule.
fn advance_all(
    racers: Vec<AreaPasses>,
    stop: usize,
    score: &(dyn Fn(&Parameterization, f64) -> Result<f64> + Sync),
) -> Vec<Raced> {
    let mut all: Vec<Raced> = racers
        .into_iter()
        .map(|r| {
            let before = r.score();
            (Ok(()), r, before)
        })
        .collect();
    let lanes = rayon::current_num_threads().max(1);
    loop {
        let mut behind: Vec<&mut Raced> =
            all.iter_mut().filter(|(e, r, _)| e.is_ok() && !r.stopped() && r.passes() < stop).collect();
        if behind.is_empty() {
            return all;
        }
        // A stable sort: ties go to the earlier start.
        behind.sort_by_key(|(_, r, _)| r.passes());
        behind.truncate(lanes);
        behind.into_par_iter().for_each(|(e, r, _)| {
            let until = (r.passes() + SEGMENT).min(stop);
            *e = r.advance(until, Some(&mut { score }));
        });
    }
}

/// A racer after [`advance_all`]: its passes' error, the racer, and its
/// best score before them.
type Raced = (Result<()>, AreaPasses, Option<f64>);

/// Passes a racer runs at a time in [`advance_all`].
const SEGMENT: usize = 10;

/// The leader's remaining passes on one core and the scores of its
/// deferred maps on the other (the passes are serial, and those maps'
/// scores do not depend on them), then its kept map. The same map is kept
/// as when they were scored after the passes: a deferred map is kept only
/// if it beats every other, and the kept score when the passes start, a
/// bound its final one stays under, bounds their scores.
fn finish_leader(
    mut leader: AreaPasses,
    score: &(dyn Fn(&Parameterization, f64) -> Result<f64> + Sync),
) -> Result<Parameterization> {
    let deferred = leader.take_deferred();
    let bound = leader.score().unwrap_or(f64::INFINITY);
    let (ran, scored) = rayon::join(
        || leader.advance(usize::MAX, Some(&mut { score })),
        || deferred.into_par_iter().map(|p| Ok((score(&p, bound)?, p))).collect::<Result<Vec<_>>>(),
    );
    ran?;
    for (s, p) in scored? {
        leader.offer(p, s);
    }
    leader.finish(Some(&mut { score }))
}

/// Every four of `0..k`, in lexicographic order.
fn fours(k: usize) -> Vec<[usize; 4]> {
    let mut out = Vec::new();
    for a in 0..k {
        for b in a + 1..k {
            for c in b + 1..k {
                for d in c + 1..k {
                    out.push([a, b, c, d]);
                }
            }
        }
    }
    out
}

/// How closely `grid` resamples the input through map `p` of its carrier:
/// the symmetric RMS surface distance, in the mesh's units (infinity once it
/// is certainly above `above`; with `every` above 1, the grid's side on
/// every `every`-th quad only). A map whose
/// samples cannot all be located (it cannot happen for a map without folds,
/// which is all the passes keep) is no candidate.
fn grid_score(
    p: &Parameterization,
    (grid, carrier): (Grid, &Carrier),
    (source, reference): (&Topology, &[Vec3]),
    target: &surface::Target,
    (above, every): (f64, usize),
) -> Result<f64> {
    let Ok(map) = SampleMap::on_carrier(grid, carrier, p) else {
        return Ok(f64::INFINITY);
    };
    let g = map.apply(reference);
    let faces = map.surface_faces();
    // Each sample of a grid face lies on an input face: near the face's
    // quadrature point by that sample.
    let near = |f: usize| {
        let on = |s: u32| {
            let c = map.corners[s as usize];
            c.iter().all(|&v| (v as usize) < reference.len()).then(|| c.map(|v| reference[v as usize]))
        };
        Some([on(faces[f][0])?, on(faces[f][1])?, on(faces[f][2])?])
    };
    surface::symmetric_rms_to((&g, &faces), &near, (reference, &source.faces), target, (above, every))
}

/// The finest step of the vertex offsets, relative to the reference
/// frame's diagonal: a rounding error of at most 2e-5 a component (3.5e-5
/// a vertex), a fifth of the finest resampling floor we measured (samba,
/// N = 256: 1.6e-4), where 1e-5 spent 8 KB more of samba's source mesh on
/// digits below any codec's error.
pub const OFFSET_STEP: f32 = 4e-5;

/// Most frames [`GeometryImage::fit_places`] reads (the reference frame
/// among them is skipped): enough to see a motion's range, few enough to
/// cost a small part of an encode.
pub const FIT_FRAMES: usize = 16;

/// Whether every face of `faces` is one of `grid`'s, in the same order
/// (the grid's mesh with some faces left out).
fn is_part_of(faces: &[[u32; 3]], grid: &[[u32; 3]]) -> bool {
    let mut rest = grid.iter();
    faces.iter().all(|f| rest.any(|g| g == f))
}

/// Each input vertex's offset from its place on the reference frame's grid
/// `reference_grid` (format version 7), quantized as a file carries it;
/// loose vertices, coded as themselves, have none.
fn offsets_of(
    grid: Grid,
    places: &[[u32; 2]],
    loose: &[u32],
    reference: &[Vec3],
    reference_grid: &[Vec3],
) -> Option<Offsets> {
    let mut offsets = SourcePoints::from_places(grid, places).offsets_to(reference_grid, reference);
    for &v in loose {
        if let Some(o) = offsets.get_mut(v as usize) {
            *o = [0.0; 3];
        }
    }
    Offsets::quantize(&offsets, crate::mesh::Bounds::of(reference).diagonal() * OFFSET_STEP)
}

/// How many times [`GeometryImage::build`] subdivides a carrier whose
/// parameterization failed (a mesh of a few dozen vertices can have no
/// four disjoint cone paths) before it reports the failure.
pub const SUBDIVISIONS: usize = 2;

/// Extremities the cones are chosen among, four at a time (so five
/// placements race). Measured at N = 128, mean over 8 frames, with every
/// 4-subset of the first six extremities fully parameterized: the best
/// subset leaves out one of the first five on all three sequences
/// (horse-gallop 0.053 % of the diagonal against 0.208 % for the first four;
/// pcow 0.097 % against 0.119 %; samba: the first four are best, 0.046 %).
pub const CONE_CANDIDATES: usize = 5;

/// The maps are ranked on every this-many-th quad of the grid mesh and
/// pair of the input's faces, and the kept map is measured whole once. On
/// the 14 runs of docs/RESULTS.md ("Speed": seven sequences at N = 128 and
/// 256) every third kept the same map as measuring every face on 12 and
/// maps at most 1.7 % worse on the other two (wolf at N = 128: 20 passes
/// instead of 30; horse-gallop at N = 128: 112 instead of 100); every
/// fourth quad and second input face kept a map 18 % worse on pcow at
/// N = 128.
pub const SCORE_EVERY: usize = 3;

/// Pass count from which the cone placements are compared. Before it the
/// ranking is noise: at 10 passes horse-gallop's eventual worst placement
/// leads.
pub const RACE_FROM: usize = 20;

/// A placement whose best score is past this many times the leader's drops
/// out. Reference-frame scores at N = 128 / 256, 20 passes: samba's
/// eventual winner is 1.29x / 1.07x the leader there (it leads from 60
/// passes on); the losers that drop are 1.7x to 2.5x.
pub const RACE_MARGIN: f64 = 1.5;

/// Scored pass counts within the race at which the placements are not
/// compared (so they race from RACE_FROM straight to RACE_DECIDE): only
/// the winner's maps of these counts are scored, when it finishes. On the
/// 14 runs of docs/RESULTS.md ("Speed") every map kept is the same as when
/// the placements were compared at each count, and samba's N = 256
/// parameterization took 3.4 s instead of 4.6 (then with 60 among them,
/// when the race was decided at 80).
pub const RACE_DEFERRED: [usize; 2] = [30, 40];

/// Pass count at which the leader alone goes on. Samba's winner (N = 128)
/// leads its runner-up by 13 % at 60 passes, 18 % at 80 and 20 % at the
/// end; the other sequences are decided earlier. Deciding at 60 instead of
/// 80 kept the same map on all 14 runs of docs/RESULTS.md ("Speed"), and
/// spares samba's two losing placements 20 passes each.
pub const RACE_DECIDE: usize = 60;
