//! A PNG contact sheet: a few objects per category, eight of their 24 views each, for a quick look.

use std::path::Path;

use anyhow::Result;
use fieldprobe_core::data::dataset::ObjectSet;
use fieldprobe_core::geometry::NUM_VIEWS;
use image::{Rgb, RgbImage};

use crate::plot::{grid, write_png};

/// Views shown per object (every third of the 24, a full turn).
const VIEWS: [usize; 8] = [0, 3, 6, 9, 12, 15, 18, 21];
/// Each 64-pixel view is shown at this zoom.
const ZOOM: u32 = 2;
const GAP: u32 = 4;

/// Writes a sheet with up to `per_category` objects of each category (from the first set of each
/// category), one row per object; colours are un-inverted back to natural, over white.
pub fn write(path: &Path, sets: &[ObjectSet], per_category: usize) -> Result<()> {
    let mut rows: Vec<(&ObjectSet, usize)> = Vec::new();
    let mut seen = Vec::new();
    for set in sets {
        if seen.contains(&set.category) || set.is_empty() {
            continue;
        }
        seen.push(set.category);
        rows.extend((0..set.len().min(per_category)).map(|i| (set, i)));
    }
    let s = sets.first().map_or(64, |s| s.image_size) as u32;
    let plane = (s * s) as usize;
    let panels: Vec<Vec<RgbImage>> = rows
        .iter()
        .map(|(set, i)| {
            VIEWS
                .iter()
                .map(|&v| {
                    debug_assert!(v < NUM_VIEWS);
                    let planes = set.view_rgba(*i, v);
                    RgbImage::from_fn(s * ZOOM, s * ZOOM, |x, y| {
                        let p = ((y / ZOOM) * s + x / ZOOM) as usize;
                        // Kato's RGB is 255 − (colour over white); invert back.
                        Rgb([0, 1, 2].map(|ch| 255 - planes[ch * plane + p]))
                    })
                })
                .collect()
        })
        .collect();
    write_png(path, &grid(&panels, GAP, Rgb([40, 40, 48])))
}
