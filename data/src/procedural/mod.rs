//! Procedural shapes in the paper's six categories, with variation in proportions and topology.
//!
//! ShapeNet cannot be downloaded here, so the project makes its own objects. Each shape is a
//! union of closed primitives ([`primitives::MeshBuilder`]); overlapping parts are fine for every
//! consumer (the rasterizer draws the union, NMR's surface voxelization + fill and the winding
//! number both give the union's solid). Shapes use ShapeNet's orientation: up is `+y`, the front
//! of an object faces `−z` (towards the camera of view 0), and are normalized to the unit cube by
//! [`generate`].
//!
//! Variation is structural, not only metric: chairs with and without arms, solid / slatted /
//! framed backs (holes), four legs or a swivel base; tables with four legs, a pedestal, trestles,
//! cross-bars and shelves; benches with slatted seats and optional backs; airplanes with or without
//! engines, different sweep and tails; cars with different cabins and wheels; boats with hulls,
//! cabins, masts and sails. Everything is drawn from a seeded ChaCha RNG, so an object is a pure
//! function of `(seed, category, split, index)`.

mod furniture;
pub mod primitives;
mod vehicles;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use self::furniture::{bench, chair, table};
use self::primitives::MeshBuilder;
use self::vehicles::{airplane, car, watercraft};
use super::category::Category;
use super::mesh::TriMesh;

/// Segments used for round parts: enough to read as round at 64×64, few enough to stay fast.
const ROUND: usize = 16;

/// The RNG for object `index` of `category` in the split numbered `split` (0 train, 1 val,
/// 2 test) under `seed`. Objects are independent of how many others are generated.
pub fn object_rng(seed: u64, category: Category, split: u64, index: u64) -> ChaCha8Rng {
    let mut h = seed ^ 0x9E37_79B9_7F4A_7C15;
    for x in [category as u64 + 1, split + 1, index + 1] {
        h = splitmix(h ^ x.wrapping_mul(0xD1B5_4A32_D192_ED03));
    }
    ChaCha8Rng::seed_from_u64(h)
}

fn splitmix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A random object of `category`, normalized to the unit cube.
pub fn generate(category: Category, rng: &mut impl Rng) -> TriMesh {
    let mut b = MeshBuilder::default();
    match category {
        Category::Airplane => airplane(&mut b, rng),
        Category::Bench => bench(&mut b, rng),
        Category::Car => car(&mut b, rng),
        Category::Chair => chair(&mut b, rng),
        Category::Table => table(&mut b, rng),
        Category::Watercraft => watercraft(&mut b, rng),
    }
    let mut mesh = b.build();
    mesh.normalize_unit_cube();
    mesh
}

/// A uniform draw in `[lo, hi)`: every proportion of every shape is one.
fn u(rng: &mut impl Rng, lo: f32, hi: f32) -> f32 {
    rng.random_range(lo..hi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::voxelize::voxelize_nmr;

    #[test]
    fn every_category_generates_valid_normalized_distinct_shapes() {
        for c in Category::ALL {
            let mut counts = Vec::new();
            for i in 0..6 {
                let m = generate(c, &mut object_rng(0, c, 0, i));
                m.validate().unwrap();
                let (lo, hi) = m.bounds();
                assert!(((hi - lo).max_element() - 1.0).abs() < 1e-5, "{c}");
                assert!(lo.min_element() >= -0.5 - 1e-5 && hi.max_element() <= 0.5 + 1e-5);
                counts.push(voxelize_nmr(&m, 32).count());
            }
            counts.sort();
            counts.dedup();
            assert!(
                counts.len() >= 5,
                "{c}: shapes should differ, voxel counts {counts:?}"
            );
        }
    }

    #[test]
    fn objects_are_reproducible_and_independent_of_each_other() {
        let a = generate(Category::Chair, &mut object_rng(7, Category::Chair, 2, 3));
        let b = generate(Category::Chair, &mut object_rng(7, Category::Chair, 2, 3));
        let c = generate(Category::Chair, &mut object_rng(7, Category::Chair, 2, 4));
        assert_eq!(a, b);
        assert_ne!(a, c);
    }
}
