//! One object of a dataset in the form both training and evaluation read, so that neither
//! depends on the other's types.

use std::sync::Arc;

use crate::data::dataset::ObjectSet;
use crate::data::image::Silhouette;
use crate::geometry::NUM_VIEWS;
use crate::probe::Supervision;

/// An object as the method sees it: its 24 input images and its silhouette supervision. What
/// training samples probes and input views from, and what evaluation encodes and projects.
///
/// Pictures and silhouettes are shared (`Arc`): a clone (the training pool gathers every
/// category's objects) copies two pointers, not 0.4 MB of data per object. The silhouettes are
/// views of the pictures' alpha planes, so an object's memory is its 24 RGBA pictures and
/// nothing else.
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
        let size = set.image_size;
        let n = NUM_VIEWS * 4 * size * size;
        let images: Arc<[u8]> = set.images[i * n..(i + 1) * n].into();
        let plane = size * size;
        let silhouettes = (0..NUM_VIEWS)
            .map(|v| Silhouette::shared_alpha(size, images.clone(), (4 * v + 3) * plane))
            .collect();
        Self {
            images,
            image_size: size,
            supervision: Arc::new(Supervision::nmr(silhouettes)),
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::Category;
    use crate::data::dataset::Split;

    #[test]
    fn silhouettes_view_the_alpha_planes_of_the_object_they_belong_to() {
        let mut set = ObjectSet::new(Category::Chair, Split::Train);
        set.image_size = 8;
        let n = NUM_VIEWS * 4 * 64;
        set.images = (0..3 * n).map(|i| (i * 7 % 251) as u8).collect();
        for i in 0..3 {
            let object = ObjectViews::from_set(&set, i);
            assert_eq!(
                object.supervision.silhouettes,
                set.silhouettes(i),
                "object {i}"
            );
            assert_eq!(&object.images[..], &set.images[i * n..(i + 1) * n]);
        }
    }
}
