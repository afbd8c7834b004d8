//! Ray-based field probing (paper §3.1): samplers, ray–anchor assignment, aggregation, and the
//! assembly of a training batch.

pub mod aggregate;
pub mod assign;
pub mod batch;
pub mod march;
pub mod sampler;

pub use aggregate::{Aggregator, AggregatorConfig, Composite, MaxPool, RayValues, SoftMax};
pub use assign::{
    Assignment, AssignmentPolicy, Probe, RaySet, assign_all_pairs, assign_binned, assign_on_device,
};
pub use batch::{ObjectProbe, ProbeBatch, ProbeSpec};
pub use march::{RayMarcher, RayMarcherConfig};
pub use sampler::{AnchorSampler, AnchorSamplerConfig, RaySampler, RaySamplerConfig, Supervision};
