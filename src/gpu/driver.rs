//! Vulkan drivers vergence refuses to run on, decided from the device's
//! VkPhysicalDeviceDriverProperties before the device is created.

use ash::vk;

/// The oldest Mesa whose lavapipe renders vergence's frames: Debian 12's
/// lavapipe (Mesa 22.3) crashes inside the driver (SIGSEGV in
/// `libvulkan_lvp.so`) and misroutes multiview draws; Mesa 23 and later
/// (Mesa 25 in the Debian 13 root the tests use) render correctly.
pub const MIN_LAVAPIPE_MESA: u32 = 23;

/// The Mesa version in a driver-info string such as `Mesa 22.3.6` or
/// `Mesa 23.0.0-devel (git-1a2b3c)`: (major, minor, patch), missing parts
/// 0. None when the string names no Mesa version.
pub fn mesa_version(info: &str) -> Option<(u32, u32, u32)> {
    let rest = &info[info.find("Mesa ")? + "Mesa ".len()..];
    let end = rest
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(rest.len());
    let mut parts = rest[..end].split('.');
    let major = parts.next()?.parse().ok()?;
    let mut next = || parts.next().and_then(|p| p.parse().ok()).unwrap_or(0);
    Some((major, next(), next()))
}

/// Why vergence refuses the driver with this driver ID and driver-info
/// string, as one line naming the version and the way that works; None to
/// use it. Only lavapipe (Mesa's llvmpipe Vulkan driver) from Mesa older
/// than [`MIN_LAVAPIPE_MESA`] is refused; an info string without a
/// readable Mesa version is not.
pub fn refusal(driver_id: vk::DriverId, info: &str) -> Option<String> {
    if driver_id != vk::DriverId::MESA_LLVMPIPE {
        return None;
    }
    let (major, minor, patch) = mesa_version(info)?;
    (major < MIN_LAVAPIPE_MESA).then(|| {
        format!(
            "the Vulkan driver is lavapipe from Mesa {major}.{minor}.{patch}, which crashes inside the driver on vergence's frames (Mesa {MIN_LAVAPIPE_MESA} or newer works); run vergence inside the Debian 13 root instead: scripts/in-root target/debug/vergence ARGS (after `cargo xtask setup`), or cargo xtask xr -- ARGS, or cargo xtask demo"
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const LVP: vk::DriverId = vk::DriverId::MESA_LLVMPIPE;

    #[test]
    fn reads_mesa_versions() {
        assert_eq!(mesa_version("Mesa 22.3.6"), Some((22, 3, 6)));
        assert_eq!(mesa_version("Mesa 23.0.0-devel"), Some((23, 0, 0)));
        assert_eq!(mesa_version("Mesa 25.0.7 (LLVM 19.1.7)"), Some((25, 0, 7)));
        assert_eq!(mesa_version("Mesa 24"), Some((24, 0, 0)));
        for garbage in ["", "Mesa", "Mesa x.y", "535.104.05", "Mesa .3"] {
            assert_eq!(mesa_version(garbage), None, "{garbage:?}");
        }
    }

    #[test]
    fn refuses_only_lavapipe_older_than_mesa_23() {
        let why = refusal(LVP, "Mesa 22.3.6").expect("Mesa 22.3.6 is refused");
        assert!(why.contains("lavapipe from Mesa 22.3.6"), "{why}");
        assert!(why.contains("scripts/in-root") && why.contains("cargo xtask xr"));
        assert!(!why.contains('\n'));
        assert!(refusal(LVP, "Mesa 22.0.0-devel").is_some());
        for ok in [
            "Mesa 25.0.7",
            "Mesa 23.0.0-devel",
            "Mesa 23.0.0",
            "garbage",
            "",
        ] {
            assert_eq!(refusal(LVP, ok), None, "{ok:?}");
        }
        // Other drivers are not judged by their Mesa version.
        assert_eq!(refusal(vk::DriverId::MESA_RADV, "Mesa 22.3.6"), None);
        assert_eq!(refusal(vk::DriverId::NVIDIA_PROPRIETARY, "535.104"), None);
    }
}
