//! Making a dataset in the published layout: procedural shapes, or a folder of `.obj` meshes,
//! rendered into the 24 NMR views and voxelized, written as Kato's npz files (or DVR's folders)
//! with `dataset.json` beside them. `make-dataset` and experiments that generate their data on
//! first run both come here.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use fieldprobe_core::data::dataset::{
    DatasetInfo, Layout, ObjectRecord, ObjectSet, Split, SplitCount, dvr, kato,
};
use fieldprobe_core::data::procedural::{generate, object_rng};
use fieldprobe_core::data::render::RenderOptions;
use fieldprobe_core::data::voxelize::Voxelizer;
use fieldprobe_core::data::{Category, TriMesh};
use rayon::prelude::*;

use crate::progress;

/// Where the objects come from.
#[derive(Clone, Debug, PartialEq)]
pub enum DatasetSource {
    /// Seeded procedural shapes: `counts` objects per category in train, val and test.
    Procedural {
        categories: Vec<Category>,
        counts: [usize; 3],
        seed: u64,
    },
    /// `dir/<category name or synset>/<id>.obj`, sorted by file name, all into `split`.
    Meshes { dir: PathBuf, split: Split },
}

/// What to make and how.
#[derive(Clone, Debug, PartialEq)]
pub struct DatasetSpec {
    pub out: PathBuf,
    pub source: DatasetSource,
    /// Ground truth: NMR's surface voxelization + fill (the published protocol) or the winding
    /// number (open meshes).
    pub voxelizer: Voxelizer,
    /// Sub-pixels per pixel side of the anti-aliased silhouettes.
    pub supersample: usize,
    pub layout: Layout,
}

impl DatasetSpec {
    /// A procedural dataset with the default rendering (what experiments generate).
    pub fn procedural(out: &Path, categories: &[Category], counts: [usize; 3], seed: u64) -> Self {
        Self {
            out: out.to_path_buf(),
            source: DatasetSource::Procedural {
                categories: categories.to_vec(),
                counts,
                seed,
            },
            voxelizer: Voxelizer::Nmr,
            supersample: 4,
            layout: Layout::Kato,
        }
    }
}

/// A made dataset: its sets (in memory, as written) and the time it took.
#[derive(Debug)]
pub struct MadeDataset {
    pub sets: Vec<ObjectSet>,
    pub seconds: f64,
}

/// Where one object comes from.
enum Source {
    Procedural { seed: u64, index: u64 },
    Mesh(TriMesh),
}

/// One category × split to make.
struct Job {
    category: Category,
    split: Split,
    objects: Vec<(String, Source)>,
}

/// The name a layout has in `dataset.json` and on the command line.
pub fn layout_name(layout: Layout) -> &'static str {
    match layout {
        Layout::Kato => "kato",
        Layout::Dvr => "dvr",
    }
}

/// Renders, voxelizes and writes every object of `spec`. Meshes are all loaded and validated
/// before anything is written, so a bad file stops it early with its name.
pub fn make_dataset(spec: &DatasetSpec) -> Result<MadeDataset> {
    let jobs = match &spec.source {
        DatasetSource::Meshes { dir, split } => mesh_jobs(dir, *split)?,
        DatasetSource::Procedural {
            categories,
            counts,
            seed,
        } => procedural_jobs(categories, *counts, *seed),
    };
    let total: usize = jobs.iter().map(|j| j.objects.len()).sum();
    if total == 0 {
        bail!("nothing to make: every split has zero objects");
    }
    let out = &spec.out;
    std::fs::create_dir_all(out)
        .with_context(|| format!("cannot create output directory {}", out.display()))?;
    let opts = RenderOptions {
        supersample: spec.supersample.max(1),
        ..RenderOptions::default()
    };
    let bar = progress::bar("render", total, 0);
    let start = Instant::now();
    let mut sets = Vec::new();
    let mut counts = Vec::new();
    for job in jobs {
        bar.message(format!("{} {}", job.category, job.split));
        let records: Vec<(String, ObjectRecord)> = job
            .objects
            .par_iter()
            .map(|(id, source)| {
                let record = match source {
                    Source::Procedural { seed, index } => {
                        let mut rng = object_rng(*seed, job.category, job.split.index(), *index);
                        let mesh = generate(job.category, &mut rng);
                        let path = out
                            .join("meshes")
                            .join(job.category.synset())
                            .join(format!("{id}.obj"));
                        mesh.write_obj(&path)?;
                        ObjectRecord::from_mesh(&mesh, spec.voxelizer, &opts)
                    }
                    Source::Mesh(mesh) => ObjectRecord::from_mesh(mesh, spec.voxelizer, &opts),
                };
                bar.inc();
                Ok((id.clone(), record))
            })
            .collect::<Result<_>>()?;
        let mut set = ObjectSet::new(job.category, job.split);
        for (id, rec) in &records {
            set.push(id.clone(), rec);
        }
        match spec.layout {
            Layout::Dvr => dvr::write(out, &set)?,
            Layout::Kato => kato::write(out, &set)?,
        }
        counts.push(SplitCount {
            category: job.category,
            synset: job.category.synset().into(),
            split: job.split,
            count: set.len(),
        });
        sets.push(set);
    }
    bar.finish();
    let seed = match &spec.source {
        DatasetSource::Procedural { seed, .. } => Some(*seed),
        DatasetSource::Meshes { .. } => None,
    };
    DatasetInfo {
        source: if seed.is_some() {
            "procedural"
        } else {
            "meshes"
        }
        .into(),
        seed,
        voxelizer: spec.voxelizer,
        supersample: opts.supersample,
        layout: layout_name(spec.layout).into(),
        objects: counts,
    }
    .write(out)?;
    Ok(MadeDataset {
        sets,
        seconds: start.elapsed().as_secs_f64(),
    })
}

fn procedural_jobs(categories: &[Category], counts: [usize; 3], seed: u64) -> Vec<Job> {
    let mut jobs = Vec::new();
    for &category in categories {
        for (split, n) in Split::ALL.into_iter().zip(counts) {
            if n == 0 {
                continue;
            }
            let objects = (0..n)
                .map(|i| {
                    let id = format!("proc_{}_{}_{:05}", category.name(), split.name(), i);
                    let index = i as u64;
                    (id, Source::Procedural { seed, index })
                })
                .collect();
            jobs.push(Job {
                category,
                split,
                objects,
            });
        }
    }
    jobs
}

/// Loads and validates every mesh before anything is written, so a bad file stops the run early
/// with its name and nothing half-made is left behind.
fn mesh_jobs(dir: &Path, split: Split) -> Result<Vec<Job>> {
    let entries = std::fs::read_dir(dir)
        .with_context(|| format!("cannot read mesh directory {}", dir.display()))?;
    let mut folders: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_dir())
        .collect();
    folders.sort();
    if folders.is_empty() {
        bail!(
            "{}: expected sub-folders named after categories (e.g. chair/ or 03001627/) holding .obj files",
            dir.display()
        );
    }
    let mut jobs = Vec::new();
    for folder in folders {
        let name = folder
            .file_name()
            .unwrap_or_default()
            .to_string_lossy()
            .into_owned();
        let category: Category = name
            .parse()
            .map_err(|e: String| anyhow::anyhow!("{}: {e}", folder.display()))?;
        let mut files: Vec<PathBuf> = std::fs::read_dir(&folder)
            .with_context(|| format!("cannot read {}", folder.display()))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x.eq_ignore_ascii_case("obj")))
            .collect();
        files.sort();
        let objects = files
            .into_par_iter()
            .map(|path| {
                let mut mesh = TriMesh::load_obj(&path)?;
                mesh.normalize_unit_cube();
                let id = path
                    .file_stem()
                    .unwrap_or_default()
                    .to_string_lossy()
                    .into_owned();
                Ok((id, Source::Mesh(mesh)))
            })
            .collect::<Result<Vec<_>, fieldprobe_core::Error>>()?;
        if objects.is_empty() {
            bail!("{}: no .obj files", folder.display());
        }
        match jobs.iter_mut().find(|j: &&mut Job| j.category == category) {
            Some(job) => job.objects.extend(objects),
            None => jobs.push(Job {
                category,
                split,
                objects,
            }),
        }
    }
    Ok(jobs)
}
