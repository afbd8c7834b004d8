//! Mutation fuzzing of the readers of outside files: `.npy`, `.npz`, `.obj` and the DVR folder
//! layout (cameras, images, masks, split list). Each case mutates a valid file (truncation,
//! flipped bytes, forged headers and sizes, huge counts, NaN/Inf coordinates, garbage inserted)
//! and reads it. The property: a clean `Err` or an `Ok`, never a panic or an abort, and no
//! allocation beyond a stated bound (a counting allocator measures the peak of every case).
//!
//! Seeded and on stable Rust (no cargo-fuzz): CI runs a few hundred cases per reader; the
//! `--ignored` tests run thousands (`cargo test --release --workspace --test fuzz -- --ignored`).
//! A failing case prints its seed and index, so it can be replayed.

mod common;

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;
use std::sync::Mutex;

use common::peak_of;
use fieldprobe_data::Category;
use fieldprobe_data::dataset::npy::{NpyArray, read_npz, read_npz_key, write_npz};
use fieldprobe_data::dataset::{ObjectRecord, ObjectSet, Split, dvr};
use fieldprobe_data::mesh::TriMesh;
use fieldprobe_data::procedural::{generate, object_rng};
use fieldprobe_data::render::RenderOptions;
use fieldprobe_data::voxelize::Voxelizer;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The allocator's counters are process-wide: one case at a time.
static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());

/// Runs `read` on one mutated input and checks the property: no panic, and a peak allocation of
/// at most `bound` bytes above what was live before. Returns whether it was `Ok`.
fn check<T, E: std::fmt::Display>(
    what: &str,
    case: usize,
    bound: usize,
    read: impl FnOnce() -> Result<T, E>,
) -> bool {
    let (out, peak) = peak_of(|| catch_unwind(AssertUnwindSafe(read)));
    let ok = match out {
        Ok(Ok(_)) => true,
        Ok(Err(e)) => {
            let msg = e.to_string();
            assert!(
                !msg.is_empty(),
                "{what} case {case}: an empty error message"
            );
            false
        }
        Err(_) => panic!("{what} case {case}: the reader panicked"),
    };
    assert!(
        peak <= bound,
        "{what} case {case}: allocated {peak} bytes at the peak, over the bound {bound}"
    );
    ok
}

/// Little-endian forged values that readers must not trust.
const FORGED: [u64; 6] = [
    0,
    u32::MAX as u64,
    u64::MAX,
    1 << 40,
    i64::MAX as u64,
    0x7FFF_FFFF,
];

/// One mutation of `valid`, chosen and placed by `rng`.
fn mutate(valid: &[u8], rng: &mut ChaCha8Rng) -> Vec<u8> {
    let mut b = valid.to_vec();
    let rounds = rng.random_range(1..=3);
    for _ in 0..rounds {
        if b.is_empty() {
            b.push(rng.random());
            continue;
        }
        let at = rng.random_range(0..b.len());
        match rng.random_range(0..7) {
            // Truncation.
            0 => b.truncate(at),
            // Flipped bits.
            1 => {
                for _ in 0..rng.random_range(1..8) {
                    let i = rng.random_range(0..b.len());
                    b[i] ^= 1 << rng.random_range(0..8);
                }
            }
            // A forged 4- or 8-byte integer (sizes, offsets, counts).
            2 => {
                let v = FORGED[rng.random_range(0..FORGED.len())].to_le_bytes();
                let n = if rng.random() { 4 } else { 8 };
                for (k, byte) in v.iter().take(n).enumerate() {
                    if at + k < b.len() {
                        b[at + k] = *byte;
                    }
                }
            }
            // Garbage inserted.
            3 => {
                let junk: Vec<u8> = (0..rng.random_range(1..64)).map(|_| rng.random()).collect();
                b.splice(at..at, junk);
            }
            // A span deleted.
            4 => {
                let end = (at + rng.random_range(1..256)).min(b.len());
                b.drain(at..end);
            }
            // A span duplicated.
            5 => {
                let end = (at + rng.random_range(1..256)).min(b.len());
                let span = b[at..end].to_vec();
                b.splice(at..at, span);
            }
            // Digits replaced in text (shapes in npy headers, counts and coordinates in .obj).
            _ => {
                if let Some(i) = (at..b.len()).find(|&i| b[i].is_ascii_digit()) {
                    let text: &[&[u8]] = &[b"99999999999999999999", b"0", b"-1", b"1e308", b"nan"];
                    let t = text[rng.random_range(0..text.len())];
                    b.splice(i..i + 1, t.iter().copied());
                }
            }
        }
    }
    b
}

fn npy_bytes() -> Vec<u8> {
    let a = NpyArray::from_f32(
        vec![4, 3, 5],
        &(0..60).map(|i| i as f32).collect::<Vec<_>>(),
    );
    let mut out = Vec::new();
    a.write_npy(&mut out).unwrap();
    out
}

fn npz_bytes(dir: &Path) -> Vec<u8> {
    let a = NpyArray::from_f32(vec![2, 8], &[0.5; 16]);
    let b = NpyArray::from_u8(vec![3, 4, 4], vec![7; 48]);
    let path = dir.join("valid.npz");
    write_npz(&path, &[("world_mat_0", &a), ("images", &b)]).unwrap();
    std::fs::read(&path).unwrap()
}

fn obj_bytes() -> Vec<u8> {
    let mesh = generate(Category::Chair, &mut object_rng(1, Category::Chair, 0, 0));
    let mut out = Vec::new();
    mesh.write_obj_to(&mut out).unwrap();
    // Keep the corpus small: the first 200 lines still make a mesh (faces may point past the
    // vertices, which the reader must reject cleanly).
    let text = String::from_utf8(out).unwrap();
    let mut lines: Vec<&str> = text
        .lines()
        .filter(|l| l.starts_with("v "))
        .take(60)
        .collect();
    lines.extend(text.lines().filter(|l| l.starts_with("f ")).take(60));
    (lines.join("\n") + "\n").into_bytes()
}

/// `cases` mutations of the npy, npz and obj corpora, seeded by `seed`.
fn fuzz_files(seed: u64, cases: usize) {
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|p| p.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let npy = npy_bytes();
    let npz = npz_bytes(dir.path());
    let obj = obj_bytes();
    let what = Path::new("fuzz.npy");
    // Bounds: what a reader may hold for an input of this size (the decoded array, the zip
    // directory, the mesh), with room; a reader that trusts a forged size blows far past them.
    const BOUND: usize = 4 << 20;
    let mut oks = [0usize; 4];
    for case in 0..cases {
        let m = mutate(&npy, &mut rng);
        oks[0] += check("npy", case, BOUND, || NpyArray::read_npy(&m, what)) as usize;

        let m = mutate(&npz, &mut rng);
        let p = dir.path().join("case.npz");
        std::fs::write(&p, &m).unwrap();
        oks[1] += check("npz", case, BOUND, || read_npz(&p)) as usize;
        check("npz key", case, BOUND, || read_npz_key(&p, "images"));

        let m = mutate(&obj, &mut rng);
        let p = dir.path().join("case.obj");
        std::fs::write(&p, &m).unwrap();
        oks[2] += check("obj", case, BOUND, || {
            TriMesh::load_obj(&p).inspect(|mesh| {
                // A mesh that loads is usable: finite coordinates, faces in range.
                assert!(mesh.vertices.iter().all(|v| v.is_finite()), "case {case}");
                let n = mesh.vertices.len() as u32;
                assert!(mesh.faces.iter().flatten().all(|&i| i < n), "case {case}");
            })
        }) as usize;
    }
    // The mutations are not all fatal (a flipped bit in a float is still a valid file): the
    // readers are exercised on both paths.
    assert!(
        oks[0] > 0 && oks[0] < cases,
        "npy: {} of {cases} read",
        oks[0]
    );
    assert!(oks[1] < cases, "npz: {} of {cases} read", oks[1]);
    assert!(
        oks[2] > 0 && oks[2] < cases,
        "obj: {} of {cases} read",
        oks[2]
    );
}

/// `cases` mutations of one file of a valid DVR folder at a time (cameras, an image, a mask, the
/// split list), read as a whole.
fn fuzz_dvr(seed: u64, cases: usize) {
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|p| p.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let opts = RenderOptions {
        supersample: 1,
        ..Default::default()
    };
    let mut set = ObjectSet::new(Category::Chair, Split::Test);
    let mesh = generate(Category::Chair, &mut object_rng(2, Category::Chair, 0, 0));
    set.push(
        "obj0".into(),
        &ObjectRecord::from_mesh(&mesh, Voxelizer::Nmr, &opts),
    );
    dvr::write(dir.path(), &set).unwrap();
    let root = dir.path();
    let files = [
        "03001627/obj0/cameras.npz",
        "03001627/obj0/image/0003.png",
        "03001627/obj0/mask/0011.png",
        "03001627/softras_test.lst",
    ];
    let valid: Vec<Vec<u8>> = files
        .iter()
        .map(|f| std::fs::read(root.join(f)).unwrap())
        .collect();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    const BOUND: usize = 8 << 20;
    for case in 0..cases {
        let k = case % files.len();
        std::fs::write(root.join(files[k]), mutate(&valid[k], &mut rng)).unwrap();
        check("dvr", case, BOUND, || {
            dvr::read(root, Category::Chair, Split::Test)
        });
        std::fs::write(root.join(files[k]), &valid[k]).unwrap();
    }
    assert!(dvr::read(root, Category::Chair, Split::Test).is_ok());
}

#[test]
fn npy_npz_and_obj_readers_survive_mutated_files() {
    fuzz_files(0x5EED, 300);
}

#[test]
fn the_dvr_reader_survives_mutated_files() {
    fuzz_dvr(0xD1A, 200);
}

#[test]
#[ignore = "long mode: thousands of cases (cargo test --test fuzz -- --ignored)"]
fn long_npy_npz_and_obj() {
    for seed in 0..10 {
        fuzz_files(seed, 1000);
    }
}

#[test]
#[ignore = "long mode: thousands of cases (cargo test --test fuzz -- --ignored)"]
fn long_dvr() {
    fuzz_dvr(7, 3000);
}
