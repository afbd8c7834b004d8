//! Is there a Vulkan driver for wgpu to use? Answered from the files the Vulkan loader itself
//! reads, without opening any device: opening an adapter is what hangs on a machine without one.

use std::path::{Path, PathBuf};

/// What to install for a Vulkan device where there is no GPU driver (Mesa's lavapipe).
pub const VULKAN_INSTALL: &str = "apt-get install mesa-vulkan-drivers libvulkan1";

/// `None` when wgpu can be used here; otherwise why not, in words a user can act on.
///
/// Only Linux is checked: there wgpu's own choice falls back from Vulkan to OpenGL, which this
/// project does not support. macOS (Metal) and Windows (DX12/Vulkan) are taken as usable.
pub fn wgpu_unavailable() -> Option<String> {
    if !cfg!(target_os = "linux") {
        return None;
    }
    let loader = loader_dirs()
        .into_iter()
        .any(|d| d.join("libvulkan.so.1").exists());
    if !loader {
        return Some("no Vulkan loader (libvulkan.so.1) found".into());
    }
    if icd_manifests().is_empty() {
        return Some(
            "no Vulkan driver (ICD manifest in vulkan/icd.d, VK_DRIVER_FILES or VK_ICD_FILENAMES) found"
                .into(),
        );
    }
    None
}

/// Folders the dynamic loader searches for `libvulkan.so.1` on common distributions.
fn loader_dirs() -> Vec<PathBuf> {
    let mut dirs: Vec<PathBuf> = std::env::var("LD_LIBRARY_PATH")
        .unwrap_or_default()
        .split(':')
        .filter(|d| !d.is_empty())
        .map(PathBuf::from)
        .collect();
    for d in [
        "/usr/lib/x86_64-linux-gnu",
        "/usr/lib/aarch64-linux-gnu",
        "/lib/x86_64-linux-gnu",
        "/lib/aarch64-linux-gnu",
        "/usr/lib64",
        "/lib64",
        "/usr/lib",
        "/lib",
        "/usr/local/lib",
    ] {
        dirs.push(PathBuf::from(d));
    }
    dirs
}

/// The ICD manifests the Vulkan loader would read: the files named by `VK_DRIVER_FILES` /
/// `VK_ICD_FILENAMES` if set, else `*.json` in `vulkan/icd.d` under the XDG config and data
/// folders and `/etc`.
fn icd_manifests() -> Vec<PathBuf> {
    for var in ["VK_DRIVER_FILES", "VK_ICD_FILENAMES"] {
        if let Ok(list) = std::env::var(var) {
            return list
                .split(':')
                .map(PathBuf::from)
                .filter(|p| p.exists())
                .collect();
        }
    }
    let env_dirs = |var: &str, default: &str| -> Vec<PathBuf> {
        std::env::var(var)
            .ok()
            .filter(|v| !v.is_empty())
            .unwrap_or_else(|| default.into())
            .split(':')
            .map(PathBuf::from)
            .collect()
    };
    let mut roots = env_dirs("XDG_CONFIG_DIRS", "/etc/xdg");
    roots.push(PathBuf::from("/etc"));
    if let Some(home) = std::env::var_os("HOME") {
        roots.push(Path::new(&home).join(".local/share"));
    }
    roots.extend(env_dirs("XDG_DATA_DIRS", "/usr/local/share:/usr/share"));
    roots
        .into_iter()
        .flat_map(|r| {
            std::fs::read_dir(r.join("vulkan/icd.d"))
                .into_iter()
                .flatten()
        })
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect()
}
