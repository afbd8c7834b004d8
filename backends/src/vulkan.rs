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

/// Whether Mesa's Vulkan `device_select` layer should be switched off (`NODEVICE_SELECT=1`) for
/// this process, given its environment `var`.
///
/// Mesa installs the layer implicitly with its drivers (lavapipe included). When the Vulkan
/// loader starts it, the layer connects to the Wayland compositor to learn which GPU drives the
/// display; on a headless machine (no `XDG_RUNTIME_DIR`) libwayland prints
/// `error: XDG_RUNTIME_DIR is invalid or not set in the environment.` once per probe, six
/// times per run, though nothing is wrong. A compute job has no display to match and this
/// project picks its adapter itself ([`crate::hardware_gpu`]), so the layer has nothing to do.
/// It is left alone wherever a user may rely on it: when any of its own variables
/// (`NODEVICE_SELECT`, `MESA_VK_DEVICE_SELECT`, `DRI_PRIME`) is set, or when `XDG_RUNTIME_DIR`
/// names a folder (a desktop session). Off Linux the layer does not exist.
pub fn device_select_is_noise(var: impl Fn(&str) -> Option<String>) -> bool {
    if !cfg!(target_os = "linux") {
        return false;
    }
    let user_set = ["NODEVICE_SELECT", "MESA_VK_DEVICE_SELECT", "DRI_PRIME"]
        .iter()
        .any(|v| var(v).is_some());
    let session = var("XDG_RUNTIME_DIR")
        .filter(|d| !d.is_empty())
        .is_some_and(|d| Path::new(&d).is_dir());
    !user_set && !session
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

#[cfg(test)]
mod tests {
    use super::*;

    fn env<'a>(vars: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<String> + 'a {
        move |name| {
            vars.iter()
                .find(|(k, _)| *k == name)
                .map(|(_, v)| v.to_string())
        }
    }

    #[test]
    #[cfg(target_os = "linux")]
    fn device_select_is_switched_off_only_on_a_headless_machine_nobody_configured() {
        // Headless: no session folder, or one that does not exist.
        assert!(device_select_is_noise(env(&[])));
        assert!(device_select_is_noise(env(&[("XDG_RUNTIME_DIR", "")])));
        assert!(device_select_is_noise(env(&[(
            "XDG_RUNTIME_DIR",
            "/nonexistent/fieldprobe-test"
        )])));
        // A desktop session: the layer may be choosing the display's GPU.
        let dir = std::env::temp_dir();
        let dir = dir.to_str().unwrap();
        assert!(!device_select_is_noise(env(&[("XDG_RUNTIME_DIR", dir)])));
        // The user configured the layer (or already switched it off).
        for var in ["NODEVICE_SELECT", "MESA_VK_DEVICE_SELECT", "DRI_PRIME"] {
            assert!(!device_select_is_noise(env(&[(var, "1")])), "{var}");
        }
    }
}
