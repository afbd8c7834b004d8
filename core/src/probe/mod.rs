//! Ray-based field probing (paper §3.1): samplers, ray–anchor assignment, aggregation, and the
//! assembly of a training batch.

pub mod aggregate;
pub mod assign;
pub mod batch;
pub mod sampler;

pub use aggregate::{Aggregator, AggregatorConfig, MaxPool, RayValues, SoftMax};
pub use assign::{Assignment, AssignmentPolicy, Probe, RaySet, assign_all_pairs, assign_binned};
pub use batch::{ObjectProbe, ProbeBatch, ProbeSpec};
pub use sampler::{AnchorSampler, AnchorSamplerConfig, RaySampler, RaySamplerConfig, Supervision};
