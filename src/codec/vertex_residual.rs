//! Version 18: the vertex residual, what the video missed at each of the
//! source mesh's vertices (`crate::format::vertex_residual` has the unit),
//! as MPEG-4 FAMC codes the residual of its skinning at the vertices
//! (Mamou, Zaharia and Prêteux 2009). The decoder adds it after the
//! grid's rebuild at the vertices (and the bones' skinning, version 17);
//! nothing of it returns to the grid, so the closed loop is unchanged and
//! the encoder codes it after each frame's video, from the frame as
//! decoded. One rule applies a unit, [`VertexResidual::apply`], which the
//! encoder runs too. Version 19 codes a unit's values, where that is
//! smaller, as what the parallelogram rule over the surface misses
//! (`crate::format::vertex_order`): where the video is coarse or absent
//! the residual is the smooth shape or motion itself, which its
//! neighbours predict.

use crate::format::vertex_order::VertexOrder;
use crate::format::vertex_residual::{Mode, Modes, ResidualUnit, MAX_VALUE};
use glam::Vec3;

/// The decoded residual at each source vertex, carried from frame to
/// frame (a unit may add to the previous frame's) and reset at each
/// random-access point.
#[derive(Debug, Clone)]
pub struct VertexResidual {
    step: f32,
    residual: Vec<Vec3>,
    /// Version 19: the walk spatial units follow (none: a version 18 file).
    order: Option<VertexOrder>,
    /// Version 20: the encoder may list a unit's counts sparsely and code
    /// its values in contexts.
    version_20: bool,
}

impl VertexResidual {
    /// The residual of `vertices` vertices on `step` (the header's).
    pub fn new(step: f32, vertices: usize) -> VertexResidual {
        VertexResidual { step, residual: vec![Vec3::ZERO; vertices], order: None, version_20: false }
    }

    /// Version 19: spatial units walk the source mesh's `faces`.
    pub fn set_faces(&mut self, faces: &[[u32; 3]]) {
        self.order = Some(VertexOrder::new(faces, self.residual.len()));
    }

    /// Version 20: the encoder lists a unit's counts sparsely and codes
    /// its values in contexts where that is shorter.
    pub fn set_version_20(&mut self, on: bool) {
        self.version_20 = on;
    }

    /// Whether spatial units can be applied (or coded).
    pub fn spatial(&self) -> bool {
        self.order.is_some()
    }

    /// A random-access point: the previous residual is zero.
    pub fn reset(&mut self) {
        self.residual.fill(Vec3::ZERO);
    }

    /// The residual of the frame decoded last, a vector a vertex.
    pub fn residual(&self) -> &[Vec3] {
        &self.residual
    }

    /// Decoder and encoder: the frame's residual from its unit (3 values a
    /// vertex; the reader checked the count). A spatial unit needs the
    /// faces ([`Self::set_faces`]).
    pub fn apply(&mut self, unit: &ResidualUnit) -> Result<(), &'static str> {
        let rebuilt;
        let values = match (unit.spatial, &self.order) {
            (false, _) => &unit.values,
            (true, Some(order)) => {
                rebuilt = order.rebuild(&unit.values).concat();
                &rebuilt
            }
            (true, None) => return Err("a spatial vertex residual unit without the source mesh's faces"),
        };
        let step = self.step;
        for (r, v) in self.residual.iter_mut().zip(values.chunks_exact(3)) {
            let d = Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32) * step;
            *r = match unit.mode {
                Mode::Intra => d,
                Mode::Delta => *r + d,
            };
        }
        Ok(())
    }

    /// Encoder: the unit that brings the residual to `target` (a vector a
    /// vertex: the true vertex less the decoded one) within half a step
    /// (where no value is clamped at [`MAX_VALUE`]), as the residual itself
    /// or its change from the last frame's, each as it is or predicted over
    /// the surface where the faces are known, whichever codes smallest;
    /// applies it and returns its bytes (`None` if the range coder fails).
    pub fn code(&mut self, target: &[Vec3]) -> Option<Vec<u8>> {
        let wanted = |from: &dyn Fn(usize) -> Vec3| -> Vec<[i32; 3]> {
            (0..self.residual.len())
                .map(|v| {
                    let t = target.get(v).copied().unwrap_or(Vec3::ZERO) - from(v);
                    // Within i32 whatever the target; the unit clamps further.
                    (t / self.step).round().clamp(Vec3::splat(-1e9), Vec3::splat(1e9)).to_array().map(|x| x as i32)
                })
                .collect()
        };
        // The smallest unit that reaches every vertex within half a step;
        // one that clamps a value only where none reaches.
        let mut best: Option<(bool, ResidualUnit, Vec<u8>)> = None;
        for mode in [Mode::Intra, Mode::Delta] {
            let q = match mode {
                Mode::Intra => wanted(&|_| Vec3::ZERO),
                Mode::Delta => wanted(&|v| self.residual[v]),
            };
            let max = MAX_VALUE as i32;
            let reached = q.iter().flatten().all(|x| x.abs() <= max);
            let plain = q.iter().flatten().map(|x| (*x).clamp(-max, max)).collect();
            let mut units = vec![(reached, ResidualUnit { mode, spatial: false, values: plain })];
            if let Some(order) = &self.order {
                // A guess that misses by more than a value holds leaves its
                // vertex off: spatial only where it reaches what plain does.
                let (values, rebuilt) = order.code(&q, max);
                if rebuilt == q || !reached {
                    units.push((rebuilt == q, ResidualUnit { mode, spatial: true, values }));
                }
            }
            for (reaches, unit) in units {
                let v20 = self.version_20;
                let bytes = unit.to_bytes(Modes { spatial: self.order.is_some(), sparse: v20, contexts: v20 })?;
                let better = |(r, _, b): &(bool, ResidualUnit, Vec<u8>)| (reaches, bytes.len() < b.len()) > (*r, false);
                if best.as_ref().is_none_or(better) {
                    best = Some((reaches, unit, bytes));
                }
            }
        }
        let (_, unit, bytes) = best?;
        self.apply(&unit).ok()?;
        Some(bytes)
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::VertexResidual;
    use crate::format::vertex_residual::{Modes, ResidualUnit};
    use glam::Vec3;

    #[test]
    fn the_decoder_follows_the_encoder_within_half_a_step() {
        let step = 0.01;
        let (mut enc, mut dec) = (VertexResidual::new(step, 50), VertexResidual::new(step, 50));
        for f in 0..6 {
            // A slowly changing residual: later frames code its change.
            let target: Vec<Vec3> =
                (0..50).map(|v| Vec3::new((v as f32 * 0.37).sin(), 0.2 * f as f32, (v as f32).cos()) * 0.05).collect();
            let bytes = enc.code(&target).unwrap();
            dec.apply(&ResidualUnit::parse(&bytes, 150, Modes::default(), 0).unwrap()).unwrap();
            assert_eq!(enc.residual(), dec.residual(), "frame {f}");
            let worst =
                target.iter().zip(dec.residual()).map(|(t, r)| (*t - *r).abs().max_element()).fold(0.0, f32::max);
            assert!(worst <= 0.5 * step + 1e-6, "frame {f}: {worst}");
            if f > 0 {
                assert_eq!(bytes[0], 1, "frame {f} codes the change");
            }
        }
        dec.reset();
        assert!(dec.residual().iter().all(|r| *r == Vec3::ZERO));
    }

    /// Two strips of triangles whose values fall and rise along them (the
    /// plain unit holds them, each within ±1000 steps, at many bits a value);
    /// the walk guesses each vertex to a fraction of a step but the second
    /// strip's first vertex as the first strip's last, 1,250 steps off, more
    /// than a value holds. The spatial unit would be far smaller and leave
    /// that vertex off; the plain one reaches every vertex.
    #[test]
    fn a_spatial_unit_is_kept_only_where_it_reaches_the_vertices() {
        let (step, n) = (0.01, 1500u32);
        let strip = |at: u32| (0..n - 2).map(move |k| [at + k, at + k + 1, at + k + 2]);
        let faces: Vec<[u32; 3]> = strip(0).chain(strip(n)).collect();
        let value = |v: u32| if v < n { 1000 - (v / 2) as i32 } else { -1000 + ((v - n) / 2) as i32 };
        let target: Vec<Vec3> = (0..2 * n).map(|v| Vec3::splat(value(v) as f32 * step)).collect();
        let (mut enc, mut dec) = (VertexResidual::new(step, 2 * n as usize), VertexResidual::new(step, 2 * n as usize));
        enc.set_faces(&faces);
        dec.set_faces(&faces);
        let bytes = enc.code(&target).unwrap();
        dec.apply(&ResidualUnit::parse(&bytes, 6 * n as usize, Modes::ALL, 0).unwrap()).unwrap();
        let worst = target.iter().zip(dec.residual()).map(|(t, r)| (*t - *r).abs().max_element()).fold(0.0, f32::max);
        assert!(worst <= 0.5 * step + 1e-6, "a vertex {worst} off (mode {})", bytes[0]);
    }
}
