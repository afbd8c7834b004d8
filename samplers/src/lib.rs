//! FieldProbe samplers: where rays and anchors go.
//!
//! | `type` | kind | distribution |
//! |---|---|---|
//! | `uniform` | ray | pixel positions uniform over the image |
//! | `uniform` | anchor | points uniform in the cube `[-extent, extent]³` |
//! | `normal` | ray | NDC coordinates `~ N(0, σ)` (paper's "normal sampling" ablation, σ = 0.4), kept on the image |
//! | `normal` | anchor | points `~ N(0, σ·I)` (σ = 0.4) |
//! | `importance` | ray | paper §3.1: Gaussian mixture (σ = 0.007 in NDC units, image = `[-1, 1]`) on the silhouette's contour map `\|∇²s\|`; uniform when there is no contour |
//! | `importance` | anchor | paper §3.1: Gaussian mixture (σ = 0.007 world units) on the 3×3×3-mean-filtered visual hull's boundary, `4m(1 − m)`, hull cached per object; uniform in `[-0.5, 0.5]³` for an empty hull |
//!
//! Each is a serde config registered with typetag (the `type` tag) and with the component
//! registry (an example TOML block for `experiments list`).

pub mod importance;
pub mod normal;
pub mod uniform;

pub use importance::{ImportanceAnchorSampler, ImportanceAnchors, ImportanceRays};
pub use normal::{NormalAnchors, NormalRays};
pub use uniform::{UniformAnchors, UniformRays};

#[cfg(test)]
mod test_support {
    use fieldprobe_core::data::Silhouette;
    use fieldprobe_core::probe::Supervision;

    /// An object with empty silhouettes (samplers here ignore them).
    pub fn blank() -> Supervision {
        Supervision::nmr(vec![Silhouette::empty(64); 24])
    }
}
