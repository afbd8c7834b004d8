//! Ablation files: an experiment (the *base*) plus `[[variants]]`, each overriding a few keys of
//! the base. Ablations are base plus deltas, never copied files.
//!
//! ```toml
//! name = "ablation-regularizer"
//! base_name = "p=0.8"              # the base's row name (default "base")
//! base_paper_iou = 0.548           # the paper's number for the base's row (optional)
//! paper_table = "Table 2, chair"   # where the paper's numbers come from (optional)
//! against = "no regularizer"       # the row the report's paired differences subtract (default: the base)
//! # ... the base: [data], [model], [probe], [regularizers.*], [train], [eval] as in any experiment
//!
//! [[variants]]
//! name = "p=1.0"                   # required, a plain name (it also names the run sub-directory)
//! paper_iou = 0.524                # optional
//! regularizers.normals = { p = 1.0 }
//!
//! [[variants]]
//! name = "no regularizer"
//! regularizers = {}                # an empty table replaces: no regularizer at all
//!
//! [[variants]]
//! name = "normal sampling"
//! probe = { ray_sampler = { type = "normal" }, anchor_sampler = { type = "normal" } }
//! ```
//!
//! A variant is resolved by deep-merging its keys (all but `name` and `paper_iou`) into the base's
//! TOML, then reading the merged document as an [`Experiment`] (so unknown keys are errors, named
//! with the file and the variant). Merge rules ([`crate::layers::merge`]):
//!
//! * a table merges into the base's table key by key, recursively;
//! * **a table whose `type` differs from the base table's `type` replaces it entirely** (a
//!   component switch must not inherit the old component's fields; the new component's defaults
//!   apply). A table with the *same* `type` as the base's merges like any other table, so
//!   `regularizers.normals = { type = "normal_consistency", p = 1.0 }` over a
//!   `normal_consistency` base keeps the base's `weight`, `delta`, `max_anchors`;
//! * **an empty table replaces the base's table** (merged, it would change nothing, so it can
//!   only mean "none of these"): `regularizers = {}` is the run without regularizers;
//! * anything else (numbers, strings, arrays) replaces the base's value.
//!
//! The base is the first entry, named by `base_name`. The reserved top-level keys (`variants`,
//! `base_name`, `base_paper_iou`, `paper_table`, `seeds`, `against`) are stripped before the base
//! is read, so [`Experiment`] itself knows nothing of variants.
//!
//! `against` names the row that the report's paired differences are taken from. The base is the
//! row every variant is a delta of, which is not always the row a reader compares with: a λ sweep
//! keeps the paper's λ as its base (so that it trains exactly as the ablations' bases) but asks
//! whether each λ changes what is learned against no regularizer at all.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, anyhow, bail};
use toml::{Table, Value};

use crate::experiment::{Experiment, renamed_key_hint};
use crate::layers::merge;
use crate::overrides::Overrides;

/// Top-level keys of an ablation file that are not experiment keys.
pub const RESERVED_TOP: [&str; 6] = [
    "variants",
    "base_name",
    "base_paper_iou",
    "paper_table",
    "seeds",
    "against",
];
/// Keys of a `[[variants]]` entry that are not overrides.
pub const RESERVED_VARIANT: [&str; 2] = ["name", "paper_iou"];

/// One entry of an ablation: the base or a variant, resolved.
#[derive(Debug)]
pub struct Variant {
    /// The row name (`base_name` for the base).
    pub name: String,
    /// The run sub-directory name ([`slug`] of `name`).
    pub slug: String,
    /// The paper's 3D IoU for this row, if given.
    pub paper_iou: Option<f32>,
    /// The overrides as written, one `key = value` per key (empty for the base).
    pub overrides: Vec<String>,
    /// The resolved experiment; its `name` is `<file name>-<slug>`.
    pub experiment: Experiment,
}

/// A parsed ablation file: the base first, then the variants in file order.
#[derive(Debug)]
pub struct AblationFile {
    pub path: PathBuf,
    /// The file's `name` (names `runs/<name>/`).
    pub name: String,
    /// Where the paper's numbers come from (`paper_table`).
    pub paper_table: Option<String>,
    /// Training seeds each entry runs with (`seeds = [0, 1]`): every entry is trained once per
    /// seed into `<slug>/seed-<s>/` and reported as the mean over seeds × evaluation objects.
    /// Empty: one run per entry with the file's `seed`, in `<slug>/`.
    pub seeds: Vec<u64>,
    pub entries: Vec<Variant>,
    /// The index in `entries` of the row the report's paired differences subtract (`against`;
    /// 0, the base, by default).
    pub against: usize,
}

impl AblationFile {
    /// The seeds each entry is trained with (the file's `seed` when `seeds` is not given).
    pub fn run_seeds(&self) -> Vec<u64> {
        if self.seeds.is_empty() {
            vec![self.base().experiment.seed]
        } else {
            self.seeds.clone()
        }
    }

    /// The run directory of `entry` with `seed` under the ablation directory `root`.
    pub fn run_dir(&self, root: &Path, entry: &Variant, seed: u64) -> PathBuf {
        if self.seeds.is_empty() {
            root.join(&entry.slug)
        } else {
            root.join(&entry.slug).join(format!("seed-{seed}"))
        }
    }

    /// The base (first entry).
    pub fn base(&self) -> &Variant {
        &self.entries[0]
    }

    /// Reads and resolves an ablation file; errors name the file (and the variant).
    pub fn load(path: &Path) -> Result<Self> {
        Self::load_with(path, &Overrides::default())
    }

    /// [`AblationFile::load`] with `--set` overrides applied to every entry, last.
    pub fn load_with(path: &Path, overrides: &Overrides) -> Result<Self> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read experiment file {}", path.display()))?;
        Self::parse_with(&text, path, overrides)
    }

    /// Resolves the text of an ablation file (`path` only names it in errors).
    pub fn parse(text: &str, path: &Path) -> Result<Self> {
        Self::parse_with(text, path, &Overrides::default())
    }

    /// [`AblationFile::parse`] with `--set` overrides applied to every entry, last.
    pub fn parse_with(text: &str, path: &Path, overrides: &Overrides) -> Result<Self> {
        let file = path.display();
        let mut top: Table = toml::from_str(text).map_err(|e| anyhow!("{file}: {e}"))?;
        let variants = match top.remove("variants") {
            Some(Value::Array(a)) if !a.is_empty() => a,
            Some(Value::Array(_)) => bail!("{file}: `variants` is empty"),
            Some(_) => bail!("{file}: `variants` must be an array of tables ([[variants]])"),
            None => bail!("{file}: no [[variants]]; this is a plain experiment file"),
        };
        let base_name = match top.remove("base_name") {
            None => "base".to_string(),
            Some(Value::String(s)) => s,
            Some(v) => bail!("{file}: base_name must be a string, got {}", v.type_str()),
        };
        let base_paper = top
            .remove("base_paper_iou")
            .map(|v| number(&v).ok_or_else(|| anyhow!("{file}: base_paper_iou must be a number")))
            .transpose()?;
        let paper_table = match top.remove("paper_table") {
            None => None,
            Some(Value::String(s)) => Some(s),
            Some(_) => bail!("{file}: paper_table must be a string"),
        };
        let seeds = match top.remove("seeds") {
            None => Vec::new(),
            Some(Value::Array(a)) => {
                let seeds: Vec<u64> = a
                    .iter()
                    .map(|v| match v {
                        Value::Integer(i) if *i >= 0 => Ok(*i as u64),
                        _ => Err(anyhow!("{file}: seeds must be non-negative integers")),
                    })
                    .collect::<Result<_>>()?;
                let mut unique = seeds.clone();
                unique.sort_unstable();
                unique.dedup();
                if seeds.is_empty() || unique.len() != seeds.len() {
                    bail!("{file}: seeds must be a non-empty list of distinct integers");
                }
                seeds
            }
            Some(_) => bail!("{file}: seeds must be a list of integers, e.g. seeds = [0, 1]"),
        };
        let against = match top.remove("against") {
            None => None,
            Some(Value::String(s)) => Some(s),
            Some(v) => bail!(
                "{file}: against must be a string (an entry's name), got {}",
                v.type_str()
            ),
        };
        let name = match top.get("name") {
            Some(Value::String(s)) => s.clone(),
            _ => bail!("{file}: name must be a string (it names the run directory)"),
        };

        let mut entries = vec![resolve(
            &top,
            &Table::new(),
            overrides,
            &name,
            (&base_name, base_paper),
            path,
            "the base",
        )?];
        for (i, v) in variants.into_iter().enumerate() {
            let Value::Table(mut v) = v else {
                bail!("{file}: variants[{i}] must be a table");
            };
            let vname = match v.remove("name") {
                Some(Value::String(s)) => s,
                Some(_) => bail!("{file}: variants[{i}].name must be a string"),
                None => bail!("{file}: variants[{i}] has no name"),
            };
            let paper = v
                .remove("paper_iou")
                .map(|p| {
                    number(&p).ok_or_else(|| {
                        anyhow!("{file}: variant '{vname}': paper_iou must be a number")
                    })
                })
                .transpose()?;
            if v.is_empty() {
                bail!("{file}: variant '{vname}' overrides no keys");
            }
            let what = format!("variant '{vname}'");
            entries.push(resolve(
                &top,
                &v,
                overrides,
                &name,
                (&vname, paper),
                path,
                &what,
            )?);
        }
        for (i, a) in entries.iter().enumerate() {
            for b in &entries[..i] {
                if a.name == b.name || a.slug == b.slug {
                    bail!(
                        "{file}: variants '{}' and '{}' need different names (run directories '{}' and '{}')",
                        b.name,
                        a.name,
                        b.slug,
                        a.slug
                    );
                }
            }
        }
        let against = match against {
            None => 0,
            Some(a) => entries.iter().position(|e| e.name == a).ok_or_else(|| {
                anyhow!(
                    "{file}: against = \"{a}\" names no entry (entries: {})",
                    entry_names(&entries)
                )
            })?,
        };
        Ok(Self {
            path: path.to_path_buf(),
            name,
            paper_table,
            seeds,
            entries,
            against,
        })
    }
}

/// The entries' names, comma-separated: what an error about a name that matches no entry lists.
pub fn entry_names(entries: &[Variant]) -> String {
    entries
        .iter()
        .map(|e| e.name.as_str())
        .collect::<Vec<_>>()
        .join(", ")
}

/// Whether `path` is a TOML file with a `variants` key (an ablation file). Unreadable or invalid
/// files are not: the plain experiment loader reports those.
pub fn has_variants(path: &Path) -> bool {
    path.extension().is_some_and(|e| e == "toml")
        && std::fs::read_to_string(path)
            .ok()
            .and_then(|t| toml::from_str::<Table>(&t).ok())
            .is_some_and(|t| t.contains_key("variants"))
}

fn number(v: &Value) -> Option<f32> {
    match v {
        Value::Float(f) => Some(*f as f32),
        Value::Integer(i) => Some(*i as f32),
        _ => None,
    }
}

/// The run sub-directory name of a variant: lowercase ASCII letters, digits, `.`, `_` and `-`;
/// every other run of characters becomes one `-` (`"p=1.0"` → `p-1.0`, `"normal sampling"` →
/// `normal-sampling`).
pub fn slug(name: &str) -> String {
    let mut s = String::new();
    for c in name.chars() {
        let c = c.to_ascii_lowercase();
        if c.is_ascii_alphanumeric() || matches!(c, '.' | '_') {
            s.push(c);
        } else if !s.ends_with('-') {
            s.push('-');
        }
    }
    s.trim_matches('-').to_string()
}

/// The entry `over` of an ablation file: the base with the entry's keys merged in, then the
/// command line's `overrides`; `(name, paper_iou)` of the entry.
fn resolve(
    base: &Table,
    over: &Table,
    overrides: &Overrides,
    file_name: &str,
    (name, paper_iou): (&str, Option<f32>),
    path: &Path,
    what: &str,
) -> Result<Variant> {
    let file = path.display();
    let slug = slug(name);
    if name.trim().is_empty() || name.contains(['/', '\\']) || slug.is_empty() {
        bail!(
            "{file}: {what}: the name must be a plain non-empty name with a letter or digit, got '{name}'"
        );
    }
    let mut merged = base.clone();
    merge(&mut merged, over);
    overrides.apply(&mut merged);
    merged.insert("name".into(), Value::String(format!("{file_name}-{slug}")));
    let hint = renamed_key_hint(&merged);
    let experiment: Experiment = Value::Table(merged).try_into().map_err(|e| {
        let e = hint.unwrap_or_else(|| one_line(&e.to_string()));
        anyhow!("{file}: {what}: {e}")
    })?;
    experiment
        .validate()
        .map_err(|e| anyhow!("{file}: {what}: {e}"))?;
    Ok(Variant {
        name: name.to_string(),
        slug,
        paper_iou,
        overrides: over
            .iter()
            .map(|(k, v)| format!("{} = {}", key(k), inline(v)))
            .collect(),
        experiment,
    })
}

/// A TOML value on one line, tables inline with their `type` first (then the other keys in
/// sorted order): `{ type = "normal_consistency", p = 2.0 }`.
pub fn inline(v: &Value) -> String {
    match v {
        Value::Table(t) if t.is_empty() => "{}".into(),
        Value::Table(t) => {
            let mut keys: Vec<&String> = t.keys().collect();
            keys.sort_by_key(|k| (k.as_str() != "type", k.as_str()));
            let body: Vec<String> = keys
                .iter()
                .map(|k| format!("{} = {}", key(k), inline(&t[k.as_str()])))
                .collect();
            format!("{{ {} }}", body.join(", "))
        }
        Value::Array(a) => format!("[{}]", a.iter().map(inline).collect::<Vec<_>>().join(", ")),
        other => other.to_string(),
    }
}

/// A serializable value (e.g. a component config) as one line of TOML ([`inline`]); numbers are
/// written as their shortest round-trip form (an `f32` 0.007 stays `0.007`).
pub fn inline_of<T: serde::Serialize + ?Sized>(v: &T) -> String {
    serde_json::to_string(v)
        .ok()
        .and_then(|j| serde_json::from_str::<serde_json::Value>(&j).ok())
        .and_then(|j| Value::try_from(j).ok())
        .map_or_else(|| "?".into(), |t| inline(&t))
}

fn key(k: &str) -> String {
    if !k.is_empty()
        && k.chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
    {
        k.to_string()
    } else {
        Value::String(k.to_string()).to_string()
    }
}

fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    const BASE: &str = r#"
name = "abl"
base_name = "full model"
base_paper_iou = 0.548
paper_table = "Table 4, chair"
seed = 3

[data]
dir = "datasets/x"
categories = ["chair"]

[model]
type = "single_view"
latent = 8
encoder = { channels = [4, 4], blocks = [1, 1] }
decoder = { hidden = [16] }

[probe]
anchors = 256
rays_per_view = 16
views = 2
assignment = "boundary_aware"
ray_sampler = { type = "importance", bandwidth = 0.01, uniform_fraction = 0.1 }
anchor_sampler = { type = "importance", resolution = 16 }

[regularizers.normals]
type = "normal_consistency"
p = 0.8
max_anchors = 64

[train]
steps = 3
batch = 2
lr = 1e-3
"#;

    fn parse(variants: &str) -> Result<AblationFile> {
        AblationFile::parse(
            &format!("{BASE}\n{variants}"),
            Path::new("ablations/x.toml"),
        )
    }

    fn toml_of<T: serde::Serialize + ?Sized>(v: &T) -> String {
        serde_json::to_string(v).unwrap()
    }

    #[test]
    fn base_comes_first_and_variants_keep_the_base_settings() {
        let f = parse(
            r#"
[[variants]]
name = "normal sampling"
paper_iou = 0.482
probe = { ray_sampler = { type = "normal" }, anchor_sampler = { type = "normal" } }

[[variants]]
name = "p=2.0"
regularizers.normals = { type = "normal_consistency", p = 2.0 }

[[variants]]
name = "no regularizer"
regularizers = {}
"#,
        )
        .unwrap();
        let names: Vec<_> = f.entries.iter().map(|e| e.name.as_str()).collect();
        assert_eq!(
            names,
            ["full model", "normal sampling", "p=2.0", "no regularizer"]
        );
        let slugs: Vec<_> = f.entries.iter().map(|e| e.slug.as_str()).collect();
        assert_eq!(
            slugs,
            ["full-model", "normal-sampling", "p-2.0", "no-regularizer"]
        );
        assert_eq!(f.name, "abl");
        assert_eq!(f.paper_table.as_deref(), Some("Table 4, chair"));
        assert_eq!(f.base().paper_iou, Some(0.548));
        assert_eq!(f.entries[1].paper_iou, Some(0.482));
        assert_eq!(f.entries[2].paper_iou, None);
        assert!(f.base().overrides.is_empty());
        assert_eq!(f.entries[3].overrides, ["regularizers = {}"]);

        let base = &f.base().experiment;
        assert_eq!(base.name, "abl-full-model");
        for e in &f.entries[1..] {
            let x = &e.experiment;
            assert_eq!(x.name, format!("abl-{}", e.slug));
            assert_eq!(x.seed, 3);
            assert_eq!(x.data, base.data);
            assert_eq!(
                serde_json::to_string(&x.model).unwrap(),
                serde_json::to_string(&base.model).unwrap()
            );
            assert_eq!(x.train, base.train);
            assert_eq!(x.eval, base.eval);
            assert_eq!(x.probe.spec.anchors, 256);
            assert_eq!(x.probe.spec.assignment, base.probe.spec.assignment);
        }
        // The sampler switch replaces the importance tables: no importance fields are inherited.
        let normal = &f.entries[1].experiment.probe;
        assert_eq!(
            toml_of(&normal.ray_sampler),
            r#"{"type":"normal","sigma":0.4}"#
        );
        assert_eq!(
            toml_of(&normal.anchor_sampler),
            r#"{"type":"normal","sigma":0.4}"#
        );
        assert_eq!(
            toml_of(&f.entries[2].experiment.probe.ray_sampler),
            toml_of(&base.probe.ray_sampler)
        );
        // Same component type: p changes, the base's other regularizer fields stay.
        let reg = toml_of(&f.entries[2].experiment.regularizers);
        assert!(
            reg.starts_with(r#"{"normals":{"#)
                && reg.contains(r#""p":2.0"#)
                && reg.contains(r#""max_anchors":64"#),
            "{reg}"
        );
        assert_eq!(base.regularizers.len(), 1);
        assert!(f.entries[3].experiment.regularizers.is_empty());
        assert!(
            f.entries[3]
                .experiment
                .components()
                .unwrap()
                .regularizers
                .is_empty()
        );
    }

    #[test]
    fn a_misspelled_key_names_the_file_the_variant_and_the_key() {
        for (variant, key) in [
            (
                "probe = { ray_sampler = { type = \"importance\", bandwidht = 0.01 } }",
                "bandwidht",
            ),
            ("regularizrs = {}", "regularizrs"),
            ("regularizers.normals = { pp = 2.0 }", "pp"),
            (
                "regularizers.normals = { type = \"none\" }",
                "unknown variant `none`",
            ),
            ("train = { stepz = 5 }", "stepz"),
            ("probe = { ray_sampler = { type = \"nromal\" } }", "nromal"),
        ] {
            let err = parse(&format!("[[variants]]\nname = \"v one\"\n{variant}\n"))
                .unwrap_err()
                .to_string();
            assert!(
                err.contains("ablations/x.toml")
                    && err.contains("variant 'v one'")
                    && err.contains(key),
                "{err}"
            );
        }
        // Values the types cannot check are validated per variant too.
        let err = parse("[[variants]]\nname = \"bad p\"\nregularizers.normals = { p = -1.0 }\n")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("variant 'bad p'") && err.contains("regularizers.normals: p must be"),
            "{err}"
        );
        // The table of earlier versions gets a hint, not only "unknown field".
        let err = parse("[[variants]]\nname = \"old\"\nregularizer = { p = 1.0 }\n")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("variant 'old'") && err.contains("[regularizers.<name>]"),
            "{err}"
        );
    }

    /// `against` picks the row the report subtracts: the base by default, or a named variant; a
    /// name that is no entry is an error listing the entries.
    #[test]
    fn against_names_an_entry_or_defaults_to_the_base() {
        let variants = "[[variants]]\nname = \"none\"\nseed = 1\n";
        assert_eq!(parse(variants).unwrap().against, 0);
        let with = |against: &str| {
            AblationFile::parse(
                &format!("against = {against}\n{BASE}\n{variants}"),
                Path::new("ablations/x.toml"),
            )
        };
        assert_eq!(with("\"none\"").unwrap().against, 1);
        assert_eq!(with("\"full model\"").unwrap().against, 0);
        let err = with("\"nothing\"").unwrap_err().to_string();
        assert!(
            err.contains("x.toml")
                && err.contains("\"nothing\"")
                && err.contains("full model, none"),
            "{err}"
        );
        let err = with("1").unwrap_err().to_string();
        assert!(err.contains("against must be a string"), "{err}");
    }

    #[test]
    fn names_are_required_plain_and_distinct() {
        let cases = [
            ("[[variants]]\nseed = 1\n", "has no name"),
            ("[[variants]]\nname = \"a/b\"\nseed = 1\n", "plain"),
            ("[[variants]]\nname = \"==\"\nseed = 1\n", "plain"),
            ("[[variants]]\nname = \"x\"\n", "overrides no keys"),
            (
                "[[variants]]\nname = \"P 1\"\nseed = 1\n[[variants]]\nname = \"p=1\"\nseed = 2\n",
                "different names",
            ),
            (
                "[[variants]]\nname = \"Full Model\"\nseed = 1\n",
                "different names",
            ),
            (
                "[[variants]]\nname = \"x\"\npaper_iou = \"high\"\nseed = 1\n",
                "paper_iou",
            ),
        ];
        for (text, needle) in cases {
            let err = parse(text).unwrap_err().to_string();
            assert!(
                err.contains(needle) && err.contains("x.toml"),
                "{text}: {err}"
            );
        }
        let err = AblationFile::parse(&format!("variants = []\n{BASE}"), Path::new("x.toml"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("x.toml: `variants` is empty"), "{err}");
        assert_eq!(slug("Δd = 0.01"), "d-0.01");
        let v: Table =
            toml::from_str("t = { z = [1, 2.5], type = \"x\", \"a b\" = { k = \"s\" }, e = {} }")
                .unwrap();
        assert_eq!(
            inline(&v["t"]),
            r#"{ type = "x", "a b" = { k = "s" }, e = {}, z = [1, 2.5] }"#
        );
        let cfg: Box<dyn fieldprobe_core::probe::RaySamplerConfig> =
            toml::from_str("type = \"importance\"\nbandwidth = 0.007").unwrap();
        assert_eq!(
            inline_of(cfg.as_ref()),
            "{ type = \"importance\", bandwidth = 0.007, uniform_fraction = 0.0 }"
        );
        assert_eq!(slug("-Imp. sampling"), "imp.-sampling");
    }
}
