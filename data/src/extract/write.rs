//! Mesh writers: binary little-endian `.ply`, and `.obj` through [`TriMesh::write_obj`]. The PLY
//! writer is thirty lines for one fixed layout (float xyz, int triangles); `ply-rs` would add a
//! generic property model to write exactly that.

use std::io::Write;
use std::path::Path;

use crate::io::write_atomic;
use crate::mesh::TriMesh;
use crate::{Error, Result};

/// Writes `mesh` as a binary little-endian PLY: `element vertex` with float `x y z`, then
/// `element face` with `property list uchar int vertex_indices` (the layout every viewer and
/// trimesh/Open3D/MeshLab read). Binary keeps f32 positions exact and is about a third of ASCII.
pub fn write_ply_to(mesh: &TriMesh, w: &mut impl Write) -> std::io::Result<()> {
    if mesh.vertices.len() > i32::MAX as usize {
        return Err(std::io::Error::other(
            "too many vertices for PLY int indices",
        ));
    }
    write!(
        w,
        "ply\nformat binary_little_endian 1.0\ncomment FieldProbe\n\
         element vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        mesh.vertices.len(),
        mesh.faces.len()
    )?;
    for v in &mesh.vertices {
        for c in v.to_array() {
            w.write_all(&c.to_le_bytes())?;
        }
    }
    for f in &mesh.faces {
        w.write_all(&[3u8])?;
        for &i in f {
            w.write_all(&(i as i32).to_le_bytes())?;
        }
    }
    Ok(())
}

/// Writes `mesh` as a binary PLY ([`write_ply_to`]) atomically (temporary file, then rename).
pub fn write_ply(mesh: &TriMesh, path: &Path) -> Result<()> {
    write_atomic(path, |w| write_ply_to(mesh, w))
}

/// Writes `mesh` atomically in the format named by the extension of `path`: `.ply`
/// ([`write_ply`]) or `.obj` ([`TriMesh::write_obj`]).
pub fn write_mesh(mesh: &TriMesh, path: &Path) -> Result<()> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    match ext.as_deref() {
        Some("ply") => write_ply(mesh, path),
        Some("obj") => mesh.write_obj(path),
        _ => Err(Error::Invalid(format!(
            "{}: unknown mesh format (use .ply or .obj)",
            path.display()
        ))),
    }
}
