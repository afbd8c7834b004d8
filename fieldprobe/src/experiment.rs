//! Experiment files: one TOML file describes a run (data, model, probing components, training,
//! evaluation). Every table rejects unknown keys, and every error names the file.
//!
//! ```toml
//! name = "quickstart"
//! seed = 0
//! backend = "auto"          # auto | wgpu | flex
//!
//! [data]
//! dir = "datasets/quickstart"    # relative to the working directory
//! categories = ["chair", "table"]
//! generate = { train = 48, val = 0, test = 8, seed = 0 }   # made on first run if missing
//!
//! [model]
//! type = "single_view"       # or "per_object", "sdf", any registered representation
//!
//! [probe]
//! anchors = 2048
//! rays_per_view = 256
//! views = 8
//! radius = 0.03
//! assignment = "naive"       # or "boundary_aware"
//! ray_sampler = { type = "uniform" }
//! anchor_sampler = { type = "uniform" }
//! # aggregator = { type = "max" }                  # the default (paper eq. 1)
//! # march = { type = "stratified", samples = 32 }  # dense ray marching instead of anchors
//! # assign_on = "device"                           # assignment on the GPU instead of the CPU
//!
//! [train]
//! steps = 1000
//! ```

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use fieldprobe_backends::BackendChoice;
use fieldprobe_core::data::Category;
use fieldprobe_core::data::dataset::Split;
use fieldprobe_core::eval::occupancy::{MaxPoolPath, VoxelProtocol};
use fieldprobe_core::extract::ExtractOptions;
use fieldprobe_core::field::FieldModelConfig;
use fieldprobe_core::probe::{
    AggregatorConfig, AnchorSamplerConfig, MaxPool, ProbeSpec, RayMarcherConfig, RaySamplerConfig,
};
use fieldprobe_core::regularize::RegularizerConfig;
use fieldprobe_core::train::{Components, TrainSpec};
use fieldprobe_models::SingleViewConfig;
use serde::{Deserialize, Serialize};

use crate::overrides::Overrides;

/// A whole experiment file.
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Experiment {
    /// Names the run directory (`runs/<name>/`).
    pub name: String,
    /// Seeds weights, sampling and batch order.
    #[serde(default)]
    pub seed: u64,
    /// `auto` (wgpu on a hardware GPU, else flex), `wgpu` or `flex`.
    #[serde(default)]
    pub backend: BackendChoice,
    pub data: DataConfig,
    /// `[model]`: the representation (default: the paper's single-view model).
    #[serde(default = "single_view")]
    pub model: Box<dyn FieldModelConfig>,
    pub probe: ProbeConfig,
    /// `[regularizers.<name>]` tables: the terms added to the silhouette loss, each under a name
    /// of the file's choosing (`[regularizers.normals] type = "normal_consistency"`). None by
    /// default: no table is the paper's "no regularizer", and the loss is `L_sil` alone.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub regularizers: BTreeMap<String, Box<dyn RegularizerConfig>>,
    pub train: TrainSpec,
    #[serde(default)]
    pub eval: EvalConfig,
}

fn single_view() -> Box<dyn FieldModelConfig> {
    Box::new(SingleViewConfig::default())
}

fn max_pool() -> Box<dyn AggregatorConfig> {
    Box::new(MaxPool {})
}

/// Where the data come from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DataConfig {
    /// Dataset directory (Kato npz layout or DVR folders).
    pub dir: PathBuf,
    /// Categories to train and evaluate on.
    pub categories: Vec<Category>,
    /// If set and the dataset is missing, generate procedural objects into `dir` first.
    #[serde(default)]
    pub generate: Option<GenerateConfig>,
    /// Split to evaluate on.
    #[serde(default = "test_split")]
    pub eval_split: Split,
    /// Use at most this many training objects per category.
    #[serde(default)]
    pub max_train_objects: Option<usize>,
    /// Evaluate at most this many objects per category.
    #[serde(default)]
    pub max_eval_objects: Option<usize>,
    /// Per-object fits: the index (in `eval_split`) of the object to fit.
    #[serde(default)]
    pub object: Option<usize>,
}

fn test_split() -> Split {
    Split::Test
}

/// Procedural generation on first run.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GenerateConfig {
    pub train: usize,
    #[serde(default)]
    pub val: usize,
    pub test: usize,
    #[serde(default)]
    pub seed: u64,
}

/// The `[probe]` table: how many anchors and rays and how they are assigned (core's
/// [`ProbeSpec`], whose keys sit directly in the table), and the components that sample and
/// aggregate them.
///
/// One table, two types: the spec is what the probing code reads, the components are built into
/// runtime objects. Deserialized through a TOML table so that both keep rejecting unknown keys
/// (serde's `flatten` cannot do that).
#[derive(Debug, Serialize, Deserialize)]
#[serde(try_from = "toml::Table")]
pub struct ProbeConfig {
    #[serde(flatten)]
    pub spec: ProbeSpec,
    pub ray_sampler: Box<dyn RaySamplerConfig>,
    pub anchor_sampler: Box<dyn AnchorSamplerConfig>,
    pub aggregator: Box<dyn AggregatorConfig>,
    /// Dense ray marching instead of field probing (`march = { type = "stratified", samples =
    /// 32 }`): the baseline the paper compares against. `probe.anchors` and the anchor sampler
    /// then give only the points regularizers see; `radius` and `assignment` are the probing's
    /// and are not read.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub march: Option<Box<dyn RayMarcherConfig>>,
    /// Where the ray–anchor assignment runs: `"cpu"` (default: binned, on the prefetch worker)
    /// or `"device"` (tensor kernels on the training device, the same pairs; for GPU runs,
    /// where the CPU's assignment costs more than the step).
    #[serde(default, skip_serializing_if = "AssignOn::is_cpu")]
    pub assign_on: AssignOn,
}

/// `probe.assign_on`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AssignOn {
    #[default]
    Cpu,
    Device,
}

impl AssignOn {
    fn is_cpu(&self) -> bool {
        *self == Self::Cpu
    }
}

impl TryFrom<toml::Table> for ProbeConfig {
    type Error = String;

    fn try_from(mut table: toml::Table) -> std::result::Result<Self, String> {
        fn component<T: serde::de::DeserializeOwned>(
            table: &mut toml::Table,
            key: &str,
        ) -> std::result::Result<Option<T>, String> {
            table
                .remove(key)
                .map(|v| v.try_into().map_err(|e| format!("probe.{key}: {e}")))
                .transpose()
        }
        let missing = |key: &str| format!("probe: missing field `{key}`");
        let ray_sampler =
            component(&mut table, "ray_sampler")?.ok_or_else(|| missing("ray_sampler"))?;
        let anchor_sampler =
            component(&mut table, "anchor_sampler")?.ok_or_else(|| missing("anchor_sampler"))?;
        let aggregator = component(&mut table, "aggregator")?.unwrap_or_else(max_pool);
        let march = component(&mut table, "march")?;
        let assign_on = component(&mut table, "assign_on")?.unwrap_or_default();
        let spec = toml::Value::Table(table)
            .try_into()
            .map_err(|e| format!("probe: {e}"))?;
        Ok(Self {
            spec,
            ray_sampler,
            anchor_sampler,
            aggregator,
            march,
            assign_on,
        })
    }
}

fn all_views() -> usize {
    24
}

/// Evaluation settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EvalConfig {
    /// Voxel grid resolution (NMR protocol: 32).
    #[serde(default = "res32")]
    pub resolution: usize,
    /// Input views per test object (NMR protocol: all 24).
    #[serde(default = "all_views")]
    pub views: usize,
    /// Lattice cells per voxel and axis of the max-pool protocol: a voxel is occupied when φ
    /// reaches ½ at any of the `(subsamples + 1)³` lattice points of its closed cell (default 4:
    /// 128³ max-pooled to 32³; see README "Evaluation" for what 8 changes).
    #[serde(default = "subsamples")]
    pub subsamples: usize,
    /// `"refined"` (default): the lattice only where φ at the voxel centres leaves a voxel open,
    /// for fields smooth at voxel scale (trained ones); `"dense"`: the whole lattice, the
    /// definition, for any field (65× the centre test at 4).
    #[serde(default)]
    pub maxpool: MaxPoolPath,
    /// Samples per ray when rendering a field's silhouettes (per-object fits, the gallery).
    #[serde(default = "silhouette_samples")]
    pub silhouette_samples: usize,
    /// Input views per test object whose predictions are turned into meshes for the mesh
    /// metrics (evenly spaced among the evaluated views, all of them if there are fewer; 0 turns
    /// mesh metrics off). Extraction costs a few grid evaluations per mesh, so by default a
    /// subset: 4.
    #[serde(default = "mesh_views")]
    pub mesh_views: usize,
    /// How meshes are extracted (`[eval.extract]`: resolution, refinements, threshold, …;
    /// default 64³ with one MISE refinement at ½, Occupancy Networks' final 128³ from a coarse
    /// grid that does not lose parts thinner than 1/31 of the cube).
    #[serde(default)]
    pub extract: ExtractOptions,
    /// Points sampled on each surface for Chamfer-L1, F-score and normal consistency (default
    /// 100 000, Occupancy Networks'). Both surfaces are point samples, so the metrics have a
    /// floor of about half the sample spacing: a perfect prediction of a procedural table scores
    /// F@1% 0.66 and Chamfer-L1 0.0087 at 10 000 points, 0.9999 and 0.0037 at 100 000
    /// (`tests/tests/solids.rs`).
    #[serde(default = "surface_points")]
    pub surface_points: usize,
    /// F-score distance threshold, in units of the object's largest extent (default 0.01).
    #[serde(default = "fscore_threshold")]
    pub fscore_threshold: f32,
    /// Test objects per category shown in `gallery.png` (0: no gallery).
    #[serde(default = "gallery_objects")]
    pub gallery_objects: usize,
    /// Keep every extracted test mesh in the run directory, as
    /// `meshes/<synset>/<id>_v<view>.ply` (`<id>.ply` for a per-object fit), to open in
    /// MeshLab or trimesh or to score with other tools (default true; about 50–150 kB each).
    #[serde(default = "yes")]
    pub save_meshes: bool,
    /// Training objects per category that the category mean shape and the mean ground-truth
    /// shape are built from (default 256), evenly spaced by index; 0 uses all of them. Each
    /// object's 24-view hull on the max-pool lattice costs about 0.27 s on 2 cores, so at Kato's
    /// size (~1000 training objects per category) all of them would add ~27 minutes to every
    /// evaluation for a reference whose mean barely moves past a few hundred shapes.
    #[serde(default = "reference_objects")]
    pub reference_objects: usize,
}

fn yes() -> bool {
    true
}

impl EvalConfig {
    /// The grid and the field-to-voxels conversion these settings ask for.
    pub fn protocol(&self) -> VoxelProtocol {
        VoxelProtocol {
            resolution: self.resolution,
            subsamples: self.subsamples,
            path: self.maxpool,
        }
    }
}

fn subsamples() -> usize {
    fieldprobe_core::eval::occupancy::DEFAULT_SUBSAMPLES
}

fn mesh_views() -> usize {
    4
}

fn surface_points() -> usize {
    100_000
}

fn fscore_threshold() -> f32 {
    0.01
}

fn gallery_objects() -> usize {
    2
}

fn reference_objects() -> usize {
    256
}

fn res32() -> usize {
    32
}

fn silhouette_samples() -> usize {
    96
}

impl Default for EvalConfig {
    fn default() -> Self {
        Self {
            resolution: res32(),
            views: all_views(),
            subsamples: subsamples(),
            maxpool: MaxPoolPath::default(),
            silhouette_samples: silhouette_samples(),
            mesh_views: mesh_views(),
            extract: ExtractOptions::default(),
            surface_points: surface_points(),
            fscore_threshold: fscore_threshold(),
            gallery_objects: gallery_objects(),
            save_meshes: yes(),
            reference_objects: reference_objects(),
        }
    }
}

impl Experiment {
    /// Reads and validates an experiment file.
    pub fn load(path: &Path) -> Result<Self> {
        Self::load_with(path, &Overrides::default())
    }

    /// Reads an experiment file, applies `--set` overrides and validates the result; errors
    /// name the file (and say when overrides were applied).
    pub fn load_with(path: &Path, overrides: &Overrides) -> Result<Self> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read experiment file {}", path.display()))?;
        let file = path.display();
        let exp: Experiment = if overrides.is_empty() {
            // Straight from the text: errors point at a line and column of the file.
            toml::from_str(&text).map_err(|e| {
                let hint = toml::from_str::<toml::Table>(&text)
                    .ok()
                    .and_then(|t| renamed_key_hint(&t));
                anyhow::anyhow!("{file}: {}", hint.unwrap_or_else(|| e.to_string()))
            })?
        } else {
            let mut doc: toml::Table =
                toml::from_str(&text).map_err(|e| anyhow::anyhow!("{file}: {e}"))?;
            overrides.apply(&mut doc);
            let hint = renamed_key_hint(&doc);
            toml::Value::Table(doc)
                .try_into()
                .map_err(|e: toml::de::Error| {
                    let e = hint.unwrap_or_else(|| e.to_string().trim().replace('\n', " "));
                    anyhow::anyhow!("{file} with --set {}: {e}", overrides.written().join(" "))
                })?
        };
        exp.validate().map_err(|e| anyhow::anyhow!("{file}: {e}"))?;
        Ok(exp)
    }

    /// Checks values the types cannot; errors name the key.
    pub fn validate(&self) -> std::result::Result<(), String> {
        if self.name.trim().is_empty() || self.name.contains(['/', '\\']) {
            return Err(format!(
                "name must be a plain non-empty name, got '{}'",
                self.name
            ));
        }
        if self.data.categories.is_empty() {
            return Err("data.categories must name at least one category".into());
        }
        self.model.validate()?;
        self.train.validate()?;
        self.probe.spec.validate()?;
        if !(2..=256).contains(&self.eval.resolution)
            || self.eval.views == 0
            || self.eval.views > 24
        {
            return Err("eval.resolution must be in 2..=256 and eval.views in 1..=24".into());
        }
        let e = &self.eval;
        if !(1..=16).contains(&e.subsamples) {
            return Err(format!(
                "eval.subsamples must be in 1..=16, got {}",
                e.subsamples
            ));
        }
        if e.mesh_views > 0 && e.surface_points == 0 {
            return Err("eval.surface_points must be positive when eval.mesh_views > 0".into());
        }
        if !(e.fscore_threshold > 0.0 && e.fscore_threshold.is_finite()) {
            return Err(format!(
                "eval.fscore_threshold must be positive, got {}",
                e.fscore_threshold
            ));
        }
        e.extract
            .validate()
            .map_err(|err| format!("eval.extract: {err}"))?;
        if !self.model.uses_image() && self.data.object.is_none() {
            return Err(
                "a per-object model (one that reads no image) needs data.object (the index of \
                 the object to fit)"
                    .into(),
            );
        }
        for (name, r) in &self.regularizers {
            r.check_model(self.model.as_ref())
                .map_err(|e| format!("regularizers.{name}: {e}"))?;
        }
        self.components()?;
        Ok(())
    }

    /// [`components`](Self::components) for training on `device`: with `probe.assign_on =
    /// "device"`, assignment runs there.
    pub fn components_on(
        &self,
        device: &burn::prelude::Device,
    ) -> std::result::Result<Components, String> {
        let mut comps = self.components()?;
        if self.probe.assign_on == AssignOn::Device {
            comps.assign_device = Some(device.clone());
        }
        Ok(comps)
    }

    /// Builds the pluggable components (validating their settings).
    pub fn components(&self) -> std::result::Result<Components, String> {
        let regularizers = self
            .regularizers
            .iter()
            .map(|(name, r)| r.build().map_err(|e| format!("regularizers.{name}: {e}")))
            .collect::<std::result::Result<_, _>>()?;
        Ok(Components {
            ray_sampler: self
                .probe
                .ray_sampler
                .build()
                .map_err(|e| format!("probe.{e}"))?,
            anchor_sampler: self
                .probe
                .anchor_sampler
                .build()
                .map_err(|e| format!("probe.{e}"))?,
            aggregator: self
                .probe
                .aggregator
                .build()
                .map_err(|e| format!("probe.aggregator: {e}"))?,
            march: self
                .probe
                .march
                .as_ref()
                .map(|m| m.build().map_err(|e| format!("probe.march: {e}")))
                .transpose()?,
            assign_device: None,
            regularizers,
        })
    }

    /// The resolved configuration as TOML (what the run directory records).
    pub fn to_toml(&self) -> Result<String> {
        toml::to_string_pretty(self).context("cannot serialize the resolved experiment")
    }

    /// The resolved configuration less what does not change the trained weights: the run's
    /// `name`, the `[eval]` table, `data.eval_split`, and `train.checkpoint_every` and
    /// `train.prefetch` (when checkpoints are written, and how far probing runs ahead of the
    /// optimizer: the prefetched loop is bit-identical to the serial one, `tests/training.rs`).
    /// Two experiments with equal training tables train the same weights from their seed, so a
    /// finished run can be evaluated again under other `[eval]` settings, or taken over by
    /// another file's entry, instead of retrained (the ablation's `--resume` does both).
    pub fn training_table(&self) -> Result<toml::Table> {
        Ok(self.split_tables()?.0)
    }

    /// What [`Experiment::training_table`] leaves out and the evaluation reads: `[eval]` and
    /// `data.eval_split`. Runs with equal training and evaluation tables have the same metrics.
    pub fn eval_table(&self) -> Result<toml::Table> {
        Ok(self.split_tables()?.1)
    }

    /// The resolved configuration as (training table, evaluation table).
    fn split_tables(&self) -> Result<(toml::Table, toml::Table)> {
        let mut table =
            toml::Table::try_from(self).context("cannot serialize the resolved experiment")?;
        table.remove("name");
        let mut eval = toml::Table::new();
        if let Some(e) = table.remove("eval") {
            eval.insert("eval".into(), e);
        }
        if let Some(toml::Value::Table(data)) = table.get_mut("data")
            && let Some(split) = data.remove("eval_split")
        {
            eval.insert("eval_split".into(), split);
        }
        if let Some(toml::Value::Table(train)) = table.get_mut("train") {
            train.remove("checkpoint_every");
            train.remove("prefetch");
        }
        Ok((table, eval))
    }
}

/// What to write instead of a key that earlier versions of the experiment format had, if `table`
/// has one; the plain "unknown field" error would not say.
pub fn renamed_key_hint(table: &toml::Table) -> Option<String> {
    table.contains_key("regularizer").then(|| {
        "the `[regularizer]` table is now `[regularizers.<name>]`, one table per term under a \
         name of your choice (e.g. `[regularizers.normals]` with `type = \"normal_consistency\"`); \
         no regularizer is no such table (in a variant: `regularizers = {}`)"
            .to_string()
    })
}

/// Loads an experiment or explains that a TOML path was expected.
pub fn load_experiment(path: &Path) -> Result<Experiment> {
    load_experiment_with(path, &Overrides::default())
}

/// [`load_experiment`] with `--set` overrides.
pub fn load_experiment_with(path: &Path, overrides: &Overrides) -> Result<Experiment> {
    if path.extension().is_none_or(|e| e != "toml") {
        bail!("{}: expected an experiment .toml file", path.display());
    }
    Experiment::load_with(path, overrides)
}
