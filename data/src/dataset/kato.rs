//! Kato's npz layout: `{synset}_{split}_images.npz` (`arr_0`, uint8 `(N, 24, 4, 64, 64)`) and
//! `{synset}_{split}_voxels.npz` (`arr_0`, bool `(N, 32, 32, 32)`).
//!
//! Voxel axis order is exactly what NMR's evaluation compares: it voxelizes a prediction into
//! `pred[x][y][z]` and compares `pred.transpose(0, 2, 1, 3)[:, :, :, ::-1]` with the file, so file
//! voxel `[a][b][c]` is world voxel `[x = b][y = a][z = R − 1 − c]`, whose centre is
//! `((b − 15.5)/31, (a − 15.5)/31, (15.5 − c)/31)` at `R = 32`.

use std::path::{Path, PathBuf};

use super::npy::{DType, NpyArray, read_npz_key, write_npz};
use super::{ObjectSet, Split};
use crate::category::Category;
use crate::geometry::camera::NUM_VIEWS;
use crate::grid::VoxelGrid;
use crate::{Error, Result};

/// Path of the images file of `category`/`split` under `dir`.
pub fn images_path(dir: &Path, category: Category, split: Split) -> PathBuf {
    dir.join(format!("{}_{}_images.npz", category.synset(), split.name()))
}

/// Path of the voxels file of `category`/`split` under `dir`.
pub fn voxels_path(dir: &Path, category: Category, split: Split) -> PathBuf {
    dir.join(format!("{}_{}_voxels.npz", category.synset(), split.name()))
}

/// Path of our object-id list (not part of Kato's distribution; optional on read).
pub fn ids_path(dir: &Path, category: Category, split: Split) -> PathBuf {
    dir.join(format!("{}_{}_ids.txt", category.synset(), split.name()))
}

/// File `[a][b][c]` → world `[x][y][z]` (see the module docs).
pub fn voxels_from_file_layout(file: &[bool], r: usize) -> VoxelGrid {
    let mut g = VoxelGrid::empty(r);
    for a in 0..r {
        for b in 0..r {
            for c in 0..r {
                g.set(b, a, r - 1 - c, file[(a * r + b) * r + c]);
            }
        }
    }
    g
}

/// World `[x][y][z]` → file `[a][b][c]`.
pub fn voxels_to_file_layout(g: &VoxelGrid) -> Vec<bool> {
    let r = g.resolution();
    let mut out = vec![false; r * r * r];
    for a in 0..r {
        for b in 0..r {
            for c in 0..r {
                out[(a * r + b) * r + c] = g.get(b, a, r - 1 - c);
            }
        }
    }
    out
}

/// Writes `set` as Kato's two npz files (and our id list) under `dir`, atomically.
pub fn write(dir: &Path, set: &ObjectSet) -> Result<()> {
    let n = set.len();
    let s = set.image_size;
    let images = NpyArray::from_u8(vec![n, NUM_VIEWS, 4, s, s], set.images.clone());
    write_npz(
        &images_path(dir, set.category, set.split),
        &[("arr_0", &images)],
    )?;
    if let Some(v) = &set.voxels {
        let r = set.voxel_res;
        let voxels = NpyArray::from_bool(vec![n, r, r, r], v);
        write_npz(
            &voxels_path(dir, set.category, set.split),
            &[("arr_0", &voxels)],
        )?;
    }
    let ids = set.ids.join("\n") + "\n";
    super::write_atomic(&ids_path(dir, set.category, set.split), |w| {
        std::io::Write::write_all(w, ids.as_bytes())
    })
}

/// Reads `category`/`split` from `dir`. Voxels are read when `with_voxels` (an error if the file
/// is missing then). Errors name the file and the key.
pub fn read(dir: &Path, category: Category, split: Split, with_voxels: bool) -> Result<ObjectSet> {
    let ipath = images_path(dir, category, split);
    if !ipath.is_file() {
        return Err(Error::io(
            &ipath,
            std::io::Error::new(std::io::ErrorKind::NotFound, "images file not found"),
        ));
    }
    let images = read_npz_key(&ipath, "arr_0")?;
    images.expect(
        &ipath,
        "arr_0",
        DType::U8,
        &[None, Some(NUM_VIEWS), Some(4), None, None],
    )?;
    let (n, s) = (images.shape[0], images.shape[3]);
    if images.shape[4] != s {
        return Err(Error::format(
            &ipath,
            format!("key 'arr_0': images are not square: {:?}", images.shape),
        ));
    }
    let voxels = if with_voxels {
        let vpath = voxels_path(dir, category, split);
        let v = read_npz_key(&vpath, "arr_0")?;
        v.expect(&vpath, "arr_0", DType::Bool, &[Some(n), None, None, None])?;
        let r = v.shape[1];
        if v.shape[2] != r || v.shape[3] != r {
            return Err(Error::format(
                &vpath,
                format!("key 'arr_0': voxels are not cubic: {:?}", v.shape),
            ));
        }
        Some((v.data.iter().map(|&b| b != 0).collect::<Vec<_>>(), r))
    } else {
        None
    };
    let id_file = ids_path(dir, category, split);
    let ids = match std::fs::read_to_string(&id_file) {
        Ok(text) => text.lines().map(str::to_string).collect::<Vec<_>>(),
        Err(_) => (0..n)
            .map(|i| format!("{}_{}_{i:05}", category.synset(), split.name()))
            .collect(),
    };
    if ids.len() != n {
        return Err(Error::format(
            &id_file,
            format!("{} ids for {n} objects", ids.len()),
        ));
    }
    let (voxels, voxel_res) = match voxels {
        Some((v, r)) => (Some(v), r),
        None => (None, super::VOXEL_RES),
    };
    Ok(ObjectSet {
        category,
        split,
        images: images.data,
        image_size: s,
        voxels,
        voxel_res,
        ids,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn file_layout_round_trips_and_matches_nmr_transpose() {
        let r = 4;
        let g = VoxelGrid::from_fn(r, |i, j, k, _| (i * 7 + j * 3 + k) % 5 == 0);
        let f = voxels_to_file_layout(&g);
        assert_eq!(voxels_from_file_layout(&f, r), g);
        // file[a][b][c] = pred[b][a][R-1-c]
        for (a, b, c) in [(0, 1, 2), (3, 0, 0), (1, 2, 3)] {
            assert_eq!(f[(a * r + b) * r + c], g.get(b, a, r - 1 - c));
        }
    }
}
