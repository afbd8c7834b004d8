//! A ResNet-style image encoder trained from scratch (the paper uses an ImageNet-pretrained
//! ResNet18; no pretrained weights are available offline, and silhouette supervision trains this
//! one end to end).
//!
//! Stem `conv3×3 / 2` (64×64 → 32×32), then stages of basic residual blocks (two 3×3 convs with
//! batch norm; a 1×1 projection on the shortcut when shape changes), each stage after the first
//! halving the resolution, then global average pooling and a linear map to the latent. The
//! default is ResNet18's widths and depths: channels `[64, 128, 256, 512]`, blocks `[2, 2, 2, 2]`.

use burn::nn::conv::{Conv2d, Conv2dConfig};
use burn::nn::pool::{AdaptiveAvgPool2d, AdaptiveAvgPool2dConfig};
use burn::nn::{BatchNorm, BatchNormConfig, Linear, LinearConfig, PaddingConfig2d};
use burn::prelude::*;
use burn::tensor::activation::relu;
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
}

impl Default for EncoderConfig {
    fn default() -> Self {
        Self {
            channels: Self::resnet18_channels(),
            blocks: Self::resnet18_blocks(),
            in_channels: Self::rgba(),
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
        Ok(())
    }

    pub fn init(&self, latent: usize, device: &Device) -> Encoder {
        let c0 = self.channels[0];
        let stem = Conv2dConfig::new([self.in_channels, c0], [3, 3])
            .with_stride([2, 2])
            .with_padding(PaddingConfig2d::Explicit(1, 1, 1, 1))
            .init(device);
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
            stem_bn: BatchNormConfig::new(c0).init(device),
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
    stem_bn: BatchNorm,
    blocks: Vec<BasicBlock>,
    pool: AdaptiveAvgPool2d,
    head: Linear,
}

impl Encoder {
    /// `[B, C, S, S]` → `[B, latent]`.
    pub fn forward(&self, images: Tensor<4>) -> Tensor<2> {
        let mut x = relu(self.stem_bn.forward(self.stem.forward(images)));
        for b in &self.blocks {
            x = b.forward(x);
        }
        let x: Tensor<2> = self.pool.forward(x).flatten(1, 3);
        self.head.forward(x)
    }
}
