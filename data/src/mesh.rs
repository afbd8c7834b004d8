//! Triangle meshes: loading `.obj` with tobj, normalizing to the NMR unit cube, writing `.obj`.

use std::io::Write;
use std::path::Path;

use glam::Vec3;

use crate::{Error, Result};

/// An indexed triangle mesh. Components may overlap (procedural shapes are unions of closed
/// parts); every consumer here (rasterizer, surface voxelization + fill, winding number) treats
/// such a union as the union of the solids.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriMesh {
    pub vertices: Vec<Vec3>,
    pub faces: Vec<[u32; 3]>,
}

impl TriMesh {
    /// Loads every group/object of an `.obj` file (polygons are triangulated) into one mesh.
    ///
    /// Errors name the file: missing/unreadable file, parse failure, no faces, non-finite
    /// vertices, out-of-range indices.
    pub fn load_obj(path: &Path) -> Result<Self> {
        if !path.is_file() {
            return Err(Error::io(
                path,
                std::io::Error::new(std::io::ErrorKind::NotFound, "no such mesh file"),
            ));
        }
        let options = tobj::LoadOptions {
            triangulate: true,
            single_index: false,
            ignore_points: true,
            ignore_lines: true,
        };
        // Materials are irrelevant for silhouettes and a missing .mtl must not fail the load.
        let (models, _materials) = tobj::load_obj(path, &options).map_err(|e| Error::Mesh {
            path: path.into(),
            message: format!("cannot parse OBJ: {e}"),
        })?;
        let mut mesh = TriMesh::default();
        for model in &models {
            let m = &model.mesh;
            let base = mesh.vertices.len() as u32;
            let n = m.positions.len() / 3;
            mesh.vertices.extend(
                m.positions
                    .chunks_exact(3)
                    .map(|p| Vec3::new(p[0], p[1], p[2])),
            );
            for tri in m.indices.chunks_exact(3) {
                if tri.iter().any(|&i| i as usize >= n) {
                    return Err(Error::Mesh {
                        path: path.into(),
                        message: format!(
                            "object '{}' has a face index out of range ({} vertices)",
                            model.name, n
                        ),
                    });
                }
                mesh.faces
                    .push([base + tri[0], base + tri[1], base + tri[2]]);
            }
        }
        mesh.validate().map_err(|message| Error::Mesh {
            path: path.into(),
            message,
        })?;
        Ok(mesh)
    }

    /// Checks what every consumer relies on: at least one face, finite vertices, indices in range,
    /// a non-zero extent. Returns a human-readable reason.
    pub fn validate(&self) -> std::result::Result<(), String> {
        if self.faces.is_empty() {
            return Err("the mesh has no faces".into());
        }
        if let Some(i) = self.vertices.iter().position(|v| !v.is_finite()) {
            return Err(format!("vertex {i} is not finite: {:?}", self.vertices[i]));
        }
        let n = self.vertices.len() as u32;
        if let Some(f) = self.faces.iter().position(|f| f.iter().any(|&i| i >= n)) {
            return Err(format!(
                "face {f} indexes a vertex out of range ({n} vertices)"
            ));
        }
        let (lo, hi) = self.bounds();
        if (hi - lo).max_element() <= 0.0 {
            return Err("the mesh has zero extent".into());
        }
        Ok(())
    }

    /// Axis-aligned bounding box `(min, max)` of the vertices used by faces.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for f in &self.faces {
            for &i in f {
                let v = self.vertices[i as usize];
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
        (lo, hi)
    }

    /// Centres the mesh on its bounding-box centre and scales it so that its largest extent is 1,
    /// i.e. into `[-0.5, 0.5]³` as the NMR/ShapeNet data are.
    pub fn normalize_unit_cube(&mut self) {
        let (lo, hi) = self.bounds();
        let centre = (lo + hi) * 0.5;
        let scale = 1.0 / (hi - lo).max_element();
        for v in &mut self.vertices {
            *v = (*v - centre) * scale;
        }
    }

    /// The three corners of face `f`.
    pub fn triangle(&self, f: usize) -> [Vec3; 3] {
        self.faces[f].map(|i| self.vertices[i as usize])
    }

    /// Appends `other`, re-indexing its faces.
    pub fn append(&mut self, other: &TriMesh) {
        let base = self.vertices.len() as u32;
        self.vertices.extend_from_slice(&other.vertices);
        self.faces
            .extend(other.faces.iter().map(|f| f.map(|i| i + base)));
    }

    /// Applies `f` to every vertex.
    pub fn map_vertices(&mut self, f: impl Fn(Vec3) -> Vec3) {
        for v in &mut self.vertices {
            *v = f(*v);
        }
    }

    /// Writes a Wavefront `.obj` (vertices and 1-based triangular faces) to `w`.
    pub fn write_obj_to(&self, w: &mut impl Write) -> std::io::Result<()> {
        for v in &self.vertices {
            writeln!(w, "v {} {} {}", v.x, v.y, v.z)?;
        }
        for f in &self.faces {
            writeln!(w, "f {} {} {}", f[0] + 1, f[1] + 1, f[2] + 1)?;
        }
        Ok(())
    }

    /// Writes a Wavefront `.obj` atomically (temporary file, then rename).
    pub fn write_obj(&self, path: &Path) -> Result<()> {
        crate::io::write_atomic(path, |w| self.write_obj_to(w))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn loads_all_groups_and_normalizes() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(
            dir.path(),
            "two.obj",
            "o a\nv 0 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\no b\nv 0 0 4\nv 1 0 4\nv 0 1 4\nv 1 1 4\nf 4 5 7 6\n",
        );
        let mut m = TriMesh::load_obj(&p).unwrap();
        assert_eq!(
            m.faces.len(),
            3,
            "quad in group b is triangulated, group a kept"
        );
        m.normalize_unit_cube();
        let (lo, hi) = m.bounds();
        assert!(((hi - lo).max_element() - 1.0).abs() < 1e-6);
        assert!(((hi + lo) * 0.5).length() < 1e-6);
        assert!((hi.z - 0.5).abs() < 1e-6 && (lo.z + 0.5).abs() < 1e-6);
    }

    #[test]
    fn clear_errors_name_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("nope.obj");
        let e = TriMesh::load_obj(&missing).unwrap_err().to_string();
        assert!(e.contains("nope.obj"), "{e}");

        let p = write(dir.path(), "nofaces.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
        let e = TriMesh::load_obj(&p).unwrap_err().to_string();
        assert!(e.contains("nofaces.obj") && e.contains("no faces"), "{e}");

        let p = write(
            dir.path(),
            "nan.obj",
            "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n",
        );
        let e = TriMesh::load_obj(&p).unwrap_err().to_string();
        assert!(e.contains("nan.obj") && e.contains("not finite"), "{e}");
    }

    #[test]
    fn obj_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let m = TriMesh {
            vertices: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z],
            faces: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        };
        let p = dir.path().join("t.obj");
        m.write_obj(&p).unwrap();
        // tobj may renumber vertices; compare the triangles themselves.
        let back = TriMesh::load_obj(&p).unwrap();
        assert_eq!(back.faces.len(), m.faces.len());
        for f in 0..m.faces.len() {
            assert_eq!(back.triangle(f), m.triangle(f));
        }
    }
}
