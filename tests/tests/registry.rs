//! Every registered component deserializes from its example TOML block and builds, and the
//! configs reject misspelled keys and unknown types.

use fieldprobe_core::field::FieldModelConfig;
use fieldprobe_core::probe::{
    AggregatorConfig, AnchorSamplerConfig, RayMarcherConfig, RaySamplerConfig,
};
use fieldprobe_core::registry::{ComponentKind, components};
use fieldprobe_core::regularize::RegularizerConfig;
// The link list: registration only sees crates that are linked.
use fieldprobe_models as _;
use fieldprobe_regularizers as _;
use fieldprobe_samplers as _;

fn build(kind: ComponentKind, text: &str) -> Result<(), String> {
    let e = |e: toml::de::Error| e.to_string();
    match kind {
        ComponentKind::Representation => {
            let config = toml::from_str::<Box<dyn FieldModelConfig>>(text).map_err(e)?;
            config.validate()?;
            let model = config.init(&burn::prelude::Device::flex());
            assert!(model.parameters() > 0);
            Ok(())
        }
        ComponentKind::RaySampler => toml::from_str::<Box<dyn RaySamplerConfig>>(text)
            .map_err(e)?
            .build()
            .map(|_| ()),
        ComponentKind::AnchorSampler => toml::from_str::<Box<dyn AnchorSamplerConfig>>(text)
            .map_err(e)?
            .build()
            .map(|_| ()),
        ComponentKind::Aggregator => toml::from_str::<Box<dyn AggregatorConfig>>(text)
            .map_err(e)?
            .build()
            .map(|_| ()),
        ComponentKind::RayMarcher => toml::from_str::<Box<dyn RayMarcherConfig>>(text)
            .map_err(e)?
            .build()
            .map(|_| ()),
        ComponentKind::Regularizer => toml::from_str::<Box<dyn RegularizerConfig>>(text)
            .map_err(e)?
            .build()
            .map(|_| ()),
    }
}

#[test]
fn every_registered_component_builds_from_its_example() {
    let all = components();
    let names: Vec<(ComponentKind, &str)> = all.iter().map(|c| (c.kind, c.name)).collect();
    for expected in [
        (ComponentKind::RaySampler, "uniform"),
        (ComponentKind::RaySampler, "normal"),
        (ComponentKind::AnchorSampler, "uniform"),
        (ComponentKind::AnchorSampler, "normal"),
        (ComponentKind::Representation, "single_view"),
        (ComponentKind::Representation, "per_object"),
        (ComponentKind::Representation, "sdf"),
        (ComponentKind::Aggregator, "max"),
        (ComponentKind::Aggregator, "composite"),
        (ComponentKind::RayMarcher, "fixed"),
        (ComponentKind::RayMarcher, "stratified"),
        (ComponentKind::Regularizer, "normal_consistency"),
        (ComponentKind::Regularizer, "eikonal"),
    ] {
        assert!(
            names.contains(&expected),
            "{expected:?} not registered: {names:?}"
        );
    }
    for c in all {
        build(c.kind, c.example)
            .unwrap_or_else(|e| panic!("{:?} '{}': {e}\n{}", c.kind, c.name, c.example));
    }
}

#[test]
fn misspelled_keys_and_unknown_types_are_errors_that_name_them() {
    let e = build(
        ComponentKind::AnchorSampler,
        "type = \"normal\"\nsigmaa = 0.4",
    )
    .unwrap_err();
    assert!(e.contains("sigmaa"), "{e}");
    let e = build(ComponentKind::RaySampler, "type = \"unifrom\"").unwrap_err();
    assert!(e.contains("unifrom") && e.contains("uniform"), "{e}");
    let e = build(
        ComponentKind::AnchorSampler,
        "type = \"normal\"\nsigma = -1.0",
    )
    .unwrap_err();
    assert!(e.contains("sigma"), "{e}");
}
