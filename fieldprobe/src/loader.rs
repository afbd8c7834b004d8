//! Loading an experiment's data: generating it on first use, then training and evaluation objects
//! per category through the one dataset reader.

use std::path::Path;

use anyhow::{Context, Result, bail};
use fieldprobe_core::data::dataset::{Layout, ObjectSet, Split, discover, read_set};
use fieldprobe_core::data::{Category, VoxelGrid};
use fieldprobe_core::object::ObjectViews;

use crate::experiment::{DataConfig, Experiment};
use crate::make::{DatasetSpec, make_dataset};

/// One category's objects.
#[derive(Debug)]
pub struct CategoryData {
    pub category: Category,
    pub train: Vec<ObjectViews>,
    /// Ground truth of the training objects (for the 3D-supervised reference only).
    pub train_gt: Vec<VoxelGrid>,
    pub eval: Vec<ObjectViews>,
    pub eval_gt: Vec<VoxelGrid>,
    pub eval_ids: Vec<String>,
}

/// Makes the procedural dataset if the experiment asks for it and it is not there yet.
pub fn ensure_dataset(exp: &Experiment) -> Result<()> {
    let d = &exp.data;
    let Some(g) = d.generate else { return Ok(()) };
    let present = d.dir.is_dir() && !discover(&d.dir)?.is_empty();
    if present {
        return Ok(());
    }
    tracing::info!(
        "data: generating {} into {}",
        d.categories
            .iter()
            .map(|c| c.name())
            .collect::<Vec<_>>()
            .join(","),
        d.dir.display()
    );
    let spec = DatasetSpec::procedural(&d.dir, &d.categories, [g.train, g.val, g.test], g.seed);
    make_dataset(&spec).map(|_| ())
}

fn read(d: &DataConfig, category: Category, split: Split) -> Result<ObjectSet> {
    let layouts: Vec<Layout> = discover(&d.dir)?
        .into_iter()
        .filter(|&(c, s, _)| c == category && s == split)
        .map(|(_, _, l)| l)
        .collect();
    let Some(&layout) = layouts.first() else {
        bail!(
            "{}: no {} {} set (expected {}_{}_images.npz or {}/softras_{}.lst)",
            d.dir.display(),
            category,
            split,
            category.synset(),
            split,
            category.synset(),
            split
        );
    };
    read_set(&d.dir, category, split, layout).map_err(Into::into)
}

fn voxels(set: &ObjectSet, i: usize, path: &Path) -> Result<VoxelGrid> {
    set.voxel_grid(i).with_context(|| {
        format!(
            "{}: {} {} has no voxels; evaluation needs them",
            path.display(),
            set.category,
            set.split
        )
    })
}

/// Loads every category of the experiment.
pub fn load(exp: &Experiment) -> Result<Vec<CategoryData>> {
    let d = &exp.data;
    let mut out = Vec::new();
    for &category in &d.categories {
        let eval_set = read(d, category, d.eval_split)?;
        let mut eval_idx: Vec<usize> = (0..eval_set.len()).collect();
        if let Some(m) = d.max_eval_objects {
            eval_idx.truncate(m);
        }
        let (train_set, mut train_idx) = match d.object {
            Some(o) => {
                if o >= eval_set.len() {
                    bail!(
                        "data.object = {o}, but {} {} has {} objects",
                        category,
                        d.eval_split,
                        eval_set.len()
                    );
                }
                eval_idx = vec![o];
                (eval_set.clone(), vec![o])
            }
            None => {
                let t = read(d, category, Split::Train)?;
                let n = t.len();
                (t, (0..n).collect())
            }
        };
        if let Some(m) = d.max_train_objects {
            train_idx.truncate(m);
        }
        if train_idx.is_empty() || eval_idx.is_empty() {
            bail!(
                "{}: {} has no training or no evaluation objects",
                d.dir.display(),
                category
            );
        }
        out.push(CategoryData {
            category,
            train: train_idx
                .iter()
                .map(|&i| ObjectViews::from_set(&train_set, i))
                .collect(),
            train_gt: train_idx
                .iter()
                .map(|&i| voxels(&train_set, i, &d.dir))
                .collect::<Result<_>>()?,
            eval: eval_idx
                .iter()
                .map(|&i| ObjectViews::from_set(&eval_set, i))
                .collect(),
            eval_gt: eval_idx
                .iter()
                .map(|&i| voxels(&eval_set, i, &d.dir))
                .collect::<Result<_>>()?,
            eval_ids: eval_idx.iter().map(|&i| eval_set.ids[i].clone()).collect(),
        });
    }
    Ok(out)
}
