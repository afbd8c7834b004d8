//! The list of pluggable components linked into a binary, with an example TOML block for each.
//!
//! typetag registers a config type with the deserializer; this registry adds what users need to
//! discover it (`experiments list`) and what tests need to check it (every example must parse and
//! build). Plugin crates call [`register_component!`](crate::register_component).

use serde::{Deserialize, Serialize};

/// Which trait a component implements (and which TOML table it goes in).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ComponentKind {
    /// `[model]`
    Representation,
    /// `[probe.ray_sampler]`
    RaySampler,
    /// `[probe.anchor_sampler]`
    AnchorSampler,
    /// `[probe.aggregator]`
    Aggregator,
    /// `[probe.march]` (dense ray marching instead of anchors)
    RayMarcher,
    /// `[regularizers.<name>]` (any number, each under a name of your choice)
    Regularizer,
}

impl ComponentKind {
    /// The TOML table a component of this kind is configured in.
    pub fn table(self) -> &'static str {
        match self {
            ComponentKind::Representation => "model",
            ComponentKind::RaySampler => "probe.ray_sampler",
            ComponentKind::AnchorSampler => "probe.anchor_sampler",
            ComponentKind::Aggregator => "probe.aggregator",
            ComponentKind::RayMarcher => "probe.march",
            ComponentKind::Regularizer => "regularizers.<name>",
        }
    }
}

/// One registered component.
#[derive(Debug)]
pub struct Component {
    pub kind: ComponentKind,
    /// The `type = "…"` tag.
    pub name: &'static str,
    /// One line on what it does.
    pub summary: &'static str,
    /// The body of its TOML table, with every field and its default.
    pub example: &'static str,
    /// The crate that provides it.
    pub provider: &'static str,
}

inventory::collect!(Component);

/// Registers a component (use once per config type, next to its `typetag` impl).
#[macro_export]
macro_rules! register_component {
    ($kind:ident, $name:literal, $summary:literal, $example:literal) => {
        $crate::inventory::submit! {
            $crate::registry::Component {
                kind: $crate::registry::ComponentKind::$kind,
                name: $name,
                summary: $summary,
                example: $example,
                provider: env!("CARGO_PKG_NAME"),
            }
        }
    };
}

/// Every component linked into this binary, sorted by kind and name.
pub fn components() -> Vec<&'static Component> {
    let mut all: Vec<&'static Component> = inventory::iter::<Component>.into_iter().collect();
    all.sort_by_key(|c| (c.kind, c.name));
    all
}

/// Every linked component as Markdown: a section per kind, each component with its provider,
/// summary and example TOML block (what `experiments list` prints).
pub fn catalogue() -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let mut last = None;
    for c in components() {
        if last != Some(c.kind) {
            let _ = writeln!(s, "## {:?} — `[{}]`\n", c.kind, c.kind.table());
            last = Some(c.kind);
        }
        let _ = writeln!(s, "### `{}` ({})\n{}\n", c.name, c.provider, c.summary);
        let _ = writeln!(s, "```toml\n[{}]\n{}\n```\n", c.kind.table(), c.example);
    }
    s
}
