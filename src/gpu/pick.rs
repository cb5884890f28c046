//! Choosing the physical device and what of it vergence enables: the
//! steps of [`super::Context`]'s device set-up, each reading one part of
//! the device's properties or features.

use super::{driver, Capabilities, DeviceFactory};
use crate::error::{Error, Result, VkContext};
use ash::vk;
use std::ffi::CStr;

/// The physical device: the one the OpenXR runtime requires, else the one
/// `VERGENCE_DEVICE` numbers, else the first discrete, then integrated,
/// then other device of Vulkan 1.3.
pub(super) fn choose(
    inst: &ash::Instance,
    required: Option<vk::PhysicalDevice>,
) -> Result<(vk::PhysicalDevice, vk::PhysicalDeviceProperties)> {
    // SAFETY: enumeration on a valid instance.
    let devices = unsafe { inst.enumerate_physical_devices() }.vk("enumerating GPUs")?;
    if devices.is_empty() {
        return Err(Error::Gpu(
            "no Vulkan device found (install mesa-vulkan-drivers for a CPU device)".into(),
        ));
    }
    let wanted: Option<usize> = std::env::var("VERGENCE_DEVICE")
        .ok()
        .and_then(|v| v.parse().ok());
    let mut candidates: Vec<(usize, vk::PhysicalDevice, vk::PhysicalDeviceProperties)> = devices
        .iter()
        .enumerate()
        // SAFETY: valid physical device handles from enumeration.
        .map(|(i, &pd)| (i, pd, unsafe { inst.get_physical_device_properties(pd) }))
        .filter(|(_, _, p)| p.api_version >= vk::API_VERSION_1_3)
        .collect();
    if let Some(r) = required {
        candidates.retain(|(_, pd, _)| *pd == r);
        if candidates.is_empty() {
            return Err(Error::Gpu(
                "the GPU the OpenXR runtime asks for does not support Vulkan 1.3".into(),
            ));
        }
    } else if let Some(w) = wanted {
        candidates.retain(|(i, _, _)| *i == w);
    }
    candidates.sort_by_key(|(_, _, p)| match p.device_type {
        vk::PhysicalDeviceType::DISCRETE_GPU => 0,
        vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
        _ => 2,
    });
    candidates
        .first()
        .map(|&(_, pd, props)| (pd, props))
        .ok_or_else(|| {
            Error::Gpu("no Vulkan 1.3 device found (or VERGENCE_DEVICE names none)".into())
        })
}

/// The driver's identity and the multiview view limit.
pub(super) struct DriverInfo {
    /// The driver's id.
    pub id: vk::DriverId,
    /// Its name and version text, as the driver gives them.
    pub name: String,
    /// Its description.
    pub info: String,
    /// maxMultiviewViewCount.
    pub max_multiview_views: u32,
}

/// The driver's identity; a driver vergence knows to fail is refused
/// ([`driver::refusal`]).
pub(super) fn driver_info(inst: &ash::Instance, pd: vk::PhysicalDevice) -> Result<DriverInfo> {
    let mut driver_props = vk::PhysicalDeviceDriverProperties::default();
    let mut multiview_props = vk::PhysicalDeviceMultiviewProperties::default();
    let mut p2 = vk::PhysicalDeviceProperties2::default()
        .push_next(&mut driver_props)
        .push_next(&mut multiview_props);
    // SAFETY: valid physical device of a Vulkan 1.3 instance (driver
    // properties are core since 1.2, multiview's since 1.1) and a
    // correctly chained query.
    unsafe { inst.get_physical_device_properties2(pd, &mut p2) };
    let c_text = |s: std::result::Result<&CStr, _>| {
        s.map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default()
    };
    let info = DriverInfo {
        id: driver_props.driver_id,
        name: c_text(driver_props.driver_name_as_c_str()),
        info: c_text(driver_props.driver_info_as_c_str()),
        max_multiview_views: multiview_props.max_multiview_view_count,
    };
    match driver::refusal(info.id, &info.info) {
        Some(why) => Err(Error::Gpu(why)),
        None => Ok(info),
    }
}

/// The first queue family with graphics, and whether it has timestamps.
pub(super) fn graphics_queue(inst: &ash::Instance, pd: vk::PhysicalDevice) -> Result<(u32, bool)> {
    // SAFETY: valid physical device.
    let families = unsafe { inst.get_physical_device_queue_family_properties(pd) };
    let family = families
        .iter()
        .position(|f| f.queue_flags.contains(vk::QueueFlags::GRAPHICS))
        .ok_or_else(|| Error::Gpu("the device has no graphics queue".into()))?;
    Ok((family as u32, families[family].timestamp_valid_bits > 0))
}

/// What the device offers of the optional features and extensions
/// vergence uses, and the required features checked.
#[derive(Clone, Copy)]
pub(super) struct Offered {
    /// Attachment fragment shading rate, and its texel size.
    pub shading_rate_texel: Option<(u32, u32)>,
    /// 64-bit buffer atomics (with shaderInt64).
    pub atomic_int64: bool,
    /// Pipeline statistics queries.
    pub pipeline_statistics: bool,
    /// Queries inherited by secondary command buffers.
    pub inherited_queries: bool,
    /// shaderDrawParameters.
    pub shader_draw_parameters: bool,
    /// Dynamic indexing of sampled-image arrays.
    pub sampled_array_indexing: bool,
    /// Anisotropic filtering.
    pub anisotropy: bool,
}

/// The device's features: multiview, dynamic rendering, synchronization2
/// and clip distances are required (one error naming what is missing);
/// the rest is what [`Offered`] lists.
pub(super) fn features(
    inst: &ash::Instance,
    pd: vk::PhysicalDevice,
    has_ext: &dyn Fn(&CStr) -> bool,
) -> Result<Offered> {
    let fsr_offered = has_ext(ash::khr::fragment_shading_rate::NAME);
    let atomic_int64_offered = has_ext(ash::khr::shader_atomic_int64::NAME);
    let mut f11 = vk::PhysicalDeviceVulkan11Features::default();
    let mut f13 = vk::PhysicalDeviceVulkan13Features::default();
    let mut ffsr = vk::PhysicalDeviceFragmentShadingRateFeaturesKHR::default();
    let mut fi64 = vk::PhysicalDeviceShaderAtomicInt64Features::default();
    let mut f2 = vk::PhysicalDeviceFeatures2::default()
        .push_next(&mut f11)
        .push_next(&mut f13);
    if atomic_int64_offered {
        f2 = f2.push_next(&mut fi64);
    }
    if fsr_offered {
        f2 = f2.push_next(&mut ffsr);
    }
    // SAFETY: valid physical device and a correctly chained query struct.
    unsafe { inst.get_physical_device_features2(pd, &mut f2) };
    let base = f2.features;
    if f11.multiview == 0 || f13.dynamic_rendering == 0 || f13.synchronization2 == 0 {
        return Err(Error::Gpu(
            "the device lacks multiview, dynamic rendering or synchronization2".into(),
        ));
    }
    // The section plane clips in the scene's vertex shader.
    if base.shader_clip_distance == 0 {
        return Err(Error::Gpu(
            "the device lacks shaderClipDistance (the section plane needs it)".into(),
        ));
    }
    let use_fsr = fsr_offered && ffsr.attachment_fragment_shading_rate != 0;
    Ok(Offered {
        shading_rate_texel: use_fsr.then(|| shading_rate_texel(inst, pd)),
        atomic_int64: atomic_int64_offered
            && base.shader_int64 != 0
            && fi64.shader_buffer_int64_atomics != 0,
        pipeline_statistics: base.pipeline_statistics_query != 0,
        inherited_queries: base.inherited_queries != 0,
        shader_draw_parameters: f11.shader_draw_parameters != 0,
        sampled_array_indexing: base.shader_sampled_image_array_dynamic_indexing != 0,
        anisotropy: base.sampler_anisotropy != 0,
    })
}

/// The smallest texel size of a fragment shading rate attachment.
fn shading_rate_texel(inst: &ash::Instance, pd: vk::PhysicalDevice) -> (u32, u32) {
    let mut fsr_props = vk::PhysicalDeviceFragmentShadingRatePropertiesKHR::default();
    let mut p2 = vk::PhysicalDeviceProperties2::default().push_next(&mut fsr_props);
    // SAFETY: valid physical device and a correctly chained query.
    unsafe { inst.get_physical_device_properties2(pd, &mut p2) };
    let t = fsr_props.min_fragment_shading_rate_attachment_texel_size;
    (t.width.max(1), t.height.max(1))
}

/// The device extensions to enable: what [`Offered`] uses, the optional
/// ones the device has (memory budget, indirect count, clip-space w
/// scaling) and `extra` (a window's), which must all be there.
pub(super) fn extensions(
    offered: &Offered,
    has_ext: &dyn Fn(&CStr) -> bool,
    extra: &[&'static CStr],
) -> Result<Vec<&'static CStr>> {
    let mut names = Vec::new();
    for &name in extra {
        if !has_ext(name) {
            return Err(Error::Gpu(format!(
                "the device offers no {} (needed for a window)",
                name.to_string_lossy()
            )));
        }
    }
    names.extend(
        [
            ash::ext::memory_budget::NAME,
            ash::khr::draw_indirect_count::NAME,
            ash::nv::clip_space_w_scaling::NAME,
        ]
        .into_iter()
        .filter(|n| has_ext(n)),
    );
    if offered.shading_rate_texel.is_some() {
        names.push(ash::khr::fragment_shading_rate::NAME);
    }
    if offered.atomic_int64 {
        names.push(ash::khr::shader_atomic_int64::NAME);
    }
    names.extend_from_slice(extra);
    Ok(names)
}

/// Creates the logical device with one queue of `queue_family` and what
/// `offered` and `exts` enable.
pub(super) fn create_device(
    factory: &dyn DeviceFactory,
    entry: &ash::Entry,
    inst: &ash::Instance,
    pd: vk::PhysicalDevice,
    queue_family: u32,
    offered: &Offered,
    exts: &[&'static CStr],
) -> Result<ash::Device> {
    let features = vk::PhysicalDeviceFeatures::default()
        .pipeline_statistics_query(offered.pipeline_statistics)
        .inherited_queries(offered.inherited_queries)
        .shader_clip_distance(true)
        .shader_int64(offered.atomic_int64)
        .shader_sampled_image_array_dynamic_indexing(offered.sampled_array_indexing)
        .sampler_anisotropy(offered.anisotropy);
    let mut e11 = vk::PhysicalDeviceVulkan11Features::default()
        .multiview(true)
        .shader_draw_parameters(offered.shader_draw_parameters);
    // Indirect count is enabled through VK_KHR_draw_indirect_count rather
    // than the Vulkan12Features bit: an OpenXR runtime creating the device
    // (XR_KHR_vulkan_enable2) may chain its own 1.2-era feature structs,
    // which must not meet a Vulkan12Features (VUID-VkDeviceCreateInfo-
    // pNext-02830). The extension implies the feature.
    let mut e13 = vk::PhysicalDeviceVulkan13Features::default()
        .dynamic_rendering(true)
        .synchronization2(true);
    let mut e_fsr = vk::PhysicalDeviceFragmentShadingRateFeaturesKHR::default()
        .attachment_fragment_shading_rate(true);
    let mut e_i64 =
        vk::PhysicalDeviceShaderAtomicInt64Features::default().shader_buffer_int64_atomics(true);
    let names: Vec<*const std::ffi::c_char> = exts.iter().map(|n| n.as_ptr()).collect();
    let prio = [1.0f32];
    let qinfo = [vk::DeviceQueueCreateInfo::default()
        .queue_family_index(queue_family)
        .queue_priorities(&prio)];
    let mut dinfo = vk::DeviceCreateInfo::default()
        .queue_create_infos(&qinfo)
        .enabled_features(&features)
        .enabled_extension_names(&names)
        .push_next(&mut e11)
        .push_next(&mut e13);
    if offered.shading_rate_texel.is_some() {
        dinfo = dinfo.push_next(&mut e_fsr);
    }
    if offered.atomic_int64 {
        dinfo = dinfo.push_next(&mut e_i64);
    }
    factory.create_device(entry, inst, pd, &dinfo)
}

/// The device's capabilities from its properties, formats and memory
/// types, with what `offered` and `has_ext` say.
pub(super) fn capabilities(
    inst: &ash::Instance,
    pd: vk::PhysicalDevice,
    props: &vk::PhysicalDeviceProperties,
    (offered, timestamps, max_multiview_views): (&Offered, bool, u32),
    has_ext: &dyn Fn(&CStr) -> bool,
) -> Result<Capabilities> {
    let lim = props.limits;
    let samples = lim.framebuffer_color_sample_counts & lim.framebuffer_depth_sample_counts;
    let max_samples = [8u32, 4, 2, 1]
        .into_iter()
        .find(|&s| samples.contains(vk::SampleCountFlags::from_raw(s)))
        .unwrap_or(1);
    let (depth_format, depth_only_format) = depth_formats(inst, pd)?;
    Ok(Capabilities {
        pipeline_statistics: offered.pipeline_statistics,
        timestamp_period_ns: if timestamps {
            lim.timestamp_period
        } else {
            0.0
        },
        lazily_allocated_memory: lazily_allocated(inst, pd),
        max_samples,
        depth_format,
        depth_only_format,
        shading_rate_texel: offered.shading_rate_texel,
        fragment_density_map: has_ext(ash::ext::fragment_density_map::NAME),
        per_view_render_areas: has_ext(ash::qcom::multiview_per_view_render_areas::NAME),
        max_multiview_views,
        memory_budget: has_ext(ash::ext::memory_budget::NAME),
        draw_indirect_count: has_ext(ash::khr::draw_indirect_count::NAME),
        shader_draw_parameters: offered.shader_draw_parameters,
        inherited_queries: offered.inherited_queries,
        min_uniform_offset_alignment: lim.min_uniform_buffer_offset_alignment,
        clip_space_w_scaling: has_ext(ash::nv::clip_space_w_scaling::NAME),
        atomic_int64: offered.atomic_int64,
        max_storage_buffer_range: lim.max_storage_buffer_range,
    })
}

/// Whether any memory type is lazily allocated (tile memory).
fn lazily_allocated(inst: &ash::Instance, pd: vk::PhysicalDevice) -> bool {
    // SAFETY: valid physical device.
    let mem = unsafe { inst.get_physical_device_memory_properties(pd) };
    mem.memory_types[..mem.memory_type_count as usize]
        .iter()
        .any(|t| {
            t.property_flags
                .contains(vk::MemoryPropertyFlags::LAZILY_ALLOCATED)
        })
}

/// The depth-stencil format (D32S8, else D24S8; one is required) and the
/// depth-only D32 where it can be sampled and copied.
fn depth_formats(
    inst: &ash::Instance,
    pd: vk::PhysicalDevice,
) -> Result<(vk::Format, Option<vk::Format>)> {
    // SAFETY: valid physical device.
    let features = |f| unsafe { inst.get_physical_device_format_properties(pd, f) };
    let depth_format = [
        vk::Format::D32_SFLOAT_S8_UINT,
        vk::Format::D24_UNORM_S8_UINT,
    ]
    .into_iter()
    .find(|&f| {
        features(f)
            .optimal_tiling_features
            .contains(vk::FormatFeatureFlags::DEPTH_STENCIL_ATTACHMENT)
    })
    .ok_or_else(|| Error::Gpu("no depth-stencil format with stencil is supported".into()))?;
    let depth_only = features(vk::Format::D32_SFLOAT)
        .optimal_tiling_features
        .contains(
            vk::FormatFeatureFlags::DEPTH_STENCIL_ATTACHMENT
                | vk::FormatFeatureFlags::SAMPLED_IMAGE
                | vk::FormatFeatureFlags::TRANSFER_SRC,
        )
        .then_some(vk::Format::D32_SFLOAT);
    Ok((depth_format, depth_only))
}
