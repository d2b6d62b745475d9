//! Version 16: every frame's own mesh (the header's `frame_meshes`), for a
//! capture whose frames are each their own triangulation (`cgv encode
//! --unregistered --mesh frames`): a decoder rebuilds each frame's own
//! vertices and faces on that frame's decoded grid, as it rebuilds the one
//! source mesh of a registered file (`super::source_mesh`) on every frame.
//!
//! The unit is the last of the frame chunk (after the loose vertices):
//! the frame's vertex and face counts (LEB128), its offsets' step (f32 LE,
//! 0 for none), then the payload of a version-12 source mesh with those
//! counts ([`SourceMesh::to_bytes`]: faces walked, places predicted,
//! offsets in the grid triangles' frames), deflated as one. No loose
//! vertices: a capture's parts are registered as one surface.

use super::source_mesh::{SourceMesh, SourceMeshInfo, MAX_SOURCE_FACES, MAX_SOURCE_VERTICES};
use super::ContainerError;
use super::{connectivity, leb128};

/// A new index for each of `vertex_count` vertices: in the order the faces,
/// walked ([`connectivity::walk_order`]), first use them, then the unused
/// ones. A capture's vertex order carries nothing (every frame is its own
/// scan), and in this order each new vertex is the walk's cheapest
/// reference, the lowest index not used yet: samba's frames' faces take
/// about a tenth of the bytes they take in the scan's order.
pub fn first_use_order(faces: &[[u32; 3]], vertex_count: usize) -> Vec<u32> {
    let mut new = vec![u32::MAX; vertex_count];
    let mut next = 0u32;
    for i in connectivity::walk_order(faces, vertex_count) {
        for &v in &faces[i] {
            if let Some(n) = new.get_mut(v as usize).filter(|n| **n == u32::MAX) {
                *n = next;
                next += 1;
            }
        }
    }
    for n in new.iter_mut().filter(|n| **n == u32::MAX) {
        *n = next;
        next += 1;
    }
    new
}

/// A frame's mesh unit.
pub fn to_unit(mesh: &SourceMesh) -> Vec<u8> {
    let mut out = Vec::new();
    leb128::write(&mut out, mesh.places.len() as u64);
    leb128::write(&mut out, mesh.faces.len() as u64);
    let step = mesh.offsets.as_ref().map_or(0.0, |o| o.step);
    out.extend_from_slice(&step.to_le_bytes());
    out.extend_from_slice(&mesh.to_bytes_with(false));
    out
}

/// The mesh of frame `frame`'s unit, in the chunk at byte `offset`.
pub fn parse_unit(unit: &[u8], frame: u32, offset: usize) -> Result<SourceMesh, ContainerError> {
    let bad = |msg: String| ContainerError::Chunk { offset, msg: format!("frame {frame}'s mesh: {msg}") };
    let mut at = 0;
    let mut count = |what: &str, most: u32| {
        leb128::read(unit, &mut at, 5)
            .and_then(|n| u32::try_from(n).ok())
            .filter(|n| (1..=most).contains(n))
            .ok_or_else(|| bad(format!("its {what} count is cut short or not in 1..={most}")))
    };
    let (vertices, faces) = (count("vertex", MAX_SOURCE_VERTICES)?, count("face", MAX_SOURCE_FACES)?);
    let step = unit
        .get(at..at + 4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .ok_or_else(|| bad("cut short before its offsets' step".into()))?;
    if !(step.is_finite() && step >= 0.0) {
        return Err(bad(format!("offsets' step {step}")));
    }
    let info = SourceMeshInfo {
        vertices,
        faces,
        offset_step: (step > 0.0).then_some(step),
        loose: None,
        walk: true,
        around: false,
    };
    info.validate().map_err(bad)?;
    SourceMesh::parse(&unit[at + 4..], &info, offset).map_err(|e| match e {
        ContainerError::Chunk { offset, msg } => {
            let msg = format!("frame {frame}'s mesh: {}", msg.strip_prefix("source mesh: ").unwrap_or(&msg));
            ContainerError::Chunk { offset, msg }
        }
        other => other,
    })
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::format::source_mesh::Offsets;

    fn quad(offsets: bool) -> SourceMesh {
        SourceMesh {
            faces: vec![[0, 1, 2], [0, 2, 3]],
            places: vec![[0, 0], [1 << 31, 0], [1 << 31, 1 << 31], [0, 1 << 31]],
            offsets: offsets.then(|| Offsets { step: 1e-3, values: vec![[1, 2, 3], [0, 0, 0], [-4, 0, 9], [7, 7, 7]] }),
            loose_of: Vec::new(),
            loose_anchors: Vec::new(),
        }
    }

    #[test]
    fn the_first_use_order_is_a_permutation_in_the_walks_order() {
        let faces = [[5, 2, 0], [2, 5, 4], [0, 2, 1]];
        let order = first_use_order(&faces, 7);
        let mut sorted = order.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..7).collect::<Vec<u32>>());
        // Vertex 3 and 6, in no face, come last.
        assert!(order[3] >= 5 && order[6] >= 5, "{order:?}");
        let first = connectivity::walk_order(&faces, 7)[0];
        assert_eq!(order[faces[first][0] as usize], 0);
    }

    #[test]
    fn a_frame_mesh_round_trips_and_a_bad_one_is_refused() {
        for offsets in [false, true] {
            let m = quad(offsets);
            let unit = to_unit(&m);
            assert_eq!(parse_unit(&unit, 3, 0).unwrap(), m);
            for cut in [1, 2, 5, unit.len() - 1] {
                assert!(parse_unit(&unit[..cut], 3, 0).is_err(), "cut at {cut}");
            }
        }
        // Counts past the limits, or zero, are refused before anything is inflated.
        let mut big = Vec::new();
        leb128::write(&mut big, u64::from(MAX_SOURCE_VERTICES) + 1);
        leb128::write(&mut big, 2);
        big.extend_from_slice(&0f32.to_le_bytes());
        let err = parse_unit(&big, 7, 40).unwrap_err().to_string();
        assert!(err.contains("frame 7's mesh") && err.contains("vertex count"), "{err}");
        let mut bad_step = to_unit(&quad(false));
        bad_step[2..6].copy_from_slice(&f32::NAN.to_le_bytes());
        assert!(parse_unit(&bad_step, 0, 0).is_err());
        // A unit that says 5 vertices where its payload has 4.
        let mut wrong = to_unit(&quad(false));
        wrong[0] = 5;
        assert!(parse_unit(&wrong, 0, 0).is_err());
    }
}
