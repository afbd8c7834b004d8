//! DVR's folder layout of the NMR data (`NMR_Dataset/`):
//!
//! ```text
//! <root>/<synset>/softras_{train,val,test}.lst     object ids, one a line
//! <root>/<synset>/<id>/image/0000.png … 0023.png   RGB, composited over white
//! <root>/<synset>/<id>/mask/0000.png … 0023.png    silhouette, 8-bit grey
//! <root>/<synset>/<id>/cameras.npz                 world_mat_i, camera_mat_i (i = 0..23)
//! ```
//!
//! The images were rendered with the same 24 NMR cameras as Kato's npz files, so the reader takes
//! the geometry from [`crate::geometry::Camera::nmr`] and only checks that `cameras.npz` holds the
//! 24 `world_mat_i` entries; the matrices themselves are not interpreted. PNG colours are natural
//! (not inverted); the reader converts them to Kato's in-memory convention so that one
//! [`ObjectSet`] serves both layouts. DVR's layout has no 32³ voxels, so `voxels` is `None`.

use std::path::{Path, PathBuf};

use image::{GrayImage, RgbImage};

use super::npy::{NpyArray, read_npz, write_npz};
use super::{ObjectSet, Split};
use crate::category::Category;
use crate::geometry::Camera;
use crate::geometry::camera::NUM_VIEWS;
use crate::{Error, Result};

fn split_list(root: &Path, category: Category, split: Split) -> PathBuf {
    root.join(category.synset())
        .join(format!("softras_{}.lst", split.name()))
}

fn view_file(obj: &Path, folder: &str, view: usize) -> PathBuf {
    obj.join(folder).join(format!("{view:04}.png"))
}

fn image_error(path: &Path, e: image::ImageError) -> Error {
    Error::format(path, format!("cannot read PNG: {e}"))
}

/// Reads `category`/`split` from a DVR-layout root.
pub fn read(root: &Path, category: Category, split: Split) -> Result<ObjectSet> {
    let list = split_list(root, category, split);
    let text = std::fs::read_to_string(&list).map_err(|e| Error::io(&list, e))?;
    let ids: Vec<String> = text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .map(String::from)
        .collect();
    let mut set = ObjectSet::new(category, split);
    set.voxels = None;
    for id in &ids {
        let obj = root.join(category.synset()).join(id);
        let cams = obj.join("cameras.npz");
        let arrays = read_npz(&cams)?;
        if let Some(v) = (0..NUM_VIEWS).find(|v| !arrays.contains_key(&format!("world_mat_{v}"))) {
            return Err(Error::format(&cams, format!("missing key 'world_mat_{v}'")));
        }
        let mut first_size = None;
        for v in 0..NUM_VIEWS {
            let ipath = view_file(&obj, "image", v);
            let mpath = view_file(&obj, "mask", v);
            let rgb = image::open(&ipath)
                .map_err(|e| image_error(&ipath, e))?
                .to_rgb8();
            let mask = image::open(&mpath)
                .map_err(|e| image_error(&mpath, e))?
                .to_luma8();
            let s = rgb.width() as usize;
            let size = *first_size.get_or_insert(s);
            if rgb.height() as usize != s || s != size || mask.dimensions() != rgb.dimensions() {
                return Err(Error::format(
                    &mpath,
                    format!(
                        "image {:?} and mask {:?} must be square and of one size ({size})",
                        rgb.dimensions(),
                        mask.dimensions()
                    ),
                ));
            }
            set.image_size = s;
            set.images.extend(super::kato_planes(&rgb, &mask));
        }
        set.ids.push(id.clone());
    }
    Ok(set)
}

/// Writes `set` in DVR's layout under `root` (PNG images and masks, cameras, split list).
pub fn write(root: &Path, set: &ObjectSet) -> Result<()> {
    let s = set.image_size;
    let plane = s * s;
    for (i, id) in set.ids.iter().enumerate() {
        let obj = root.join(set.category.synset()).join(id);
        for v in 0..NUM_VIEWS {
            let planes = set.view_rgba(i, v);
            let rgb = RgbImage::from_fn(s as u32, s as u32, |x, y| {
                let p = y as usize * s + x as usize;
                image::Rgb([0, 1, 2].map(|ch| 255 - planes[ch * plane + p]))
            });
            let mask = GrayImage::from_raw(s as u32, s as u32, planes[3 * plane..].to_vec())
                .expect("mask plane has S² bytes");
            for (folder, img) in [
                ("image", image::DynamicImage::from(rgb)),
                ("mask", mask.into()),
            ] {
                let path = view_file(&obj, folder, v);
                super::write_atomic(&path, |w| {
                    img.write_to(w, image::ImageFormat::Png)
                        .map_err(std::io::Error::other)
                })?;
            }
        }
        // World-to-camera rows (x_c, y_c, z_c) and a pinhole intrinsic with focal 1/tan(15°) in
        // NDC; recorded for completeness, the reader relies on the fixed NMR cameras.
        let mut mats: Vec<(String, NpyArray)> = Vec::new();
        for v in 0..NUM_VIEWS {
            let c = Camera::nmr(v);
            let t = [-c.right.dot(c.eye), -c.up.dot(c.eye), -c.forward.dot(c.eye)];
            let world = [
                c.right.x,
                c.right.y,
                c.right.z,
                t[0],
                c.up.x,
                c.up.y,
                c.up.z,
                t[1],
                c.forward.x,
                c.forward.y,
                c.forward.z,
                t[2],
                0.0,
                0.0,
                0.0,
                1.0,
            ];
            let f = 1.0 / c.tan_half_fov;
            let cam = [f, 0., 0., 0., 0., f, 0., 0., 0., 0., 1., 0., 0., 0., 0., 1.];
            mats.push((
                format!("world_mat_{v}"),
                NpyArray::from_f32(vec![4, 4], &world),
            ));
            mats.push((
                format!("camera_mat_{v}"),
                NpyArray::from_f32(vec![4, 4], &cam),
            ));
        }
        let refs: Vec<(&str, &NpyArray)> = mats.iter().map(|(k, a)| (k.as_str(), a)).collect();
        write_npz(&obj.join("cameras.npz"), &refs)?;
    }
    let list = set.ids.join("\n") + "\n";
    super::write_atomic(&split_list(root, set.category, set.split), |w| {
        std::io::Write::write_all(w, list.as_bytes())
    })
}
