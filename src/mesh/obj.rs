//! Wavefront OBJ: positions and faces only (normals, texture coordinates,
//! groups and materials are ignored). Polygons are split into fans.

use super::source::{check_frame, FrameSource};
use super::{Frame, Topology};
use crate::error::{Error, MeshProblem, Result};
use crate::output::AtomicFile;
use glam::Vec3;
use std::path::{Path, PathBuf};

/// Parses OBJ text. `path` only labels errors.
pub fn parse_obj(text: &str, path: &Path) -> Result<(Frame, Vec<[u32; 3]>)> {
    let mut positions: Vec<Vec3> = Vec::new();
    let mut faces: Vec<[u32; 3]> = Vec::new();
    let mut poly: Vec<u32> = Vec::with_capacity(8);
    for (line_no, line) in text.lines().enumerate() {
        let err = |msg: String| Error::Parse { path: path.to_path_buf(), line: line_no + 1, msg };
        let line = line.trim();
        let mut words = line.split_ascii_whitespace();
        match words.next() {
            Some("v") => {
                let mut p = [0f32; 3];
                for (k, slot) in p.iter_mut().enumerate() {
                    let w = words.next().ok_or_else(|| err(format!("vertex has {k} coordinates, expected 3")))?;
                    *slot = w.parse().map_err(|_| err(format!("'{w}' is not a number")))?;
                }
                positions.push(Vec3::from_array(p));
            }
            Some("f") => {
                poly.clear();
                for w in words {
                    let idx = w.split('/').next().unwrap_or("");
                    let i: i64 = idx.parse().map_err(|_| err(format!("'{w}' is not a vertex index")))?;
                    // OBJ indices are 1-based; negative ones count back from the last vertex.
                    let resolved = if i > 0 { i - 1 } else { positions.len() as i64 + i };
                    if i == 0 || resolved < 0 || resolved > u32::MAX as i64 {
                        return Err(err(format!("vertex index {i} is out of range")));
                    }
                    poly.push(resolved as u32);
                }
                if poly.len() < 3 {
                    return Err(err(format!("face has {} vertices, expected at least 3", poly.len())));
                }
                for k in 1..poly.len() - 1 {
                    faces.push([poly[0], poly[k], poly[k + 1]]);
                }
            }
            _ => {}
        }
    }
    let count = positions.len();
    for (f, face) in faces.iter().enumerate() {
        for &i in face {
            if i as usize >= count {
                return Err(Error::mesh(path, MeshProblem::IndexOutOfRange { face: f, index: i as i64 + 1, count }));
            }
        }
    }
    Ok((positions, faces))
}

/// Reads an OBJ file.
pub fn read_obj(path: &Path) -> Result<(Frame, Vec<[u32; 3]>)> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    parse_obj(&text, path)
}

/// Formats one frame as OBJ text.
pub fn format_obj(positions: &[Vec3], faces: &[[u32; 3]]) -> String {
    use std::fmt::Write;
    let mut s = String::with_capacity(positions.len() * 36 + faces.len() * 24);
    for p in positions {
        let _ = writeln!(s, "v {} {} {}", p.x, p.y, p.z);
    }
    for f in faces {
        let _ = writeln!(s, "f {} {} {}", f[0] + 1, f[1] + 1, f[2] + 1);
    }
    s
}

/// [`format_obj`] with texture coordinates (`vt`, one per vertex, v
/// flipped: OBJ's origin is the image's bottom-left, glTF's its top-left)
/// and the material `input` of `material.mtl`.
pub fn format_textured_obj(positions: &[Vec3], faces: &[[u32; 3]], uvs: &[[f32; 2]]) -> String {
    use std::fmt::Write;
    let mut s = String::with_capacity(positions.len() * 60 + faces.len() * 40);
    s.push_str("mtllib material.mtl\nusemtl input\n");
    for p in positions {
        let _ = writeln!(s, "v {} {} {}", p.x, p.y, p.z);
    }
    for uv in uvs {
        let _ = writeln!(s, "vt {} {}", uv[0], 1.0 - uv[1]);
    }
    for f in faces {
        let [a, b, c] = f.map(|i| i + 1);
        let _ = writeln!(s, "f {a}/{a} {b}/{b} {c}/{c}");
    }
    s
}

/// The `material.mtl` beside textured OBJ frames: the base colour, and the
/// texture file `texture` when there is one.
pub fn format_mtl(base_color: [f32; 4], texture: Option<&str>) -> String {
    let [r, g, b, a] = base_color;
    let mut s = format!("newmtl input\nKd {r} {g} {b}\nd {a}\n");
    if let Some(t) = texture {
        s.push_str(&format!("map_Kd {t}\n"));
    }
    s
}

/// Writes one frame as an OBJ file, atomically.
pub fn write_obj(path: &Path, positions: &[Vec3], topology: &Topology) -> Result<()> {
    let mut f = AtomicFile::create(path)?;
    f.write_all(format_obj(positions, &topology.faces).as_bytes())?;
    f.commit()
}

/// The frame number in a file name: the last run of digits in its stem
/// (`mesh_0012.obj` -> 12, `7.obj` -> 7). Frames are ordered by it, so `2.obj`
/// comes before `10.obj`.
pub fn frame_number(path: &Path) -> Option<u64> {
    let stem = path.file_stem()?.to_str()?;
    let bytes = stem.as_bytes();
    let end = bytes.iter().rposition(|b| b.is_ascii_digit())? + 1;
    let start = bytes[..end].iter().rposition(|b| !b.is_ascii_digit()).map_or(0, |p| p + 1);
    stem[start..end].parse().ok()
}

/// The OBJ files of a folder, one per frame, in the order of the number
/// in their names (2 before 10), then by name for files without one.
pub fn frame_files(dir: &Path) -> Result<Vec<PathBuf>> {
    let files = files_with(dir, &["obj"])?;
    if files.is_empty() {
        return Err(Error::Argument(format!("{}: no .obj files in this folder", dir.display())));
    }
    Ok(files)
}

/// The files of a folder whose extension is one of `extensions` (any
/// case), ordered as [`frame_files`] orders them; none is not an error.
pub fn files_with(dir: &Path, extensions: &[&str]) -> Result<Vec<PathBuf>> {
    let entries = std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))?;
    let mut files = Vec::new();
    for entry in entries {
        let entry = entry.map_err(|e| Error::io(dir, e))?;
        let p = entry.path();
        let ext = p.extension().and_then(|e| e.to_str()).unwrap_or("");
        if extensions.iter().any(|x| ext.eq_ignore_ascii_case(x)) {
            files.push(p);
        }
    }
    files.sort_by(|a, b| {
        (frame_number(a).is_none(), frame_number(a), a.file_name()).cmp(&(
            frame_number(b).is_none(),
            frame_number(b),
            b.file_name(),
        ))
    });
    Ok(files)
}

/// A folder of OBJ files, one per frame, in the order of the number in their
/// names; or a single OBJ file as a one-frame sequence.
pub struct ObjFolder {
    label: PathBuf,
    files: Vec<PathBuf>,
    fps: f32,
    topology: Topology,
}

impl ObjFolder {
    pub fn open(dir: &Path, fps: f32) -> Result<ObjFolder> {
        Self::from_files(dir, frame_files(dir)?, fps)
    }

    pub fn single(path: &Path, fps: f32) -> Result<ObjFolder> {
        Self::from_files(path, vec![path.to_path_buf()], fps)
    }

    fn from_files(label: &Path, files: Vec<PathBuf>, fps: f32) -> Result<ObjFolder> {
        let (positions, faces) = read_obj(&files[0])?;
        let topology = Topology { vertex_count: positions.len(), faces };
        check_frame(&files[0], &topology, &positions, None)?;
        Ok(ObjFolder { label: label.to_path_buf(), files, fps, topology })
    }
}

impl FrameSource for ObjFolder {
    fn label(&self) -> &Path {
        &self.label
    }
    fn frame_count(&self) -> usize {
        self.files.len()
    }
    fn fps(&self) -> f32 {
        self.fps
    }
    fn topology(&self) -> &Topology {
        &self.topology
    }
    fn kind(&self) -> &'static str {
        if self.files.len() == 1 && self.files[0] == self.label {
            "OBJ file"
        } else {
            "folder of OBJ files"
        }
    }
    fn read_frame(&self, i: usize) -> Result<Frame> {
        let path = self
            .files
            .get(i)
            .ok_or_else(|| Error::Argument(format!("frame {i} is past the last frame {}", self.files.len() - 1)))?;
        let (positions, faces) = read_obj(path)?;
        check_frame(path, &self.topology, &positions, Some(&faces))?;
        Ok(positions)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_polygons_and_slashes() {
        let text = "# c\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1 4//1\nf -4 -3 -2\n";
        let (p, f) = parse_obj(text, Path::new("t.obj")).unwrap();
        assert_eq!(p.len(), 4);
        assert_eq!(f, vec![[0, 1, 2], [0, 2, 3], [0, 1, 2]]);
    }

    #[test]
    fn rejects_bad_numbers_with_line() {
        let e = parse_obj("v 0 0 0\nv 1 x 0\n", Path::new("a.obj")).unwrap_err();
        assert!(e.to_string().contains("a.obj:2"), "{e}");
        let e = parse_obj("v 0 0 0\nf 1 2 3\n", Path::new("a.obj")).unwrap_err();
        assert!(matches!(e, Error::Mesh { problem: MeshProblem::IndexOutOfRange { .. }, .. }), "{e}");
    }

    #[test]
    fn frame_numbers() {
        assert_eq!(frame_number(Path::new("mesh_0012.obj")), Some(12));
        assert_eq!(frame_number(Path::new("dir/7.obj")), Some(7));
        assert_eq!(frame_number(Path::new("take2_frame10.obj")), Some(10));
        assert_eq!(frame_number(Path::new("rest.obj")), None);
    }
}
