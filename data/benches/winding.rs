//! The winding number at many points on a ShapeNet-sized mesh (about 100k faces): the tree of
//! dipoles (`FastWinding`) against the exact sum over faces, per query, side by side in one run;
//! and the whole outer-surface filter of the mesh metrics' reference sample (100k points).
//!
//! `cargo bench --workspace --bench winding`

use criterion::{Criterion, criterion_group, criterion_main};
use fieldprobe_data::procedural::{generate, object_rng};
use fieldprobe_data::voxelize::winding_number;
use fieldprobe_data::winding::FastWinding;
use fieldprobe_data::{Category, TriMesh};
use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Splits every face into four at its edge midpoints until the mesh has `faces` faces or more.
fn subdivided(mut mesh: TriMesh, faces: usize) -> TriMesh {
    while mesh.faces.len() < faces {
        let mut out = TriMesh {
            vertices: mesh.vertices.clone(),
            faces: Vec::with_capacity(mesh.faces.len() * 4),
        };
        let mut mid = std::collections::HashMap::new();
        let mut midpoint = |a: u32, b: u32, out: &mut TriMesh| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let v = (out.vertices[a as usize] + out.vertices[b as usize]) * 0.5;
                out.vertices.push(v);
                out.vertices.len() as u32 - 1
            })
        };
        for &[a, b, c] in &mesh.faces {
            let (ab, bc, ca) = (
                midpoint(a, b, &mut out),
                midpoint(b, c, &mut out),
                midpoint(c, a, &mut out),
            );
            out.faces
                .extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
        }
        mesh = out;
    }
    mesh
}

/// A procedural chair subdivided to at least 100k faces, and query points just off its surface
/// (where the filter asks) and in its cube.
fn big_chair() -> (TriMesh, Vec<Vec3>) {
    let mesh = subdivided(
        generate(Category::Chair, &mut object_rng(0, Category::Chair, 0, 0)),
        100_000,
    );
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let points = (0..1000)
        .map(|i| {
            if i % 2 == 0 {
                let [a, b, c] = mesh.triangle(rng.random_range(0..mesh.faces.len()));
                let n = (b - a).cross(c - a).normalize_or_zero();
                (a + b + c) / 3.0 + n * 1e-4
            } else {
                Vec3::from_array([0; 3].map(|_| rng.random_range(-0.5..0.5)))
            }
        })
        .collect();
    (mesh, points)
}

fn winding(c: &mut Criterion) {
    let (mesh, points) = big_chair();
    eprintln!("mesh: {} faces", mesh.faces.len());
    let mut g = c.benchmark_group(format!("winding number, {} faces", mesh.faces.len()));
    g.sample_size(10);
    g.bench_function("tree build", |b| b.iter(|| FastWinding::new(&mesh)));
    let fast = FastWinding::new(&mesh);
    g.bench_function("tree, 1000 queries", |b| {
        b.iter(|| points.iter().map(|&p| fast.winding(p)).sum::<f64>())
    });
    g.bench_function("exact sum, 10 queries", |b| {
        b.iter(|| {
            points[..10]
                .iter()
                .map(|&p| winding_number(&mesh, p))
                .sum::<f64>()
        })
    });
    g.finish();
}

criterion_group!(benches, winding);
criterion_main!(benches);
