//! What registering a capture found ([`super::register`]): its features,
//! tracks and cones, the frames its maps mended, its segments, for
//! `cgv info` and the encoder's report.

/// What the registration found, for `cgv info` and the encoder's report.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct RegisterReport {
    pub frames: usize,
    /// Features found per frame, on average.
    pub features_per_frame: f64,
    pub tracks: usize,
    /// The tracks the cones follow (indices into [`super::tracking::track_capture`]'s).
    pub cone_tracks: [usize; 4],
    /// The share of frames each cone's track was seen in (the rest placed
    /// between its sightings); over several segments, the worst segment's.
    pub cones_seen: [f64; 4],
    /// The share of all the cones' frames (four a frame, each segment's
    /// own) in which the cone's feature was seen: the whole capture's
    /// tracking, where [`RegisterReport::cones_seen`] is its worst stretch.
    pub cones_seen_overall: f64,
    /// Frames whose cones the cut put on other sides of the square than
    /// most frames', turned back by a turn of the grid.
    pub turned_frames: usize,
    /// Frames whose cones no turn puts back (their cyclic order around the
    /// square differs): the grid flips there.
    pub unmatched_frames: usize,
    /// Frames whose grid still jumped ([`super::jumps`]) when mapped again
    /// with their neighbours' cuts, and was bridged from their neighbours.
    pub bridged_frames: usize,
    /// Frames whose grid was smoothed in time ([`super::smooth`]).
    pub smoothed_frames: usize,
    /// The registered runs' frames `[a, b)` (frames that share one mesh:
    /// [`super::capture::is_registered_run`]), each run mapped once
    /// ([`super::frame_map::map_run`]) rather than frame by frame.
    pub registered_runs: Vec<[usize; 2]>,
    /// Whether this piece goes on with the last piece's run map (a run
    /// cut at the longest segment): joined, the two are one run.
    #[serde(skip)]
    pub goes_on_with_run: bool,
    /// Frames whose grid lay far from their own mesh, rebuilt from their
    /// neighbours ([`super::outliers`]).
    pub rebuilt_frames: usize,
    /// How far each frame's grid lies from the frame's own mesh (symmetric
    /// surface RMS, a fraction of that frame's bounding-box diagonal): the
    /// mean over frames and the worst frame. The registration's own floor,
    /// under which no coding of its grid goes.
    pub resampling_mean: f64,
    pub resampling_worst: f64,
    /// Grid faces over the capture's holes ([`super::lids`]), left out of
    /// the grid mesh it comes back as (and of the floor above).
    pub lid_faces: usize,
    /// For each grid face, the pieces (each its own map) in which it lies
    /// over a hole ([`super::lids::over_holes`]), of `lid_pieces`.
    #[serde(skip)]
    pub lid_votes: Vec<u32>,
    #[serde(skip)]
    pub lid_pieces: u32,
    /// The kept pieces' features and maps; a segment that failed its
    /// checks had its halves registered too, which `seconds` counts.
    pub seconds_features: f64,
    pub seconds_maps: f64,
    /// The whole registration, wall clock (set by [`super::register::register`]).
    pub seconds: f64,
    /// Frames where a segment (after the first) starts: the topology
    /// changed there, a registered run starts or ends there, or the last
    /// segment reached its longest ([`super::segments::segment_ranges`]).
    pub segments: Vec<u32>,
    /// Each segment's (each piece's, a split segment's halves apart)
    /// tracking and floor, in order: where [`RegisterReport::cones_seen`]
    /// and `resampling_worst` say how bad the worst stretch is, this says
    /// which.
    pub per_segment: Vec<SegmentReport>,
}

/// One segment's part of the report: its first frame (in the capture),
/// its frames, the share of them each of its cones' tracks was seen in,
/// the frames its map could not describe, and its grid's floor (as
/// [`RegisterReport::resampling_mean`], over its frames).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct SegmentReport {
    pub start: usize,
    pub frames: usize,
    pub cones_seen: [f64; 4],
    pub unmatched_frames: usize,
    pub bridged_frames: usize,
    pub resampling_mean: f64,
    pub resampling_worst: f64,
}

impl RegisterReport {
    /// The tracking's part of a segment's report (its features, tracks and
    /// cones; nothing mapped yet).
    pub fn of_tracking(tracked: &super::track::Tracked) -> RegisterReport {
        RegisterReport {
            frames: tracked.features.len(),
            features_per_frame: tracked.features_per_frame(),
            tracks: tracked.tracks.len(),
            cone_tracks: tracked.cones,
            cones_seen: tracked.cones_seen(),
            cones_seen_overall: tracked.cones_seen_overall(),
            seconds_features: tracked.seconds,
            per_segment: vec![SegmentReport {
                frames: tracked.features.len(),
                cones_seen: tracked.cones_seen(),
                ..Default::default()
            }],
            ..Default::default()
        }
    }

    /// The reports of consecutive segments starting at frames `starts`
    /// (the first at 0), joined.
    pub fn joined(starts: &[usize], parts: impl IntoIterator<Item = RegisterReport>) -> RegisterReport {
        let mut all: Option<RegisterReport> = None;
        for (&start, part) in starts.iter().zip(parts) {
            match &mut all {
                Some(all) => all.join(start, &part),
                None => all = Some(part),
            }
        }
        all.unwrap_or_default()
    }

    /// Adds the report of the segment starting at frame `start`: counts
    /// add up, shares are weighted by frames, cones' shares are the worst
    /// segment's (the cones are each segment's own).
    pub(super) fn join(&mut self, start: usize, next: &RegisterReport) {
        let (a, b) = (self.frames as f64, next.frames as f64);
        let weighted = |x: f64, y: f64| (x * a + y * b) / (a + b).max(1.0);
        self.features_per_frame = weighted(self.features_per_frame, next.features_per_frame);
        self.cones_seen_overall = weighted(self.cones_seen_overall, next.cones_seen_overall);
        self.frames += next.frames;
        self.tracks += next.tracks;
        self.cones_seen = std::array::from_fn(|k| self.cones_seen[k].min(next.cones_seen[k]));
        self.turned_frames += next.turned_frames;
        self.unmatched_frames += next.unmatched_frames;
        self.bridged_frames += next.bridged_frames;
        self.smoothed_frames += next.smoothed_frames;
        for &[a, b] in &next.registered_runs {
            // A run cut at the longest segment goes on with one map: one run.
            match self.registered_runs.last_mut() {
                Some(last) if next.goes_on_with_run && a == 0 && last[1] == start => last[1] = start + b,
                _ => self.registered_runs.push([start + a, start + b]),
            }
        }
        self.seconds_features += next.seconds_features;
        self.seconds_maps += next.seconds_maps;
        self.lid_votes = super::lids::added(&self.lid_votes, &next.lid_votes);
        self.lid_pieces += next.lid_pieces;
        self.segments.push(start as u32);
        let moved = next.per_segment.iter().map(|t| SegmentReport { start: start + t.start, ..t.clone() });
        self.per_segment.extend(moved);
    }

    /// Frames in registered runs ([`RegisterReport::registered_runs`]).
    pub fn shared_mesh_frames(&self) -> usize {
        self.registered_runs.iter().map(|[a, b]| b - a).sum()
    }

    /// The frames' floors `relative` (each frame's resampling error over
    /// its diagonal, in capture order) read into the whole report and each
    /// segment's.
    pub(super) fn set_floors(&mut self, relative: &[f64]) {
        let (mean, worst) = mean_and_worst(relative);
        (self.resampling_mean, self.resampling_worst) = (mean, worst);
        for s in &mut self.per_segment {
            let own = relative.get(s.start..(s.start + s.frames).min(relative.len())).unwrap_or(&[]);
            (s.resampling_mean, s.resampling_worst) = mean_and_worst(own);
        }
    }
}

fn mean_and_worst(x: &[f64]) -> (f64, f64) {
    (x.iter().sum::<f64>() / x.len().max(1) as f64, x.iter().copied().fold(0.0, f64::max))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Joined reports weigh shares by frames, and keep each cone's worst.
    #[test]
    fn a_whole_capture_reads_its_segments_by_their_frames() {
        let part = |frames, seen: [f64; 4]| RegisterReport {
            frames,
            cones_seen: seen,
            per_segment: vec![SegmentReport { frames, cones_seen: seen, unmatched_frames: 1, ..Default::default() }],
            cones_seen_overall: seen.iter().sum::<f64>() / 4.0,
            ..Default::default()
        };
        let all = RegisterReport::joined(&[0, 30], [part(30, [1.0; 4]), part(10, [1.0, 1.0, 0.5, 0.5])]);
        assert_eq!((all.frames, all.segments.clone()), (40, vec![30]));
        assert_eq!(all.cones_seen, [1.0, 1.0, 0.5, 0.5]);
        assert!((all.cones_seen_overall - 37.5 / 40.0).abs() < 1e-12, "{all:?}");
        let starts: Vec<(usize, usize)> = all.per_segment.iter().map(|t| (t.start, t.frames)).collect();
        assert_eq!(starts, [(0, 30), (30, 10)]);
        assert_eq!(all.per_segment[1].cones_seen, [1.0, 1.0, 0.5, 0.5]);
        assert_eq!(all.per_segment.iter().map(|t| t.unmatched_frames).collect::<Vec<_>>(), [1, 1]);
    }

    /// Each segment's floor is read over its own frames.
    #[test]
    fn each_segments_floor_is_its_own_frames() {
        let part = |frames| RegisterReport {
            frames,
            per_segment: vec![SegmentReport { frames, ..Default::default() }],
            ..Default::default()
        };
        let mut all = RegisterReport::joined(&[0, 2], [part(2), part(3)]);
        all.set_floors(&[1.0, 3.0, 0.5, 0.5, 8.0]);
        assert_eq!((all.resampling_mean, all.resampling_worst), (2.6, 8.0));
        let floors: Vec<(f64, f64)> = all.per_segment.iter().map(|s| (s.resampling_mean, s.resampling_worst)).collect();
        assert_eq!(floors, [(2.0, 3.0), (3.0, 8.0)]);
    }
}
