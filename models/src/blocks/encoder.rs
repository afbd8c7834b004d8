//! A ResNet image encoder: trained from scratch by default, or started from a torchvision
//! ResNet's ImageNet weights as the paper does (`pretrained`).
//!
//! A stem, then stages of basic residual blocks (two 3×3 convs with batch norm; a 1×1
//! projection on the shortcut when shape changes), each stage after the first halving the
//! resolution, then global average pooling and a linear map to the latent. The default is
//! ResNet18's widths and depths: channels `[64, 128, 256, 512]`, blocks `[2, 2, 2, 2]`.
//!
//! Two stems (`stem`):
//! * `"compact"` (default): one 3×3 stride-2 convolution on RGBA (64×64 → 32×32), no pooling.
//!   Small pictures keep their detail; what this project trains from scratch.
//! * `"resnet"`: torchvision's stem, so that its weights fit: a 7×7 stride-2 convolution on the
//!   RGB planes normalized with ImageNet's mean and deviation, batch norm, a 3×3 stride-2 max
//!   pool. A torchvision ResNet reads RGB only; the silhouette (alpha) enters through its own
//!   7×7 convolution added to the RGB one and initialized to zero, so an imported network first
//!   computes exactly what it computed on ImageNet, and training teaches it the fourth channel.
//!   Pictures are fed as the dataset stores them (Kato's inverted RGB, as NMR and SoftRas feed
//!   them).
//!
//! `pretrained` names a torchvision-layout ResNet-18 or -34 `state_dict` saved as safetensors
//! (README, "Weights in and out"); its names are mapped onto this module by
//! [`EncoderConfig::torchvision_import`], `fc` (ImageNet's classifier) is left out and the
//! latent head keeps its random start.

use std::path::PathBuf;

use burn::nn::Initializer;
use burn::nn::conv::{Conv2d, Conv2dConfig};
use burn::nn::pool::{AdaptiveAvgPool2d, AdaptiveAvgPool2dConfig};
use burn::nn::pool::{MaxPool2d, MaxPool2dConfig};
use burn::nn::{BatchNorm, BatchNormConfig, Linear, LinearConfig, PaddingConfig2d};
use burn::prelude::*;
use burn::tensor::activation::relu;
use fieldprobe_core::field::FieldModel;
use fieldprobe_core::weights::Import;
use serde::{Deserialize, Serialize};

/// Encoder widths and depths.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EncoderConfig {
    /// Channels per stage (ResNet18: [64, 128, 256, 512]).
    #[serde(default = "EncoderConfig::resnet18_channels")]
    pub channels: Vec<usize>,
    /// Residual blocks per stage (ResNet18: [2, 2, 2, 2]).
    #[serde(default = "EncoderConfig::resnet18_blocks")]
    pub blocks: Vec<usize>,
    /// Input channels: 4 (RGB + alpha).
    #[serde(default = "EncoderConfig::rgba")]
    pub in_channels: usize,
    /// `"compact"` (3×3 stride-2 convolution, no pooling) or `"resnet"` (torchvision's 7×7 stem
    /// and max pool; needed by `pretrained`). See the module docs.
    #[serde(default)]
    pub stem: Stem,
    /// A torchvision-layout ResNet-18/34 `state_dict` as `.safetensors` to start from (ImageNet
    /// weights, as the paper). Read once when training starts; `--resume` and evaluation take
    /// the weights from the run's checkpoint.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pretrained: Option<PathBuf>,
}

/// The encoder's first layers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Stem {
    /// One 3×3 stride-2 convolution on all input channels.
    #[default]
    Compact,
    /// torchvision's ResNet stem on ImageNet-normalized RGB, the alpha plane through its own
    /// zero-initialized convolution.
    Resnet,
}

/// ImageNet's per-channel mean and standard deviation (torchvision's normalization).
const IMAGENET_MEAN: [f32; 3] = [0.485, 0.456, 0.406];
const IMAGENET_STD: [f32; 3] = [0.229, 0.224, 0.225];

impl Default for EncoderConfig {
    fn default() -> Self {
        Self {
            channels: Self::resnet18_channels(),
            blocks: Self::resnet18_blocks(),
            in_channels: Self::rgba(),
            stem: Stem::Compact,
            pretrained: None,
        }
    }
}

impl EncoderConfig {
    fn resnet18_channels() -> Vec<usize> {
        vec![64, 128, 256, 512]
    }
    fn resnet18_blocks() -> Vec<usize> {
        vec![2, 2, 2, 2]
    }
    fn rgba() -> usize {
        4
    }

    pub fn validate(&self) -> Result<(), String> {
        if self.channels.is_empty() || self.channels.len() != self.blocks.len() {
            return Err(format!(
                "model.encoder.channels ({:?}) and model.encoder.blocks ({:?}) must be non-empty and of equal length",
                self.channels, self.blocks
            ));
        }
        if self.channels.contains(&0) || self.blocks.contains(&0) || self.in_channels == 0 {
            return Err("model.encoder sizes must be positive".into());
        }
        if self.stem == Stem::Resnet && self.in_channels != 4 {
            return Err(format!(
                "model.encoder.stem = \"resnet\" reads RGB + alpha: in_channels must be 4, not {}",
                self.in_channels
            ));
        }
        if let Some(path) = &self.pretrained {
            if self.stem != Stem::Resnet {
                return Err(
                    "model.encoder.pretrained needs stem = \"resnet\" (torchvision's stem)".into(),
                );
            }
            if self.channels != Self::resnet18_channels() {
                return Err(format!(
                    "model.encoder.pretrained is a torchvision ResNet-18/34: channels must be {:?}, not {:?}",
                    Self::resnet18_channels(),
                    self.channels
                ));
            }
            if !path.is_file() {
                return Err(format!(
                    "model.encoder.pretrained: {} is not a file (README, \"Weights in and out\", says how to make one)",
                    path.display()
                ));
            }
        }
        Ok(())
    }

    /// How a torchvision ResNet's `state_dict` names (`conv1.weight`, `bn1.running_mean`,
    /// `layer2.0.downsample.1.weight`, …) map onto this encoder's tensors under `prefix` (the
    /// field's name in its model, e.g. `"encoder"`). Every convolution and batch norm must come
    /// from the file; the alpha convolution and the latent head keep their own start.
    pub fn torchvision_import(&self, prefix: &str) -> Import {
        // "encoder" + "stem." → "encoder.stem."; an empty prefix is the encoder itself.
        let at = |rest: &str| match prefix {
            "" => rest.to_string(),
            p => format!("{p}.{rest}"),
        };
        let mut rename = vec![
            (r"^conv1\.".to_string(), at("stem.")),
            (r"^bn1\.".to_string(), at("stem_bn.")),
        ];
        let mut index = 0;
        for (stage, &n) in self.blocks.iter().enumerate() {
            for block in 0..n {
                let from = format!(r"^layer{}\.{block}\.", stage + 1);
                let to = at(&format!("blocks.{index}."));
                rename.push((
                    format!(r"{from}downsample\.0\."),
                    format!("{to}shortcut.conv."),
                ));
                rename.push((
                    format!(r"{from}downsample\.1\."),
                    format!("{to}shortcut.bn."),
                ));
                rename.push((from, to));
                index += 1;
            }
        }
        Import {
            rename,
            pytorch: true,
            required: vec![at("")],
            optional: vec![at("stem_alpha."), at("head.")],
        }
    }

    /// Loads `pretrained`, if set, into the encoder at `prefix` of `model`.
    pub fn load_pretrained(&self, prefix: &str, model: &mut dyn FieldModel) -> Result<(), String> {
        let Some(path) = &self.pretrained else {
            return Ok(());
        };
        let report = model
            .import_safetensors(path, &self.torchvision_import(prefix))
            .map_err(|e| format!("model.encoder.pretrained: {e}"))?;
        log::info!(
            "encoder: {} tensors from {} (not used: {})",
            report.loaded,
            path.display(),
            if report.unused.is_empty() {
                "none".to_string()
            } else {
                report.unused.join(", ")
            }
        );
        Ok(())
    }

    pub fn init(&self, latent: usize, device: &Device) -> Encoder {
        let c0 = self.channels[0];
        let (stem, stem_alpha, stem_pool) = match self.stem {
            Stem::Compact => (
                Conv2dConfig::new([self.in_channels, c0], [3, 3])
                    .with_stride([2, 2])
                    .with_padding(PaddingConfig2d::Explicit(1, 1, 1, 1))
                    .init(device),
                None,
                None,
            ),
            Stem::Resnet => {
                let conv7 = |cin: usize| {
                    Conv2dConfig::new([cin, c0], [7, 7])
                        .with_stride([2, 2])
                        .with_padding(PaddingConfig2d::Explicit(3, 3, 3, 3))
                        .with_bias(false)
                };
                let pool = MaxPool2dConfig::new([3, 3])
                    .with_strides([2, 2])
                    .with_padding(PaddingConfig2d::Explicit(1, 1, 1, 1))
                    .init();
                (
                    conv7(3).init(device),
                    Some(conv7(1).with_initializer(Initializer::Zeros).init(device)),
                    Some(pool),
                )
            }
        };
        let mut blocks = Vec::new();
        let mut prev = c0;
        for (s, (&c, &n)) in self.channels.iter().zip(&self.blocks).enumerate() {
            for b in 0..n {
                let stride = if s > 0 && b == 0 { 2 } else { 1 };
                blocks.push(BasicBlock::new(prev, c, stride, device));
                prev = c;
            }
        }
        Encoder {
            stem,
            stem_alpha,
            stem_bn: BatchNormConfig::new(c0).init(device),
            stem_pool,
            blocks,
            pool: AdaptiveAvgPool2dConfig::new([1, 1]).init(),
            head: LinearConfig::new(prev, latent).init(device),
        }
    }
}

fn conv3(cin: usize, cout: usize, stride: usize, device: &Device) -> Conv2d {
    Conv2dConfig::new([cin, cout], [3, 3])
        .with_stride([stride, stride])
        .with_padding(PaddingConfig2d::Explicit(1, 1, 1, 1))
        .with_bias(false)
        .init(device)
}

/// Two 3×3 convolutions with batch norm and a residual connection.
#[derive(Module, Debug)]
pub struct BasicBlock {
    conv1: Conv2d,
    bn1: BatchNorm,
    conv2: Conv2d,
    bn2: BatchNorm,
    shortcut: Option<Projection>,
}

/// The 1×1 convolution + batch norm on a shortcut whose shape changes.
#[derive(Module, Debug)]
pub struct Projection {
    conv: Conv2d,
    bn: BatchNorm,
}

impl BasicBlock {
    fn new(cin: usize, cout: usize, stride: usize, device: &Device) -> Self {
        let shortcut = (cin != cout || stride != 1).then(|| Projection {
            conv: Conv2dConfig::new([cin, cout], [1, 1])
                .with_stride([stride, stride])
                .with_bias(false)
                .init(device),
            bn: BatchNormConfig::new(cout).init(device),
        });
        Self {
            conv1: conv3(cin, cout, stride, device),
            bn1: BatchNormConfig::new(cout).init(device),
            conv2: conv3(cout, cout, 1, device),
            bn2: BatchNormConfig::new(cout).init(device),
            shortcut,
        }
    }

    fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        let y = relu(self.bn1.forward(self.conv1.forward(x.clone())));
        let y = self.bn2.forward(self.conv2.forward(y));
        let skip = match &self.shortcut {
            Some(p) => p.bn.forward(p.conv.forward(x)),
            None => x,
        };
        relu(y + skip)
    }
}

/// The encoder module.
#[derive(Module, Debug)]
pub struct Encoder {
    stem: Conv2d,
    /// The alpha plane's convolution of the `resnet` stem (`None`: the compact stem reads RGBA).
    stem_alpha: Option<Conv2d>,
    stem_bn: BatchNorm,
    stem_pool: Option<MaxPool2d>,
    blocks: Vec<BasicBlock>,
    pool: AdaptiveAvgPool2d,
    head: Linear,
}

impl Encoder {
    /// `[B, C, S, S]` → `[B, latent]`.
    pub fn forward(&self, images: Tensor<4>) -> Tensor<2> {
        self.head.forward(self.features(images))
    }

    /// The pooled features before the latent head, `[B, channels.last()]` (for a torchvision
    /// ResNet, what its `fc` reads).
    pub fn features(&self, images: Tensor<4>) -> Tensor<2> {
        let x = match &self.stem_alpha {
            None => self.stem.forward(images),
            Some(alpha) => {
                let device = images.device();
                let mean = Tensor::<1>::from_floats(IMAGENET_MEAN, &device).reshape([1, 3, 1, 1]);
                let std = Tensor::<1>::from_floats(IMAGENET_STD, &device).reshape([1, 3, 1, 1]);
                let rgb = (images.clone().narrow(1, 0, 3) - mean) / std;
                self.stem.forward(rgb) + alpha.forward(images.narrow(1, 3, 1))
            }
        };
        let mut x = relu(self.stem_bn.forward(x));
        if let Some(pool) = &self.stem_pool {
            x = pool.forward(x);
        }
        for b in &self.blocks {
            x = b.forward(x);
        }
        self.pool.forward(x).flatten(1, 3)
    }
}
