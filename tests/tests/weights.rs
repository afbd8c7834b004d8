//! Weights in and out: a torchvision-layout ResNet-18 (`state_dict` names, PyTorch layouts,
//! `fc` and `num_batches_tracked` included), written by the test's own safetensors writer, loads
//! into the `resnet` encoder, which then computes what a plain f64 ResNet-18 computes from the
//! same file; a trained model's safetensors export imports back bit-exactly; bad files are named.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Mutex;

use burn::prelude::*;
use fieldprobe_core::field::{FieldModel, FieldModelConfig};
use fieldprobe_core::weights::{self, Import};
use fieldprobe_models::{DecoderConfig, EncoderConfig, SingleViewConfig, Stem};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// burn's flex RNG is process-wide: tests that seed it must not interleave.
static SEEDED: Mutex<()> = Mutex::new(());

/// A tensor of the test's files: f32 data, or a PyTorch int64 scalar (`num_batches_tracked`).
#[derive(Clone, Debug, PartialEq)]
enum Entry {
    F32(Vec<usize>, Vec<f32>),
    I64(i64),
}

/// Safetensors, written from the format's definition (an 8-byte little-endian header length, a
/// JSON header of dtype/shape/offsets, the raw bytes), independently of burn's writer.
fn write_safetensors(path: &Path, tensors: &BTreeMap<String, Entry>) {
    let mut header = serde_json::Map::new();
    header.insert("__metadata__".into(), serde_json::json!({ "format": "pt" }));
    let mut data = Vec::new();
    for (name, entry) in tensors {
        let start = data.len();
        let (dtype, shape) = match entry {
            Entry::F32(shape, values) => {
                values
                    .iter()
                    .for_each(|v| data.extend_from_slice(&v.to_le_bytes()));
                ("F32", shape.clone())
            }
            Entry::I64(v) => {
                data.extend_from_slice(&v.to_le_bytes());
                ("I64", vec![])
            }
        };
        header.insert(
            name.clone(),
            serde_json::json!({ "dtype": dtype, "shape": shape, "data_offsets": [start, data.len()] }),
        );
    }
    let mut json = serde_json::to_vec(&header).unwrap();
    while !json.len().is_multiple_of(8) {
        json.push(b' ');
    }
    let mut bytes = (json.len() as u64).to_le_bytes().to_vec();
    bytes.extend(json);
    bytes.extend(data);
    std::fs::write(path, bytes).unwrap();
}

/// Every tensor of a safetensors file as (dtype, shape, raw bytes), by name.
fn read_safetensors(path: &Path) -> BTreeMap<String, (String, Vec<usize>, Vec<u8>)> {
    let bytes = std::fs::read(path).unwrap();
    let n = u64::from_le_bytes(bytes[..8].try_into().unwrap()) as usize;
    let header: serde_json::Value = serde_json::from_slice(&bytes[8..8 + n]).unwrap();
    let data = &bytes[8 + n..];
    header
        .as_object()
        .unwrap()
        .iter()
        .filter(|(k, _)| *k != "__metadata__")
        .map(|(k, v)| {
            let offsets: Vec<usize> = serde_json::from_value(v["data_offsets"].clone()).unwrap();
            let shape: Vec<usize> = serde_json::from_value(v["shape"].clone()).unwrap();
            let dtype = v["dtype"].as_str().unwrap().to_string();
            (
                k.clone(),
                (dtype, shape, data[offsets[0]..offsets[1]].to_vec()),
            )
        })
        .collect()
}

/// A torchvision ResNet-18 `state_dict` with random weights (He-scaled convolutions, batch norms
/// with non-trivial statistics), named and shaped exactly as torchvision names and shapes them.
fn torchvision_resnet18(seed: u64) -> BTreeMap<String, Entry> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut t = BTreeMap::new();
    let mut conv = |t: &mut BTreeMap<String, Entry>, name: &str, co: usize, ci: usize, k: usize| {
        let scale = (2.0 / (ci * k * k) as f32).sqrt();
        let w = (0..co * ci * k * k)
            .map(|_| scale * (rng.random::<f32>() * 2.0 - 1.0) * 1.7)
            .collect();
        t.insert(format!("{name}.weight"), Entry::F32(vec![co, ci, k, k], w));
    };
    let mut bn_rng = ChaCha8Rng::seed_from_u64(seed + 1);
    let mut bn = |t: &mut BTreeMap<String, Entry>, name: &str, c: usize| {
        let mut v = |lo: f32, hi: f32| -> Vec<f32> {
            (0..c)
                .map(|_| lo + (hi - lo) * bn_rng.random::<f32>())
                .collect()
        };
        t.insert(format!("{name}.weight"), Entry::F32(vec![c], v(0.5, 1.5)));
        t.insert(format!("{name}.bias"), Entry::F32(vec![c], v(-0.2, 0.2)));
        t.insert(
            format!("{name}.running_mean"),
            Entry::F32(vec![c], v(-0.2, 0.2)),
        );
        t.insert(
            format!("{name}.running_var"),
            Entry::F32(vec![c], v(0.5, 2.0)),
        );
        t.insert(format!("{name}.num_batches_tracked"), Entry::I64(1000));
    };
    conv(&mut t, "conv1", 64, 3, 7);
    bn(&mut t, "bn1", 64);
    let mut cin = 64;
    for (l, c) in [64usize, 128, 256, 512].into_iter().enumerate() {
        for b in 0..2 {
            let p = format!("layer{}.{b}", l + 1);
            let (i, stride2) = if b == 0 { (cin, l > 0) } else { (c, false) };
            conv(&mut t, &format!("{p}.conv1"), c, i, 3);
            bn(&mut t, &format!("{p}.bn1"), c);
            conv(&mut t, &format!("{p}.conv2"), c, c, 3);
            bn(&mut t, &format!("{p}.bn2"), c);
            if b == 0 && (stride2 || i != c) {
                conv(&mut t, &format!("{p}.downsample.0"), c, i, 1);
                bn(&mut t, &format!("{p}.downsample.1"), c);
            }
        }
        cin = c;
    }
    let fc: Vec<f32> = (0..1000 * 512).map(|i| (i % 7) as f32 * 0.01).collect();
    t.insert("fc.weight".into(), Entry::F32(vec![1000, 512], fc));
    t.insert("fc.bias".into(), Entry::F32(vec![1000], vec![0.0; 1000]));
    t
}

/// A feature map `[C][H][W]` in f64.
type Map = Vec<Vec<Vec<f64>>>;

fn f32s(t: &BTreeMap<String, Entry>, name: &str) -> (Vec<usize>, Vec<f64>) {
    match &t[name] {
        Entry::F32(shape, v) => (shape.clone(), v.iter().map(|&x| x as f64).collect()),
        Entry::I64(_) => panic!("{name} is not f32"),
    }
}

fn conv2d(x: &Map, t: &BTreeMap<String, Entry>, name: &str, stride: usize, pad: usize) -> Map {
    let (shape, w) = f32s(t, &format!("{name}.weight"));
    let (co, ci, k) = (shape[0], shape[1], shape[2]);
    let (h, wd) = (x[0].len(), x[0][0].len());
    let oh = (h + 2 * pad - k) / stride + 1;
    let ow = (wd + 2 * pad - k) / stride + 1;
    let mut y = vec![vec![vec![0.0; ow]; oh]; co];
    for (o, yo) in y.iter_mut().enumerate() {
        for (r, row) in yo.iter_mut().enumerate() {
            for (c, out) in row.iter_mut().enumerate() {
                let mut s = 0.0;
                for (i, xi) in x.iter().enumerate().take(ci) {
                    for dy in 0..k {
                        let yy = (r * stride + dy) as isize - pad as isize;
                        if yy < 0 || yy >= h as isize {
                            continue;
                        }
                        for dx in 0..k {
                            let xx = (c * stride + dx) as isize - pad as isize;
                            if xx < 0 || xx >= wd as isize {
                                continue;
                            }
                            s += w[((o * ci + i) * k + dy) * k + dx] * xi[yy as usize][xx as usize];
                        }
                    }
                }
                *out = s;
            }
        }
    }
    y
}

fn batch_norm(x: Map, t: &BTreeMap<String, Entry>, name: &str) -> Map {
    let g = f32s(t, &format!("{name}.weight")).1;
    let b = f32s(t, &format!("{name}.bias")).1;
    let m = f32s(t, &format!("{name}.running_mean")).1;
    let v = f32s(t, &format!("{name}.running_var")).1;
    x.into_iter()
        .enumerate()
        .map(|(c, plane)| {
            let scale = g[c] / (v[c] + 1e-5).sqrt();
            plane
                .into_iter()
                .map(|row| row.into_iter().map(|a| (a - m[c]) * scale + b[c]).collect())
                .collect()
        })
        .collect()
}

fn relu(x: Map) -> Map {
    x.into_iter()
        .map(|p| {
            p.into_iter()
                .map(|r| r.into_iter().map(|a| a.max(0.0)).collect())
                .collect()
        })
        .collect()
}

fn add(a: Map, b: &Map) -> Map {
    a.into_iter()
        .zip(b)
        .map(|(p, q)| {
            p.into_iter()
                .zip(q)
                .map(|(r, s)| r.into_iter().zip(s).map(|(x, y)| x + y).collect())
                .collect()
        })
        .collect()
}

fn max_pool_3x3_s2_p1(x: &Map) -> Map {
    let (h, w) = (x[0].len(), x[0][0].len());
    let (oh, ow) = ((h + 2 - 3) / 2 + 1, (w + 2 - 3) / 2 + 1);
    x.iter()
        .map(|p| {
            (0..oh)
                .map(|r| {
                    (0..ow)
                        .map(|c| {
                            let mut m = f64::NEG_INFINITY;
                            for dy in 0..3 {
                                for dx in 0..3 {
                                    let (yy, xx) =
                                        ((2 * r + dy) as isize - 1, (2 * c + dx) as isize - 1);
                                    if (0..h as isize).contains(&yy)
                                        && (0..w as isize).contains(&xx)
                                    {
                                        m = m.max(p[yy as usize][xx as usize]);
                                    }
                                }
                            }
                            m
                        })
                        .collect()
                })
                .collect()
        })
        .collect()
}

/// torchvision's `resnet18` in eval mode up to the average pool, on ImageNet-normalized RGB
/// (`[3][H][W]` in `[0, 1]`): the 512 features its `fc` reads.
fn reference_features(t: &BTreeMap<String, Entry>, rgb: &Map) -> Vec<f64> {
    const MEAN: [f64; 3] = [0.485, 0.456, 0.406];
    const STD: [f64; 3] = [0.229, 0.224, 0.225];
    let x: Map = rgb
        .iter()
        .enumerate()
        .map(|(c, p)| {
            p.iter()
                .map(|r| r.iter().map(|a| (a - MEAN[c]) / STD[c]).collect())
                .collect()
        })
        .collect();
    let x = relu(batch_norm(conv2d(&x, t, "conv1", 2, 3), t, "bn1"));
    let mut x = max_pool_3x3_s2_p1(&x);
    for l in 0..4 {
        for b in 0..2 {
            let p = format!("layer{}.{b}", l + 1);
            let stride = if l > 0 && b == 0 { 2 } else { 1 };
            let y = relu(batch_norm(
                conv2d(&x, t, &format!("{p}.conv1"), stride, 1),
                t,
                &format!("{p}.bn1"),
            ));
            let y = batch_norm(
                conv2d(&y, t, &format!("{p}.conv2"), 1, 1),
                t,
                &format!("{p}.bn2"),
            );
            let skip = if t.contains_key(&format!("{p}.downsample.0.weight")) {
                batch_norm(
                    conv2d(&x, t, &format!("{p}.downsample.0"), stride, 0),
                    t,
                    &format!("{p}.downsample.1"),
                )
            } else {
                x.clone()
            };
            x = relu(add(y, &skip));
        }
    }
    x.iter()
        .map(|p| p.iter().flatten().sum::<f64>() / (p.len() * p[0].len()) as f64)
        .collect()
}

fn resnet_encoder(pretrained: Option<&Path>) -> EncoderConfig {
    EncoderConfig {
        stem: Stem::Resnet,
        pretrained: pretrained.map(Path::to_path_buf),
        ..EncoderConfig::default()
    }
}

/// The imported encoder computes torchvision's features: names, PyTorch layouts (batch norm's
/// `weight`/`bias`), the stem (7×7 convolution, max pool), ImageNet normalization and the
/// running statistics all agree with the plain reference; the alpha plane, whose convolution
/// starts at zero, changes nothing yet.
#[test]
fn a_torchvision_resnet18_loads_and_computes_the_reference_features() {
    let _g = SEEDED.lock().unwrap_or_else(|p| p.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("resnet18.safetensors");
    let tensors = torchvision_resnet18(7);
    write_safetensors(&file, &tensors);

    let config = resnet_encoder(Some(&file));
    config.validate().unwrap();
    let device = Device::flex();
    device.seed(3);
    let mut encoder = config.init(16, &device);
    let report = weights::import(&mut encoder, &file, &config.torchvision_import("")).unwrap();
    // 20 convolutions + 20 batch norms × 4 tensors: every one of the encoder's.
    assert_eq!(report.loaded, 20 + 20 * 4, "{report:?}");
    let unused: Vec<&str> = report
        .unused
        .iter()
        .map(String::as_str)
        .filter(|n| !n.ends_with("num_batches_tracked"))
        .collect();
    assert_eq!(unused, ["fc.bias", "fc.weight"]);

    let size = 32;
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let pixels: Vec<f32> = (0..2 * 4 * size * size)
        .map(|_| rng.random::<f32>())
        .collect();
    let images =
        Tensor::<4>::from_data(TensorData::new(pixels.clone(), [2, 4, size, size]), &device);
    let got: Vec<f32> = encoder.features(images).try_into_vec_as().unwrap();
    assert_eq!(got.len(), 2 * 512);
    for b in 0..2 {
        let rgb: Map = (0..3)
            .map(|c| {
                (0..size)
                    .map(|r| {
                        (0..size)
                            .map(|x| pixels[((b * 4 + c) * size + r) * size + x] as f64)
                            .collect()
                    })
                    .collect()
            })
            .collect();
        let want = reference_features(&tensors, &rgb);
        let scale = want.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        for (i, (&g, &w)) in got[b * 512..(b + 1) * 512].iter().zip(&want).enumerate() {
            assert!(
                (g as f64 - w).abs() <= 1e-4 * scale,
                "image {b}, feature {i}: {g} vs reference {w} (scale {scale})"
            );
        }
    }
}

/// The same file through the experiment's path (`model.encoder.pretrained`), and the errors a
/// user meets: a missing tensor and a mis-shaped one are named with the file, a file that does
/// not exist or a compact stem is refused when the config is checked.
#[test]
fn pretrained_encoders_load_through_the_config_and_bad_files_are_named() {
    let _g = SEEDED.lock().unwrap_or_else(|p| p.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("resnet18.safetensors");
    let tensors = torchvision_resnet18(1);
    write_safetensors(&good, &tensors);
    let config = |file: &Path| SingleViewConfig {
        latent: 8,
        encoder: resnet_encoder(Some(file)),
        decoder: DecoderConfig {
            hidden: vec![16],
            frequencies: 0,
        },
    };
    let device = Device::flex();
    let c = config(&good);
    c.validate().unwrap();
    let mut model = c.init(&device);
    c.load_pretrained(model.as_mut()).unwrap();

    let mut missing = tensors.clone();
    missing.remove("layer3.1.conv2.weight");
    let file = dir.path().join("missing.safetensors");
    write_safetensors(&file, &missing);
    let e = config(&file).load_pretrained(model.as_mut()).unwrap_err();
    assert!(
        e.contains("missing.safetensors") && e.contains("encoder.blocks.5.conv2.weight"),
        "{e}"
    );

    let mut wrong = tensors;
    wrong.insert(
        "conv1.weight".into(),
        Entry::F32(vec![64, 4, 7, 7], vec![0.0; 64 * 4 * 49]),
    );
    let file = dir.path().join("wrong.safetensors");
    write_safetensors(&file, &wrong);
    let e = config(&file).load_pretrained(model.as_mut()).unwrap_err();
    assert!(
        e.contains("wrong.safetensors") && e.contains("encoder.stem.weight"),
        "{e}"
    );

    let e = config(&dir.path().join("absent.safetensors"))
        .validate()
        .unwrap_err();
    assert!(
        e.contains("absent.safetensors") && e.contains("pretrained"),
        "{e}"
    );
    let compact = EncoderConfig {
        pretrained: Some(good),
        ..EncoderConfig::default()
    };
    assert!(compact.validate().unwrap_err().contains("stem"));
}

/// Export writes every tensor (batch-norm statistics included) under its module path, and a
/// fresh model (other random weights) that imports the file holds the same bytes and computes
/// the same outputs, bit for bit; a file for another shape of model is refused by name.
#[test]
fn safetensors_export_then_import_is_bit_exact() {
    let _g = SEEDED.lock().unwrap_or_else(|p| p.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let config = SingleViewConfig {
        latent: 8,
        encoder: EncoderConfig {
            channels: vec![4, 8],
            blocks: vec![1, 1],
            ..EncoderConfig::default()
        },
        decoder: DecoderConfig {
            hidden: vec![16, 16],
            frequencies: 2,
        },
    };
    let device = Device::flex();
    device.seed(1);
    let mut a = config.init(&device);
    // Move the batch norms' running statistics off their start, as training does.
    let autodiff = device.clone().autodiff();
    autodiff.seed(1);
    let trained = config.init(&autodiff);
    let images = Tensor::<4>::random(
        [3, 4, 16, 16],
        burn::tensor::Distribution::Default,
        &autodiff,
    );
    let _ = trained.encode(images);
    let first = dir.path().join("a.safetensors");
    trained.export_safetensors(&first, &[]).unwrap();
    a.import_safetensors(&first, &Import::default()).unwrap();

    let out = dir.path().join("model.safetensors");
    a.export_safetensors(&out, &[("fieldprobe.step".into(), "3".into())])
        .unwrap();
    let written = read_safetensors(&out);
    for part in ["encoder.", "decoder.", "running_mean", "running_var"] {
        assert!(
            written
                .keys()
                .any(|k| k.starts_with(part) || k.ends_with(part)),
            "{part}: {:?}",
            written.keys()
        );
    }

    device.seed(2);
    let mut b = config.init(&device);
    let report = b.import_safetensors(&out, &Import::default()).unwrap();
    assert!(report.unused.is_empty(), "{report:?}");
    let again = dir.path().join("again.safetensors");
    b.export_safetensors(&again, &[]).unwrap();
    assert_eq!(
        read_safetensors(&again),
        written,
        "every tensor, byte for byte"
    );

    let images = Tensor::<4>::random([2, 4, 16, 16], burn::tensor::Distribution::Default, &device);
    let points = Tensor::<3>::random(
        [2, 50, 3],
        burn::tensor::Distribution::Uniform(-0.5, 0.5),
        &device,
    );
    let logits = |m: &dyn FieldModel| -> Vec<f32> {
        let z = m.encode(images.clone());
        m.logits(z, points.clone()).try_into_vec_as().unwrap()
    };
    assert_eq!(
        logits(a.valid_model().as_ref()),
        logits(b.valid_model().as_ref())
    );

    let other = SingleViewConfig {
        latent: 4,
        ..config
    };
    let mut c = other.init(&device);
    let e = c.import_safetensors(&out, &Import::default()).unwrap_err();
    assert!(
        e.contains("model.safetensors") && e.contains("mismatch"),
        "{e}"
    );
}
