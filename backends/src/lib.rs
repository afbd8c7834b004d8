//! The runtime choice of burn [`Device`]: `auto`, `wgpu` or `flex`.
//!
//! burn 0.22 selects the backend through a runtime `Device`, so nothing in FieldProbe is generic
//! over a backend type. This crate turns the user's choice (a TOML/CLI string) into a device and a
//! human-readable description of what was picked, so runs can log and record it.
//!
//! * `flex` — burn's portable CPU backend; always available.
//! * `wgpu` — the default wgpu adapter (a hardware GPU if present, else a software Vulkan/GL
//!   implementation such as Mesa's lavapipe).
//! * `auto` — wgpu when a *hardware* GPU adapter exists, otherwise flex (a software rasterizer is
//!   slower than flex for this workload).
//!
//! On Linux wgpu reaches GPUs (and Mesa's software device) through Vulkan; without a Vulkan
//! driver it falls back to OpenGL on llvmpipe, where cubecl's autotune has hung a test run
//! forever. So `wgpu` is refused there with a line saying what to install, and `auto` goes to
//! flex without opening an adapter ([`wgpu_unavailable`]). Tests that drive a device use
//! [`testing`]: a skip line instead of a hang, and a watchdog on every device test.

use std::fmt;
use std::str::FromStr;

pub use burn::tensor::Device;
use burn::tensor::{DeviceKind, DeviceType};
use serde::{Deserialize, Serialize};

pub mod testing;
mod vulkan;

pub use vulkan::{device_select_is_noise, wgpu_unavailable};

/// Which backend to run on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BackendChoice {
    /// wgpu on a hardware GPU if one is present, else flex.
    #[default]
    Auto,
    /// wgpu's default adapter.
    Wgpu,
    /// burn's CPU backend.
    Flex,
}

impl FromStr for BackendChoice {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "auto" => Ok(Self::Auto),
            "wgpu" => Ok(Self::Wgpu),
            "flex" | "cpu" => Ok(Self::Flex),
            _ => Err(format!(
                "unknown backend '{s}': expected auto, wgpu or flex"
            )),
        }
    }
}

impl fmt::Display for BackendChoice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Auto => "auto",
            Self::Wgpu => "wgpu",
            Self::Flex => "flex",
        })
    }
}

/// A resolved backend: the device and what it is.
#[derive(Clone, Debug)]
pub struct Selected {
    pub device: Device,
    /// `flex` or `wgpu`.
    pub backend: &'static str,
    /// E.g. `wgpu: NVIDIA H100 (hardware)` or `flex (CPU)`.
    pub description: String,
}

/// The name of the first wgpu adapter that is a physical card, if any. Opens the adapters.
pub fn hardware_gpu() -> Option<(Device, String)> {
    Device::enumerate(DeviceType::Wgpu)
        .into_vec()
        .into_iter()
        .find_map(|d| {
            let id = d.identity()?;
            id.physical.as_ref()?;
            Some((d, id.name))
        })
}

impl BackendChoice {
    /// Resolves the choice to a device (without autodiff; call `.autodiff()` to train).
    ///
    /// `wgpu` is refused, with what to install, where wgpu has no Vulkan driver to run on
    /// ([`wgpu_unavailable`]); `auto` then takes flex without opening any wgpu adapter.
    pub fn select(self) -> Result<Selected, BackendError> {
        match self {
            Self::Flex => Ok(flex()),
            Self::Wgpu => {
                if let Some(reason) = wgpu_unavailable() {
                    return Err(BackendError::NoVulkan(reason));
                }
                let device = Device::wgpu(DeviceKind::DefaultDevice);
                let name = device
                    .identity()
                    .map_or_else(|| "default adapter".into(), |i| i.name);
                Ok(Selected {
                    device,
                    backend: "wgpu",
                    description: format!("wgpu: {name}"),
                })
            }
            Self::Auto => Ok(
                match wgpu_unavailable().map_or_else(hardware_gpu, |_| None) {
                    Some((device, name)) => Selected {
                        device,
                        backend: "wgpu",
                        description: format!("wgpu: {name} (hardware GPU found)"),
                    },
                    None => Selected {
                        description: "flex (CPU; no hardware GPU adapter found)".into(),
                        ..flex()
                    },
                },
            ),
        }
    }
}

impl Selected {
    /// `k` devices of this backend for data-parallel training (`train.devices`): the selected
    /// device alone for `k = 1`; flex's one CPU device `k` times (replicas on one device: the
    /// machinery, not a speedup); for wgpu the first `k` adapters that wgpu enumerates, hardware
    /// GPUs first, or an error saying how many there are.
    pub fn devices(&self, k: usize) -> Result<Vec<Device>, BackendError> {
        if k <= 1 {
            return Ok(vec![self.device.clone()]);
        }
        if self.backend == "flex" {
            return Ok(vec![self.device.clone(); k]);
        }
        let mut all = Device::enumerate(DeviceType::Wgpu).into_vec();
        // Stable: hardware adapters first, in wgpu's order.
        all.sort_by_key(|d| d.identity().and_then(|i| i.physical).is_none());
        if all.len() < k {
            return Err(BackendError::TooFewDevices {
                wanted: k,
                found: all.len(),
            });
        }
        all.truncate(k);
        Ok(all)
    }
}

/// Why a backend cannot be used here.
#[derive(Debug, thiserror::Error)]
pub enum BackendError {
    #[error(
        "backend \"wgpu\": {0}. wgpu would fall back to OpenGL, which FieldProbe does not run on \
         (cubecl's autotune has been seen to wait forever there). Install a Vulkan driver (for a \
         software device: `{install}`) or use backend = \"flex\"",
        install = vulkan::VULKAN_INSTALL
    )]
    NoVulkan(String),
    #[error(
        "train.devices = {wanted}, but wgpu lists {found} adapter(s) on this machine; lower \
         train.devices"
    )]
    TooFewDevices { wanted: usize, found: usize },
}

fn flex() -> Selected {
    Selected {
        device: Device::flex(),
        backend: "flex",
        description: "flex (CPU)".into(),
    }
}
