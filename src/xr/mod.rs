//! The OpenXR wrapper (any conformant runtime): errors in vergence's
//! terms, the debug messenger the core validation layer reports through,
//! swapchains, views as located (sanitized, placed in the world),
//! visibility masks, the session lifecycle in [`state`], the Vulkan device
//! made through XR_KHR_vulkan_enable2 in [`vulkan`] and the call watchdog.
//! The application's session loop that uses them lives above, in
//! `targets::xr_session`.

pub mod actions;
pub mod instance;
pub mod remote;
pub mod state;
pub mod vulkan;
pub mod watchdog;

use crate::error::{Error, Result};
use crate::interact::locomotion::Origin;
use crate::view::{Fov, HiddenArea, Pose, StereoRig, View};
use ash::vk;
use ash::vk::Handle;
use glam::{DQuat, DVec3};
use openxr as xr;
use openxr::sys;
use state::SessionState;
use std::ffi::CStr;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Duration;

/// The OpenXR core validation layer.
pub const CORE_VALIDATION_LAYER: &str = "XR_APILAYER_LUNARG_core_validation";

/// Longest an OpenXR call may block before the runtime counts as gone.
pub const CALL_LIMIT: Duration = Duration::from_secs(4);

/// Colour formats vergence can fill, in no order: the runtime's list decides.
const SRGB_FORMATS: [vk::Format; 2] = [vk::Format::R8G8B8A8_SRGB, vk::Format::B8G8R8A8_SRGB];

/// The first sRGB format in the runtime's preference-ordered list that the
/// renderer can fill.
pub fn choose_color_format(runtime_formats: &[vk::Format]) -> Option<vk::Format> {
    runtime_formats
        .iter()
        .copied()
        .find(|f| SRGB_FORMATS.contains(f))
}

/// Where the OpenXR loader looks for the active runtime, for messages.
pub fn runtime_manifest_hint() -> String {
    if let Ok(p) = std::env::var("XR_RUNTIME_JSON") {
        let state = if std::path::Path::new(&p).exists() {
            "exists"
        } else {
            "does not exist"
        };
        return format!("XR_RUNTIME_JSON={p} ({state})");
    }
    let home = std::env::var("XDG_CONFIG_HOME")
        .ok()
        .or_else(|| std::env::var("HOME").ok().map(|h| format!("{h}/.config")))
        .unwrap_or_else(|| "~/.config".into());
    let dirs = std::env::var("XDG_CONFIG_DIRS").unwrap_or_else(|_| "/etc/xdg".into());
    let mut candidates = vec![format!("{home}/openxr/1/active_runtime.json")];
    candidates.extend(
        dirs.split(':')
            .filter(|d| !d.is_empty())
            .map(|d| format!("{d}/openxr/1/active_runtime.json")),
    );
    candidates.push("/etc/openxr/1/active_runtime.json".into());
    match candidates.iter().find(|c| std::path::Path::new(c).exists()) {
        Some(found) => format!("active runtime manifest {found}"),
        None => format!(
            "no active runtime manifest (XR_RUNTIME_JSON unset; looked for {})",
            candidates.join(", ")
        ),
    }
}

/// A failed call that means no runtime or headset is usable, with where
/// the loader looked for the runtime.
pub fn unavailable(what: &str, r: sys::Result) -> Error {
    Error::XrUnavailable(format!(
        "{what} failed with {r}; {}",
        runtime_manifest_hint()
    ))
}

/// Wraps a failed OpenXR call; results that mean the runtime went away
/// say so.
pub fn xr_err(what: &str, r: sys::Result) -> Error {
    let context = match r {
        sys::Result::ERROR_INSTANCE_LOST
        | sys::Result::ERROR_SESSION_LOST
        | sys::Result::ERROR_RUNTIME_FAILURE => {
            format!("{what} (the OpenXR runtime stopped or failed; the session cannot continue)")
        }
        _ => what.to_string(),
    };
    Error::Xr { context, result: r }
}

/// OpenXR results as vergence errors naming the call.
pub trait XrCall<T> {
    /// The value, or the error of the call `what`.
    fn call(self, what: &str) -> Result<T>;
}

impl<T> XrCall<T> for std::result::Result<T, sys::Result> {
    fn call(self, what: &str) -> Result<T> {
        self.map_err(|r| xr_err(what, r))
    }
}

/// Counts OpenXR debug-utils warnings and errors (the core validation
/// layer reports through it).
#[derive(Default)]
struct XrLog {
    count: AtomicUsize,
    first: Mutex<Vec<String>>,
}

unsafe extern "system" fn xr_debug_callback(
    severity: sys::DebugUtilsMessageSeverityFlagsEXT,
    _types: sys::DebugUtilsMessageTypeFlagsEXT,
    data: *const sys::DebugUtilsMessengerCallbackDataEXT,
    user: *mut std::ffi::c_void,
) -> sys::Bool32 {
    // SAFETY: the runtime passes valid callback data; `user` is the boxed
    // log owned by the messenger guard, alive until the messenger is gone.
    let (log, message) = unsafe {
        let log = &*(user as *const XrLog);
        let m = if data.is_null() || (*data).message.is_null() {
            String::new()
        } else {
            CStr::from_ptr((*data).message)
                .to_string_lossy()
                .into_owned()
        };
        (log, m)
    };
    let bad = sys::DebugUtilsMessageSeverityFlagsEXT::WARNING
        | sys::DebugUtilsMessageSeverityFlagsEXT::ERROR;
    if severity.intersects(bad) {
        log.count.fetch_add(1, Ordering::SeqCst);
        tracing::error!("OpenXR validation: {message}");
        if let Ok(mut f) = log.first.lock() {
            if f.len() < 16 {
                f.push(message);
            }
        }
    } else {
        tracing::debug!("OpenXR: {message}");
    }
    sys::FALSE
}

/// The debug-utils messenger and its log.
pub struct Messenger {
    instance: xr::Instance,
    handle: sys::DebugUtilsMessengerEXT,
    log: Box<XrLog>,
}

impl Messenger {
    /// Warnings and errors reported so far.
    pub fn count(&self) -> usize {
        self.log.count.load(Ordering::SeqCst)
    }

    /// The first reported messages (at most 16).
    pub fn first_messages(&self) -> Vec<String> {
        self.log.first.lock().map(|f| f.clone()).unwrap_or_default()
    }

    /// A messenger on `instance` (None without XR_EXT_debug_utils).
    pub fn new(instance: &xr::Instance) -> Option<Messenger> {
        let du = instance.exts().ext_debug_utils.as_ref()?;
        let log = Box::<XrLog>::default();
        let info = sys::DebugUtilsMessengerCreateInfoEXT {
            ty: sys::DebugUtilsMessengerCreateInfoEXT::TYPE,
            next: std::ptr::null(),
            message_severities: sys::DebugUtilsMessageSeverityFlagsEXT::VERBOSE
                | sys::DebugUtilsMessageSeverityFlagsEXT::INFO
                | sys::DebugUtilsMessageSeverityFlagsEXT::WARNING
                | sys::DebugUtilsMessageSeverityFlagsEXT::ERROR,
            message_types: sys::DebugUtilsMessageTypeFlagsEXT::GENERAL
                | sys::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                | sys::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE
                | sys::DebugUtilsMessageTypeFlagsEXT::CONFORMANCE,
            user_callback: Some(xr_debug_callback),
            user_data: &*log as *const XrLog as *mut std::ffi::c_void,
        };
        let mut handle = <sys::DebugUtilsMessengerEXT as sys::Handle>::NULL;
        // SAFETY: valid instance and create info; the log box outlives the
        // messenger (destroyed in Drop before the box).
        let r = unsafe { (du.create_debug_utils_messenger)(instance.as_raw(), &info, &mut handle) };
        if r.into_raw() < 0 {
            tracing::warn!("cannot create the OpenXR debug messenger: {r}");
            return None;
        }
        Some(Messenger {
            instance: instance.clone(),
            handle,
            log,
        })
    }
}

impl Drop for Messenger {
    fn drop(&mut self) {
        if let Some(du) = self.instance.exts().ext_debug_utils.as_ref() {
            // SAFETY: the messenger was created from this instance.
            unsafe { (du.destroy_debug_utils_messenger)(self.handle) };
        }
    }
}

/// One swapchain and its images.
pub struct Chain {
    /// The swapchain.
    pub swapchain: xr::Swapchain<xr::Vulkan>,
    /// Its images, by acquire index.
    pub images: Vec<vk::Image>,
}

impl Chain {
    /// A swapchain of `layers`-layer images at `extent` (one sample).
    pub fn new(
        session: &xr::Session<xr::Vulkan>,
        format: vk::Format,
        usage: xr::SwapchainUsageFlags,
        extent: vk::Extent2D,
        layers: u32,
    ) -> Result<Chain> {
        let swapchain = session
            .create_swapchain(&xr::SwapchainCreateInfo {
                create_flags: xr::SwapchainCreateFlags::EMPTY,
                usage_flags: usage,
                format: format.as_raw() as u32,
                sample_count: 1,
                width: extent.width,
                height: extent.height,
                face_count: 1,
                array_size: layers,
                mip_count: 1,
            })
            .call("xrCreateSwapchain")?;
        let images = swapchain
            .enumerate_images()
            .call("xrEnumerateSwapchainImagesKHR")?
            .into_iter()
            .map(vk::Image::from_raw)
            .collect();
        Ok(Chain { swapchain, images })
    }
}

fn pose_of(p: &xr::Posef) -> Pose {
    Pose {
        position: DVec3::new(
            p.position.x as f64,
            p.position.y as f64,
            p.position.z as f64,
        ),
        orientation: DQuat::from_xyzw(
            p.orientation.x as f64,
            p.orientation.y as f64,
            p.orientation.z as f64,
            p.orientation.w as f64,
        ),
    }
}

/// An OpenXR FOV in vergence's [`Fov`] (radians as f64).
pub fn fov_of(f: &xr::Fovf) -> Fov {
    Fov {
        left: f.angle_left as f64,
        right: f.angle_right as f64,
        up: f.angle_up as f64,
        down: f.angle_down as f64,
    }
}

/// A view as located: its sanitized pose and FOV plus the raw view that
/// goes back to the runtime in the projection layer.
pub type TrackedView = (Pose, Fov, xr::View);

/// Tracking-space views of one frame, with invalid ones replaced by the
/// last valid view: a view counts as valid when the runtime flags both
/// orientation and position valid and its numbers pass
/// [`Pose::validate`] and [`Fov::validate`]. Returns None until every view
/// was valid once, and whether any view was replaced.
pub fn sanitize_views(
    flags: xr::ViewStateFlags,
    views: &[xr::View],
    last_valid: &mut Vec<Option<TrackedView>>,
) -> (Option<Vec<TrackedView>>, bool) {
    last_valid.resize(views.len(), None);
    let tracked = flags.contains(xr::ViewStateFlags::ORIENTATION_VALID)
        && flags.contains(xr::ViewStateFlags::POSITION_VALID);
    let mut replaced = false;
    for (i, v) in views.iter().enumerate() {
        let pose = pose_of(&v.pose);
        let fov = fov_of(&v.fov);
        if tracked && pose.validate().is_ok() && fov.validate().is_ok() {
            let orientation = pose.orientation.normalize();
            last_valid[i] = Some((
                Pose {
                    orientation,
                    ..pose
                },
                fov,
                *v,
            ));
        } else {
            replaced = true;
        }
    }
    let out: Option<Vec<_>> = last_valid.iter().copied().collect();
    (out.filter(|v| !v.is_empty()), replaced)
}

/// The head in tracking space: between the eyes, with the orientation
/// halfway between theirs.
pub fn tracking_head(views: &[(Pose, Fov)]) -> Pose {
    let n = views.len().max(1) as f64;
    let center = views.iter().map(|(p, _)| p.position).sum::<DVec3>() / n;
    let orientation = match views {
        [a, b, ..] => a.0.orientation.slerp(b.0.orientation, 0.5),
        [a] => a.0.orientation,
        [] => DQuat::IDENTITY,
    };
    Pose {
        position: center,
        orientation,
    }
}

/// The world-space rig of tracking-space views seen through the tracking
/// origin `origin` (position, yaw and scale: a scaled origin scales the
/// eye separation too): the head sits between the eyes with the
/// orientation halfway between theirs.
pub fn world_rig(origin: &Origin, views: &[(Pose, Fov)]) -> StereoRig {
    let head = origin.pose(&tracking_head(views));
    StereoRig {
        head,
        views: views
            .iter()
            .map(|(p, f)| View {
                pose: origin.pose(p),
                fov: *f,
            })
            .collect(),
        hidden_area: None,
    }
}

/// The runtime's hidden-area meshes of the first `views` views of the
/// session's view configuration `view_type`.
pub fn fetch_masks(
    session: &xr::Session<xr::Vulkan>,
    view_type: xr::ViewConfigurationType,
    views: u32,
) -> Result<Vec<HiddenArea>> {
    (0..views)
        .map(|i| {
            let m = session
                .get_visibility_mask_khr(
                    view_type,
                    i,
                    xr::VisibilityMaskTypeKHR::HIDDEN_TRIANGLE_MESH,
                )
                .call("xrGetVisibilityMaskKHR")?;
            Ok(HiddenArea {
                vertices: m.vertices.iter().map(|v| [v.x, v.y]).collect(),
                indices: m.indices,
            })
        })
        .collect()
}

/// The lifecycle state of an OpenXR session state.
pub fn state_of(s: xr::SessionState) -> SessionState {
    match s {
        xr::SessionState::IDLE => SessionState::Idle,
        xr::SessionState::READY => SessionState::Ready,
        xr::SessionState::SYNCHRONIZED => SessionState::Synchronized,
        xr::SessionState::VISIBLE => SessionState::Visible,
        xr::SessionState::FOCUSED => SessionState::Focused,
        xr::SessionState::STOPPING => SessionState::Stopping,
        xr::SessionState::LOSS_PENDING => SessionState::LossPending,
        xr::SessionState::EXITING => SessionState::Exiting,
        _ => SessionState::Unknown,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colour_format_follows_the_runtime_order() {
        let f = [
            vk::Format::R16G16B16A16_SFLOAT,
            vk::Format::B8G8R8A8_SRGB,
            vk::Format::R8G8B8A8_SRGB,
        ];
        assert_eq!(choose_color_format(&f), Some(vk::Format::B8G8R8A8_SRGB));
        assert_eq!(choose_color_format(&[vk::Format::R8G8B8A8_UNORM]), None);
    }

    fn view(x: f32, fov: f32) -> xr::View {
        xr::View {
            pose: xr::Posef {
                orientation: xr::Quaternionf {
                    x: 0.0,
                    y: 0.0,
                    z: 0.0,
                    w: 1.0,
                },
                position: xr::Vector3f { x, y: 1.6, z: 0.0 },
            },
            fov: xr::Fovf {
                angle_left: -fov,
                angle_right: fov,
                angle_up: fov,
                angle_down: -fov,
            },
        }
    }

    #[test]
    fn invalid_views_keep_the_last_valid_pose_and_never_pass_nan() {
        let valid = xr::ViewStateFlags::ORIENTATION_VALID | xr::ViewStateFlags::POSITION_VALID;
        let mut last = Vec::new();
        let (none, replaced) = sanitize_views(
            xr::ViewStateFlags::EMPTY,
            &[view(-0.03, 0.7), view(0.03, 0.7)],
            &mut last,
        );
        assert!(
            none.is_none() && replaced,
            "no valid pose yet: nothing to render"
        );
        let (some, replaced) =
            sanitize_views(valid, &[view(-0.03, 0.7), view(0.03, 0.7)], &mut last);
        assert!(!replaced);
        let first = some.expect("valid");
        let mut nan = view(f32::NAN, 0.7);
        nan.pose.orientation.w = f32::NAN;
        let (kept, replaced) = sanitize_views(valid, &[nan, view(0.05, 0.6)], &mut last);
        let kept = kept.expect("last valid reused");
        assert!(replaced);
        assert_eq!(
            kept[0].0, first[0].0,
            "NaN view replaced by the last valid one"
        );
        assert!(
            (kept[1].0.position.x - 0.05).abs() < 1e-6,
            "valid view updated"
        );
        let mut bad_fov = view(0.0, 0.7);
        bad_fov.fov.angle_right = -1.0;
        let (kept, replaced) = sanitize_views(valid, &[bad_fov, view(0.05, 0.6)], &mut last);
        assert!(replaced);
        assert_eq!(kept.expect("kept")[0].1, first[0].1);
        let (kept, _) = sanitize_views(
            xr::ViewStateFlags::ORIENTATION_VALID,
            &[view(9.0, 0.7), view(9.0, 0.7)],
            &mut last,
        );
        for (p, f, _) in kept.expect("kept") {
            assert!(p.validate().is_ok() && f.validate().is_ok());
            assert!(p.position.x.abs() < 1.0, "untracked position ignored");
        }
    }

    #[test]
    fn world_rig_places_tracking_views_at_the_spawn_pose() {
        let spawn = Pose::from_euler_deg(DVec3::new(10.0, 0.0, 5.0), 90.0, 0.0, 0.0);
        let f = Fov::symmetric(0.7, 0.7);
        let eyes = [
            (
                Pose {
                    position: DVec3::new(-0.03, 1.6, 0.0),
                    orientation: DQuat::IDENTITY,
                },
                f,
            ),
            (
                Pose {
                    position: DVec3::new(0.03, 1.6, 0.0),
                    orientation: DQuat::IDENTITY,
                },
                f,
            ),
        ];
        let rig = world_rig(&Origin::from_pose(&spawn), &eyes);
        assert!((rig.head.position - DVec3::new(10.0, 1.6, 5.0)).length() < 1e-9);
        // Yaw 90° turns tracking +x into world -z.
        assert!((rig.views[0].pose.position - DVec3::new(10.0, 1.6, 5.03)).length() < 1e-9);
        assert!((rig.views[1].pose.position - DVec3::new(10.0, 1.6, 4.97)).length() < 1e-9);
    }
}
