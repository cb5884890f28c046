//! Connecting to the OpenXR runtime: the loader, the instance with
//! XR_KHR_vulkan_enable2 and the optional extensions vergence uses when
//! offered, the core validation layer as `VERGENCE_XR_VALIDATION` asks, the
//! debug messenger, and the head-mounted system.

use super::{runtime_manifest_hint, unavailable, Messenger, XrCall, CORE_VALIDATION_LAYER};
use crate::error::{Error, Result};
use crate::gpu::Validation;
use openxr as xr;

/// An instance connected to a runtime with a headset.
pub struct Connection {
    /// The instance.
    pub instance: xr::Instance,
    /// The head-mounted system.
    pub system: xr::SystemId,
    /// The extensions enabled.
    pub exts: xr::ExtensionSet,
    /// The API layers enabled.
    pub layers: Vec<&'static str>,
    /// The debug messenger (None without XR_EXT_debug_utils).
    pub messenger: Option<Messenger>,
    /// The runtime's name and version.
    pub props: xr::InstanceProperties,
    /// The system's name and limits.
    pub system_props: xr::SystemProperties,
    /// The OpenXR API version the instance was created for.
    pub api_version: xr::Version,
}

/// Loads the OpenXR loader, creates the instance (for OpenXR 1.1 where
/// offered when `prefer_1_1`, else 1.0) and finds the headset.
/// No loader, runtime, Vulkan binding or headset is
/// [`Error::XrUnavailable`], naming where the loader looked.
pub fn connect(prefer_1_1: bool) -> Result<Connection> {
    // SAFETY: loads the system's OpenXR loader, a conformant library.
    let entry = unsafe { xr::Entry::load(&()) }.map_err(|e| {
            Error::XrUnavailable(format!(
                "cannot load the OpenXR loader libopenxr_loader.so.1 ({e}); install libopenxr-loader1 and a runtime"
            ))
        })?;
    let available = entry
        .enumerate_extensions()
        .map_err(|r| unavailable("xrEnumerateInstanceExtensionProperties", r))?;
    if !available.khr_vulkan_enable2 {
        return Err(Error::XrUnavailable(format!(
            "the OpenXR runtime does not offer XR_KHR_vulkan_enable2 ({})",
            runtime_manifest_hint()
        )));
    }
    let mut exts = xr::ExtensionSet::default();
    exts.khr_vulkan_enable2 = true;
    exts.khr_visibility_mask = available.khr_visibility_mask;
    exts.khr_composition_layer_depth = available.khr_composition_layer_depth;
    exts.ext_debug_utils = available.ext_debug_utils;
    exts.fb_display_refresh_rate = available.fb_display_refresh_rate;
    // The inset goes out as four views where offered (quad views).
    exts.varjo_quad_views = available.varjo_quad_views;
    let foveation = available.fb_foveation
        && available.fb_foveation_configuration
        && available.fb_swapchain_update_state;
    exts.fb_foveation = foveation;
    exts.fb_foveation_configuration = foveation;
    exts.fb_swapchain_update_state = foveation;
    exts.fb_foveation_vulkan = foveation && available.fb_foveation_vulkan;
    let layers = entry.enumerate_layers().unwrap_or_default();
    let has_core = layers.iter().any(|l| l.layer_name == CORE_VALIDATION_LAYER);
    let use_core = match Validation::from_var("VERGENCE_XR_VALIDATION") {
            Validation::Off => false,
            Validation::IfAvailable => has_core,
            Validation::Required if has_core => true,
            Validation::Required => {
                return Err(Error::config(
                    "VERGENCE_XR_VALIDATION",
                    format!("{CORE_VALIDATION_LAYER} is required but not installed (apt-get install openxr-layer-corevalidation)"),
                ))
            }
        };
    let layer_names: Vec<&str> = if use_core {
        vec![CORE_VALIDATION_LAYER]
    } else {
        Vec::new()
    };
    // OpenXR 1.1 first when asked (its core foveated-inset view
    // configuration), 1.0 where the loader or runtime has no 1.1.
    let versions: &[xr::Version] = if prefer_1_1 {
        &[xr::Version::new(1, 1, 0), xr::Version::new(1, 0, 0)]
    } else {
        &[xr::Version::new(1, 0, 0)]
    };
    let mut made = None;
    for (i, &api_version) in versions.iter().enumerate() {
        let app = xr::ApplicationInfo {
            application_name: "vergence",
            application_version: 1,
            engine_name: "vergence",
            engine_version: 1,
            api_version,
        };
        match entry.create_instance(&app, &exts, &layer_names, &()) {
            Ok(instance) => {
                made = Some((instance, api_version));
                break;
            }
            // Any refusal of 1.1 falls back (some loaders and runtimes
            // answer other than ERROR_API_VERSION_UNSUPPORTED).
            Err(r) if i + 1 < versions.len() => {
                tracing::info!("OpenXR {api_version} refused ({r}); trying an older version");
            }
            Err(r) => return Err(unavailable("xrCreateInstance", r)),
        }
    }
    let Some((instance, api_version)) = made else {
        return Err(unavailable(
            "xrCreateInstance",
            xr::sys::Result::ERROR_API_VERSION_UNSUPPORTED,
        ));
    };
    let messenger = Messenger::new(&instance);
    let props = instance.properties().call("xrGetInstanceProperties")?;
    let system = instance
            .system(xr::FormFactor::HEAD_MOUNTED_DISPLAY)
            .map_err(|r| {
                Error::XrUnavailable(format!(
                    "no headset: the runtime {} answers xrGetSystem with {r} (is the headset connected and on?)",
                    props.runtime_name
                ))
            })?;
    let sys_props = instance
        .system_properties(system)
        .call("xrGetSystemProperties")?;
    Ok(Connection {
        instance,
        system,
        exts,
        layers: layer_names,
        messenger,
        props,
        system_props: sys_props,
        api_version,
    })
}
