//! Mesh files in the formats users' collections come in: `.obj` (ShapeNet, through tobj),
//! `.off` (ModelNet, Princeton), `.ply` (Stanford, scanners; ascii and binary, through
//! `ply-rs-bw`) and `.stl` (CAD, 3D printing; ascii and binary, through `stl_io`). Every reader
//! ends in [`TriMesh::validate`], so a mesh with no faces, a NaN coordinate or an index out of
//! range is an error naming the file, whatever its format.
//!
//! `.off` is read here (forty lines): it is a whitespace-separated list of counts, vertices and
//! polygons, and no maintained crate reads just that.

use std::io::{BufRead, BufReader};
use std::path::Path;

use glam::Vec3;

use crate::mesh::TriMesh;
use crate::{Error, Result};

/// The mesh file extensions [`load_mesh`] reads (lowercase).
pub const MESH_EXTENSIONS: [&str; 4] = ["obj", "off", "ply", "stl"];

/// Whether `path` has one of [`MESH_EXTENSIONS`] (any case).
pub fn is_mesh_file(path: &Path) -> bool {
    path.extension().is_some_and(|e| {
        let e = e.to_string_lossy().to_ascii_lowercase();
        MESH_EXTENSIONS.contains(&e.as_str())
    })
}

/// Loads a mesh by its extension (`.obj`, `.off`, `.ply`, `.stl`); polygons are fanned into
/// triangles. Errors name the file.
pub fn load_mesh(path: &Path) -> Result<TriMesh> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let mesh = match ext.as_str() {
        "obj" => return TriMesh::load_obj(path),
        "off" => read_off(path)?,
        "ply" => read_ply(path)?,
        "stl" => read_stl(path)?,
        _ => {
            return Err(mesh_error(
                path,
                format!("unknown mesh format '.{ext}' (expected one of .obj, .off, .ply, .stl)"),
            ));
        }
    };
    mesh.validate().map_err(|m| mesh_error(path, m))?;
    Ok(mesh)
}

fn mesh_error(path: &Path, message: impl Into<String>) -> Error {
    Error::Mesh {
        path: path.into(),
        message: message.into(),
    }
}

fn open(path: &Path) -> Result<BufReader<std::fs::File>> {
    std::fs::File::open(path)
        .map(BufReader::new)
        .map_err(|e| Error::io(path, e))
}

/// Appends polygon `poly` as a fan of triangles; indices are checked against `n` vertices.
fn push_polygon(mesh: &mut TriMesh, poly: &[i64], n: usize) -> std::result::Result<(), String> {
    if poly.len() < 3 {
        return Ok(()); // points and edges carry no surface
    }
    if let Some(i) = poly.iter().find(|&&i| i < 0 || i as usize >= n) {
        return Err(format!("a face indexes vertex {i} of {n}"));
    }
    for k in 1..poly.len() - 1 {
        mesh.faces
            .push([poly[0] as u32, poly[k] as u32, poly[k + 1] as u32]);
    }
    Ok(())
}

/// `OFF` (optionally `COFF`/`NOFF` headers with per-vertex extras, which are skipped):
/// `nv nf ne`, then `nv` vertices and `nf` polygons `k i₁ … i_k`. `#` starts a comment.
fn read_off(path: &Path) -> Result<TriMesh> {
    let mut words = Vec::new();
    for line in open(path)?.lines() {
        let line = line.map_err(|e| Error::io(path, e))?;
        let line = line.split('#').next().unwrap_or("");
        words.extend(line.split_whitespace().map(str::to_string));
    }
    let bad = |m: String| mesh_error(path, format!("cannot parse OFF: {m}"));
    let mut w = words.iter().map(String::as_str);
    let header = w.next().ok_or_else(|| bad("the file is empty".into()))?;
    // "OFF" alone, or glued to the vertex count ("OFF8 6 0" in some ModelNet files).
    let glued = match header {
        "OFF" => None,
        h if h.starts_with("OFF") && h[3..].chars().all(|c| c.is_ascii_digit()) => Some(&h[3..]),
        h if h.ends_with("OFF") => {
            return Err(bad(format!(
                "'{h}' files (with colours, normals or texture coordinates) are not supported; \
                 convert to plain OFF"
            )));
        }
        h => return Err(bad(format!("expected an OFF header, got '{h}'"))),
    };
    let mut w = glued.into_iter().chain(w);
    let mut count = |what: &str| -> Result<usize> {
        let t = w
            .next()
            .ok_or_else(|| bad(format!("missing the {what} count")))?;
        t.parse()
            .map_err(|_| bad(format!("the {what} count '{t}' is not a number")))
    };
    let (nv, nf) = (count("vertex")?, count("face")?);
    count("edge")?;
    let per_vertex = 3;
    let mut num = |what: &str| -> Result<f64> {
        let t = w
            .next()
            .ok_or_else(|| bad(format!("the file ends inside the {what}")))?;
        t.parse()
            .map_err(|_| bad(format!("'{t}' in the {what} is not a number")))
    };
    // Counts are checked against what the file can hold before anything is reserved.
    if nv.saturating_mul(per_vertex).saturating_add(nf) > words.len() {
        return Err(bad(format!(
            "{nv} vertices and {nf} faces do not fit in {} numbers",
            words.len()
        )));
    }
    let mut mesh = TriMesh::default();
    mesh.vertices.reserve(nv);
    for _ in 0..nv {
        let (x, y, z) = (num("vertices")?, num("vertices")?, num("vertices")?);
        mesh.vertices.push(Vec3::new(x as f32, y as f32, z as f32));
    }
    for _ in 0..nf {
        let k = num("faces")?;
        if !(k >= 0.0 && k.fract() == 0.0 && (k as usize) <= words.len()) {
            return Err(bad(format!("a face has {k} vertices")));
        }
        let poly = (0..k as usize)
            .map(|_| num("faces").map(|i| i as i64))
            .collect::<Result<Vec<_>>>()?;
        push_polygon(&mut mesh, &poly, nv).map_err(bad)?;
    }
    Ok(mesh)
}

/// PLY (ascii, binary little or big endian): the `vertex` element's `x`, `y`, `z` and the
/// `face` element's `vertex_indices` (or `vertex_index`) lists, of any numeric type.
fn read_ply(path: &Path) -> Result<TriMesh> {
    use ply_rs_bw::parser::Parser;
    use ply_rs_bw::ply::{DefaultElement, Property};
    let bad = |m: String| mesh_error(path, format!("cannot parse PLY: {m}"));
    let ply = Parser::<DefaultElement>::new()
        .read_ply(&mut open(path)?)
        .map_err(|e| bad(e.to_string()))?;
    let scalar = |p: &Property| -> Option<f64> {
        Some(match *p {
            Property::Char(v) => v as f64,
            Property::UChar(v) => v as f64,
            Property::Short(v) => v as f64,
            Property::UShort(v) => v as f64,
            Property::Int(v) => v as f64,
            Property::UInt(v) => v as f64,
            Property::Float(v) => v as f64,
            Property::Double(v) => v,
            _ => return None,
        })
    };
    let list = |p: &Property| -> Option<Vec<i64>> {
        Some(match p {
            Property::ListChar(v) => v.iter().map(|&i| i as i64).collect(),
            Property::ListUChar(v) => v.iter().map(|&i| i as i64).collect(),
            Property::ListShort(v) => v.iter().map(|&i| i as i64).collect(),
            Property::ListUShort(v) => v.iter().map(|&i| i as i64).collect(),
            Property::ListInt(v) => v.iter().map(|&i| i as i64).collect(),
            Property::ListUInt(v) => v.iter().map(|&i| i as i64).collect(),
            _ => return None,
        })
    };
    let vertices = ply
        .payload
        .get("vertex")
        .ok_or_else(|| bad("no 'vertex' element".into()))?;
    let mut mesh = TriMesh::default();
    for (i, v) in vertices.iter().enumerate() {
        let mut xyz = [0.0f32; 3];
        for (k, name) in ["x", "y", "z"].iter().enumerate() {
            xyz[k] = v
                .get(*name)
                .and_then(scalar)
                .ok_or_else(|| bad(format!("vertex {i} has no numeric '{name}'")))?
                as f32;
        }
        mesh.vertices.push(Vec3::from(xyz));
    }
    let n = mesh.vertices.len();
    for (f, face) in ply.payload.get("face").into_iter().flatten().enumerate() {
        let poly = ["vertex_indices", "vertex_index"]
            .iter()
            .find_map(|k| face.get(*k))
            .and_then(list)
            .ok_or_else(|| bad(format!("face {f} has no integer 'vertex_indices' list")))?;
        push_polygon(&mut mesh, &poly, n).map_err(bad)?;
    }
    Ok(mesh)
}

/// STL, ascii or binary; coincident vertices are merged by `stl_io`.
fn read_stl(path: &Path) -> Result<TriMesh> {
    let stl = stl_io::read_stl(&mut open(path)?)
        .map_err(|e| mesh_error(path, format!("cannot parse STL: {e}")))?;
    let mut mesh = TriMesh {
        vertices: stl
            .vertices
            .iter()
            .map(|v| Vec3::new(v[0], v[1], v[2]))
            .collect(),
        faces: Vec::with_capacity(stl.faces.len()),
    };
    let n = mesh.vertices.len();
    for t in &stl.faces {
        let poly = t.vertices.map(|i| i as i64);
        push_polygon(&mut mesh, &poly, n).map_err(|m| mesh_error(path, m))?;
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit tetrahedron in every format; each reads back as the same four triangles.
    #[test]
    fn off_ply_and_stl_read_the_same_tetrahedron_as_obj() {
        let dir = tempfile::tempdir().unwrap();
        let v = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ];
        let f = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        let tet = TriMesh {
            vertices: v.iter().map(|p| Vec3::from(*p)).collect(),
            faces: f.to_vec(),
        };
        let obj = dir.path().join("t.obj");
        tet.write_obj(&obj).unwrap();
        let mut off = String::from("OFF\n# a comment\n4 4 6\n");
        for p in v {
            off += &format!("{} {} {}\n", p[0], p[1], p[2]);
        }
        for t in f {
            off += &format!("3 {} {} {}\n", t[0], t[1], t[2]);
        }
        std::fs::write(dir.path().join("t.off"), off).unwrap();
        let mut ply = String::from(
            "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n",
        );
        for p in v {
            ply += &format!("{} {} {}\n", p[0], p[1], p[2]);
        }
        for t in f {
            ply += &format!("3 {} {} {}\n", t[0], t[1], t[2]);
        }
        std::fs::write(dir.path().join("t.ply"), ply).unwrap();
        // Binary PLY through our own writer, too.
        crate::extract::write_ply(&tet, &dir.path().join("b.ply")).unwrap();
        let stl_mesh = stl_io::IndexedMesh {
            vertices: v
                .iter()
                .map(|p| stl_io::Vertex::new([p[0], p[1], p[2]]))
                .collect(),
            faces: f
                .iter()
                .map(|t| stl_io::IndexedTriangle {
                    normal: stl_io::Normal::new([0.0, 0.0, 0.0]),
                    vertices: t.map(|i| i as usize),
                })
                .collect(),
        };
        let mut stl = std::fs::File::create(dir.path().join("t.stl")).unwrap();
        stl_io::write_stl(&mut stl, stl_mesh.into_triangle_vec().iter()).unwrap();
        drop(stl);
        let want = load_mesh(&obj).unwrap();
        for name in ["t.off", "t.ply", "b.ply", "t.stl"] {
            let m = load_mesh(&dir.path().join(name)).unwrap();
            assert_eq!(m.faces.len(), 4, "{name}");
            let tri = |m: &TriMesh, k: usize| m.triangle(k);
            for k in 0..4 {
                assert_eq!(tri(&m, k), tri(&want, k), "{name} face {k}");
            }
        }
    }

    #[test]
    fn bad_mesh_files_are_named_with_what_is_wrong() {
        let dir = tempfile::tempdir().unwrap();
        let cases: [(&str, &[u8], &str); 6] = [
            ("a.off", b"OFF\n3 1 0\n0 0 0\n1 0 0\n", "ends inside"),
            (
                "b.off",
                b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n",
                "vertex 7",
            ),
            ("c.off", b"OFF\n999999999 1 0\n", "do not fit"),
            ("d.off", b"PLY\n", "OFF header"),
            (
                "e.ply",
                b"ply\nformat ascii 1.0\nelement face 0\nend_header\n",
                "vertex",
            ),
            ("f.mesh", b"", "unknown mesh format"),
        ];
        for (name, bytes, needle) in cases {
            let p = dir.path().join(name);
            std::fs::write(&p, bytes).unwrap();
            let e = load_mesh(&p).unwrap_err().to_string();
            assert!(e.contains(name) && e.contains(needle), "{name}: {e}");
        }
        // A file with no faces at all is refused by the common validation.
        let p = dir.path().join("g.off");
        std::fs::write(&p, "OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n").unwrap();
        let e = load_mesh(&p).unwrap_err().to_string();
        assert!(e.contains("g.off") && e.contains("no faces"), "{e}");
    }
}
