//! `experiments reconstruct --run RUN_DIR --image IMG.png [--mask MASK.png] --out mesh.obj`: a
//! mesh from one picture with a trained model, plus a turntable PNG of it.
//!
//! The image: a PNG or JPEG (told apart by content), with an alpha channel, or without one (every
//! JPEG, a photo) together with `--mask` (8-bit grey, object bright; a given mask wins over an
//! alpha channel). Colours are composited over white
//! with the mask (the published renderings are over white), a non-square image is padded to a
//! square around its centre, and the result is resized (triangle filter) to the size the model
//! was trained on — `--exact-size` turns the resize into an error instead. The model sees the
//! image as if it were taken by an NMR camera (distance 2.732, elevation 30°, field of view 30°,
//! object in the unit cube), which is what it was trained on.
//!
//! Outputs: the mesh (`.obj` or `.ply`, by extension), `<stem>_turntable.png`, and
//! `<stem>_input.png` (the image as the model saw it). With `--gt-mesh` the mesh is also scored
//! against a reference mesh, as `eval` scores test objects: mesh IoU (NMR voxelization of both),
//! the 32³ grid IoU of the same prediction, Chamfer-L1, F-score and normal consistency, printed
//! and written to `<stem>_metrics.json`.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, anyhow, bail};
use burn::prelude::*;
use fieldprobe_core::data::TriMesh;
use fieldprobe_core::data::dataset::{kato_planes, write_atomic};
use fieldprobe_core::data::voxelize::voxelize_nmr;
use fieldprobe_core::eval::surface::SurfaceMetrics;
use fieldprobe_core::eval::{extract_field_mesh, predict_voxels};
use fieldprobe_core::extract::write_mesh;
use image::imageops::FilterType;
use image::{GrayImage, Luma, Rgb, RgbImage};
use serde::{Deserialize, Serialize};
use tracing::info;

use crate::{pictures, plot};
use fieldprobe::evaluate::{reference_surface, score_mesh};
use fieldprobe::run_dir::RunDir;

/// Arguments of `reconstruct`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The run directory of a trained model.
    #[arg(long)]
    run: PathBuf,
    /// The input picture (PNG or JPEG); not used by a per-object fit, which has no encoder.
    #[arg(long)]
    image: Option<PathBuf>,
    /// A mask for an image without alpha (8-bit grey, object bright).
    #[arg(long)]
    mask: Option<PathBuf>,
    /// The mesh to write: `.obj` or `.ply`.
    #[arg(long)]
    out: PathBuf,
    /// Refuse images whose size differs from the model's input instead of resizing them.
    #[arg(long)]
    exact_size: bool,
    /// MISE refinements (default: the run's `eval.extract.refinements`).
    #[arg(long)]
    refinements: Option<usize>,
    /// Turntable frames.
    #[arg(long, default_value_t = 8)]
    frames: usize,
    /// Score the mesh against this reference mesh (in the unit-cube frame of the dataset).
    #[arg(long)]
    gt_mesh: Option<PathBuf>,
}

/// What `<stem>_metrics.json` holds.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ReconstructMetrics {
    pub mesh_iou: f32,
    pub grid_iou: f32,
    pub surface: SurfaceMetrics,
    pub fscore_threshold: f32,
    pub surface_points: usize,
    pub resolution: usize,
}

/// `path` with its stem suffixed: `out/chair.obj` + `_turntable.png` → `out/chair_turntable.png`.
pub fn sibling(path: &Path, suffix: &str) -> PathBuf {
    let stem = path
        .file_stem()
        .map_or("mesh".into(), |s| s.to_string_lossy().into_owned());
    path.with_file_name(format!("{stem}{suffix}"))
}

/// The largest picture side `reconstruct` reads, and the most memory its decoder may take: a
/// forged header cannot make it allocate more (the image crate's own default is 512 MiB).
pub const MAX_SIDE: u32 = 8192;
pub const MAX_DECODE_BYTES: u64 = 256 << 20;

/// Decodes a PNG or JPEG (by its content, not its extension) within [`MAX_SIDE`] and
/// [`MAX_DECODE_BYTES`].
pub fn open_image(path: &Path) -> image::ImageResult<image::DynamicImage> {
    let mut reader = image::ImageReader::open(path)?.with_guessed_format()?;
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_SIDE);
    limits.max_image_height = Some(MAX_SIDE);
    limits.max_alloc = Some(MAX_DECODE_BYTES);
    reader.limits(limits);
    reader.decode()
}

/// Reads a picture (and optional mask) into Kato's `[4, S, S]` planes at `size` (see the module
/// docs). Errors name the file.
pub fn load_input(image: &Path, mask: Option<&Path>, size: usize, exact: bool) -> Result<Vec<u8>> {
    let img =
        open_image(image).map_err(|e| anyhow!("{}: cannot read image: {e}", image.display()))?;
    let (w, h) = (img.width(), img.height());
    if w == 0 || h == 0 {
        bail!("{}: empty image", image.display());
    }
    if exact && (w as usize != size || h as usize != size) {
        bail!(
            "model/image size mismatch: the model was trained on {size}×{size} images, {} is {w}×{h} (drop --exact-size to resize it)",
            image.display()
        );
    }
    let alpha: GrayImage = match mask {
        Some(m) => {
            let mask = open_image(m)
                .map_err(|e| anyhow!("{}: cannot read mask: {e}", m.display()))?
                .to_luma8();
            if mask.dimensions() != (w, h) {
                bail!(
                    "{} is {}×{} but {} is {w}×{h}: image and mask must have one size",
                    m.display(),
                    mask.width(),
                    mask.height(),
                    image.display()
                );
            }
            mask
        }
        None if img.color().has_alpha() => {
            let rgba = img.to_rgba8();
            GrayImage::from_fn(w, h, |x, y| Luma([rgba.get_pixel(x, y)[3]]))
        }
        None => bail!(
            "{} has no alpha channel; pass --mask MASK.png (object bright) to say which pixels are the object",
            image.display()
        ),
    };
    let rgba = img.to_rgba8();
    // Composite over white with the mask, padding to a square around the centre.
    let side = w.max(h);
    let (ox, oy) = ((side - w) / 2, (side - h) / 2);
    let mut rgb = RgbImage::from_pixel(side, side, Rgb([255, 255, 255]));
    let mut a = GrayImage::new(side, side);
    for (x, y, px) in rgba.enumerate_pixels() {
        let m = f32::from(alpha.get_pixel(x, y)[0]) / 255.0;
        let c = [0, 1, 2].map(|ch| (f32::from(px[ch]) * m + 255.0 * (1.0 - m)).round() as u8);
        rgb.put_pixel(x + ox, y + oy, Rgb(c));
        a.put_pixel(x + ox, y + oy, *alpha.get_pixel(x, y));
    }
    let s = size as u32;
    let (rgb, a) = if side == s {
        (rgb, a)
    } else {
        (
            image::imageops::resize(&rgb, s, s, FilterType::Triangle),
            image::imageops::resize(&a, s, s, FilterType::Triangle),
        )
    };
    Ok(kato_planes(&rgb, &a))
}

pub fn run(args: Args) -> Result<()> {
    let rd = RunDir::open(&args.run)?;
    let mut extract = rd.exp.eval.extract.clone();
    if let Some(r) = args.refinements {
        extract.refinements = r;
    }
    extract
        .validate()
        .map_err(|e| anyhow!("--refinements: {e}"))?;
    match args.out.extension().and_then(|e| e.to_str()) {
        Some("obj" | "ply") => {}
        _ => bail!(
            "--out {}: the mesh must be a .obj or .ply file",
            args.out.display()
        ),
    }
    let selected = rd.exp.backend.select()?;
    info!("backend: {}", selected.description);
    let device = &selected.device;
    let model = rd.model(device)?;
    let size = rd.input_size()?;
    let latent = match (rd.exp.model.uses_image(), &args.image) {
        (true, Some(image)) => {
            let planes = load_input(image, args.mask.as_deref(), size, args.exact_size)?;
            let seen = pictures::input_image(&planes, size, 1);
            plot::write_png(&sibling(&args.out, "_input.png"), &seen)?;
            let px: Vec<f32> = planes.iter().map(|&b| f32::from(b) / 255.0).collect();
            let x = Tensor::<4>::from_data(TensorData::new(px, [1, 4, size, size]), device);
            model.encode(x)
        }
        (true, None) => bail!(
            "{}: this model reads an image; pass --image IMG.png",
            rd.dir.display()
        ),
        (false, Some(_)) => bail!(
            "{}: a per-object fit has no image encoder; drop --image to extract its one object",
            rd.dir.display()
        ),
        (false, None) => None,
    };
    let mesh = extract_field_mesh(model.as_ref(), latent.as_ref(), &extract, device);
    if let Some(parent) = args.out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent)
            .with_context(|| format!("cannot create {}", parent.display()))?;
    }
    write_mesh(&mesh, &args.out)?;
    let turntable = sibling(&args.out, "_turntable.png");
    plot::write_png(
        &turntable,
        &pictures::turntable_strip(&mesh, args.frames, 128),
    )?;
    println!(
        "mesh: {} ({} vertices, {} faces{}); turntable: {}",
        args.out.display(),
        mesh.vertices.len(),
        mesh.faces.len(),
        if mesh.faces.is_empty() {
            ": the field is nowhere ≥ ½"
        } else {
            ""
        },
        turntable.display()
    );
    if let Some(gt) = &args.gt_mesh {
        let m = compare(&rd, model.as_ref(), latent.as_ref(), &mesh, gt, device)?;
        let json = serde_json::to_string_pretty(&m)?;
        let path = sibling(&args.out, "_metrics.json");
        write_atomic(&path, |w| std::io::Write::write_all(w, json.as_bytes()))?;
        println!(
            "against {}: mesh IoU {:.3}, grid IoU {:.3} ({r}³, NMR protocol); Chamfer-L1 ×10 {:.4}, F-score@{} {:.3}, normal consistency {:.3} ({} points) → {}",
            gt.display(),
            m.mesh_iou,
            m.grid_iou,
            m.surface.chamfer_l1 * 10.0,
            m.fscore_threshold,
            m.surface.fscore,
            m.surface.normal_consistency,
            m.surface_points,
            path.display(),
            r = m.resolution
        );
    }
    Ok(())
}

/// Scores `mesh` (and the field's grid) against the reference mesh at `gt`, whose NMR
/// voxelization stands in for the dataset's voxels (it is how they were made).
fn compare(
    rd: &RunDir,
    model: &dyn fieldprobe_core::field::Field,
    latent: Option<&Tensor<2>>,
    mesh: &TriMesh,
    gt: &Path,
    device: &Device,
) -> Result<ReconstructMetrics> {
    let cfg = &rd.exp.eval;
    let gt_mesh = TriMesh::load_obj(gt)?;
    let res = cfg.resolution;
    let gt_voxels = voxelize_nmr(&gt_mesh, res);
    let gt_surface = reference_surface(&gt_mesh, cfg, 0);
    let (mesh_iou, surface) = score_mesh(mesh, &gt_voxels, Some(&gt_surface), cfg, 1);
    Ok(ReconstructMetrics {
        mesh_iou,
        grid_iou: predict_voxels(model, latent, &cfg.protocol(), device)
            .maxpool
            .iou(&gt_voxels),
        surface: surface.expect("a reference surface was given"),
        fscore_threshold: cfg.fscore_threshold,
        surface_points: cfg.surface_points,
        resolution: res,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::{DynamicImage, RgbaImage};

    fn save(dir: &Path, name: &str, img: DynamicImage) -> PathBuf {
        let p = dir.join(name);
        img.save(&p).unwrap();
        p
    }

    #[test]
    fn an_rgba_picture_becomes_katos_planes_at_the_model_size() {
        let dir = tempfile::tempdir().unwrap();
        // 40×20, left half an opaque red object, right half transparent.
        let img = RgbaImage::from_fn(40, 20, |x, _| {
            if x < 20 {
                image::Rgba([255, 0, 0, 255])
            } else {
                image::Rgba([0, 0, 0, 0])
            }
        });
        let p = save(dir.path(), "a.png", DynamicImage::ImageRgba8(img));
        let planes = load_input(&p, None, 16, false).unwrap();
        assert_eq!(planes.len(), 4 * 16 * 16);
        let at = |ch: usize, x: usize, y: usize| planes[ch * 256 + y * 16 + x];
        // Padded to 40×40 (rows 10..30 hold the image), then resized to 16: row 8 is inside.
        assert_eq!(at(3, 2, 8), 255, "object alpha");
        assert_eq!(at(0, 2, 8), 0, "red is kept (inverted: 255 − 255)");
        assert_eq!(at(1, 2, 8), 255, "no green (inverted)");
        assert_eq!(at(3, 13, 8), 0, "transparent half");
        assert_eq!(at(0, 13, 8), 0, "background white (inverted: 0)");
        assert_eq!(at(3, 2, 0), 0, "padding is background");
    }

    #[test]
    fn bad_pictures_get_clear_errors() {
        let dir = tempfile::tempdir().unwrap();
        let rgb = save(
            dir.path(),
            "rgb.png",
            DynamicImage::ImageRgb8(RgbImage::new(8, 8)),
        );
        let e = load_input(&rgb, None, 8, false).unwrap_err().to_string();
        assert!(
            e.contains("no alpha channel") && e.contains("rgb.png"),
            "{e}"
        );
        let mask = save(
            dir.path(),
            "m.png",
            DynamicImage::ImageLuma8(GrayImage::new(4, 4)),
        );
        let e = load_input(&rgb, Some(&mask), 8, false)
            .unwrap_err()
            .to_string();
        assert!(e.contains("one size") && e.contains("m.png"), "{e}");
        let e = load_input(&rgb, None, 16, true).unwrap_err().to_string();
        assert!(e.contains("size mismatch") && e.contains("16×16"), "{e}");
        let junk = dir.path().join("junk.png");
        std::fs::write(&junk, b"not a png").unwrap();
        let e = load_input(&junk, None, 8, false).unwrap_err().to_string();
        assert!(e.contains("junk.png") && e.contains("cannot read"), "{e}");
        // RGB with a matching mask works.
        let ok = save(
            dir.path(),
            "m8.png",
            DynamicImage::ImageLuma8(GrayImage::new(8, 8)),
        );
        assert_eq!(load_input(&rgb, Some(&ok), 8, true).unwrap().len(), 4 * 64);
    }

    #[test]
    fn a_jpeg_photo_with_a_mask_is_read() {
        let dir = tempfile::tempdir().unwrap();
        let photo = save(
            dir.path(),
            "photo.jpg",
            DynamicImage::ImageRgb8(RgbImage::from_pixel(24, 24, image::Rgb([200, 30, 30]))),
        );
        let mask = save(
            dir.path(),
            "mask.png",
            DynamicImage::ImageLuma8(GrayImage::from_pixel(24, 24, Luma([255]))),
        );
        let planes = load_input(&photo, Some(&mask), 8, false).unwrap();
        assert_eq!(planes.len(), 4 * 64);
        // Red survives JPEG (inverted: 255 − ~200), alpha is the mask.
        assert!((40..=70).contains(&planes[4 * 8 + 4]), "{}", planes[36]);
        assert_eq!(planes[3 * 64 + 36], 255);
        // Without a mask: the JPEG has no alpha, and the error says what to pass.
        let e = load_input(&photo, None, 8, false).unwrap_err().to_string();
        assert!(e.contains("photo.jpg") && e.contains("--mask"), "{e}");
    }

    /// Mutated PNG and JPEG files (truncated, flipped, forged sizes): a clean error or a picture,
    /// never a panic; the decoder's memory is bounded by [`MAX_DECODE_BYTES`].
    #[test]
    fn mutated_pictures_are_read_or_refused_cleanly() {
        use rand::{Rng, SeedableRng};
        let dir = tempfile::tempdir().unwrap();
        let rgba = RgbaImage::from_fn(32, 32, |x, y| {
            image::Rgba([x as u8 * 8, y as u8 * 8, 90, 255])
        });
        let png = std::fs::read(save(dir.path(), "v.png", DynamicImage::ImageRgba8(rgba))).unwrap();
        let rgb = RgbImage::from_fn(32, 32, |x, y| image::Rgb([x as u8 * 8, y as u8 * 8, 90]));
        let jpg = std::fs::read(save(dir.path(), "v.jpg", DynamicImage::ImageRgb8(rgb))).unwrap();
        let mask = save(
            dir.path(),
            "mask.png",
            DynamicImage::ImageLuma8(GrayImage::from_pixel(32, 32, Luma([255]))),
        );
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x1A6E);
        let case_path = dir.path().join("case.img");
        let mut read = [0usize; 2];
        for case in 0..300 {
            let (valid, k) = if case % 2 == 0 { (&png, 0) } else { (&jpg, 1) };
            let mut b = valid.clone();
            match rng.random_range(0..3) {
                0 => b.truncate(rng.random_range(0..b.len())),
                1 => {
                    for _ in 0..rng.random_range(1..6) {
                        let i = rng.random_range(0..b.len());
                        b[i] ^= 1 << rng.random_range(0..8);
                    }
                }
                _ => {
                    // A forged width/height field (PNG IHDR at 16..24; JPEG SOF near the start).
                    let at = if k == 0 {
                        16 + rng.random_range(0..8)
                    } else {
                        rng.random_range(0..b.len().min(200))
                    };
                    if at < b.len() {
                        b[at] = 0xFF;
                    }
                }
            }
            std::fs::write(&case_path, &b).unwrap();
            let out = std::panic::catch_unwind(|| load_input(&case_path, Some(&mask), 16, false));
            match out {
                Ok(Ok(planes)) => {
                    assert_eq!(planes.len(), 4 * 256, "case {case}");
                    read[k] += 1;
                }
                Ok(Err(e)) => assert!(!e.to_string().is_empty(), "case {case}"),
                Err(_) => panic!("case {case}: decoding panicked"),
            }
        }
        assert!(
            read[0] > 0 && read[1] > 0,
            "both decoders exercised: {read:?}"
        );
    }

    #[test]
    fn outputs_sit_beside_the_mesh() {
        assert_eq!(
            sibling(Path::new("out/chair.obj"), "_turntable.png"),
            Path::new("out/chair_turntable.png")
        );
    }
}
