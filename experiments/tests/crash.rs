//! Runs survive kills: a real training run (the `experiments` binary as a child process) is
//! killed with SIGKILL mid-run, a torn checkpoint write is left behind as a kill during a write
//! leaves it, and `--resume` finishes the run with exactly the weights of an uninterrupted run
//! of the same seed. A second process on a directory in use is refused.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

const RUN: &str = r#"
name = "crash"
seed = 3
backend = "flex"

[data]
dir = "DATA"
categories = ["chair"]
generate = { train = 2, val = 0, test = 1, seed = 0 }

[model]
type = "single_view"
latent = 8
encoder = { channels = [4, 8], blocks = [1, 1] }
decoder = { hidden = [32, 32] }

[probe]
anchors = 256
rays_per_view = 32
views = 2
ray_sampler = { type = "uniform" }
anchor_sampler = { type = "uniform" }

[train]
steps = 600
batch = 2
checkpoint_every = 20

[eval]
views = 1
mesh_views = 0
gallery_objects = 0
save_meshes = false
"#;

/// Steps between checkpoints (the file's `checkpoint_every`).
const EVERY: usize = 20;

fn binary() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_experiments"));
    c.env("FIELDPROBE_LOG", "warn");
    c
}

fn run_to_end(file: &Path, out: &Path, resume: bool) -> Output {
    let mut c = binary();
    c.arg(file).arg("--out").arg(out);
    if resume {
        c.arg("--resume");
    }
    let o = c.output().expect("the binary runs");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    o
}

fn start(file: &Path, out: &Path) -> Child {
    binary()
        .arg(file)
        .arg("--out")
        .arg(out)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("the binary starts")
}

/// The step `latest.json` names, if there is one yet.
fn latest_step(run: &Path) -> Option<usize> {
    let text = std::fs::read_to_string(run.join("checkpoints/latest.json")).ok()?;
    let v: serde_json::Value = serde_json::from_str(&text).ok()?;
    v["step"].as_u64().map(|s| s as usize)
}

/// The last step `history.csv` logged (the steps done when the process died, to the interval).
fn last_logged_step(run: &Path) -> usize {
    let text = std::fs::read_to_string(run.join("history.csv")).unwrap_or_default();
    text.lines()
        .skip(1)
        .filter_map(|l| l.split(',').next()?.parse().ok())
        .max()
        .unwrap_or(0)
}

/// What the final model computes: φ at fixed points for a fixed input image, bit for bit. (The
/// checkpoint files themselves differ between processes: burn records a random id per
/// parameter.)
fn final_field(run: &Path) -> Vec<u32> {
    use burn::prelude::*;
    let device = Device::flex();
    let model = fieldprobe::run_dir::RunDir::open(run)
        .unwrap()
        .model(&device)
        .unwrap();
    let s = 64;
    let pixels: Vec<f32> = (0..4 * s * s).map(|i| (i % 97) as f32 / 97.0).collect();
    let image = Tensor::<4>::from_data(TensorData::new(pixels, [1, 4, s, s]), &device);
    let points: Vec<f32> = (0..3 * 500)
        .map(|i| ((i * 37) % 101) as f32 / 101.0 - 0.5)
        .collect();
    let points = Tensor::<3>::from_data(TensorData::new(points, [1, 500, 3]), &device);
    let phi = model.occupancy(model.encode(image), points);
    phi.into_data()
        .try_to_vec::<f32>()
        .unwrap()
        .into_iter()
        .map(f32::to_bits)
        .collect()
}

#[test]
fn a_killed_run_resumes_to_the_weights_of_an_uninterrupted_one() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    let file = dir.path().join("crash.toml");
    std::fs::write(&file, RUN.replace("DATA", data.to_str().unwrap())).unwrap();

    // The reference: the same seed, never interrupted (it also generates the shared data).
    let whole = dir.path().join("whole");
    run_to_end(&file, &whole, false);
    assert_eq!(latest_step(&whole), Some(600));

    // Killed once it has two checkpoints.
    let killed = dir.path().join("killed");
    let mut child = start(&file, &killed);
    let t0 = Instant::now();
    while latest_step(&killed).is_none_or(|s| s < 2 * EVERY) {
        assert!(
            t0.elapsed() < Duration::from_secs(240),
            "no second checkpoint after 4 minutes"
        );
        if let Some(status) = child.try_wait().unwrap() {
            panic!("the run ended before it was killed: {status}");
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    // While it runs, a second process on the same directory is refused and says why.
    let second = binary()
        .arg(&file)
        .arg("--out")
        .arg(&killed)
        .arg("--resume")
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&second.stderr);
    assert!(!second.status.success() && e.contains("in use"), "{e}");
    child.kill().unwrap(); // SIGKILL: no destructor, no flush runs in the child.
    child.wait().unwrap();

    // What a kill leaves: latest.json names a complete checkpoint, at most one interval old.
    let at = latest_step(&killed).expect("latest.json parses after a kill");
    let logged = last_logged_step(&killed);
    assert!(
        at + EVERY >= logged,
        "checkpoint at step {at}, but {logged} steps were logged: more than one interval lost"
    );
    let ckpt = killed.join(format!("checkpoints/step-{at:07}"));
    for f in ["model.bpk", "optim.bpk"] {
        assert!(ckpt.join(f).metadata().unwrap().len() > 0, "{f}");
    }
    // A kill in the middle of writing the next checkpoint leaves a partial directory and a
    // temporary file; neither may be read or block the resume.
    let torn = killed.join(format!("checkpoints/step-{:07}", at + EVERY));
    std::fs::create_dir_all(&torn).unwrap();
    std::fs::write(torn.join("model.bpk"), b"half a record").unwrap();
    std::fs::write(
        killed.join("checkpoints/.latest.json.x1y2z3.tmp"),
        b"{\"step\": 9",
    )
    .unwrap();

    run_to_end(&file, &killed, true);
    assert_eq!(latest_step(&killed), Some(600));
    // (Not `assert_eq!`: on a mismatch it would print thousands of numbers.)
    assert!(
        final_field(&killed) == final_field(&whole),
        "a resumed CPU run computes a field different from the uninterrupted run's"
    );
    let m = |run: &PathBuf| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(run.join("metrics.json")).unwrap()).unwrap()
    };
    assert_eq!(m(&killed)["mean_iou"], m(&whole)["mean_iou"]);
    assert!(
        !torn.exists(),
        "the torn checkpoint directory was cleaned up"
    );
    // history.csv: one row per logged interval, no duplicate steps across the kill.
    let steps: Vec<usize> = std::fs::read_to_string(killed.join("history.csv"))
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap().parse().unwrap())
        .collect();
    assert!(steps.windows(2).all(|w| w[0] < w[1]), "{steps:?}");
    assert_eq!(steps.last(), Some(&600));
}
