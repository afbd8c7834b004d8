//! Mutation fuzzing of experiment files: every shipped experiment and ablation file (with
//! `[[variants]]` and their overrides), mutated (lines dropped, duplicated or swapped, values
//! replaced by other types, NaN/Inf, huge and negative numbers, keys misspelled, tables
//! emptied) and `--set` overrides at random. The property: loading gives a clean error or an
//! experiment whose components build, never a panic. Seeded; a few hundred cases in CI,
//! thousands with `--ignored`.

use std::path::{Path, PathBuf};

use fieldprobe::experiment::Experiment;
use fieldprobe::overrides::Overrides;
use fieldprobe::variants::AblationFile;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn shipped() -> Vec<(PathBuf, String)> {
    let root = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("run by cargo test"))
        .join("../experiments");
    let mut files = Vec::new();
    for dir in ["", "ablations", "ablations/paper", "bench", "sdf", "sweeps"] {
        for e in std::fs::read_dir(root.join(dir)).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|x| x == "toml") {
                let text = std::fs::read_to_string(&p).unwrap();
                files.push((p, text));
            }
        }
    }
    files.sort();
    assert!(files.len() >= 10, "{files:?}");
    files
}

const VALUES: [&str; 14] = [
    "nan",
    "inf",
    "-inf",
    "-1",
    "0",
    "1e30",
    "9223372036854775807",
    "\"\"",
    "\"none\"",
    "[]",
    "{}",
    "true",
    "{ type = \"nromal\" }",
    "[1, \"a\"]",
];

/// One mutation of an experiment file's text.
fn mutate(text: &str, rng: &mut ChaCha8Rng) -> String {
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    for _ in 0..rng.random_range(1..=3) {
        if lines.is_empty() {
            break;
        }
        let i = rng.random_range(0..lines.len());
        match rng.random_range(0..6) {
            0 => {
                lines.remove(i);
            }
            1 => {
                let l = lines[i].clone();
                lines.insert(i, l);
            }
            2 => {
                let j = rng.random_range(0..lines.len());
                lines.swap(i, j);
            }
            3 => {
                // Another value, of another type maybe.
                if let Some((k, _)) = lines[i].split_once('=') {
                    let v = VALUES[rng.random_range(0..VALUES.len())];
                    lines[i] = format!("{k}= {v}");
                }
            }
            4 => {
                // A misspelled key.
                if let Some((k, v)) = lines[i].clone().split_once('=') {
                    lines[i] = format!("{}x ={v}", k.trim_end());
                }
            }
            _ => {
                // Truncated mid-line.
                let n = lines[i].len();
                if n > 0 {
                    let cut = rng.random_range(0..n);
                    let cut = (0..=cut)
                        .rev()
                        .find(|&c| lines[i].is_char_boundary(c))
                        .unwrap();
                    lines[i].truncate(cut);
                }
            }
        }
    }
    lines.join("\n")
}

fn random_set(rng: &mut ChaCha8Rng) -> Vec<String> {
    const KEYS: [&str; 8] = [
        "train.steps",
        "train.lr",
        "probe.anchors",
        "probe.ray_sampler.type",
        "regularizers",
        "regularizers.normals.p",
        "eval.views",
        "model.latent",
    ];
    (0..rng.random_range(0..3))
        .map(|_| {
            let k = KEYS[rng.random_range(0..KEYS.len())];
            let v = VALUES[rng.random_range(0..VALUES.len())];
            format!("{k}={v}")
        })
        .collect()
}

fn named(file: &Path, e: String) -> anyhow::Error {
    anyhow::anyhow!("{}: {e}", file.display())
}

/// Loads mutated files through the same paths as the CLI; returns how many loaded.
fn fuzz(seed: u64, cases: usize) -> usize {
    let files = shipped();
    let dir = tempfile::tempdir().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut loaded = 0;
    for case in 0..cases {
        let (path, text) = &files[case % files.len()];
        let mutated = mutate(text, &mut rng);
        let sets = random_set(&mut rng);
        let file = dir.path().join(path.file_name().unwrap());
        std::fs::write(&file, &mutated).unwrap();
        let out = std::panic::catch_unwind(|| -> anyhow::Result<usize> {
            let overrides = Overrides::parse(&sets)?;
            if text.contains("[[variants]]") {
                let a = AblationFile::load_with(&file, &overrides)?;
                for e in &a.entries {
                    e.experiment.components().map_err(|e| named(&file, e))?;
                }
                Ok(a.entries.len())
            } else {
                let e = Experiment::load_with(&file, &overrides)?;
                e.components().map_err(|e| named(&file, e))?;
                Ok(1)
            }
        });
        match out {
            Ok(Ok(_)) => loaded += 1,
            Ok(Err(e)) => {
                let msg = format!("{e:#}");
                assert!(
                    msg.contains(&*file.file_name().unwrap().to_string_lossy())
                        || msg.contains("--set"),
                    "case {case} ({}, --set {sets:?}): the error does not name the file: {msg}",
                    path.display()
                );
            }
            Err(_) => panic!(
                "case {case}: loading {} mutated (--set {sets:?}) panicked:\n{mutated}",
                path.display()
            ),
        }
    }
    loaded
}

#[test]
fn mutated_experiment_files_load_or_fail_cleanly() {
    let loaded = fuzz(0x70_4D, 300);
    // Many mutations are harmless (a duplicated comment, a swapped pair of lines in one table):
    // both outcomes are exercised.
    assert!(loaded > 0 && loaded < 300, "{loaded} of 300 loaded");
}

#[test]
#[ignore = "long mode: thousands of cases (cargo test --test fuzz_toml -- --ignored)"]
fn long_mutated_experiment_files() {
    for seed in 0..10 {
        fuzz(seed, 1000);
    }
}
