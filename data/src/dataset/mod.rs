//! Datasets in the published layouts, and the in-memory form every layout reads into.
//!
//! * [`kato`] — Kato's npz distribution used by NMR, SoftRas and the paper
//!   (`{synset}_{split}_images.npz`, `{synset}_{split}_voxels.npz`).
//! * [`dvr`] — DVR's folder layout (`<synset>/<id>/{image,mask}/0000.png`, `cameras.npz`,
//!   `softras_{split}.lst`).
//!
//! Both read into an [`ObjectSet`]: one category × split, images in Kato's convention
//! (`(N, 24, 4, 64, 64)` uint8, RGB composited over white then inverted, alpha = silhouette) and
//! optional voxels. Files we generate go through the same readers as the published files.

pub mod dvr;
pub mod kato;
pub mod npy;

use std::fmt;
use std::io::Write;
use std::path::Path;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use super::category::Category;
use super::grid::VoxelGrid;
use super::image::Silhouette;
use super::mesh::TriMesh;
use super::render::{RenderOptions, RenderedView, render_nmr_views};
use super::voxelize::Voxelizer;
use crate::geometry::camera::{NMR_IMAGE_SIZE, NUM_VIEWS};
use crate::{Error, Result};

/// Re-exported from [`crate::io`], where it lives for every writer of the crate.
pub use crate::io::write_atomic;

/// Voxel resolution of the published ground truth.
pub const VOXEL_RES: usize = 32;

/// A dataset split.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Split {
    Train,
    Val,
    Test,
}

impl Split {
    pub const ALL: [Split; 3] = [Split::Train, Split::Val, Split::Test];

    pub fn name(self) -> &'static str {
        match self {
            Split::Train => "train",
            Split::Val => "val",
            Split::Test => "test",
        }
    }

    /// 0, 1, 2: used to decorrelate procedural seeds across splits.
    pub fn index(self) -> u64 {
        self as u64
    }
}

impl fmt::Display for Split {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Split {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|x| x.name() == s)
            .ok_or_else(|| format!("unknown split '{s}': expected train, val or test"))
    }
}

/// One category × split in memory.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectSet {
    pub category: Category,
    pub split: Split,
    /// `(N, 24, 4, S, S)` uint8 in Kato's convention.
    pub images: Vec<u8>,
    /// Image side `S` (64 for the published data).
    pub image_size: usize,
    /// `(N, R, R, R)` bool in Kato's file axis order, if the layout has voxels.
    pub voxels: Option<Vec<bool>>,
    /// Voxel resolution `R` (32).
    pub voxel_res: usize,
    /// Object identifiers, if the layout has them (DVR's ids; our `{category}_{split}_{i}`).
    pub ids: Vec<String>,
}

impl ObjectSet {
    /// An empty set.
    pub fn new(category: Category, split: Split) -> Self {
        Self {
            category,
            split,
            images: Vec::new(),
            image_size: NMR_IMAGE_SIZE,
            voxels: Some(Vec::new()),
            voxel_res: VOXEL_RES,
            ids: Vec::new(),
        }
    }

    fn view_len(&self) -> usize {
        4 * self.image_size * self.image_size
    }

    /// Number of objects.
    pub fn len(&self) -> usize {
        self.images.len() / (NUM_VIEWS * self.view_len())
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The `(4, S, S)` RGBA planes of view `view` of object `i`.
    pub fn view_rgba(&self, i: usize, view: usize) -> &[u8] {
        let n = self.view_len();
        let at = (i * NUM_VIEWS + view) * n;
        &self.images[at..at + n]
    }

    /// The silhouette (alpha plane) of view `view` of object `i`.
    pub fn silhouette(&self, i: usize, view: usize) -> Silhouette {
        let plane = self.image_size * self.image_size;
        Silhouette::from_u8(self.image_size, &self.view_rgba(i, view)[3 * plane..])
    }

    /// All 24 silhouettes of object `i`.
    pub fn silhouettes(&self, i: usize) -> Vec<Silhouette> {
        (0..NUM_VIEWS).map(|v| self.silhouette(i, v)).collect()
    }

    /// Ground-truth voxels of object `i` in world axes (`[x][y][z]`), if the set has voxels.
    pub fn voxel_grid(&self, i: usize) -> Option<VoxelGrid> {
        let r = self.voxel_res;
        let n = r * r * r;
        let file = &self.voxels.as_ref()?[i * n..(i + 1) * n];
        Some(kato::voxels_from_file_layout(file, r))
    }

    /// Appends one object.
    pub fn push(&mut self, id: String, record: &ObjectRecord) {
        assert_eq!(record.images.len(), NUM_VIEWS * self.view_len());
        self.images.extend_from_slice(&record.images);
        if let Some(v) = &mut self.voxels {
            v.extend(kato::voxels_to_file_layout(&record.voxels));
        }
        self.ids.push(id);
    }
}

/// Everything the dataset holds for one object, made from its mesh.
#[derive(Clone, Debug)]
pub struct ObjectRecord {
    /// `(24, 4, 64, 64)` uint8, Kato's convention.
    pub images: Vec<u8>,
    /// Solid voxels, world axes.
    pub voxels: VoxelGrid,
}

impl ObjectRecord {
    /// Renders the 24 NMR views of a unit-cube mesh and voxelizes it.
    pub fn from_mesh(mesh: &TriMesh, voxelizer: Voxelizer, opts: &RenderOptions) -> Self {
        let views = render_nmr_views(mesh, opts);
        let images = views.iter().flat_map(encode_kato_view).collect();
        Self {
            images,
            voxels: voxelizer.voxelize(mesh, VOXEL_RES),
        }
    }
}

/// One rendered view as Kato's `(4, S, S)` planes: RGB composited over white then inverted
/// (`255·(1 − c)·α`, so the background is 0), alpha = coverage.
pub fn encode_kato_view(view: &RenderedView) -> Vec<u8> {
    let plane = view.alpha.len();
    let mut out = vec![0u8; 4 * plane];
    for (p, c) in view.over_white().enumerate() {
        for ch in 0..3 {
            out[ch * plane + p] = to_u8(1.0 - c[ch]);
        }
        out[3 * plane + p] = to_u8(view.alpha.get(p));
    }
    out
}

/// A natural-colour RGB image (composited over white) and its 8-bit mask as Kato's `(4, S, S)`
/// planes: RGB inverted (`255 − c`, so a white background becomes 0) and the mask as alpha. The
/// in-memory convention every reader converts to (DVR's PNGs, images given to `reconstruct`).
pub fn kato_planes(rgb: &image::RgbImage, mask: &image::GrayImage) -> Vec<u8> {
    assert_eq!(rgb.dimensions(), mask.dimensions(), "image and mask sizes");
    let plane = mask.as_raw().len();
    let mut planes = vec![0u8; 4 * plane];
    for (p, px) in rgb.pixels().enumerate() {
        for ch in 0..3 {
            planes[ch * plane + p] = 255 - px[ch];
        }
    }
    planes[3 * plane..].copy_from_slice(mask.as_raw());
    planes
}

/// `[0, 1]` → `0..=255`, rounded.
pub fn to_u8(x: f32) -> u8 {
    (x.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// What made a dataset, written beside it as `dataset.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DatasetInfo {
    /// `procedural` or `meshes`.
    pub source: String,
    /// Seed of the procedural generator (absent for meshes).
    pub seed: Option<u64>,
    /// Which voxelization made the ground truth.
    pub voxelizer: Voxelizer,
    /// Sub-pixels per pixel side used for anti-aliased alpha.
    pub supersample: usize,
    /// Layout written (`kato`).
    pub layout: String,
    /// Objects per category and split.
    pub objects: Vec<SplitCount>,
}

/// Number of objects in one category × split.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SplitCount {
    pub category: Category,
    pub synset: String,
    pub split: Split,
    pub count: usize,
}

impl DatasetInfo {
    pub const FILE: &'static str = "dataset.json";

    pub fn write(&self, dir: &Path) -> Result<()> {
        let text = serde_json::to_string_pretty(self).expect("DatasetInfo serializes");
        write_atomic(&dir.join(Self::FILE), |w| w.write_all(text.as_bytes()))
    }

    pub fn read(dir: &Path) -> Result<Self> {
        let path = dir.join(Self::FILE);
        let text = std::fs::read_to_string(&path).map_err(|e| Error::io(&path, e))?;
        serde_json::from_str(&text).map_err(|e| Error::format(&path, e.to_string()))
    }
}

/// A dataset layout on disk.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Layout {
    Kato,
    Dvr,
}

/// The category × split sets present under `dir`, in either layout, sorted.
pub fn discover(dir: &Path) -> Result<Vec<(Category, Split, Layout)>> {
    let entries = std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))?;
    let mut found = Vec::new();
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        if let Some(stem) = name.strip_suffix("_images.npz") {
            let mut parts = stem.splitn(2, '_');
            let (Some(syn), Some(split)) = (parts.next(), parts.next()) else {
                continue;
            };
            if let (Some(c), Ok(s)) = (Category::from_synset(syn), split.parse()) {
                found.push((c, s, Layout::Kato));
            }
        } else if let Some(c) = Category::from_synset(&name) {
            for s in Split::ALL {
                if entry
                    .path()
                    .join(format!("softras_{}.lst", s.name()))
                    .is_file()
                {
                    found.push((c, s, Layout::Dvr));
                }
            }
        }
    }
    found.sort();
    Ok(found)
}

/// Reads one discovered set (voxels too where the layout has them).
pub fn read_set(dir: &Path, category: Category, split: Split, layout: Layout) -> Result<ObjectSet> {
    match layout {
        Layout::Kato => kato::read(
            dir,
            category,
            split,
            kato::voxels_path(dir, category, split).is_file(),
        ),
        Layout::Dvr => dvr::read(dir, category, split),
    }
}
