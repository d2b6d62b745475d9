//! The header's checks: its own consistency and the format's limits, before
//! anything is allocated from it (a header is untrusted input).

use super::{
    check_grid_size, stream, CodecKind, ContainerError, CorrectionMode, Header, StreamName, MAX_ANCHORS, MAX_FRAMES,
    MAX_SHRINK, MAX_STREAMS, MIN_GRID, SEAM_RULE,
};

impl Header {
    /// Checks the header's own consistency and limits.
    pub fn validate(&self) -> Result<(), ContainerError> {
        let bad = |m: String| Err(ContainerError::Header(m));
        check_grid_size(self.grid.into()).map_err(ContainerError::Header)?;
        if self.seam != SEAM_RULE {
            return bad(format!("unknown seam rule '{}'", self.seam));
        }
        if self.frames == 0 || self.frames > MAX_FRAMES {
            return bad(format!("frame count {} is not in 1..={MAX_FRAMES}", self.frames));
        }
        if !(self.fps.is_finite() && self.fps > 0.0 && self.fps <= 1000.0) {
            return bad(format!("frame rate {} is not in (0, 1000]", self.fps));
        }
        if self.streams.len() > MAX_STREAMS || self.streams.is_empty() && !self.without_video() {
            return bad(format!(
                "{} streams (1..={MAX_STREAMS} allowed; none only where the vertex residual has an origin)",
                self.streams.len()
            ));
        }
        self.validate_streams()?;
        if self.key_frames.first() != Some(&0)
            || self.key_frames.windows(2).any(|w| w[1] <= w[0])
            || self.key_frames.last().is_some_and(|&k| k >= self.frames)
        {
            return bad("key frames must start at 0, increase, and lie inside the sequence".into());
        }
        let samples = self.grid * self.grid;
        if self.anchors.len() > MAX_ANCHORS || self.anchors.iter().any(|&a| a >= samples) {
            return bad(format!("anchors must be at most {MAX_ANCHORS} grid samples below {samples}"));
        }
        // The paper's solver needs anchors; the closed loop (correction
        // streams) does not.
        let closed_loop = self.is_closed_loop();
        let world: Vec<u8> =
            stream::CORRECTION.iter().filter_map(|&n| self.stream(n)).map(|s| self.streams[s].shrink).collect();
        let normal = self.stream(StreamName::Dn).is_some();
        if !(world.is_empty() && !normal || world.len() == 3 && world.windows(2).all(|w| w[0] == w[1])) {
            return bad("correction streams are dx, dy, dz (all three the same size), with or without dn".into());
        }
        if self.corrections == CorrectionMode::Motion {
            let ok = self.codec == CodecKind::Cgv
                && self.correction_streams().is_some()
                && self.streams.iter().all(|s| !s.scaled);
            if !ok {
                return bad("motion corrections need a CGV file with unscaled correction streams".into());
            }
        }
        if self.codec == CodecKind::Cgv
            && (self.stream(StreamName::H).is_none() || self.stream(StreamName::Lambda).is_none())
            && self.corrections != CorrectionMode::Motion
        {
            return bad("only a motion-corrected CGV file may leave out the H and lambda streams".into());
        }
        if self.max_lag > 0 && !closed_loop {
            return bad("cycle predictions (max_lag) need correction streams".into());
        }
        self.validate_skin()?;
        if self.codec == CodecKind::Cgv && self.anchors.len() < 4 && !closed_loop {
            return bad("a CGV file without correction streams needs at least 4 anchors".into());
        }
        if let Some(m) = &self.source_mesh {
            m.validate().map_err(ContainerError::Header)?;
        }
        if self.frame_meshes && self.source_mesh.is_some() {
            return bad("frame meshes and a source mesh: a file has one or the other".into());
        }
        if let Some(a) = &self.appearance {
            if self.source_mesh.is_none() {
                return bad("an appearance needs a source mesh".into());
            }
            a.validate().map_err(ContainerError::Header)?;
        }
        self.validate_vertex_residual()?;
        self.validate_random_access()
    }

    /// Version 20: a file without streams, its vertices coded as the
    /// residual from the header's origin.
    fn without_video(&self) -> bool {
        self.vertex_residual.is_some_and(|r| r.origin.is_some())
    }

    /// Version 18: a residual at the source mesh's vertices, over a grid
    /// the encoder decoded as the decoder will (GV or the closed loop);
    /// version 20: with an origin, in place of any grid, alone in its file.
    fn validate_vertex_residual(&self) -> Result<(), ContainerError> {
        let Some(r) = &self.vertex_residual else { return Ok(()) };
        r.validate().map_err(ContainerError::Header)?;
        if r.origin.is_some() {
            let alone = self.streams.is_empty()
                && self.codec == CodecKind::Gv
                && self.anchors.is_empty()
                && self.skin.is_none()
                && self.max_lag == 0
                && !self.frame_meshes
                && self.source_mesh.is_some_and(|m| m.loose.is_none());
            if !alone {
                return Err(ContainerError::Header(
                    "a vertex residual with an origin is the whole file: a GV header without streams, anchors, \
                     bones or loose vertices, with a source mesh"
                        .into(),
                ));
            }
        }
        if self.source_mesh.is_none() || !self.loose_follow_grid() {
            return Err(ContainerError::Header(
                "a vertex residual needs a source mesh, in a GV or closed-loop file".into(),
            ));
        }
        Ok(())
    }

    /// The bones: on the grid, with correction streams to predict; on the
    /// vertices (version 17), in a GV file with a source mesh.
    fn validate_skin(&self) -> Result<(), ContainerError> {
        let Some(skin) = &self.skin else { return Ok(()) };
        let bad = |m: &str| Err(ContainerError::Header(m.into()));
        skin.check(self.grid).map_err(ContainerError::Header)?;
        if skin.on_vertices() {
            let loose = self.source_mesh.is_some_and(|m| m.loose.is_some());
            if self.codec != CodecKind::Gv || self.source_mesh.is_none() || loose || self.frame_meshes {
                return bad("bones on the vertices need a GV file (what they miss) and a source mesh without loose \
                            vertices");
            }
        } else if !self.is_closed_loop() {
            return bad("bones (skin) need correction streams");
        }
        Ok(())
    }

    /// Each stream: a valid range, a shrink only where allowed, and a
    /// layer-2 stream refining a full-size layer-1 stream before it.
    fn validate_streams(&self) -> Result<(), ContainerError> {
        let bad = |m: String| Err(ContainerError::Header(m));
        for (i, s) in self.streams.iter().enumerate() {
            if !s.quant.is_valid() {
                return bad(format!("stream {i} has an invalid range"));
            }
            let side = s.size(self.grid);
            let shrinkable = s.name.axis().is_some() && s.name.is_correction() && self.stream(StreamName::Dn).is_some();
            if s.shrink > 0 && !(shrinkable && side >= MIN_GRID && side % 2 == 0 && s.shrink <= MAX_SHRINK) {
                return bad(format!(
                    "stream {i} ({}) is shrunk {} times to {side} samples a side: only dx, dy, dz beside dn \
                     may be, at most {MAX_SHRINK} times, to an even size of at least {MIN_GRID}",
                    s.name, s.shrink
                ));
            }
            match (s.layer, s.refines) {
                (1, None) => {}
                (2, Some(r))
                    if (r as usize) < i
                        && self.streams[r as usize].layer == 1
                        && self.streams[r as usize].shrink == 0 => {}
                _ => return bad(format!("stream {i} has an invalid layer {} / refines {:?}", s.layer, s.refines)),
            }
        }
        Ok(())
    }

    /// Random-access points: an interval of at least 1 frame, and each
    /// point a key frame (the key-frame streams restart there too).
    fn validate_random_access(&self) -> Result<(), ContainerError> {
        let bad = |m: String| Err(ContainerError::Header(m));
        let Some(k) = self.random_access else {
            return match self.segments.is_empty() {
                true => Ok(()),
                false => bad("segments in a file without random-access points".into()),
            };
        };
        if k == 0 || k > MAX_FRAMES {
            return bad(format!("random_access {k} is not in 1..={MAX_FRAMES}"));
        }
        super::check_segments(&self.segments, self.frames).map_err(ContainerError::Header)?;
        let mut points = (0..self.frames).step_by(k as usize).chain(self.segments.iter().copied());
        if let Some(r) = points.find(|&r| !self.is_key_frame(r)) {
            return bad(format!("random-access point {r} is not a key frame"));
        }
        Ok(())
    }
}
