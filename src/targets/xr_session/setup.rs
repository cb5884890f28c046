//! The OpenXR session's set-up steps, in the order `run_session` takes
//! them: what the runtime is, which views it wants, whether its Vulkan
//! range includes ours, the session, its reference space and the
//! swapchain formats.

use super::super::session::{RunStats, ViewInfo};
use crate::error::{Error, Result};
use crate::gpu::Context;
use crate::xr::instance::Connection;
use crate::xr::XrCall;
use ash::vk;
use ash::vk::Handle;
use openxr as xr;

/// The view configuration the session runs: stereo, or quad views with
/// the inset.
pub(super) struct Views {
    /// The runtime takes the inset as four views.
    pub quad: bool,
    /// The view configuration type.
    pub view_type: xr::ViewConfigurationType,
    /// Its views' recommended and largest sizes.
    pub config: Vec<xr::ViewConfigurationView>,
}

/// Records the runtime, system, extensions and layers in `stats`.
pub(super) fn record_runtime(c: &Connection, stats: &mut RunStats) {
    stats.mode = "openxr".into();
    stats.runtime = Some(format!(
        "{} {}",
        c.props.runtime_name, c.props.runtime_version
    ));
    stats.system = c.system_props.system_name.clone();
    stats.extensions_enabled = c
        .exts
        .names()
        .iter()
        .map(|n| {
            String::from_utf8_lossy(n)
                .trim_end_matches('\0')
                .to_string()
        })
        .collect();
    stats.api_layers = c.layers.iter().map(|s| s.to_string()).collect();
    tracing::info!(
        "OpenXR runtime {} {}, system {}",
        c.props.runtime_name,
        c.props.runtime_version,
        c.system_props.system_name
    );
}

/// The views: with the inset (not composited here) and a runtime that
/// takes quad views (XR_VARJO_quad_views, or OpenXR 1.1), the four views
/// go out as they are. Both name one value: XR_VARJO_quad_views'
/// PRIMARY_QUAD_VARJO is OpenXR 1.1's PRIMARY_STEREO_WITH_FOVEATED_INSET.
pub(super) fn choose_views(c: &Connection, inset_out: bool, stats: &mut RunStats) -> Result<Views> {
    let foveated_inset = xr::ViewConfigurationType::PRIMARY_STEREO_WITH_FOVEATED_INSET;
    let quad = (c.exts.varjo_quad_views || c.api_version >= xr::Version::new(1, 1, 0))
        && inset_out
        && c.instance
            .enumerate_view_configurations(c.system)
            .call("xrEnumerateViewConfigurations")?
            .contains(&foveated_inset);
    let view_type = match quad {
        true => foveated_inset,
        false => xr::ViewConfigurationType::PRIMARY_STEREO,
    };
    let config = c
        .instance
        .enumerate_view_configuration_views(c.system, view_type)
        .call("xrEnumerateViewConfigurationViews")?;
    let wanted = if quad { 4 } else { 2 };
    if config.len() != wanted {
        return Err(Error::config(
            "view configuration",
            format!(
                "the view configuration has {} views; the renderer needs {wanted}",
                config.len()
            ),
        ));
    }
    let name = match (quad, c.exts.varjo_quad_views) {
        (false, _) => "PRIMARY_STEREO",
        (true, true) => "PRIMARY_QUAD_VARJO",
        (true, false) => "PRIMARY_STEREO_WITH_FOVEATED_INSET",
    };
    stats.view_configuration = Some(name.into());
    stats.api_version = Some(c.api_version.to_string());
    if quad {
        tracing::info!("the runtime takes quad views: the inset goes out as four views");
    }
    stats.views = config.iter().map(view_info).collect();
    Ok(Views {
        quad,
        view_type,
        config,
    })
}

/// A view's sizes for the run's stats.
fn view_info(v: &xr::ViewConfigurationView) -> ViewInfo {
    ViewInfo {
        recommended: [
            v.recommended_image_rect_width,
            v.recommended_image_rect_height,
        ],
        max: [v.max_image_rect_width, v.max_image_rect_height],
        fov: None,
    }
}

/// The runtime's first environment blend mode (opaque if it lists none).
pub(super) fn blend_mode(c: &Connection, views: &Views) -> Result<xr::EnvironmentBlendMode> {
    Ok(c.instance
        .enumerate_environment_blend_modes(c.system, views.view_type)
        .call("xrEnumerateEnvironmentBlendModes")?
        .first()
        .copied()
        .unwrap_or(xr::EnvironmentBlendMode::OPAQUE))
}

/// Refuses a runtime whose Vulkan range starts above 1.3; warns where it
/// was tested only below 1.3.
pub(super) fn check_vulkan(c: &Connection) -> Result<()> {
    let reqs = c
        .instance
        .graphics_requirements::<xr::Vulkan>(c.system)
        .call("xrGetVulkanGraphicsRequirements2KHR")?;
    if reqs.min_api_version_supported > xr::Version::new(1, 3, 0) {
        return Err(Error::Gpu(format!(
            "the OpenXR runtime needs Vulkan {} or newer; vergence uses Vulkan 1.3",
            reqs.min_api_version_supported
        )));
    }
    let max = reqs.max_api_version_supported;
    if max.major() < 1 || (max.major() == 1 && max.minor() < 3) {
        tracing::warn!(
            "the runtime was tested up to Vulkan {max}; vergence needs 1.3 and goes ahead"
        );
    }
    Ok(())
}

/// The eye size: the user's `--width`/`--height`, else the largest of the
/// two eyes' recommended sizes.
pub(super) fn eye_extent(
    size: Option<(u32, u32)>,
    views: &[xr::ViewConfigurationView],
) -> vk::Extent2D {
    let (width, height) = size.unwrap_or_else(|| {
        views.iter().take(2).fold((1, 1), |m, v| {
            (
                m.0.max(v.recommended_image_rect_width),
                m.1.max(v.recommended_image_rect_height),
            )
        })
    });
    vk::Extent2D { width, height }
}

/// The largest image both eyes' swapchains may hold.
pub(super) fn max_extent(views: &[xr::ViewConfigurationView]) -> (u32, u32) {
    views.iter().take(2).fold((u32::MAX, u32::MAX), |m, v| {
        (
            m.0.min(v.max_image_rect_width),
            m.1.min(v.max_image_rect_height),
        )
    })
}

/// The session with its frame waiter and stream, on `ctx`'s device.
pub(super) fn create_session(
    c: &Connection,
    ctx: &Context,
) -> Result<(
    xr::Session<xr::Vulkan>,
    xr::FrameWaiter,
    xr::FrameStream<xr::Vulkan>,
)> {
    // SAFETY: the handles come from the context created through this
    // runtime and outlive the session (see `Live`'s drop order).
    unsafe {
        c.instance.create_session::<xr::Vulkan>(
            c.system,
            &xr::vulkan::SessionCreateInfo {
                instance: ctx.instance.handle().as_raw() as _,
                physical_device: ctx.physical_device.as_raw() as _,
                device: ctx.device.handle().as_raw() as _,
                queue_family_index: ctx.queue_family,
                queue_index: 0,
            },
        )
    }
    .call("xrCreateSession")
}

/// The display refresh rates (with XR_FB_display_refresh_rate) and the
/// reference space: STAGE where offered, else LOCAL.
pub(super) fn reference_space(
    c: &Connection,
    session: &xr::Session<xr::Vulkan>,
    stats: &mut RunStats,
) -> Result<xr::Space> {
    if c.exts.fb_display_refresh_rate {
        stats.display_refresh_hz = session.get_display_refresh_rate().ok();
        stats.display_refresh_rates = session
            .enumerate_display_refresh_rates()
            .unwrap_or_default();
    }
    let spaces = session
        .enumerate_reference_spaces()
        .call("xrEnumerateReferenceSpaces")?;
    let stage = spaces.contains(&xr::ReferenceSpaceType::STAGE);
    let (space_type, name) = match stage {
        true => (xr::ReferenceSpaceType::STAGE, "STAGE"),
        false => (xr::ReferenceSpaceType::LOCAL, "LOCAL"),
    };
    stats.reference_space = Some(name.into());
    session
        .create_reference_space(space_type, xr::Posef::IDENTITY)
        .call("xrCreateReferenceSpace")
}

/// The swapchains' colour format and, where the runtime takes depth
/// layers (not with quad views) in the device's depth format, the depth
/// format.
pub(super) fn swapchain_formats(
    c: &Connection,
    session: &xr::Session<xr::Vulkan>,
    quad: bool,
    ctx: &Context,
    stats: &mut RunStats,
) -> Result<(vk::Format, Option<vk::Format>)> {
    let formats: Vec<vk::Format> = session
        .enumerate_swapchain_formats()
        .call("xrEnumerateSwapchainFormats")?
        .into_iter()
        .map(|f| vk::Format::from_raw(f as i32))
        .collect();
    let color = crate::xr::choose_color_format(&formats).ok_or_else(|| {
        Error::Gpu(format!(
            "the runtime offers no sRGB colour format vergence can fill (offered: {formats:?})"
        ))
    })?;
    let depth =
        (c.exts.khr_composition_layer_depth && !quad && formats.contains(&ctx.caps.depth_format))
            .then_some(ctx.caps.depth_format);
    stats.color_format = Some(format!("{color:?}"));
    stats.depth_format = depth.map(|f| format!("{f:?}"));
    Ok((color, depth))
}
