//! One object of a dataset in the form both training and evaluation read, so that neither
//! depends on the other's types.

use std::sync::Arc;

use crate::data::dataset::ObjectSet;
use crate::geometry::NUM_VIEWS;
use crate::probe::Supervision;

/// An object as the method sees it: its 24 input images and its silhouette supervision. What
/// training samples probes and input views from, and what evaluation encodes and projects.
///
/// Pictures and silhouettes are shared (`Arc`): a clone (the training pool gathers every
/// category's objects) copies two pointers, not 0.8 MB of data per object.
#[derive(Clone, Debug)]
pub struct ObjectViews {
    /// `[24, 4, S, S]` uint8 in Kato's convention.
    pub images: Arc<[u8]>,
    pub image_size: usize,
    pub supervision: Arc<Supervision>,
}

impl ObjectViews {
    /// Object `i` of a dataset set.
    pub fn from_set(set: &ObjectSet, i: usize) -> Self {
        let n = NUM_VIEWS * 4 * set.image_size * set.image_size;
        Self {
            images: set.images[i * n..(i + 1) * n].into(),
            image_size: set.image_size,
            supervision: Arc::new(Supervision::nmr(set.silhouettes(i))),
        }
    }

    /// View `v` as `[4, S, S]` floats in `[0, 1]`.
    pub fn view(&self, v: usize) -> impl Iterator<Item = f32> + '_ {
        let n = 4 * self.image_size * self.image_size;
        self.images[v * n..(v + 1) * n]
            .iter()
            .map(|&b| b as f32 / 255.0)
    }
}
