//! The `experiments` binary end to end: procedural and mesh sources, errors that name files.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use fieldprobe_core::data::Category;
use fieldprobe_core::data::dataset::{Split, kato};

fn experiments(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_experiments"))
        .args(args)
        .output()
        .expect("the binary runs")
}

fn ok(out: &Output) -> String {
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "{text}");
    text
}

fn fails(out: &Output) -> String {
    let text = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "expected failure, got: {text}");
    text
}

#[test]
fn procedural_dataset_has_the_published_files_and_a_contact_sheet() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("d");
    let o = out.to_str().unwrap();
    ok(&experiments(&[
        "make-dataset",
        "--out",
        o,
        "--categories",
        "chair,04379243",
        "--train",
        "2",
        "--val",
        "1",
        "--test",
        "1",
        "--seed",
        "5",
    ]));
    for syn in ["03001627", "04379243"] {
        for split in ["train", "val", "test"] {
            for kind in ["images", "voxels"] {
                assert!(
                    out.join(format!("{syn}_{split}_{kind}.npz")).is_file(),
                    "{syn} {split} {kind}"
                );
            }
        }
    }
    assert!(
        out.join("meshes/03001627/proc_chair_train_00000.obj")
            .is_file()
    );
    let info = std::fs::read_to_string(out.join("dataset.json")).unwrap();
    assert!(
        info.contains("\"voxelizer\": \"nmr\"") && info.contains("\"seed\": 5"),
        "{info}"
    );
    let sheet = image::open(out.join("contact_sheet.png")).unwrap();
    assert!(sheet.width() > 8 * 128 && sheet.height() > 2 * 128);

    let report = ok(&experiments(&["check-dataset", "--data", o]));
    assert!(report.contains("| chair | 03001627 | train |"), "{report}");

    // The written meshes, fed back through the mesh source, give the same images and voxels:
    // generated and user meshes share one code path.
    let again = dir.path().join("again");
    ok(&experiments(&[
        "make-dataset",
        "--out",
        again.to_str().unwrap(),
        "--meshes",
        out.join("meshes").to_str().unwrap(),
        "--split",
        "test",
    ]));
    let first = kato::read(&out, Category::Chair, Split::Train, true).unwrap();
    let second = kato::read(&again, Category::Chair, Split::Test, true).unwrap();
    for (i, id) in first.ids.iter().enumerate() {
        let j = second
            .ids
            .iter()
            .position(|x| x == id)
            .unwrap_or_else(|| panic!("{id} missing"));
        assert_eq!(first.silhouettes(i), second.silhouettes(j), "{id}");
        assert_eq!(first.voxel_grid(i), second.voxel_grid(j), "{id}");
    }
}

fn write(path: &Path, text: &str) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::write(path, text).unwrap();
}

const TETRA: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";

#[test]
fn mesh_folder_goes_into_the_named_split_in_sorted_order() {
    let dir = tempfile::tempdir().unwrap();
    let meshes = dir.path().join("meshes");
    write(&meshes.join("car/b.obj"), TETRA);
    write(
        &meshes.join("car/a.obj"),
        "o x\nv 0 0 0\nv 2 0 0\nv 2 1 0\nv 0 1 0\nv 0 0 1\nv 2 0 1\nv 2 1 1\nv 0 1 1\nf 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n",
    );
    write(&meshes.join("03001627/only.obj"), TETRA);
    let out = dir.path().join("d");
    ok(&experiments(&[
        "make-dataset",
        "--out",
        out.to_str().unwrap(),
        "--meshes",
        meshes.to_str().unwrap(),
        "--split",
        "val",
        "--voxelizer",
        "winding",
    ]));
    let ids = std::fs::read_to_string(out.join("02958343_val_ids.txt")).unwrap();
    assert_eq!(ids, "a\nb\n");
    assert!(out.join("03001627_val_images.npz").is_file());
    assert!(!out.join("02958343_test_images.npz").exists());
    let info = std::fs::read_to_string(out.join("dataset.json")).unwrap();
    assert!(
        info.contains("\"voxelizer\": \"winding\"") && info.contains("\"source\": \"meshes\""),
        "{info}"
    );
}

/// A ShapeNetCore-v2-shaped tree (`<synset>/<id>/models/model_normalized.obj`), a v1 folder
/// (`<id>/model.obj`), loose `.off`, `.ply` and `.stl` files, and SoftRas split lists: every
/// object goes to the split its list names, objects in no list are skipped.
#[test]
fn shapenet_layouts_mixed_formats_and_split_lists_make_a_dataset() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("ShapeNetCore.v2");
    let tet_off = "OFF\n4 4 6\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
    let tet_ply = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
    let tet_stl = "solid t\n\
        facet normal 0 0 -1\nouter loop\nvertex 0 0 0\nvertex 0 1 0\nvertex 1 0 0\nendloop\nendfacet\n\
        facet normal 0 -1 0\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 0 1\nendloop\nendfacet\n\
        facet normal -1 0 0\nouter loop\nvertex 0 0 0\nvertex 0 0 1\nvertex 0 1 0\nendloop\nendfacet\n\
        facet normal 1 1 1\nouter loop\nvertex 1 0 0\nvertex 0 1 0\nvertex 0 0 1\nendloop\nendfacet\n\
        endsolid t\n";
    write(
        &root.join("03001627/1a2b/models/model_normalized.obj"),
        TETRA,
    );
    write(&root.join("03001627/3c4d/model.obj"), TETRA);
    write(&root.join("03001627/5e6f.off"), tet_off);
    write(&root.join("03001627/7a8b.ply"), tet_ply);
    write(&root.join("03001627/9c0d.stl"), tet_stl);
    write(&root.join("03001627/unlisted.obj"), TETRA);
    let lists = dir.path().join("lists");
    write(&lists.join("softras_train.lst"), "1a2b\n5e6f\n7a8b\n");
    write(
        &lists.join("softras_test.lst"),
        "# SoftRas test split\n3c4d\n9c0d\n",
    );
    let out = dir.path().join("d");
    ok(&experiments(&[
        "make-dataset",
        "--out",
        out.to_str().unwrap(),
        "--meshes",
        root.to_str().unwrap(),
        "--split-list",
        lists.join("softras_train.lst").to_str().unwrap(),
        "--split-list",
        lists.join("softras_test.lst").to_str().unwrap(),
        "--voxelizer",
        "winding",
        "--supersample",
        "1",
    ]));
    let ids = |split: &str| std::fs::read_to_string(out.join(format!("03001627_{split}_ids.txt")));
    assert_eq!(ids("train").unwrap(), "1a2b\n5e6f\n7a8b\n");
    assert_eq!(ids("test").unwrap(), "3c4d\n9c0d\n");
    assert!(ids("val").is_err(), "no val list, no val split");
    // The normalized ground-truth meshes are kept for the mesh metrics.
    assert!(out.join("meshes/03001627/7a8b.obj").is_file());
    let set = kato::read(&out, Category::Chair, Split::Train, false).unwrap();
    assert_eq!(set.len(), 3);
    // Every format made the same shape (a tetrahedron, normalized alike): equal silhouettes.
    assert_eq!(set.silhouettes(0), set.silhouettes(1));
    assert_eq!(set.silhouettes(0), set.silhouettes(2));
}

#[test]
fn bad_meshes_and_folders_are_named_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let meshes = dir.path().join("meshes");
    write(&meshes.join("chair/good.obj"), TETRA);
    write(
        &meshes.join("chair/empty.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\n",
    );
    let out = dir.path().join("d");
    let err = fails(&experiments(&[
        "make-dataset",
        "--out",
        out.to_str().unwrap(),
        "--meshes",
        meshes.to_str().unwrap(),
    ]));
    assert!(
        err.contains("empty.obj") && err.contains("no faces"),
        "{err}"
    );
    assert!(!out.exists(), "nothing is written when a mesh is bad");

    std::fs::remove_file(meshes.join("chair/empty.obj")).unwrap();
    write(&meshes.join("sofa/x.obj"), TETRA);
    let err = fails(&experiments(&[
        "make-dataset",
        "--out",
        out.to_str().unwrap(),
        "--meshes",
        meshes.to_str().unwrap(),
    ]));
    assert!(
        err.contains("sofa") && err.contains("unknown category"),
        "{err}"
    );

    let err = fails(&experiments(&[
        "make-dataset",
        "--out",
        out.to_str().unwrap(),
        "--categories",
        "chiar",
    ]));
    assert!(err.contains("chiar"), "{err}");
}

#[test]
fn experiment_files_with_bad_keys_or_components_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let good = std::fs::read_to_string(
        PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("run by cargo test"))
            .join("quickstart.toml"),
    )
    .unwrap();
    let cases = [
        (
            good.replace("rays_per_view", "rayz_per_view"),
            "rayz_per_view",
        ),
        (
            good.replace(
                "ray_sampler = { type = \"importance\"",
                "ray_sampler = { type = \"importanse\"",
            ),
            "importanse",
        ),
        (
            good.lines()
                .map(|l| {
                    if l.starts_with("steps = ") {
                        "steps = 0"
                    } else {
                        l
                    }
                })
                .collect::<Vec<_>>()
                .join("\n"),
            "train.steps",
        ),
    ];
    for (i, (text, needle)) in cases.iter().enumerate() {
        assert_ne!(text, &good, "case {i} must change the file");
        let file = dir.path().join(format!("bad{i}.toml"));
        std::fs::write(&file, text).unwrap();
        let err = fails(&experiments(&[
            file.to_str().unwrap(),
            "--out",
            dir.path().join("run").to_str().unwrap(),
        ]));
        assert!(
            err.contains(&format!("bad{i}.toml")) && err.contains(needle),
            "{err}"
        );
    }
    // Bad `--set` arguments and the table of earlier versions are named too.
    let file = dir.path().join("quickstart.toml");
    std::fs::write(&file, &good).unwrap();
    let old = dir.path().join("old.toml");
    std::fs::write(
        &old,
        good.replace("[regularizers.normals]", "[regularizer]"),
    )
    .unwrap();
    for (args, needles) in [
        (
            vec![file.to_str().unwrap(), "--set", "train.stepz=3"],
            vec!["quickstart.toml", "--set train.stepz=3", "stepz"],
        ),
        (
            vec![file.to_str().unwrap(), "--set", "train.steps"],
            vec!["KEY=VALUE"],
        ),
        (
            vec![file.to_str().unwrap(), "--set", "train.steps=0"],
            vec!["quickstart.toml", "train.steps"],
        ),
        (
            vec![old.to_str().unwrap()],
            vec!["old.toml", "[regularizers.<name>]"],
        ),
    ] {
        let mut args = args.clone();
        let out = dir.path().join("run");
        args.extend(["--out", out.to_str().unwrap()]);
        let err = fails(&experiments(&args));
        for n in needles {
            assert!(err.contains(n), "{n} not in: {err}");
        }
    }
    assert!(
        !dir.path().join("run").exists(),
        "nothing is written for a bad file"
    );
}

/// An empty invocation shows the help (to stderr, as clap does for a missing argument), under
/// either binary name; flags work before a file and after a subcommand.
#[test]
fn an_empty_invocation_prints_help_and_flags_parse() {
    let out = experiments(&[]);
    let text = String::from_utf8_lossy(&out.stderr);
    assert!(
        text.contains("Usage:") && text.contains("make-dataset") && text.contains("--verbose"),
        "{text}"
    );
    let quiet = ok(&experiments(&["list", "-q"]));
    assert!(quiet.contains("[regularizers.<name>]"), "{quiet}");
    let out = Command::new(env!("CARGO_BIN_EXE_fieldprobe"))
        .arg("--help")
        .output()
        .unwrap();
    assert!(ok(&out).contains("Usage: fieldprobe"));
}

#[test]
fn list_shows_every_component_with_an_example() {
    let out = ok(&experiments(&["list"]));
    for needle in [
        "`uniform`",
        "`normal`",
        "`max`",
        "`softmax`",
        "`normal_consistency`",
        "`eikonal`",
        "[regularizers.<name>]",
        "`single_view`",
        "`sdf`",
        "[model]",
        "[probe.ray_sampler]",
        "sigma = 0.4",
    ] {
        assert!(out.contains(needle), "{needle} missing from:\n{out}");
    }
}

const TINY_RUN: &str = r#"
name = "tiny"
seed = 1
backend = "flex"

[data]
dir = "DATA"
categories = ["chair"]
generate = { train = 2, val = 0, test = 1, seed = 0 }

[model]
type = "single_view"
latent = 8
encoder = { channels = [4, 8], blocks = [1, 1] }
decoder = { hidden = [16] }

[probe]
anchors = 256
rays_per_view = 32
views = 2
ray_sampler = { type = "uniform" }
anchor_sampler = { type = "uniform" }

[train]
steps = 3
batch = 2
checkpoint_every = 0

[eval]
views = 2
mesh_views = 1
gallery_objects = 1
surface_points = 2000
extract = { refinements = 1 }
"#;

/// Every edge of `obj` is shared by exactly two faces, traversed once in each direction: closed
/// and consistently oriented (what trimesh's `is_watertight` and `is_winding_consistent` check).
fn closed_and_oriented(obj: &Path) -> (usize, bool) {
    let mesh = fieldprobe_core::data::TriMesh::load_obj(obj).unwrap();
    let mut edges = std::collections::HashMap::new();
    for f in &mesh.faces {
        for k in 0..3 {
            *edges.entry((f[k], f[(k + 1) % 3])).or_insert(0) += 1;
        }
    }
    let ok = edges
        .iter()
        .all(|(&(a, b), &n)| n == 1 && edges.get(&(b, a)) == Some(&1));
    (mesh.faces.len(), ok)
}

#[test]
fn a_run_reports_meshes_and_pictures_and_its_inputs_reconstruct() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    let file = dir.path().join("tiny.toml");
    std::fs::write(&file, TINY_RUN.replace("DATA", data.to_str().unwrap())).unwrap();
    let run = dir.path().join("run");
    let r = run.to_str().unwrap();
    // `--resume` on a directory with no checkpoint starts from step 0 (scripts always pass it).
    // `--set` changes a key of the file (3 steps in the file, 4 here).
    ok(&experiments(&[
        file.to_str().unwrap(),
        "--out",
        r,
        "--resume",
        "--set",
        "train.steps=4",
    ]));
    let config = std::fs::read_to_string(run.join("config.toml")).unwrap();
    assert!(config.contains("steps = 4"), "{config}");
    // history.csv: one row per logged interval (every step of a 4-step run).
    let history = std::fs::read_to_string(run.join("history.csv")).unwrap();
    let lines: Vec<&str> = history.lines().collect();
    assert_eq!(
        lines[0],
        "step,loss,silhouette_loss,regularizer_loss,lr,steps_per_second,wall_seconds"
    );
    assert_eq!(lines.len(), 5, "{history}");
    assert!(lines[4].starts_with("4,"), "{history}");
    // objects.csv: a row per prediction (1 object × 2 views), the meshed one with its mesh.
    let objects = std::fs::read_to_string(run.join("objects.csv")).unwrap();
    let rows: Vec<Vec<&str>> = objects.lines().map(|l| l.split(',').collect()).collect();
    let header = &rows[0];
    assert_eq!(rows.len(), 3, "{objects}");
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let meshed: Vec<_> = rows[1..]
        .iter()
        .filter(|r| !r[col("mesh_iou")].is_empty())
        .collect();
    assert_eq!(meshed.len(), 1, "{objects}");
    let mesh_file = run.join(meshed[0][col("mesh_file")]);
    assert!(
        mesh_file.starts_with(run.join("meshes/03001627")) && mesh_file.is_file(),
        "{}",
        mesh_file.display()
    );
    for r in &rows[1..] {
        let iou: f32 = r[col("iou")].parse().unwrap();
        assert!((0.0..=1.0).contains(&iou), "{objects}");
    }

    for name in [
        "config.toml",
        "input.json",
        "metrics.json",
        "report.md",
        "gallery.png",
        "training_curves.png",
    ] {
        assert!(run.join(name).is_file(), "{name}");
    }
    let metrics: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(run.join("metrics.json")).unwrap()).unwrap();
    let mesh = &metrics["per_category"]["chair"]["mesh"];
    assert_eq!(mesh["meshes"], 1, "{mesh}");
    for key in [
        "iou",
        "grid_iou",
        "chamfer_l1",
        "fscore",
        "normal_consistency",
    ] {
        let v = mesh[key]
            .as_f64()
            .unwrap_or_else(|| panic!("{key} missing: {mesh}"));
        assert!(v.is_finite() && v >= 0.0, "{key} = {v}");
    }
    // The two predictions' voxel conversions read every centre, and at most the whole lattice
    // besides.
    let (r3, s) = (
        metrics["resolution"].as_u64().unwrap().pow(3),
        metrics["subsamples"].as_u64().unwrap(),
    );
    let lattice = (metrics["resolution"].as_u64().unwrap() * s + 1).pow(3);
    let points = metrics["eval_grid_points"].as_u64().unwrap();
    assert!(
        (2 * r3..=2 * (r3 + lattice)).contains(&points),
        "{points} grid points"
    );
    let report = std::fs::read_to_string(run.join("report.md")).unwrap();
    for needle in [
        "## Meshes",
        "Chamfer-L1 ×10",
        "![gallery](gallery.png)",
        "![training curve](training_curves.png)",
    ] {
        assert!(report.contains(needle), "{needle} not in\n{report}");
    }
    let gallery = image::open(run.join("gallery.png")).unwrap();
    assert_eq!(gallery.height(), 128 + 8, "one row of 128-pixel panels");
    assert_eq!(
        gallery.width(),
        8 * (128 + 4) + 4,
        "input, 3 silhouettes, 4 turntable frames"
    );

    // Reconstruct from the gallery's input picture, scored against the object's mesh.
    let inputs: Vec<_> = std::fs::read_dir(run.join("inputs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(inputs.len(), 1);
    let id = std::fs::read_to_string(data.join("03001627_test_ids.txt")).unwrap();
    let gt = data
        .join("meshes/03001627")
        .join(format!("{}.obj", id.trim()));
    let out = dir.path().join("rec/mesh.obj");
    let log = ok(&experiments(&[
        "reconstruct",
        "--run",
        r,
        "--image",
        inputs[0].to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--gt-mesh",
        gt.to_str().unwrap(),
        "--frames",
        "3",
    ]));
    assert!(log.contains("mesh IoU"), "{log}");
    for name in [
        "mesh.obj",
        "mesh_turntable.png",
        "mesh_input.png",
        "mesh_metrics.json",
    ] {
        assert!(dir.path().join("rec").join(name).is_file(), "{name}");
    }
    let (faces, closed) = closed_and_oriented(&out);
    assert!(faces == 0 || closed, "{faces} faces, not closed");
    // The reconstruction's metrics are the evaluation's for that view (same model, same image).
    let rec: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("rec/mesh_metrics.json")).unwrap(),
    )
    .unwrap();
    let (a, b) = (
        rec["grid_iou"].as_f64().unwrap(),
        mesh["grid_iou"].as_f64().unwrap(),
    );
    assert!((a - b).abs() < 0.02, "reconstruct grid IoU {a} vs eval {b}");

    // `eval` recomputes the same numbers from the checkpoint.
    let again = dir.path().join("again");
    ok(&experiments(&[
        "eval",
        "--run",
        r,
        "--out",
        again.to_str().unwrap(),
    ]));
    let m2: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(again.join("metrics.json")).unwrap())
            .unwrap();
    // (Up to voxels whose φ sits at ½ within float noise of the CPU kernels.)
    let close = |a: &serde_json::Value, b: &serde_json::Value| {
        (a.as_f64().unwrap() - b.as_f64().unwrap()).abs() < 0.01
    };
    assert!(close(&m2["mean_iou"], &metrics["mean_iou"]), "{m2}");
    assert!(
        close(&m2["per_category"]["chair"]["mesh"]["iou"], &mesh["iou"]),
        "{m2}"
    );

    // `export` writes the weights as safetensors with the run's [model] table in the header; a
    // run started from them (`train.init_from`) trains on, and a model of another shape refuses
    // them, naming the file.
    let weights = dir.path().join("exported/model.safetensors");
    let w = weights.to_str().unwrap();
    let log = ok(&experiments(&["export", "--run", r, "--out", w]));
    assert!(
        log.contains("parameters") && log.contains("step 4"),
        "{log}"
    );
    let bytes = String::from_utf8_lossy(&std::fs::read(&weights).unwrap()).into_owned();
    assert!(
        bytes.contains("fieldprobe.model") && bytes.contains("single_view"),
        "the header names the model"
    );
    let init = format!("train.init_from=\"{w}\"");
    let tuned = dir.path().join("tuned");
    ok(&experiments(&[
        file.to_str().unwrap(),
        "--out",
        tuned.to_str().unwrap(),
        "--set",
        &init,
        "--set",
        "train.steps=1",
    ]));
    let e = fails(&experiments(&[
        file.to_str().unwrap(),
        "--out",
        dir.path().join("other").to_str().unwrap(),
        "--set",
        &init,
        "--set",
        "model.latent=4",
    ]));
    assert!(
        e.contains("init_from") && e.contains("model.safetensors") && e.contains("mismatch"),
        "{e}"
    );

    // Clear errors.
    let e = fails(&experiments(&[
        "reconstruct",
        "--run",
        "/nonexistent/run",
        "--image",
        "x.png",
        "--out",
        "m.obj",
    ]));
    assert!(
        e.contains("/nonexistent/run") && e.contains("no such run directory"),
        "{e}"
    );
    let e = fails(&experiments(&[
        "reconstruct",
        "--run",
        r,
        "--out",
        out.to_str().unwrap(),
    ]));
    assert!(e.contains("pass --image"), "{e}");
    let junk = dir.path().join("junk.png");
    std::fs::write(&junk, b"not a png").unwrap();
    let e = fails(&experiments(&[
        "reconstruct",
        "--run",
        r,
        "--image",
        junk.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]));
    assert!(
        e.contains("junk.png") && e.contains("cannot read image"),
        "{e}"
    );
    let e = fails(&experiments(&[
        "reconstruct",
        "--run",
        r,
        "--image",
        inputs[0].to_str().unwrap(),
        "--out",
        "m.stl",
    ]));
    assert!(e.contains(".obj or .ply"), "{e}");
    let e = fails(&experiments(&["eval", "--run", data.to_str().unwrap()]));
    assert!(e.contains("not a run directory"), "{e}");
}
