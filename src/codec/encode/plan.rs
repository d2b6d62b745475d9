//! Step 1: what the file will hold, from the options alone: which streams
//! at which frames, the key frames, the frames with corrections. (The
//! header, which needs the other steps' measurements too, is made in
//! [`super::header`].)

use super::EncodeOptions;
use crate::codec::corrections::Layout;
use crate::error::{Error, Result};
use crate::format::stream::{CORRECTION, POSITION, SEED};
use crate::format::{self, CodecKind, Coverage, StreamName};
use crate::grid::{coarse, Grid};
use crate::solve::predictor::{Extrapolation, ALL_EXTRAPOLATIONS, MOTION_EXTRAPOLATIONS};

/// The layout of one encode.
pub(super) struct Plan {
    pub codec: CodecKind,
    pub grid: Grid,
    pub frames: usize,
    /// The encoder runs the predictive decoder on what it codes.
    pub closed_loop: bool,
    /// The corrections are coded as their running sum.
    pub motion: bool,
    /// Motion files: corrections on frames 0, 1 and every `interval`-th
    /// after; other files: λ every `interval`-th frame.
    interval: u32,
    pub key_frames: Vec<u32>,
    /// Layer-1 streams and the frames each has.
    pub names: Vec<(StreamName, Coverage)>,
    pub anchor_count: usize,
    /// The extrapolations the encoder may choose from.
    pub allowed: &'static [Extrapolation],
    /// What the correction pictures mean.
    pub layout: Layout,
    /// A random-access point every this many frames (none but frame 0
    /// when absent).
    pub random_access: Option<u32>,
    /// Random-access points besides the interval's, where segments start.
    pub segments: Vec<u32>,
}

impl Plan {
    /// The plan of `opts` (already validated) for a motion of `frames`
    /// frames at `fps`.
    pub fn new(opts: &EncodeOptions, frames: usize, fps: f32) -> Result<Plan> {
        let (closed_loop, motion) = (opts.closed_loop(), opts.motion());
        // Motion files have no λ: their key frames are the frames with
        // corrections, 0, 1 (which has no velocity to predict with yet), then
        // every `interval`-th.
        let interval = if motion { opts.correction_interval } else { opts.key_interval };
        let mut plan = Plan {
            codec: opts.codec(),
            grid: Grid::new(opts.grid)?,
            frames,
            closed_loop,
            motion,
            interval,
            key_frames: Vec::new(),
            names: Vec::new(),
            anchor_count: opts.anchor_count(),
            allowed: if motion { MOTION_EXTRAPOLATIONS } else { &ALL_EXTRAPOLATIONS },
            layout: correction_layout(opts)?,
            random_access: random_access_interval(opts.random_access, fps, frames),
            segments: opts.segments.clone(),
        };
        let frame_count = u32::try_from(frames).unwrap_or(u32::MAX);
        format::check_segments(&opts.segments, frame_count).map_err(Error::Argument)?;
        // Segments need the index of points: one at frame 0 at least.
        if !plan.segments.is_empty() && plan.random_access.is_none() {
            plan.random_access = Some(frames as u32);
        }
        // Every random-access point is a key frame, and the key frames'
        // rhythm starts again at each.
        plan.key_frames = match (interval, motion) {
            (0, _) | (1, true) => (0..frames).filter(|&f| plan.is_rap(f)).map(|f| f as u32).collect(),
            (_, true) => (0..frames as u32).filter(|&f| plan.corrected(f as usize)).collect(),
            _ => (0..frames).filter(|&f| (f - plan.rap(f)) % interval as usize == 0).map(|f| f as u32).collect(),
        };
        plan.names = plan.stream_names();
        Ok(plan)
    }

    fn stream_names(&self) -> Vec<(StreamName, Coverage)> {
        let mut names: Vec<(StreamName, Coverage)> = match self.codec {
            CodecKind::Gv => POSITION.map(|s| (s, Coverage::All)).to_vec(),
            CodecKind::Cgv => {
                // Motion files leave out H and λ (format version 3): the motion
                // predictor never chose an H step (0 frames of 48-175 on
                // horse-gallop, pcow and samba at QP 36 and 44), and they were
                // 7-10 % of its files.
                let mut v = if self.motion {
                    Vec::new()
                } else {
                    vec![(StreamName::H, Coverage::All), (StreamName::Lambda, Coverage::Key)]
                };
                v.extend(SEED.map(|s| (s, Coverage::First)));
                v
            }
        };
        if self.closed_loop {
            let coverage = if self.motion && self.interval > 1 { Coverage::Key } else { Coverage::All };
            names.extend(CORRECTION.map(|s| (s, coverage)));
            if self.layout.normal {
                names.push((StreamName::Dn, coverage));
            }
        }
        names
    }

    /// Whether frame `f` has corrections (every frame but in motion files
    /// with a correction interval: there the random-access point and the
    /// frame after it, then every `interval`-th).
    pub fn corrected(&self, f: usize) -> bool {
        let d = f - self.rap(f);
        !self.motion || d == 0 || (d - 1) % self.interval as usize == 0
    }

    /// The last random-access point at or before frame `f`.
    pub fn rap(&self, f: usize) -> usize {
        format::random_access_point(self.random_access, &self.segments, f as u32) as usize
    }

    /// Whether frame `f` is a random-access point.
    pub fn is_rap(&self, f: usize) -> bool {
        self.rap(f) == f
    }

    /// How many random-access points the motion has.
    pub fn raps(&self) -> usize {
        (0..self.frames).filter(|&f| self.is_rap(f)).count()
    }

    pub fn is_key(&self, f: usize) -> bool {
        self.key_frames.binary_search(&(f as u32)).is_ok()
    }

    /// Whether any stream carries a differential quantity (H, λ) rather
    /// than positions, so the frames' features must be computed (the
    /// normal correction, also no axis, is made from the prediction).
    pub fn needs_features(&self) -> bool {
        self.names.iter().any(|(n, _)| n.axis().is_none() && !n.is_correction())
    }
}

/// Frames between random-access points for `seconds` at `fps` (at least
/// 1); none in a motion shorter than two intervals, where a seek from
/// frame 0 decodes at most twice what one from a point would, and a point
/// would cost a seed (the default motion, 72 frames at 2 s: 33.3 KB at QP
/// 30 with a point at frame 60, 25.5 KB without).
pub(super) fn random_access_interval(seconds: f32, fps: f32, frames: usize) -> Option<u32> {
    // At most the format's frame count: past it a point is never reached.
    let k = (seconds * fps).round().clamp(1.0, format::MAX_FRAMES as f32) as u32;
    (seconds > 0.0 && 2 * k as usize <= frames).then_some(k)
}

/// The correction pictures' layout the options ask for: with a normal
/// picture, x, y, z halved `correction_shrink` times (as many times as the
/// grid allows, down to H.264's 16 samples a side); without, x, y, z at
/// full size.
fn correction_layout(opts: &EncodeOptions) -> Result<Layout> {
    if !opts.normal_correction() {
        return Ok(Layout::WORLD);
    }
    let grid = Grid::new(opts.grid)?;
    let shrink = (0..=opts.correction_shrink)
        .rev()
        .find(|&k| coarse::coarser(grid, k, format::MIN_GRID as usize).is_some())
        .unwrap_or(0);
    Ok(Layout { shrink, normal: true })
}
