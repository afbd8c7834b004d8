//! Making a dataset in the published layout: procedural shapes, or a folder of `.obj` meshes,
//! rendered into the 24 NMR views and voxelized, written as Kato's npz files (or DVR's folders)
//! with `dataset.json` beside them. `make-dataset` and experiments that generate their data on
//! first run both come here.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use fieldprobe_core::data::dataset::{
    DatasetInfo, Layout, ObjectRecord, ObjectSet, Split, SplitCount, dvr, kato,
};
use fieldprobe_core::data::mesh_files::{is_mesh_file, load_mesh};
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
    /// Meshes under `dir/<category name or synset>/`, each `<id>.{obj,off,ply,stl}`, or a
    /// ShapeNetCore folder `<id>/model.obj` (v1) or `<id>/models/model_normalized.obj` (v2);
    /// sorted by id. Without `split_lists` every object goes into `split`; with them, an object
    /// goes into the split of the list naming its id (a list's split is read from its file name,
    /// `softras_train.lst`, `val.txt`, …, else `split`), and objects no list names are skipped.
    Meshes {
        dir: PathBuf,
        split: Split,
        split_lists: Vec<PathBuf>,
    },
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
    Procedural {
        seed: u64,
        index: u64,
    },
    /// A mesh file, read (and normalized to the unit cube) when its object is rendered, so that
    /// only the meshes being rendered are in memory.
    MeshFile(PathBuf),
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

/// Renders, voxelizes and writes every object of `spec`. Mesh files are all read and validated
/// once before anything is written (a bad file stops it early with its name), then read again
/// one per worker as they are rendered: memory holds the meshes in flight, not the collection.
pub fn make_dataset(spec: &DatasetSpec) -> Result<MadeDataset> {
    let jobs = match &spec.source {
        DatasetSource::Meshes {
            dir,
            split,
            split_lists,
        } => mesh_jobs(dir, *split, split_lists)?,
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
                let mesh = match source {
                    Source::Procedural { seed, index } => {
                        let mut rng = object_rng(*seed, job.category, job.split.index(), *index);
                        generate(job.category, &mut rng)
                    }
                    Source::MeshFile(path) => normalized(path)?,
                };
                // The ground truth's surface, for the mesh metrics (`meshes/<synset>/<id>.obj`).
                let path = out
                    .join("meshes")
                    .join(job.category.synset())
                    .join(format!("{id}.obj"));
                mesh.write_obj(&path)?;
                let record = ObjectRecord::from_mesh(&mesh, spec.voxelizer, &opts);
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

/// A mesh file read and scaled into the unit cube.
fn normalized(path: &Path) -> fieldprobe_core::Result<TriMesh> {
    let mut mesh = load_mesh(path)?;
    mesh.normalize_unit_cube();
    Ok(mesh)
}

/// The meshes of one category folder: `(id, file)` sorted by id (see [`DatasetSource::Meshes`]).
fn category_meshes(folder: &Path) -> Result<Vec<(String, PathBuf)>> {
    let mut found: Vec<(String, PathBuf)> = Vec::new();
    let entries =
        std::fs::read_dir(folder).with_context(|| format!("cannot read {}", folder.display()))?;
    for path in entries.filter_map(|e| e.ok().map(|e| e.path())) {
        let name = path
            .file_name()
            .unwrap_or_default()
            .to_string_lossy()
            .into_owned();
        if path.is_dir() {
            // ShapeNetCore v1 and v2.
            let file = ["model.obj", "models/model_normalized.obj"]
                .iter()
                .map(|f| path.join(f))
                .find(|f| f.is_file());
            if let Some(file) = file {
                found.push((name, file));
            }
        } else if is_mesh_file(&path) {
            let id = path
                .file_stem()
                .unwrap_or_default()
                .to_string_lossy()
                .into_owned();
            found.push((id, path));
        }
    }
    found.sort();
    if let Some(w) = found.windows(2).find(|w| w[0].0 == w[1].0) {
        bail!(
            "{}: two meshes for object '{}' ({} and {})",
            folder.display(),
            w[0].0,
            w[0].1.display(),
            w[1].1.display()
        );
    }
    Ok(found)
}

/// The split a list file is for, from its name (`softras_train.lst`, `test.txt`, `val_ids.lst`),
/// or `fallback` when the name says none.
pub fn split_of_list(path: &Path, fallback: Split) -> Split {
    let stem = path
        .file_stem()
        .unwrap_or_default()
        .to_string_lossy()
        .to_ascii_lowercase();
    Split::ALL
        .into_iter()
        .find(|s| {
            stem.split(|c: char| !c.is_ascii_alphanumeric())
                .any(|w| w == s.name())
        })
        .unwrap_or(fallback)
}

/// Reads split lists into `id → split` (one id per line; blank lines and `#` comments skipped).
fn read_split_lists(lists: &[PathBuf], fallback: Split) -> Result<BTreeMap<String, Split>> {
    let mut map = BTreeMap::new();
    for list in lists {
        let split = split_of_list(list, fallback);
        let text = std::fs::read_to_string(list)
            .with_context(|| format!("cannot read split list {}", list.display()))?;
        for id in text
            .lines()
            .map(|l| l.split('#').next().unwrap_or("").trim())
            .filter(|l| !l.is_empty())
        {
            if let Some(other) = map.insert(id.to_string(), split)
                && other != split
            {
                bail!(
                    "{}: object '{id}' is in the {} split and the {} split",
                    list.display(),
                    other.name(),
                    split.name()
                );
            }
        }
    }
    Ok(map)
}

/// Finds every mesh under `dir` and reads each once (in parallel) to validate it before anything
/// is written, so a bad file stops the run early with its name and nothing half-made is left.
fn mesh_jobs(dir: &Path, split: Split, split_lists: &[PathBuf]) -> Result<Vec<Job>> {
    let entries = std::fs::read_dir(dir)
        .with_context(|| format!("cannot read mesh directory {}", dir.display()))?;
    let mut folders: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_dir())
        .collect();
    folders.sort();
    if folders.is_empty() {
        bail!(
            "{}: expected sub-folders named after categories (e.g. chair/ or 03001627/) holding meshes",
            dir.display()
        );
    }
    let lists = read_split_lists(split_lists, split)?;
    let mut jobs: Vec<Job> = Vec::new();
    let mut skipped = 0;
    for folder in folders {
        let name = folder
            .file_name()
            .unwrap_or_default()
            .to_string_lossy()
            .into_owned();
        let category: Category = name
            .parse()
            .map_err(|e: String| anyhow::anyhow!("{}: {e}", folder.display()))?;
        let meshes = category_meshes(&folder)?;
        if meshes.is_empty() {
            bail!(
                "{}: no meshes (.obj, .off, .ply, .stl, or ShapeNet's <id>/model.obj or <id>/models/model_normalized.obj)",
                folder.display()
            );
        }
        meshes
            .par_iter()
            .try_for_each(|(_, path)| normalized(path).map(drop))?;
        for (id, path) in meshes {
            let split = if lists.is_empty() {
                split
            } else if let Some(s) = lists.get(&id) {
                *s
            } else {
                skipped += 1;
                continue;
            };
            let object = (id, Source::MeshFile(path));
            match jobs
                .iter_mut()
                .find(|j| j.category == category && j.split == split)
            {
                Some(job) => job.objects.push(object),
                None => jobs.push(Job {
                    category,
                    split,
                    objects: vec![object],
                }),
            }
        }
    }
    if skipped > 0 {
        tracing::info!("{skipped} meshes are in no split list and were skipped");
    }
    jobs.sort_by_key(|j| (j.category, j.split.index()));
    Ok(jobs)
}
