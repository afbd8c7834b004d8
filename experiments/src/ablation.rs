//! Running an ablation file (an experiment with `[[variants]]`, see [`crate::variants`]): the base
//! and then each variant is trained and evaluated into its own run directory, and one comparison
//! is written beside them:
//!
//! ```text
//! runs/<name>/
//!   ablation.toml          the file as run
//!   <slug>/                one ordinary run directory per entry (config.toml, checkpoints/,
//!                          metrics.json, report.md), the base first
//!   ablation.json          the finished entries, base first (rewritten after each one)
//!   report.md              the comparison table, ordering vs the paper, pictures
//!   training_curves.png    the loss history of every finished entry
//!   samples.png            rays and anchors of the base's samplers vs a comparison sampler
//! ```
//!
//! All entries share the dataset (generated once, loaded once per distinct `[data]`). With
//! `--resume` an entry whose `metrics.json` exists is skipped, the one with a checkpoint continues,
//! and the rest start; without it, a directory already holding any entry is refused. An entry that
//! fails (e.g. a non-finite loss) is reported, the others still run, and the command exits with
//! an error at the end.
//!
//! # Ordering vs the paper
//!
//! The paper's numbers are ShapeNet IoUs at full scale; ours are CPU-scale runs on procedural
//! data, so only orderings are compared ([`compare`]). For each pair of finished entries with
//! paper numbers: the paper orders them by its IoUs (equal numbers: a paper tie, not counted); our
//! order is the sign of the difference of mean IoUs, and it counts as *resolved* only if that
//! difference exceeds twice the standard error of the paired per-object IoU differences (the
//! same evaluation objects under both entries) and at least [`MIN_RESOLVED_DIFF`]. A resolved
//! pair agrees or disagrees with the paper; an unresolved one is within noise and is reported as
//! such, with its sign. The noise bar covers the choice of evaluation objects only, not training
//! noise (another seed could reorder close rows), which the report says.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, anyhow, bail};
use fieldprobe_core::data::dataset::write_atomic;
use fieldprobe_core::probe::{AnchorSamplerConfig, RaySamplerConfig};
use fieldprobe_core::train::{checkpoint, step_rng};
use serde::{Deserialize, Serialize};
use tracing::{error, info};

use crate::data::{CategoryData, ensure_dataset, load};
use crate::evaluate::CategoryMetrics;
use crate::experiment::{DataConfig, Experiment};
use crate::plot;
use crate::run::{Metrics, RunArgs, prepare_dir, run_one};
use crate::variants::{AblationFile, Variant, inline_of};

/// One finished entry as `ablation.json` lists it: the mean over its seeds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AblationEntry {
    /// The entry's name (`base_name` for the base).
    pub variant: String,
    /// Its run directory, relative to the ablation directory.
    pub dir: String,
    /// The overrides of the base, `key = value` (empty for the base).
    pub overrides: Vec<String>,
    /// The paper's IoU for this row, if the file gives one.
    pub paper_iou: Option<f32>,
    /// Mean over seeds of the max-pool IoU (NMR protocol).
    pub mean_iou: f32,
    /// The training seeds, and the mean IoU of each.
    #[serde(default)]
    pub seeds: Vec<u64>,
    #[serde(default)]
    pub seed_ious: Vec<f32>,
    /// Per seed and evaluation object (`s<seed>/<category>/<id>`): its IoU.
    #[serde(default)]
    pub per_seed_object: BTreeMap<String, f32>,
    /// Means over seeds of the centre-sampled IoU, the share of volume outside the visual hull,
    /// and the mesh metrics (averaged over categories; absent without meshes).
    #[serde(default)]
    pub centre_iou: f32,
    #[serde(default)]
    pub outside_hull: f32,
    #[serde(default)]
    pub mesh_iou: Option<f32>,
    #[serde(default)]
    pub chamfer_l1: Option<f32>,
    #[serde(default)]
    pub normal_consistency: Option<f32>,
    /// The first seed's per-category metrics.
    pub per_category: BTreeMap<String, CategoryMetrics>,
    pub visual_hull_iou: f32,
    pub mean_shape_iou: Option<f32>,
    /// Summed over seeds.
    pub train_seconds: f64,
    pub eval_seconds: f64,
    pub steps: usize,
    /// Means over seeds of the last logged interval's loss and its terms.
    pub final_loss: Option<f32>,
    #[serde(default)]
    pub final_silhouette_loss: Option<f32>,
    #[serde(default)]
    pub final_regularizer_loss: Option<f32>,
    /// The first seed's training loss history: `(step, mean loss of the logged interval)`.
    pub loss_history: Vec<(usize, f32)>,
}

fn mean_f32(v: impl IntoIterator<Item = f32>) -> Option<f32> {
    let v: Vec<f32> = v.into_iter().collect();
    (!v.is_empty()).then(|| v.iter().sum::<f32>() / v.len() as f32)
}

/// The mean of a per-category mesh metric over the categories that have it.
fn mesh_mean(m: &Metrics, f: impl Fn(&crate::evaluate::MeshMetrics) -> Option<f32>) -> Option<f32> {
    mean_f32(
        m.per_category
            .values()
            .filter_map(|c| c.mesh.as_ref().and_then(&f)),
    )
}

/// One finished training run of an entry.
#[derive(Clone, Debug)]
pub struct SeedRun {
    pub seed: u64,
    pub metrics: Metrics,
    pub history: Vec<(usize, f32)>,
}

impl AblationEntry {
    /// The entry of `variant` from its runs (one per seed, at least one).
    pub fn new(variant: &Variant, runs: &[SeedRun]) -> Self {
        let first = &runs[0].metrics;
        let over = |f: &dyn Fn(&Metrics) -> Option<f32>| {
            let v: Vec<f32> = runs.iter().filter_map(|r| f(&r.metrics)).collect();
            (v.len() == runs.len()).then(|| mean_f32(v)).flatten()
        };
        let per_seed_object = runs
            .iter()
            .flat_map(|r| {
                r.metrics.per_category.iter().flat_map(move |(c, m)| {
                    m.per_object
                        .iter()
                        .map(move |(id, v)| (format!("s{}/{c}/{id}", r.seed), *v))
                })
            })
            .collect();
        Self {
            variant: variant.name.clone(),
            dir: variant.slug.clone(),
            overrides: variant.overrides.clone(),
            paper_iou: variant.paper_iou,
            mean_iou: over(&|m| Some(m.mean_iou)).unwrap_or(0.0),
            seeds: runs.iter().map(|r| r.seed).collect(),
            seed_ious: runs.iter().map(|r| r.metrics.mean_iou).collect(),
            per_seed_object,
            centre_iou: over(&|m| Some(m.centre_iou)).unwrap_or(0.0),
            outside_hull: over(&|m| Some(m.outside_hull)).unwrap_or(0.0),
            mesh_iou: over(&|m| mesh_mean(m, |x| Some(x.iou))),
            chamfer_l1: over(&|m| mesh_mean(m, |x| x.chamfer_l1)),
            normal_consistency: over(&|m| mesh_mean(m, |x| x.normal_consistency)),
            per_category: first.per_category.clone(),
            visual_hull_iou: first.visual_hull_iou,
            mean_shape_iou: first.mean_shape_iou,
            train_seconds: runs.iter().map(|r| r.metrics.train_seconds).sum(),
            eval_seconds: runs.iter().map(|r| r.metrics.eval_seconds).sum(),
            steps: first.steps,
            final_loss: over(&|m| m.final_loss),
            final_silhouette_loss: over(&|m| m.final_silhouette_loss),
            final_regularizer_loss: over(&|m| m.final_regularizer_loss),
            loss_history: runs[0].history.clone(),
        }
    }

    /// Per seed and evaluation object (`s<seed>/<category>/<id>`): its IoU. Rows are paired on
    /// these keys, so a pair's noise covers both the objects and the training seeds.
    pub fn per_object(&self) -> BTreeMap<String, f32> {
        if !self.per_seed_object.is_empty() {
            return self.per_seed_object.clone();
        }
        self.per_category
            .iter()
            .flat_map(|(c, m)| {
                m.per_object
                    .iter()
                    .map(move |(id, v)| (format!("{c}/{id}"), *v))
            })
            .collect()
    }
}

/// Where an entry stands.
#[derive(Clone, Debug, PartialEq)]
pub enum Status {
    Pending,
    Finished(Box<AblationEntry>),
    Failed(String),
}

/// What `samples.png` shows, for the report.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SamplesInfo {
    /// E.g. "the first training chair, view 3".
    pub object: String,
    /// The left column's samplers (the base's).
    pub left: String,
    /// The right column's samplers and where they come from.
    pub right: String,
    pub rays: usize,
    pub anchors: usize,
}

/// The view shown in `samples.png` (45° azimuth, like the paper's figure a view off the front).
pub const SAMPLE_VIEW: usize = 3;
/// Zoom of the 64² silhouettes in `samples.png`.
const SAMPLE_ZOOM: u32 = 4;

/// `experiments FILE.toml` for a file with `[[variants]]`.
pub fn run(args: &RunArgs) -> Result<()> {
    let file = AblationFile::load(&args.file)?;
    let root = args
        .out
        .clone()
        .unwrap_or_else(|| Path::new("runs").join(&file.name));
    let seeds = file.run_seeds();
    if let Some(v) = &args.variant
        && !file.entries.iter().any(|e| &e.name == v || &e.slug == v)
    {
        bail!(
            "{}: no entry named '{v}' (entries: {})",
            args.file.display(),
            file.entries
                .iter()
                .map(|e| e.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    if let Some(s) = args.seed
        && !seeds.contains(&s)
    {
        bail!(
            "{}: --seed {s} is not one of the file's seeds {seeds:?}",
            args.file.display()
        );
    }
    // Every (entry, seed) run, with its experiment and directory.
    let mut runs: Vec<Vec<(u64, Experiment, PathBuf)>> = Vec::new();
    for e in &file.entries {
        let mut per = Vec::new();
        for &seed in &seeds {
            let exp = with_seed(&e.experiment, seed)
                .with_context(|| format!("{}: variant '{}'", args.file.display(), e.name))?;
            per.push((seed, exp, file.run_dir(&root, e, seed)));
        }
        runs.push(per);
    }

    // Check everything before writing anything.
    for (e, per) in file.entries.iter().zip(&runs) {
        for (seed, exp, dir) in per {
            check_run_dir(args, e, *seed, exp, dir, &root)?;
        }
    }
    std::fs::create_dir_all(&root).with_context(|| format!("cannot create {}", root.display()))?;
    let source = std::fs::read(&args.file)
        .with_context(|| format!("cannot read {}", args.file.display()))?;
    write_atomic(&root.join("ablation.toml"), |w| {
        std::io::Write::write_all(w, &source)
    })?;

    let mut cache = DataCache::default();
    let base = &file.base().experiment;
    let samples = write_samples(&root.join("samples.png"), &file, cache.get(base)?)?;

    let mut status = vec![Status::Pending; file.entries.len()];
    let total = file.entries.len() * seeds.len();
    let mut k = 0;
    for (i, (e, per)) in file.entries.iter().zip(&runs).enumerate() {
        let mut done = Vec::new();
        let mut failure = None;
        let chosen = args
            .variant
            .as_ref()
            .is_none_or(|v| v == &e.name || v == &e.slug);
        let mut skipped = false;
        for (seed, exp, dir) in per {
            k += 1;
            let finished = dir.join("metrics.json").is_file();
            let wanted = chosen && args.seed.is_none_or(|s| s == *seed);
            if !finished && !wanted {
                skipped = true;
                continue;
            }
            let outcome = if finished {
                info!(
                    "run {k}/{total} '{}' seed {seed}: finished, skipping ({})",
                    e.name,
                    dir.display()
                );
                read_finished(*seed, dir)
            } else {
                info!(
                    "run {k}/{total} '{}' seed {seed} → {}",
                    e.name,
                    dir.display()
                );
                let resume = checkpoint::latest(&dir.join("checkpoints"))?.is_some();
                (|| {
                    let data = cache.get(exp)?;
                    prepare_dir(exp, dir)?;
                    let o = run_one(exp, &args.file, data, dir, resume)?;
                    info!(
                        "'{}' seed {seed}: mean IoU {:.3}",
                        e.name, o.metrics.mean_iou
                    );
                    Ok(SeedRun {
                        seed: *seed,
                        metrics: o.metrics,
                        history: o.history,
                    })
                })()
            };
            match outcome {
                Ok(r) => done.push(r),
                Err(err) => {
                    let msg = format!("seed {seed}: {err:#}");
                    error!("variant '{}' failed: {msg}", e.name);
                    failure = Some(msg);
                    break;
                }
            }
        }
        status[i] = match failure {
            Some(msg) => Status::Failed(msg),
            None if skipped => Status::Pending,
            None => Status::Finished(Box::new(AblationEntry::new(e, &done))),
        };
        write_outputs(&root, &file, &status, &samples)?;
    }
    let report = render_report(&file, &status, &samples);
    println!("{report}");
    println!("ablation directory: {}", root.display());
    let failed: Vec<&str> = file
        .entries
        .iter()
        .zip(&status)
        .filter(|(_, s)| matches!(s, Status::Failed(_)))
        .map(|(e, _)| e.name.as_str())
        .collect();
    if !failed.is_empty() {
        bail!(
            "{}: variant(s) {} failed (see above and {}); fix and rerun with --resume",
            args.file.display(),
            failed.join(", "),
            root.join("report.md").display()
        );
    }
    Ok(())
}

/// Datasets loaded so far, one per distinct `[data]`.
#[derive(Default)]
struct DataCache {
    sets: Vec<(DataConfig, Vec<CategoryData>)>,
}

impl DataCache {
    fn get(&mut self, exp: &Experiment) -> Result<&[CategoryData]> {
        let i = match self.sets.iter().position(|(d, _)| *d == exp.data) {
            Some(i) => i,
            None => {
                ensure_dataset(exp)?;
                self.sets.push((exp.data.clone(), load(exp)?));
                self.sets.len() - 1
            }
        };
        Ok(&self.sets[i].1)
    }
}

/// `exp` with its training seed replaced (through its resolved TOML, so that the copy is
/// validated like a file).
fn with_seed(exp: &Experiment, seed: u64) -> Result<Experiment> {
    let mut table: toml::Table = toml::from_str(&exp.to_toml()?)?;
    table.insert("seed".into(), toml::Value::Integer(seed as i64));
    let copy: Experiment = toml::from_str(&toml::to_string(&table)?)?;
    copy.validate().map_err(|e| anyhow!(e))?;
    Ok(copy)
}

/// Refuses to run over a run directory that holds results, unless resuming with the same
/// configuration.
fn check_run_dir(
    args: &RunArgs,
    e: &Variant,
    seed: u64,
    exp: &Experiment,
    dir: &Path,
    root: &Path,
) -> Result<()> {
    let done = dir.join("metrics.json").is_file();
    let ckpt = checkpoint::latest(&dir.join("checkpoints"))?;
    if !args.resume && (done || ckpt.is_some()) {
        bail!(
            "{} already holds variant '{}' seed {seed} ({}); pass --resume to continue the ablation (finished runs are skipped) or --out DIR to start a new one",
            root.display(),
            e.name,
            if done {
                "finished".to_string()
            } else {
                format!("checkpoint at step {}", ckpt.as_ref().map_or(0, |c| c.step))
            }
        );
    }
    let config = dir.join("config.toml");
    if args.resume && (done || ckpt.is_some()) && config.is_file() {
        let old = std::fs::read_to_string(&config)
            .with_context(|| format!("cannot read {}", config.display()))?;
        if old != exp.to_toml()? {
            bail!(
                "{}: variant '{}' was run with a different configuration ({}); restore the file, remove {} to rerun it, or pass --out DIR",
                args.file.display(),
                e.name,
                config.display(),
                dir.display()
            );
        }
    }
    Ok(())
}

/// A run that finished in an earlier invocation.
fn read_finished(seed: u64, dir: &Path) -> Result<SeedRun> {
    let path = dir.join("metrics.json");
    let text = std::fs::read_to_string(&path)
        .with_context(|| format!("cannot read {}", path.display()))?;
    let metrics: Metrics =
        serde_json::from_str(&text).map_err(|err| anyhow!("{}: {err}", path.display()))?;
    let history = checkpoint::latest(&dir.join("checkpoints"))?
        .map(|s| s.history)
        .unwrap_or_default();
    Ok(SeedRun {
        seed,
        metrics,
        history,
    })
}

/// The finished entries, in file order (the base first).
pub fn finished(status: &[Status]) -> Vec<&AblationEntry> {
    status
        .iter()
        .filter_map(|s| match s {
            Status::Finished(e) => Some(e.as_ref()),
            _ => None,
        })
        .collect()
}

/// Writes `ablation.json`, `training_curves.png` and `report.md` for the current state.
pub fn write_outputs(
    root: &Path,
    file: &AblationFile,
    status: &[Status],
    samples: &SamplesInfo,
) -> Result<()> {
    let json = serde_json::to_string_pretty(&finished(status))?;
    write_atomic(&root.join("ablation.json"), |w| {
        std::io::Write::write_all(w, json.as_bytes())
    })?;
    plot::write_png(&root.join("training_curves.png"), &training_curves(status))?;
    let report = render_report(file, status, samples);
    write_atomic(&root.join("report.md"), |w| {
        std::io::Write::write_all(w, report.as_bytes())
    })?;
    Ok(())
}

/// The loss history of every finished entry (entry `i` in colour `i`, labelled `i + 1`), log y.
pub fn training_curves(status: &[Status]) -> image::RgbImage {
    let histories: Vec<(usize, &[(usize, f32)])> = status
        .iter()
        .enumerate()
        .filter_map(|(i, s)| match s {
            Status::Finished(e) => Some((i, e.loss_history.as_slice())),
            _ => None,
        })
        .collect();
    plot::loss_chart(&histories)
}

// ---------------------------------------------------------------------------------------------
// samples.png
// ---------------------------------------------------------------------------------------------

/// Draws, for the first training object of the base's first category and view [`SAMPLE_VIEW`],
/// the base's samplers (left column) against a comparison (right column): the first variant that
/// changes a sampler, else `type = "normal"` (the paper's N(0, 0.4) comparison) for both. Top row:
/// one view's rays (`probe.rays_per_view` pixels, dots); bottom row: one object's anchors
/// (`probe.anchors` points) projected into the same view. Dots are red on the left, blue on the
/// right, over the grey silhouette.
pub fn write_samples(
    path: &Path,
    file: &AblationFile,
    data: &[CategoryData],
) -> Result<SamplesInfo> {
    let base = &file.base().experiment;
    let probe = &base.probe;
    let key = |r: &dyn RaySamplerConfig, a: &dyn AnchorSamplerConfig| {
        (
            serde_json::to_string(r).unwrap_or_default(),
            serde_json::to_string(a).unwrap_or_default(),
        )
    };
    let base_key = key(probe.ray_sampler.as_ref(), probe.anchor_sampler.as_ref());
    let other = file.entries[1..].iter().find(|v| {
        let p = &v.experiment.probe;
        key(p.ray_sampler.as_ref(), p.anchor_sampler.as_ref()) != base_key
    });
    let normal_rays: Box<dyn RaySamplerConfig>;
    let normal_anchors: Box<dyn AnchorSamplerConfig>;
    let (rays_b, anchors_b, from): (&dyn RaySamplerConfig, &dyn AnchorSamplerConfig, String) =
        match other {
            Some(v) => (
                v.experiment.probe.ray_sampler.as_ref(),
                v.experiment.probe.anchor_sampler.as_ref(),
                format!("variant '{}'", v.name),
            ),
            None => {
                normal_rays = toml::from_str("type = \"normal\"")?;
                normal_anchors = toml::from_str("type = \"normal\"")?;
                (
                    normal_rays.as_ref(),
                    normal_anchors.as_ref(),
                    "the paper's comparison (no variant changes a sampler)".into(),
                )
            }
        };
    let cat = data
        .first()
        .filter(|c| !c.train.is_empty())
        .ok_or_else(|| {
            anyhow!(
                "{}: no training objects to draw samples of",
                file.path.display()
            )
        })?;
    let object = &cat.train[0].supervision;
    let view = SAMPLE_VIEW.min(object.cameras.len() - 1);
    let sil = &object.silhouettes[view];
    let cam = &object.cameras[view];
    let mut columns = Vec::new();
    for (c, (rc, ac)) in [
        (probe.ray_sampler.as_ref(), probe.anchor_sampler.as_ref()),
        (rays_b, anchors_b),
    ]
    .into_iter()
    .enumerate()
    {
        let where_ = |e: String| anyhow!("{}: samples.png: {e}", file.path.display());
        let rays = rc.build().map_err(where_)?;
        let anchors = ac.build().map_err(where_)?;
        let color = if c == 0 {
            plot::color(3).1
        } else {
            plot::color(0).1
        };
        let mut rng = step_rng(base.seed, 0, 1000 + c);
        let px: Vec<(f32, f32)> = rays
            .sample_pixels(object, view, probe.rays_per_view, &mut rng)
            .iter()
            .map(|p| (p.col, p.row))
            .collect();
        let pts: Vec<(f32, f32)> = anchors
            .sample_anchors(object, probe.anchors, &mut rng)
            .into_iter()
            .filter_map(|a| {
                let (p, depth) = cam.project(a);
                (depth > 0.0).then_some((p.col, p.row))
            })
            .collect();
        let mut top = plot::silhouette_panel(sil, SAMPLE_ZOOM);
        plot::dots(&mut top, &px, SAMPLE_ZOOM, 3, color);
        let mut bottom = plot::silhouette_panel(sil, SAMPLE_ZOOM);
        plot::dots(&mut bottom, &pts, SAMPLE_ZOOM, 2, color);
        columns.push((top, bottom));
    }
    let [(a_top, a_bottom), (b_top, b_bottom)]: [_; 2] = columns.try_into().expect("two columns");
    let img = plot::grid(
        &[vec![a_top, b_top], vec![a_bottom, b_bottom]],
        8,
        image::Rgb([60, 60, 68]),
    );
    plot::write_png(path, &img)?;
    Ok(SamplesInfo {
        object: format!(
            "the first training {} of `{}`, view {view} of 24",
            cat.category.name(),
            base.data.dir.display()
        ),
        left: format!(
            "the base '{}': rays {}, anchors {}",
            file.base().name,
            inline_of(probe.ray_sampler.as_ref()),
            inline_of(probe.anchor_sampler.as_ref())
        ),
        right: format!(
            "{from}: rays {}, anchors {}",
            inline_of(rays_b),
            inline_of(anchors_b)
        ),
        rays: probe.rays_per_view,
        anchors: probe.anchors,
    })
}

// ---------------------------------------------------------------------------------------------
// Ordering vs the paper
// ---------------------------------------------------------------------------------------------

/// The smallest difference of mean IoUs read as an ordering (half a point of IoU): below it a
/// pair is within noise however consistent the per-object differences are (nearly identical
/// models give tiny, consistent differences).
pub const MIN_RESOLVED_DIFF: f32 = 0.005;

/// One row of the comparison: our mean IoU, the paper's, and our per-object IoUs (keyed by
/// `category/id`, for the paired noise estimate).
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub name: String,
    pub ours: f32,
    pub paper: f32,
    pub per_object: BTreeMap<String, f32>,
}

/// How one pair's order compares.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Same order as the paper, and our difference exceeds 2 SE and [`MIN_RESOLVED_DIFF`].
    Agrees,
    /// Opposite order, and our difference exceeds 2 SE and [`MIN_RESOLVED_DIFF`].
    Disagrees,
    /// Our difference is within 2 SE or below [`MIN_RESOLVED_DIFF`] (or the SE cannot be
    /// estimated): within noise. `sign_agrees`: the
    /// sign of our difference matches the paper's order anyway.
    Unresolved { sign_agrees: bool },
    /// The paper gives both the same number.
    PaperTie,
}

/// One pair of rows (`a < b`, indices into the rows).
#[derive(Clone, Debug, PartialEq)]
pub struct Pair {
    pub a: usize,
    pub b: usize,
    /// Our `ours[a] − ours[b]`.
    pub diff: f32,
    /// Standard error of the paired per-object differences; `None` with fewer than 2 shared
    /// objects.
    pub se: Option<f32>,
    pub verdict: Verdict,
}

/// Rankings and pairwise verdicts of rows.
#[derive(Clone, Debug, PartialEq)]
pub struct Comparison {
    pub pairs: Vec<Pair>,
    /// Rank of each row by our IoU (1 = best; equal values share a rank).
    pub ours_rank: Vec<usize>,
    /// Rank of each row by the paper's IoU.
    pub paper_rank: Vec<usize>,
}

fn ranks(v: &[f32]) -> Vec<usize> {
    v.iter()
        .map(|x| 1 + v.iter().filter(|y| *y > x).count())
        .collect()
}

/// The paired standard error of `a − b` over the objects both have.
fn paired_se(a: &BTreeMap<String, f32>, b: &BTreeMap<String, f32>) -> Option<f32> {
    let d: Vec<f64> = a
        .iter()
        .filter_map(|(k, x)| b.get(k).map(|y| (*x - *y) as f64))
        .collect();
    let n = d.len();
    if n < 2 {
        return None;
    }
    let mean = d.iter().sum::<f64>() / n as f64;
    let var = d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    Some((var / n as f64).sqrt() as f32)
}

/// Compares our ordering of `rows` with the paper's (the rule is in the module docs).
pub fn compare(rows: &[Row]) -> Comparison {
    let mut pairs = Vec::new();
    for a in 0..rows.len() {
        for b in a + 1..rows.len() {
            let (ra, rb) = (&rows[a], &rows[b]);
            let diff = ra.ours - rb.ours;
            let se = paired_se(&ra.per_object, &rb.per_object);
            let paper = ra.paper - rb.paper;
            let verdict = if paper == 0.0 {
                Verdict::PaperTie
            } else {
                let sign_agrees = diff != 0.0 && (diff > 0.0) == (paper > 0.0);
                let resolved =
                    diff.abs() >= MIN_RESOLVED_DIFF && se.is_some_and(|se| diff.abs() > 2.0 * se);
                match (resolved, sign_agrees) {
                    (true, true) => Verdict::Agrees,
                    (true, false) => Verdict::Disagrees,
                    (false, s) => Verdict::Unresolved { sign_agrees: s },
                }
            };
            pairs.push(Pair {
                a,
                b,
                diff,
                se,
                verdict,
            });
        }
    }
    Comparison {
        pairs,
        ours_rank: ranks(&rows.iter().map(|r| r.ours).collect::<Vec<_>>()),
        paper_rank: ranks(&rows.iter().map(|r| r.paper).collect::<Vec<_>>()),
    }
}

/// Counts of verdicts: `(agree, disagree, unresolved, unresolved with the paper's sign, ties)`.
fn tally<'a>(pairs: impl Iterator<Item = &'a Pair>) -> (usize, usize, usize, usize, usize) {
    let mut t = (0, 0, 0, 0, 0);
    for p in pairs {
        match p.verdict {
            Verdict::Agrees => t.0 += 1,
            Verdict::Disagrees => t.1 += 1,
            Verdict::Unresolved { sign_agrees } => {
                t.2 += 1;
                t.3 += sign_agrees as usize;
            }
            Verdict::PaperTie => t.4 += 1,
        }
    }
    t
}

/// A one-paragraph verdict on the whole ordering.
pub fn summary(rows: &[Row], c: &Comparison) -> String {
    if rows.len() < 2 {
        return "Fewer than two finished variants with the paper's numbers: nothing to compare yet."
            .into();
    }
    let (agree, disagree, unresolved, same_sign, ties) = tally(c.pairs.iter());
    let counted = agree + disagree + unresolved;
    let overall = if disagree > 0 {
        format!(
            "**Our ordering disagrees with the paper's** on {disagree} of {counted} pair(s) beyond noise"
        )
    } else if unresolved > 0 {
        format!(
            "**No resolved pair contradicts the paper's ordering, but {unresolved} of {counted} pair(s) are within noise**, so our runs do not confirm it"
        )
    } else {
        format!(
            "**Our ordering agrees with the paper's** on all {counted} pair(s), each beyond noise"
        )
    };
    let best = |ranks: &[usize]| -> Vec<&str> {
        rows.iter()
            .zip(ranks)
            .filter(|(_, r)| **r == 1)
            .map(|(r, _)| r.name.as_str())
            .collect()
    };
    let (ob, pb) = (best(&c.ours_rank), best(&c.paper_rank));
    let best_match = if ob == pb {
        "matches"
    } else {
        "does not match"
    };
    let mut s = format!(
        "{overall}: {agree} agree, {disagree} disagree, {unresolved} within noise ({same_sign} of them with the paper's sign)"
    );
    if ties > 0 {
        let _ = write!(s, ", {ties} tied in the paper (not counted)");
    }
    let _ = write!(
        s,
        ". Our best: {}; the paper's best: {} — {best_match}.",
        ob.join(", "),
        pb.join(", ")
    );
    s
}

fn verdict_text(v: Verdict) -> &'static str {
    match v {
        Verdict::Agrees => "agrees",
        Verdict::Disagrees => "**disagrees**",
        Verdict::Unresolved { sign_agrees: true } => "within noise (same sign as the paper)",
        Verdict::Unresolved { sign_agrees: false } => "within noise (opposite sign)",
        Verdict::PaperTie => "paper tie",
    }
}

// ---------------------------------------------------------------------------------------------
// report.md
// ---------------------------------------------------------------------------------------------

fn se_of(v: &[f32]) -> Option<f32> {
    let n = v.len();
    (n >= 2).then(|| {
        let m = v.iter().sum::<f32>() / n as f32;
        let var = v.iter().map(|x| (x - m).powi(2)).sum::<f32>() / (n - 1) as f32;
        (var / n as f32).sqrt()
    })
}

/// The ablation's `report.md`.
pub fn render_report(file: &AblationFile, status: &[Status], samples: &SamplesInfo) -> String {
    let mut s = String::new();
    let base = &file.base().experiment;
    let _ = writeln!(s, "# Ablation: {}\n", file.name);
    let cats: Vec<&str> = base.data.categories.iter().map(|c| c.name()).collect();
    let _ = writeln!(
        s,
        "Each row is the base with the overrides shown, trained and evaluated into its own run \
         directory; all share the data (`{}`, {}, evaluated on the {} split), the training \
         seed(s) {} and the evaluation (3D IoU at {}³ in the NMR max-pool protocol, {}³ points per \
         voxel, {} input view(s) per object).",
        base.data.dir.display(),
        cats.join(", "),
        base.data.eval_split.name(),
        file.run_seeds()
            .iter()
            .map(|s| s.to_string())
            .collect::<Vec<_>>()
            .join(", "),
        base.eval.resolution,
        base.eval.subsamples,
        base.eval.views
    );
    let paper_src = file
        .paper_table
        .as_deref()
        .unwrap_or("the paper's ablation tables");
    let _ = writeln!(
        s,
        "The paper's column is its 3D IoU on ShapeNet at full scale ({paper_src}); ours come from \
         a different scale and data, so compare orderings, not values.\n"
    );

    // Rows with the paper's numbers, for the ordering.
    let done: Vec<(usize, &AblationEntry)> = status
        .iter()
        .enumerate()
        .filter_map(|(i, s)| match s {
            Status::Finished(e) => Some((i, e.as_ref())),
            _ => None,
        })
        .collect();
    let compared: Vec<(usize, Row)> = done
        .iter()
        .filter_map(|&(i, e)| {
            e.paper_iou.map(|p| {
                (
                    i,
                    Row {
                        name: e.variant.clone(),
                        ours: e.mean_iou,
                        paper: p,
                        per_object: e.per_object(),
                    },
                )
            })
        })
        .collect();
    let rows: Vec<Row> = compared.iter().map(|(_, r)| r.clone()).collect();
    let cmp = compare(&rows);
    let pos = |i: usize| compared.iter().position(|(j, _)| *j == i);

    let _ = writeln!(
        s,
        "| # | variant | overrides | steps | train (s) | our mean IoU ± SE | per seed | centre IoU | outside hull | mesh IoU | Chamfer-L1 ×10 | normal consistency | final L_sil / L_reg | our rank | paper IoU | paper rank | pairs vs the paper |"
    );
    let _ = writeln!(
        s,
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    for (i, (v, st)) in file.entries.iter().zip(status).enumerate() {
        let name = if i == 0 {
            format!("{} (base)", v.name)
        } else {
            v.name.clone()
        };
        let overrides = if v.overrides.is_empty() {
            "–".to_string()
        } else {
            v.overrides
                .iter()
                .map(|o| format!("`{}`", o.replace('|', "\\|")))
                .collect::<Vec<_>>()
                .join("<br>")
        };
        let paper = v.paper_iou.map_or("–".into(), |p| format!("{p:.3}"));
        match st {
            Status::Finished(e) => {
                let objs: Vec<f32> = e.per_object().into_values().collect();
                let se = se_of(&objs).map_or(String::new(), |x| format!(" ± {x:.3}"));
                let (our_rank, paper_rank, pairs) = match pos(i) {
                    Some(k) => {
                        let (a, d, u, _, t) =
                            tally(cmp.pairs.iter().filter(|p| p.a == k || p.b == k));
                        let mut txt = format!("{a} agree, {d} disagree, {u} within noise");
                        if t > 0 {
                            let _ = write!(txt, ", {t} paper tie(s)");
                        }
                        (
                            cmp.ours_rank[k].to_string(),
                            cmp.paper_rank[k].to_string(),
                            txt,
                        )
                    }
                    None => ("–".into(), "–".into(), "–".into()),
                };
                let o = |v: Option<f32>, scale: f32| {
                    v.map_or_else(|| "–".to_string(), |v| format!("{:.3}", v * scale))
                };
                let per_seed = e
                    .seed_ious
                    .iter()
                    .map(|v| format!("{v:.3}"))
                    .collect::<Vec<_>>()
                    .join(", ");
                let losses = format!(
                    "{} / {}",
                    e.final_silhouette_loss
                        .map_or_else(|| "–".into(), |v| format!("{v:.4}")),
                    e.final_regularizer_loss
                        .map_or_else(|| "–".into(), |v| format!("{v:.5}"))
                );
                let _ = writeln!(
                    s,
                    "| {} | {name} | {overrides} | {} | {:.0} | **{:.3}**{se} | {per_seed} | {:.3} | {:.1} % | {} | {} | {} | {losses} | {our_rank} | {paper} | {paper_rank} | {pairs} |",
                    i + 1,
                    e.steps,
                    e.train_seconds,
                    e.mean_iou,
                    e.centre_iou,
                    100.0 * e.outside_hull,
                    o(e.mesh_iou, 1.0),
                    o(e.chamfer_l1, 10.0),
                    o(e.normal_consistency, 1.0),
                );
            }
            Status::Pending => {
                let _ = writeln!(
                    s,
                    "| {} | {name} | {overrides} | | | not run yet | | | | | | | | | {paper} | | |",
                    i + 1
                );
            }
            Status::Failed(msg) => {
                let _ = writeln!(
                    s,
                    "| {} | {name} | {overrides} | | | failed: {} | | | | | | | | | {paper} | | |",
                    i + 1,
                    msg.replace('|', "\\|").replace('\n', " ")
                );
            }
        }
    }
    if let Some((_, e)) = done.first() {
        let _ = writeln!(
            s,
            "\nReferences on the same evaluation objects: visual hull (24 views) {:.3}, category mean \
             shape {}. SE: standard error of the mean over seeds × evaluation objects. Train (s) \
             is summed over seeds; centre IoU reads φ at voxel centres only (secondary); outside \
             hull is the share of predicted voxels outside the 24-view visual hull; mesh metrics \
             are means over the meshed views and seeds.",
            e.visual_hull_iou,
            e.mean_shape_iou.map_or("–".into(), |v| format!("{v:.3}"))
        );
    }

    let _ = writeln!(s, "\n## Ordering vs the paper\n");
    let _ = writeln!(
        s,
        "Rule: every pair of finished rows with the paper's numbers is compared. The paper orders \
         a pair by its two IoUs (equal numbers are a tie and not counted). Our order is the sign of \
         the difference Δ of our mean IoUs; it is *resolved* only when |Δ| exceeds twice the \
         standard error of the paired differences (the same evaluation object under the same \
         training seed in both rows) and is at least {MIN_RESOLVED_DIFF}. A resolved pair agrees \
         or disagrees with the paper; an unresolved one is reported as within noise, and its 2·SE \
         is the smallest difference this run could have resolved. The noise bar is rough (not a \
         significance test); it covers the choice of evaluation objects and, with several seeds, \
         training noise (with one seed, close rows could swap under another).\n"
    );
    let _ = writeln!(s, "{}\n", summary(&rows, &cmp));
    if !cmp.pairs.is_empty() {
        let _ = writeln!(s, "| pair | paper | ours: Δ (2·SE) | verdict |");
        let _ = writeln!(s, "|---|---|---|---|");
        for p in &cmp.pairs {
            let (a, b) = (&rows[p.a], &rows[p.b]);
            let rel = |d: f32| {
                if d > 0.0 {
                    ">"
                } else if d < 0.0 {
                    "<"
                } else {
                    "="
                }
            };
            let _ = writeln!(
                s,
                "| {} vs {} | {:.3} {} {:.3} | {:+.3} ({}) | {} |",
                a.name,
                b.name,
                a.paper,
                rel(a.paper - b.paper),
                b.paper,
                p.diff,
                p.se.map_or("n/a".into(), |se| format!("{:.3}", 2.0 * se)),
                verdict_text(p.verdict)
            );
        }
    }

    let _ = writeln!(s, "\n## Training curves\n");
    let _ = writeln!(s, "![training curves](training_curves.png)\n");
    let _ = writeln!(
        s,
        "Mean training loss per logged interval (silhouette MSE plus the regularizer's term, so \
         rows with different regularizers differ in what the loss includes) against the step, log \
         scale. Legend (the numbered boxes in the picture):\n"
    );
    for (i, (v, st)) in file.entries.iter().zip(status).enumerate() {
        let (cname, c) = plot::color(i);
        let note = match st {
            Status::Finished(_) => "",
            _ => " (not drawn: not finished)",
        };
        let _ = writeln!(
            s,
            "* **{}** — {cname} (`{}`): {}{note}",
            i + 1,
            plot::hex(c),
            v.name
        );
    }

    let _ = writeln!(s, "\n## Samples\n");
    let _ = writeln!(s, "![samples](samples.png)\n");
    let _ = writeln!(
        s,
        "{}, silhouette in grey. Top row: the pixels of one view's {} rays; bottom row: one \
         object's {} anchors projected into the same view — what one training step draws for one \
         object. Left column (red): {}. Right column (blue): {}.",
        upper_first(&samples.object),
        samples.rays,
        samples.anchors,
        samples.left,
        samples.right
    );

    let _ = writeln!(s, "\n## Run directories\n");
    for v in &file.entries {
        let _ = writeln!(
            s,
            "* `{}/` — {} (config.toml, metrics.json, report.md, checkpoints/)",
            v.slug, v.name
        );
    }
    s
}

fn upper_first(s: &str) -> String {
    let mut c = s.chars();
    c.next()
        .map(|f| f.to_uppercase().chain(c).collect())
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(name: &str, paper: f32, objects: &[f32]) -> Row {
        Row {
            name: name.into(),
            ours: objects.iter().sum::<f32>() / objects.len() as f32,
            paper,
            per_object: objects
                .iter()
                .enumerate()
                .map(|(i, v)| (format!("chair/{i}"), *v))
                .collect(),
        }
    }

    #[test]
    fn pairs_agree_disagree_or_stay_within_noise() {
        let rows = [
            // Clearly best in both.
            row("a", 0.548, &[0.60, 0.62, 0.61, 0.63]),
            // Clearly below a; the paper puts it second, but it is clearly below c too.
            row("b", 0.524, &[0.40, 0.42, 0.41, 0.43]),
            // Above b everywhere (resolved, against the paper), far below a.
            row("c", 0.502, &[0.50, 0.52, 0.51, 0.53]),
            // Noisy: mean just above c's but the per-object differences scatter widely.
            row("d", 0.502, &[0.70, 0.30, 0.66, 0.42]),
        ];
        let c = compare(&rows);
        let v = |a: usize, b: usize| {
            c.pairs
                .iter()
                .find(|p| p.a == a && p.b == b)
                .unwrap()
                .verdict
        };
        assert_eq!(v(0, 1), Verdict::Agrees);
        assert_eq!(v(0, 2), Verdict::Agrees);
        assert_eq!(v(1, 2), Verdict::Disagrees);
        assert_eq!(v(2, 3), Verdict::PaperTie);
        // d − b = +0.105, paper says b > d: opposite sign, but 2·SE ≈ 0.21.
        assert_eq!(v(1, 3), Verdict::Unresolved { sign_agrees: false });
        assert_eq!(v(0, 3), Verdict::Unresolved { sign_agrees: true });
        assert_eq!(c.pairs.len(), 6);
        assert_eq!(c.ours_rank, [1, 4, 3, 2]);
        assert_eq!(c.paper_rank, [1, 2, 3, 3]);
        let s = summary(&rows, &c);
        assert!(
            s.contains("disagrees with the paper's** on 1 of 5")
                && s.contains(
                    "2 agree, 1 disagree, 2 within noise (1 of them with the paper's sign)"
                )
                && s.contains("1 tied in the paper")
                && s.contains("Our best: a; the paper's best: a — matches"),
            "{s}"
        );
    }

    #[test]
    fn agreement_needs_every_pair_resolved() {
        let clean = [
            row("x", 0.5, &[0.6, 0.61, 0.62]),
            row("y", 0.4, &[0.5, 0.51, 0.52]),
        ];
        let c = compare(&clean);
        assert_eq!(c.pairs[0].verdict, Verdict::Agrees);
        assert!(summary(&clean, &c).contains("**Our ordering agrees with the paper's** on all 1"));
        // Tiny but perfectly consistent differences are not an ordering.
        let close = [
            row("x", 0.5, &[0.600, 0.610, 0.620]),
            row("y", 0.4, &[0.598, 0.608, 0.618]),
        ];
        let c = compare(&close);
        assert!(c.pairs[0].se.unwrap() < 1e-4);
        assert_eq!(
            c.pairs[0].verdict,
            Verdict::Unresolved { sign_agrees: true }
        );
        // One evaluation object: no noise estimate, so nothing is resolved.
        let single = [row("x", 0.5, &[0.7]), row("y", 0.4, &[0.2])];
        let c = compare(&single);
        assert_eq!(c.pairs[0].se, None);
        assert_eq!(
            c.pairs[0].verdict,
            Verdict::Unresolved { sign_agrees: true }
        );
        let s = summary(&single, &c);
        assert!(
            s.contains("No resolved pair contradicts") && s.contains("do not confirm"),
            "{s}"
        );
        // Best variants differ.
        let flipped = [row("x", 0.5, &[0.2, 0.21]), row("y", 0.4, &[0.7, 0.71])];
        let s = summary(&flipped, &compare(&flipped));
        assert!(
            s.contains("Our best: y; the paper's best: x — does not match"),
            "{s}"
        );
        assert!(summary(&flipped[..1], &compare(&flipped[..1])).contains("nothing to compare"));
    }

    fn metrics(ious: &[f32]) -> Metrics {
        let per_object: Vec<(String, f32)> = ious
            .iter()
            .enumerate()
            .map(|(i, v)| (format!("o{i}"), *v))
            .collect();
        let iou = ious.iter().sum::<f32>() / ious.len() as f32;
        let cm = CategoryMetrics {
            iou,
            centre_iou: iou,
            outside_hull: 0.0,
            visual_hull_iou: 0.7,
            mean_shape_iou: Some(0.3),
            mean_gt_shape_iou: None,
            silhouette_iou: None,
            objects: ious.len(),
            views: 24,
            per_object,
            mesh: None,
        };
        Metrics {
            experiment: "t".into(),
            mean_iou: iou,
            centre_iou: iou,
            outside_hull: 0.0,
            visual_hull_iou: 0.7,
            mean_shape_iou: Some(0.3),
            mean_gt_shape_iou: None,
            silhouette_iou: None,
            per_category: [("chair".to_string(), cm)].into(),
            split: "test".into(),
            resolution: 32,
            subsamples: 4,
            maxpool: Default::default(),
            steps: 10,
            train_seconds: 5.0,
            eval_seconds: 1.0,
            final_loss: Some(0.1),
            final_silhouette_loss: Some(0.09),
            final_regularizer_loss: Some(0.01),
            backend: "flex".into(),
            device: "cpu".into(),
        }
    }

    fn run(seed: u64, ious: &[f32], hist: &[(usize, f32)]) -> SeedRun {
        SeedRun {
            seed,
            metrics: metrics(ious),
            history: hist.to_vec(),
        }
    }

    /// Several seeds: the entry is their mean, its per-object IoUs are keyed by seed, and two
    /// entries pair the same (seed, object).
    #[test]
    fn seeds_average_and_pair_by_seed_and_object() {
        let text = "name = \"abl\"\nseeds = [3, 5]\n[data]\ndir = \"d\"\ncategories = [\"chair\"]\n\
                    [probe]\nanchors = 8\nrays_per_view = 4\nray_sampler = { type = \"uniform\" }\n\
                    anchor_sampler = { type = \"uniform\" }\n[train]\nsteps = 10\n\
                    [[variants]]\nname = \"naive\"\npaper_iou = 0.524\nprobe = { assignment = \"naive\" }\n";
        let file = AblationFile::parse(text, Path::new("abl.toml")).unwrap();
        assert_eq!(file.run_seeds(), [3, 5]);
        let root = Path::new("r");
        assert_eq!(
            file.run_dir(root, &file.entries[1], 5),
            Path::new("r/naive/seed-5")
        );
        let e = AblationEntry::new(
            &file.entries[0],
            &[run(3, &[0.5, 0.7], &[]), run(5, &[0.3, 0.5], &[])],
        );
        assert!((e.mean_iou - 0.5).abs() < 1e-6);
        assert!((e.seed_ious[0] - 0.6).abs() < 1e-6 && (e.seed_ious[1] - 0.4).abs() < 1e-6);
        let keys: Vec<String> = e.per_object().into_keys().collect();
        assert_eq!(
            keys,
            ["s3/chair/o0", "s3/chair/o1", "s5/chair/o0", "s5/chair/o1"]
        );
        assert_eq!(e.train_seconds, 10.0, "summed over seeds");
        assert!(with_seed(&file.entries[1].experiment, 9).unwrap().seed == 9);
        let bad = "name = \"a\"\nseeds = [1, 1]\n[data]\ndir = \"d\"\ncategories = [\"chair\"]\n[probe]\nanchors = 8\nrays_per_view = 4\nray_sampler = { type = \"uniform\" }\nanchor_sampler = { type = \"uniform\" }\n[train]\nsteps = 10\n[[variants]]\nname = \"x\"\nseed = 2\n";
        let err = AblationFile::parse(bad, Path::new("abl.toml")).unwrap_err();
        assert!(format!("{err}").contains("seeds"), "{err}");
    }

    fn file_with(variants: &str) -> AblationFile {
        let text = format!(
            "name = \"abl\"\nbase_name = \"full\"\nbase_paper_iou = 0.548\npaper_table = \"Table 4, chair\"\n\
             [data]\ndir = \"data/abl\"\ncategories = [\"chair\"]\n[probe]\nanchors = 8\nrays_per_view = 4\n\
             ray_sampler = {{ type = \"uniform\" }}\nanchor_sampler = {{ type = \"uniform\" }}\n[train]\nsteps = 10\n{variants}"
        );
        AblationFile::parse(&text, Path::new("abl.toml")).unwrap()
    }

    #[test]
    fn ablation_json_lists_finished_entries_base_first_and_the_report_has_every_row() {
        let file = file_with(
            "[[variants]]\nname = \"normal\"\npaper_iou = 0.482\nprobe = { ray_sampler = { type = \"normal\" } }\n\
             [[variants]]\nname = \"naive\"\npaper_iou = 0.524\nprobe = { assignment = \"naive\" }\n\
             [[variants]]\nname = \"extra\"\nseed = 4\n",
        );
        let hist = vec![(5, 0.2), (10, 0.1)];
        let status = vec![
            Status::Finished(Box::new(AblationEntry::new(
                &file.entries[0],
                &[run(0, &[0.60, 0.62, 0.61], &hist)],
            ))),
            Status::Finished(Box::new(AblationEntry::new(
                &file.entries[1],
                &[run(0, &[0.40, 0.42, 0.41], &hist)],
            ))),
            Status::Failed("the loss became NaN | at step 3".into()),
            Status::Pending,
        ];
        let dir = tempfile::tempdir().unwrap();
        let samples = SamplesInfo {
            object: "the first training chair".into(),
            left: "L".into(),
            right: "R".into(),
            rays: 4,
            anchors: 8,
        };
        write_outputs(dir.path(), &file, &status, &samples).unwrap();
        let json = std::fs::read_to_string(dir.path().join("ablation.json")).unwrap();
        let entries: Vec<AblationEntry> = serde_json::from_str(&json).unwrap();
        let names: Vec<&str> = entries.iter().map(|e| e.variant.as_str()).collect();
        assert_eq!(names, ["full", "normal"]);
        assert_eq!(entries[0].paper_iou, Some(0.548));
        assert_eq!(entries[0].dir, "full");
        assert!(entries[0].overrides.is_empty());
        assert_eq!(
            entries[1].overrides,
            ["probe = { ray_sampler = { type = \"normal\" } }"]
        );
        assert!((entries[1].mean_iou - 0.41).abs() < 1e-6);
        assert_eq!(entries[1].per_category["chair"].per_object.len(), 3);
        assert_eq!(entries[1].loss_history, hist);
        assert_eq!((entries[1].steps, entries[1].train_seconds), (10, 5.0));
        for key in [
            "\"visual_hull_iou\"",
            "\"mean_shape_iou\"",
            "\"per_category\"",
        ] {
            assert!(json.contains(key), "{key}");
        }

        let report = std::fs::read_to_string(dir.path().join("report.md")).unwrap();
        for needle in [
            "| 1 | full (base) | – | 10 | 5 | **0.610** ± 0.006 | 0.610 | 0.610 | 0.0 % | – | – | – | 0.0900 / 0.01000 | 1 | 0.548 | 1 | 1 agree, 0 disagree, 0 within noise |",
            "| 2 | normal | `probe = { ray_sampler = { type = \"normal\" } }` |",
            "| 3 | naive |",
            "failed: the loss became NaN \\| at step 3",
            "| 4 | extra | `seed = 4` | | | not run yet |",
            "**Our ordering agrees with the paper's** on all 1 pair(s)",
            "| full vs normal | 0.548 > 0.482 | +0.200 (",
            "![training curves](training_curves.png)",
            "![samples](samples.png)",
            "* **2** — orange (`#ff7f0e`): normal",
            "* **3** — green (`#2ca02c`): naive (not drawn: not finished)",
            "Table 4, chair",
        ] {
            assert!(report.contains(needle), "missing {needle:?} in\n{report}");
        }
        let curves = image::open(dir.path().join("training_curves.png"))
            .unwrap()
            .to_rgb8();
        assert_eq!(curves.dimensions(), (800, 480));
        for i in [0, 1] {
            let c = plot::color(i).1;
            assert!(
                curves.pixels().filter(|p| **p == c).count() > 100,
                "series {i}"
            );
        }
        assert_eq!(
            curves.pixels().filter(|p| **p == plot::color(2).1).count(),
            0,
            "a failed entry draws no curve"
        );
    }
}
