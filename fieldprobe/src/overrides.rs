//! `--set key=value`: changes to any key of an experiment file from the command line, the way
//! Hydra and nerfstudio users change a run without editing its file.
//!
//! Each `key=value` is a dotted TOML key and a TOML value (`train.steps=10`,
//! `probe.ray_sampler.type="normal"`, `data.categories=["chair"]`); a value that is not valid
//! TOML is taken as a string (`backend=flex`). The overrides are merged into the file with the
//! rules of ablation variants ([`crate::layers::merge`]: tables key by key, a new `type`
//! replaces the component, an empty table removes it), as the last layer: over the base of a
//! plain file, over every entry of an ablation. The resolved `config.toml` of a run records the
//! result, so a run stays reproducible from its directory alone.

use anyhow::{Result, bail};
use toml::{Table, Value};

use crate::layers::merge;

/// Parsed `--set` arguments: a TOML table to merge last.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Overrides {
    table: Table,
    /// As written, for messages.
    written: Vec<String>,
}

impl Overrides {
    /// Parses `key=value` arguments; an error names the argument.
    pub fn parse<S: AsRef<str>>(args: &[S]) -> Result<Self> {
        let mut out = Self::default();
        for arg in args {
            let arg = arg.as_ref();
            let Some((key, value)) = arg.split_once('=') else {
                bail!("--set {arg}: expected KEY=VALUE, e.g. --set train.steps=10");
            };
            let path: Vec<&str> = key.trim().split('.').map(str::trim).collect();
            if path.iter().any(|p| {
                p.is_empty()
                    || !p
                        .chars()
                        .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
            }) {
                bail!(
                    "--set {arg}: '{key}' is not a dotted key of plain names (e.g. probe.ray_sampler.type)"
                );
            }
            let value = parse_value(value.trim());
            let mut nested = value;
            for name in path.iter().rev() {
                let mut t = Table::new();
                t.insert((*name).to_string(), nested);
                nested = Value::Table(t);
            }
            let Value::Table(t) = nested else {
                unreachable!("a key has at least one part")
            };
            merge(&mut out.table, &t);
            out.written.push(arg.to_string());
        }
        Ok(out)
    }

    /// Whether there is nothing to override.
    pub fn is_empty(&self) -> bool {
        self.table.is_empty()
    }

    /// The arguments as written.
    pub fn written(&self) -> &[String] {
        &self.written
    }

    /// Merges the overrides into an experiment's TOML table.
    pub fn apply(&self, doc: &mut Table) {
        merge(doc, &self.table);
    }
}

/// A TOML value, or the text as a string when it is not one (`flex`, `runs/a b`).
fn parse_value(text: &str) -> Value {
    toml::from_str::<Table>(&format!("v = {text}"))
        .ok()
        .and_then(|mut t| t.remove("v"))
        .unwrap_or_else(|| Value::String(text.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dotted_keys_become_nested_tables_and_values_keep_their_toml_type() {
        let o = Overrides::parse(&[
            "train.steps=10",
            "train.lr = 1e-3",
            "backend=flex",
            "data.categories=[\"chair\", \"table\"]",
            "probe.ray_sampler.type=\"normal\"",
        ])
        .unwrap();
        let want: Table = toml::from_str(
            "backend = \"flex\"\n[train]\nsteps = 10\nlr = 1e-3\n[data]\ncategories = [\"chair\", \"table\"]\n[probe.ray_sampler]\ntype = \"normal\"",
        )
        .unwrap();
        assert_eq!(o.table, want);
        assert_eq!(o.written().len(), 5);
    }

    #[test]
    fn overrides_merge_like_variants() {
        let mut doc: Table = toml::from_str(
            "[train]\nsteps = 100\nbatch = 4\n[probe.ray_sampler]\ntype = \"importance\"\nbandwidth = 0.01\n[regularizers.normals]\ntype = \"normal_consistency\"\np = 0.8",
        )
        .unwrap();
        Overrides::parse(&[
            "train.steps=10",
            "probe.ray_sampler.type=normal",
            "regularizers={}",
        ])
        .unwrap()
        .apply(&mut doc);
        let want: Table = toml::from_str(
            "regularizers = {}\n[train]\nsteps = 10\nbatch = 4\n[probe.ray_sampler]\ntype = \"normal\"",
        )
        .unwrap();
        assert_eq!(doc, want);
    }

    #[test]
    fn malformed_arguments_are_named() {
        for (arg, what) in [
            ("train.steps", "KEY=VALUE"),
            ("=3", "dotted key"),
            ("train..steps=3", "dotted key"),
            ("train.st eps=3", "dotted key"),
        ] {
            let e = Overrides::parse(&[arg]).unwrap_err().to_string();
            assert!(e.contains(arg) && e.contains(what), "{arg}: {e}");
        }
    }
}
