//! FieldProbe samplers: where rays and anchors go.
//!
//! | `type` | kind | distribution |
//! |---|---|---|
//! | `uniform` | ray | pixel positions uniform over the image |
//! | `uniform` | anchor | points uniform in the cube `[-extent, extent]³` |
//! | `normal` | ray | NDC coordinates `~ N(0, σ)` (paper's "normal sampling" ablation, σ = 0.4), kept on the image |
//! | `normal` | anchor | points `~ N(0, σ·I)` (σ = 0.4) |
//! | `importance` | ray | paper §3.1: Gaussian mixture (σ = 0.007 in NDC units, image = `[-1, 1]`) on the silhouette's contour map `\|∇²s\|`; uniform when there is no contour |
//! | `fixed` | march | the centres of `samples` equal bins of each ray inside the cube (dense marching baseline) |
//! | `stratified` | march | one uniform depth per bin (NeRF's coarse sampler) |
//! | `importance` | anchor | paper §3.1: Gaussian mixture (σ = 0.007 world units) on the 3×3×3-mean-filtered visual hull's boundary, `4m(1 − m)`, hull cached per object; uniform in `[-0.5, 0.5]³` for an empty hull |
//!
//! Each is a serde config registered with typetag (the `type` tag) and with the component
//! registry (an example TOML block for `experiments list`).

pub mod importance;
pub mod march;
pub mod normal;
pub mod uniform;

pub use importance::{ImportanceAnchorSampler, ImportanceAnchors, ImportanceRays};
pub use march::{FixedDepths, StratifiedDepths};
pub use normal::{NormalAnchors, NormalRays};
pub use uniform::{UniformAnchors, UniformRays};

#[cfg(test)]
mod test_support {
    use fieldprobe_core::data::Silhouette;
    use fieldprobe_core::geometry::PixelPos;
    use fieldprobe_core::probe::Supervision;

    /// An object with empty silhouettes (samplers here ignore them).
    pub fn blank() -> Supervision {
        Supervision::nmr(vec![Silhouette::empty(64); 24])
    }

    /// Asserts that pixels of a 64-pixel image fall evenly into its four quadrants: each count
    /// within 4σ of a binomial with p = ¼ (what a uniform sample does).
    pub fn assert_even_quadrants(px: &[PixelPos]) {
        let mut q = [0usize; 4];
        for p in px {
            q[(p.col >= 31.5) as usize + 2 * (p.row >= 31.5) as usize] += 1;
        }
        let n = px.len() as f32;
        let sd = (n * 0.25 * 0.75).sqrt();
        for c in q {
            assert!((c as f32 - n / 4.0).abs() < 4.0 * sd, "{q:?}");
        }
    }
}
