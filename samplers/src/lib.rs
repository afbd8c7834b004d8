//! FieldProbe samplers: ray samplers (pixels per view) and anchor samplers (3D points).
//!
//! This crate is the home of the uniform, normal and importance samplers. It is part of the
//! workspace skeleton laid down with the data foundation; the `Sampler` traits and their
//! implementations arrive with the probing work (issue "Ray-based field probing end to end").
