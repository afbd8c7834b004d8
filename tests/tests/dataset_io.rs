//! The published layouts: what we write is what the readers read, one reader serves both, and
//! malformed files give errors that name the file and the key.

use fieldprobe_core::data::Category;
use fieldprobe_core::data::dataset::npy::{NpyArray, write_npz};
use fieldprobe_core::data::dataset::{
    Layout, ObjectRecord, ObjectSet, Split, discover, dvr, kato, read_set,
};
use fieldprobe_core::data::procedural::{generate, object_rng};
use fieldprobe_core::data::render::RenderOptions;
use fieldprobe_core::data::voxelize::Voxelizer;

fn small_set(category: Category, split: Split, n: usize) -> (ObjectSet, Vec<ObjectRecord>) {
    let opts = RenderOptions {
        supersample: 2,
        ..Default::default()
    };
    let mut set = ObjectSet::new(category, split);
    let mut records = Vec::new();
    for i in 0..n {
        let mesh = generate(
            category,
            &mut object_rng(3, category, split.index(), i as u64),
        );
        let rec = ObjectRecord::from_mesh(&mesh, Voxelizer::Nmr, &opts);
        set.push(format!("obj{i}"), &rec);
        records.push(rec);
    }
    (set, records)
}

#[test]
fn kato_layout_round_trips_with_published_shapes_and_axis_order() {
    let dir = tempfile::tempdir().unwrap();
    let (set, records) = small_set(Category::Table, Split::Val, 2);
    kato::write(dir.path(), &set).unwrap();
    assert!(dir.path().join("04379243_val_images.npz").is_file());
    assert!(dir.path().join("04379243_val_voxels.npz").is_file());
    let back = kato::read(dir.path(), Category::Table, Split::Val, true).unwrap();
    assert_eq!(back, set);
    for (i, rec) in records.iter().enumerate() {
        assert_eq!(
            back.voxel_grid(i).unwrap(),
            rec.voxels,
            "world-axis voxels survive the file layout"
        );
    }
    // Raw shapes and dtypes as NumPy sees them.
    let images = fieldprobe_core::data::dataset::npy::read_npz_key(
        &kato::images_path(dir.path(), Category::Table, Split::Val),
        "arr_0",
    )
    .unwrap();
    assert_eq!(images.shape, vec![2, 24, 4, 64, 64]);
    assert_eq!(images.dtype.descr(), "|u1");
    let voxels = fieldprobe_core::data::dataset::npy::read_npz_key(
        &kato::voxels_path(dir.path(), Category::Table, Split::Val),
        "arr_0",
    )
    .unwrap();
    assert_eq!(voxels.shape, vec![2, 32, 32, 32]);
    assert_eq!(voxels.dtype.descr(), "|b1");
    // A table stands on the ground: in the file, axis 0 is world y, so the lowest file layer
    // a = 0 (y ≈ −0.5) holds legs and the top of the table is near the highest occupied layer.
    let g = back.voxel_grid(0).unwrap();
    let layer = |y: usize| {
        (0..32)
            .flat_map(|x| (0..32).map(move |z| (x, z)))
            .filter(|&(x, z)| g.get(x, y, z))
            .count()
    };
    let top = (0..32).rev().find(|&y| layer(y) > 0).unwrap();
    let bottom = (0..32).find(|&y| layer(y) > 0).unwrap();
    assert!(
        layer(top) > 3 * layer(bottom),
        "table top ({}) wider than its feet ({})",
        layer(top),
        layer(bottom)
    );
}

#[test]
fn background_is_zero_and_alpha_is_the_silhouette() {
    let (set, _) = small_set(Category::Car, Split::Test, 1);
    let v = set.view_rgba(0, 0);
    let plane = 64 * 64;
    assert_eq!(
        [v[0], v[plane], v[2 * plane]],
        [0, 0, 0],
        "corner pixel's RGB: inverted white is 0"
    );
    assert_eq!(v[3 * plane], 0);
    let covered = (0..plane).filter(|&p| v[3 * plane + p] == 255).count();
    assert!(covered > 100, "the car covers pixels fully");
    // Where alpha is full, inverted shaded colour is non-zero (the surface is not white).
    let p = (0..plane).find(|&p| v[3 * plane + p] == 255).unwrap();
    assert!(v[p] > 0);
}

#[test]
fn dvr_layout_reads_into_the_same_object_set() {
    let dir = tempfile::tempdir().unwrap();
    let (set, _) = small_set(Category::Chair, Split::Test, 2);
    dvr::write(dir.path(), &set).unwrap();
    assert!(dir.path().join("03001627/obj0/image/0000.png").is_file());
    assert!(dir.path().join("03001627/obj1/mask/0023.png").is_file());
    assert!(dir.path().join("03001627/softras_test.lst").is_file());
    let back = dvr::read(dir.path(), Category::Chair, Split::Test).unwrap();
    assert_eq!(back.images, set.images);
    assert_eq!(back.ids, set.ids);
    assert!(back.voxels.is_none());
    assert_eq!(
        discover(dir.path()).unwrap(),
        vec![(Category::Chair, Split::Test, Layout::Dvr)]
    );
    let via_discover = read_set(dir.path(), Category::Chair, Split::Test, Layout::Dvr).unwrap();
    assert_eq!(via_discover.silhouettes(1), set.silhouettes(1));

    // A missing mask names the file.
    std::fs::remove_file(dir.path().join("03001627/obj1/mask/0005.png")).unwrap();
    let e = dvr::read(dir.path(), Category::Chair, Split::Test)
        .unwrap_err()
        .to_string();
    assert!(e.contains("0005.png"), "{e}");
}

#[test]
fn malformed_npz_files_name_the_file_and_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Wrong dtype.
    let bad = NpyArray::from_f32(vec![1, 24, 4, 2, 2], &[0.0; 24 * 4 * 4]);
    write_npz(
        &kato::images_path(d, Category::Bench, Split::Train),
        &[("arr_0", &bad)],
    )
    .unwrap();
    let e = kato::read(d, Category::Bench, Split::Train, false)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("02828884_train_images.npz")
            && e.contains("arr_0")
            && e.contains("|u1")
            && e.contains("<f4"),
        "{e}"
    );
    // Wrong shape (23 views).
    let bad = NpyArray::from_u8(vec![1, 23, 4, 2, 2], vec![0; 23 * 16]);
    write_npz(
        &kato::images_path(d, Category::Bench, Split::Train),
        &[("arr_0", &bad)],
    )
    .unwrap();
    let e = kato::read(d, Category::Bench, Split::Train, false)
        .unwrap_err()
        .to_string();
    assert!(e.contains("shape") && e.contains("23"), "{e}");
    // Missing key.
    let ok = NpyArray::from_u8(vec![1, 24, 4, 2, 2], vec![0; 24 * 16]);
    write_npz(
        &kato::images_path(d, Category::Bench, Split::Train),
        &[("images", &ok)],
    )
    .unwrap();
    let e = kato::read(d, Category::Bench, Split::Train, false)
        .unwrap_err()
        .to_string();
    assert!(e.contains("missing key 'arr_0'"), "{e}");
    // Voxels with the wrong object count.
    write_npz(
        &kato::images_path(d, Category::Bench, Split::Train),
        &[("arr_0", &ok)],
    )
    .unwrap();
    let vox = NpyArray::from_bool(vec![2, 32, 32, 32], &vec![false; 2 * 32768]);
    write_npz(
        &kato::voxels_path(d, Category::Bench, Split::Train),
        &[("arr_0", &vox)],
    )
    .unwrap();
    let e = kato::read(d, Category::Bench, Split::Train, true)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("02828884_train_voxels.npz") && e.contains("arr_0"),
        "{e}"
    );
    // Truncated file.
    std::fs::write(
        kato::voxels_path(d, Category::Bench, Split::Train),
        b"PK\x03\x04garbage",
    )
    .unwrap();
    let e = kato::read(d, Category::Bench, Split::Train, true)
        .unwrap_err()
        .to_string();
    assert!(e.contains("02828884_train_voxels.npz"), "{e}");
}
