//! The Vulkan layer (ash): instance and device, memory, frame ring with
//! deferred destruction, queries, pipelines described as plain data and the
//! embedded SPIR-V. Raw Vulkan calls live here and in `render/`'s recording
//! code only through the handles exposed by [`Context`].

pub mod barrier;
pub mod driver;
pub mod fault;
pub mod memory;
mod pick;
pub mod pipeline;
pub mod query;
pub mod rendering;
pub mod ring;
pub mod shaders;
pub mod surface;
pub mod ui_layer;
pub mod validation;

use crate::error::{Error, Result, VkContext};
use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};
use std::collections::BTreeMap;
use std::ffi::{CStr, CString};
use std::sync::Mutex;
use validation::ValidationLog;

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// How the Vulkan validation layer is used.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Validation {
    /// Not loaded.
    Off,
    /// Loaded when installed, with synchronization validation.
    IfAvailable,
    /// Loaded, and an error when it is not installed.
    Required,
}

impl Validation {
    /// From `VERGENCE_VALIDATION` (`0`, `1`, `required`); default: on in
    /// debug builds when available, off in release builds.
    pub fn from_env() -> Validation {
        Validation::from_var("VERGENCE_VALIDATION")
    }

    /// From the environment variable `name`, with the rules of
    /// [`Validation::from_env`].
    pub fn from_var(name: &str) -> Validation {
        match std::env::var(name).as_deref() {
            Ok("0") | Ok("off") => Validation::Off,
            Ok("required") => Validation::Required,
            Ok(_) => Validation::IfAvailable,
            Err(_) if cfg!(debug_assertions) => Validation::IfAvailable,
            Err(_) => Validation::Off,
        }
    }
}

/// Whether depth format `format` has both a depth and a stencil aspect
/// (the combined formats the renderer chooses from).
pub fn has_stencil(format: vk::Format) -> bool {
    matches!(
        format,
        vk::Format::D32_SFLOAT_S8_UINT
            | vk::Format::D24_UNORM_S8_UINT
            | vk::Format::D16_UNORM_S8_UINT
    )
}

/// The aspects of depth format `format`: depth, and stencil when it has one.
pub fn depth_aspect(format: vk::Format) -> vk::ImageAspectFlags {
    if has_stencil(format) {
        vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL
    } else {
        vk::ImageAspectFlags::DEPTH
    }
}

/// Optional device capabilities the renderer may use.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct Capabilities {
    /// Pipeline-statistics queries are available.
    pub pipeline_statistics: bool,
    /// Nanoseconds per timestamp tick (0 when timestamps are unsupported).
    pub timestamp_period_ns: f32,
    /// A LAZILY_ALLOCATED memory type exists (transient attachments).
    pub lazily_allocated_memory: bool,
    /// Largest sample count usable for colour and depth together.
    pub max_samples: u32,
    /// The depth-stencil format (with a stencil aspect): the depth
    /// attachment's format when a pass uses stencil or the depth goes to a
    /// depth swapchain, and the fallback when no depth-only format is
    /// offered.
    #[serde(skip)]
    pub depth_format: vk::Format,
    /// A depth format without stencil for frames that use no stencil
    /// (D32_SFLOAT where it can be a sampled depth attachment): clearing
    /// it costs less than a depth-stencil image (H200 at 4x: 0.86 ms per
    /// frame, `bench/results/2026-12-03-h200-raster-floors.md`).
    #[serde(skip)]
    pub depth_only_format: Option<vk::Format>,
    /// VK_KHR_fragment_shading_rate with attachment rates is enabled: the
    /// rate attachment's texel size (None: not offered).
    pub shading_rate_texel: Option<(u32, u32)>,
    /// VK_EXT_fragment_density_map is offered (not used yet).
    pub fragment_density_map: bool,
    /// VK_QCOM_multiview_per_view_render_areas is offered.
    pub per_view_render_areas: bool,
    /// maxMultiviewViewCount: the most views one multiview scope draws
    /// (`inset` draws its four views in one scope when this is at least 4).
    pub max_multiview_views: u32,
    /// VK_EXT_memory_budget is enabled ([`Context::memory_budget`]).
    pub memory_budget: bool,
    /// VK_KHR_draw_indirect_count is enabled (vkCmdDrawIndexedIndirectCount,
    /// used by `gpu-cull`; core in Vulkan 1.2 as the drawIndirectCount
    /// feature).
    pub draw_indirect_count: bool,
    /// The shaderDrawParameters feature is enabled (`gl_BaseInstance`,
    /// used by `--per-draw ssbo`).
    pub shader_draw_parameters: bool,
    /// The inheritedQueries feature is enabled: secondary command buffers
    /// may run inside the frame's pipeline-statistics query
    /// (`--record-threads`; without it those frames skip the query).
    pub inherited_queries: bool,
    /// minUniformBufferOffsetAlignment: the step of dynamic uniform offsets.
    pub min_uniform_offset_alignment: u64,
    /// VK_NV_clip_space_w_scaling is enabled (`lms` scales w in the
    /// rasterizer; without it, in the vertex shaders).
    pub clip_space_w_scaling: bool,
    /// maxStorageBufferRange: the most bytes one storage-buffer descriptor
    /// reaches (a point cloud is spread over several buffers past it).
    pub max_storage_buffer_range: u32,
    /// shaderInt64 and shaderBufferInt64Atomics are enabled
    /// (VK_KHR_shader_atomic_int64): point clouds rasterize in compute.
    pub atomic_int64: bool,
}

/// Device-local memory as VK_EXT_memory_budget reports it, summed over the
/// device-local heaps.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct MemoryBudget {
    /// Bytes this process uses.
    pub usage: u64,
    /// Bytes this process can use before allocations may fail or slow down.
    pub budget: u64,
}

/// Extensions a caller needs beyond the renderer's own: a window's surface
/// extensions on the instance, VK_KHR_swapchain on the device. Under
/// OpenXR they go into the create infos handed to the runtime
/// (XR_KHR_vulkan_enable2), which adds its own to them.
#[derive(Clone, Debug, Default)]
pub struct ExtraExtensions {
    /// Instance extensions (all must be offered).
    pub instance: Vec<&'static CStr>,
    /// Device extensions (all must be offered).
    pub device: Vec<&'static CStr>,
}

/// The Vulkan instance, device, queue and allocator.
pub struct Context {
    /// Loader entry points.
    pub entry: ash::Entry,
    /// The instance.
    pub instance: ash::Instance,
    /// The physical device in use.
    pub physical_device: vk::PhysicalDevice,
    /// The logical device.
    pub device: ash::Device,
    /// The graphics queue.
    pub queue: vk::Queue,
    /// Its family index.
    pub queue_family: u32,
    /// Device name as the driver reports it.
    pub device_name: String,
    /// Driver name and version info.
    pub driver: String,
    /// The driver's Vulkan driver ID (lavapipe: `MESA_LLVMPIPE`).
    pub driver_id: vk::DriverId,
    /// Optional capabilities.
    pub caps: Capabilities,
    /// The memory allocator (behind a mutex: allocation happens at init only).
    pub allocator: Mutex<Option<Allocator>>,
    /// Bytes allocated per category (vertex, index, texture, ...).
    pub memory_by_category: Mutex<BTreeMap<&'static str, u64>>,
    debug_utils_device: Option<ash::ext::debug_utils::Device>,
    debug: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    validation_log: Box<ValidationLog>,
    validation_enabled: bool,
}

/// Creates the Vulkan instance and device: directly ([`Direct`]) or through
/// an OpenXR runtime (XR_KHR_vulkan_enable2), which adds what it needs to the
/// create infos and picks the physical device.
pub trait DeviceFactory {
    /// Creates the instance from `info`.
    fn create_instance(
        &self,
        entry: &ash::Entry,
        info: &vk::InstanceCreateInfo,
    ) -> Result<ash::Instance>;
    /// The physical device that must be used, or None to choose freely.
    fn required_physical_device(
        &self,
        instance: &ash::Instance,
    ) -> Result<Option<vk::PhysicalDevice>>;
    /// Creates the logical device from `info` on `pd`.
    fn create_device(
        &self,
        entry: &ash::Entry,
        instance: &ash::Instance,
        pd: vk::PhysicalDevice,
        info: &vk::DeviceCreateInfo,
    ) -> Result<ash::Device>;
}

/// Plain `vkCreateInstance` / `vkCreateDevice` (headless rendering).
pub struct Direct;

impl DeviceFactory for Direct {
    fn create_instance(
        &self,
        entry: &ash::Entry,
        info: &vk::InstanceCreateInfo,
    ) -> Result<ash::Instance> {
        // SAFETY: all pointers in `info` reference data that outlives the call.
        unsafe { entry.create_instance(info, None) }.vk("creating the Vulkan instance")
    }

    fn required_physical_device(
        &self,
        _instance: &ash::Instance,
    ) -> Result<Option<vk::PhysicalDevice>> {
        Ok(None)
    }

    fn create_device(
        &self,
        _entry: &ash::Entry,
        instance: &ash::Instance,
        pd: vk::PhysicalDevice,
        info: &vk::DeviceCreateInfo,
    ) -> Result<ash::Device> {
        // SAFETY: `info` references locals alive for the call.
        unsafe { instance.create_device(pd, info, None) }.vk("creating the Vulkan device")
    }
}

/// Whether to enable the Khronos validation layer: never, where
/// installed, or always (an error naming the package when it is not).
fn validation_wanted(entry: &ash::Entry, validation: Validation) -> Result<bool> {
    // SAFETY: plain enumeration call on a loaded entry.
    let layers =
        unsafe { entry.enumerate_instance_layer_properties() }.vk("enumerating instance layers")?;
    let has_layer = layers
        .iter()
        .any(|l| l.layer_name_as_c_str().ok() == Some(VALIDATION_LAYER));
    match validation {
        Validation::Off => Ok(false),
        Validation::IfAvailable => Ok(has_layer),
        Validation::Required if has_layer => Ok(true),
        Validation::Required => Err(Error::Gpu("VK_LAYER_KHRONOS_validation is required but not installed (apt-get install vulkan-validationlayers)".into())),
    }
}

/// The instance extensions to enable: debug utils where offered (and
/// whether it is), and `extra` (a window's), which must all be there.
fn instance_extensions(
    entry: &ash::Entry,
    extra: &[&'static CStr],
) -> Result<(bool, Vec<*const std::ffi::c_char>)> {
    // SAFETY: plain enumeration call.
    let exts = unsafe { entry.enumerate_instance_extension_properties(None) }
        .vk("enumerating instance extensions")?;
    let has = |name: &CStr| {
        exts.iter()
            .any(|e| e.extension_name_as_c_str().ok() == Some(name))
    };
    let has_debug_utils = has(ash::ext::debug_utils::NAME);
    let mut names = Vec::new();
    if has_debug_utils {
        names.push(ash::ext::debug_utils::NAME.as_ptr());
    }
    for &name in extra {
        if !has(name) {
            return Err(Error::Gpu(format!(
                "the Vulkan loader offers no {} (needed for a window)",
                name.to_string_lossy()
            )));
        }
        names.push(name.as_ptr());
    }
    Ok((has_debug_utils, names))
}

impl Context {
    /// The device memory allocated so far, bytes by category.
    pub fn memory_snapshot(&self) -> BTreeMap<String, u64> {
        self.memory_by_category
            .lock()
            .map(|m| m.iter().map(|(k, v)| (k.to_string(), *v)).collect())
            .unwrap_or_default()
    }

    /// Creates a headless context (no surface) on the first suitable device;
    /// `VERGENCE_DEVICE=<index>` picks another.
    pub fn new_headless(validation: Validation) -> Result<Context> {
        Context::new(validation, &Direct)
    }

    /// Creates a context whose instance and device come from `factory`.
    pub fn new(validation: Validation, factory: &dyn DeviceFactory) -> Result<Context> {
        Context::with_extensions(validation, factory, &ExtraExtensions::default())
    }

    /// Creates a context whose instance and device come from `factory`,
    /// with `extra` extensions enabled (an error names the first one the
    /// driver does not offer).
    pub fn with_extensions(
        validation: Validation,
        factory: &dyn DeviceFactory,
        extra: &ExtraExtensions,
    ) -> Result<Context> {
        // SAFETY: loading the Vulkan loader library; failure is reported.
        let entry = unsafe { ash::Entry::load() }
            .map_err(|e| Error::Gpu(format!("cannot load the Vulkan loader (libvulkan.so.1): {e}; install libvulkan1 and a driver (e.g. mesa-vulkan-drivers)")))?;
        let validation_enabled = validation_wanted(&entry, validation)?;
        let app_name = c"vergence";
        let app = vk::ApplicationInfo::default()
            .application_name(app_name)
            .engine_name(app_name)
            .api_version(vk::API_VERSION_1_3);
        let mut layer_names = Vec::new();
        let (has_debug_utils, ext_names) = instance_extensions(&entry, &extra.instance)?;
        if validation_enabled {
            layer_names.push(VALIDATION_LAYER.as_ptr());
        }
        let enables = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
        let mut vfeatures =
            vk::ValidationFeaturesEXT::default().enabled_validation_features(&enables);
        let validation_log = Box::<ValidationLog>::default();
        let mut messenger_info = vk::DebugUtilsMessengerCreateInfoEXT::default()
            .message_severity(
                vk::DebugUtilsMessageSeverityFlagsEXT::ERROR
                    | vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                    | vk::DebugUtilsMessageSeverityFlagsEXT::INFO,
            )
            .message_type(
                vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                    | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                    | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
            )
            .pfn_user_callback(Some(validation::callback))
            .user_data(&*validation_log as *const ValidationLog as *mut std::ffi::c_void);
        let mut info = vk::InstanceCreateInfo::default()
            .application_info(&app)
            .enabled_layer_names(&layer_names)
            .enabled_extension_names(&ext_names);
        if validation_enabled {
            info = info.push_next(&mut vfeatures);
        }
        if has_debug_utils {
            info = info.push_next(&mut messenger_info);
        }
        let instance = factory.create_instance(&entry, &info)?;
        let debug = if has_debug_utils {
            let du = ash::ext::debug_utils::Instance::new(&entry, &instance);
            let info = vk::DebugUtilsMessengerCreateInfoEXT {
                p_next: std::ptr::null(),
                ..messenger_info
            };
            // SAFETY: valid create info without a pNext chain; the user-data
            // box lives in `Context`.
            let m = unsafe { du.create_debug_utils_messenger(&info, None) }
                .vk("creating the debug messenger")?;
            Some((du, m))
        } else {
            None
        };
        let mut ctx_partial = PartialInstance {
            entry,
            instance,
            debug,
            validation_log,
            validation_enabled,
        };
        let dev = ctx_partial.pick_device(has_debug_utils, factory, &extra.device);
        match dev {
            Ok(c) => Ok(c),
            Err(e) => {
                ctx_partial.destroy();
                Err(e)
            }
        }
    }

    /// Bytes vergence has allocated, over all categories.
    pub fn allocated_bytes(&self) -> u64 {
        self.memory_by_category
            .lock()
            .map(|m| m.values().sum())
            .unwrap_or(0)
    }

    /// Device-local memory usage and budget (None without
    /// VK_EXT_memory_budget).
    pub fn memory_budget(&self) -> Option<MemoryBudget> {
        if !self.caps.memory_budget {
            return None;
        }
        let mut b = vk::PhysicalDeviceMemoryBudgetPropertiesEXT::default();
        let mut p2 = vk::PhysicalDeviceMemoryProperties2::default().push_next(&mut b);
        // SAFETY: valid physical device; the extension is enabled and the
        // query struct is correctly chained.
        unsafe {
            self.instance
                .get_physical_device_memory_properties2(self.physical_device, &mut p2)
        };
        let props = p2.memory_properties;
        let heaps = &props.memory_heaps[..props.memory_heap_count as usize];
        let mut out = MemoryBudget::default();
        for (i, h) in heaps.iter().enumerate() {
            if h.flags.contains(vk::MemoryHeapFlags::DEVICE_LOCAL) {
                out.usage += b.heap_usage[i];
                out.budget += b.heap_budget[i];
            }
        }
        Some(out)
    }

    /// The GPU memory budget and how much of it is free, in bytes:
    /// VK_EXT_memory_budget's device-local budget, capped by
    /// `VERGENCE_GPU_MEMORY_BUDGET_MB` when set (then against what vergence
    /// allocated). None when neither is known. Returns (budget, free,
    /// capped by the variable).
    pub fn memory_headroom(&self) -> Option<(u64, u64, bool)> {
        let allocated = self.allocated_bytes();
        let cap = std::env::var("VERGENCE_GPU_MEMORY_BUDGET_MB")
            .ok()
            .and_then(|v| v.trim().parse::<u64>().ok())
            .and_then(|mb| mb.checked_mul(1 << 20));
        let device = self
            .memory_budget()
            .map(|b| (b.budget, b.budget.saturating_sub(b.usage)));
        match (cap, device) {
            // The tighter of the two limits is the one to name.
            (Some(c), Some((budget, free))) => {
                let capped = c.saturating_sub(allocated);
                if capped <= free {
                    Some((c, capped, true))
                } else {
                    Some((budget, free, false))
                }
            }
            (Some(c), None) => Some((c, c.saturating_sub(allocated), true)),
            (None, Some((budget, free))) => Some((budget, free, false)),
            (None, None) => None,
        }
    }

    /// Fails with a message naming the need and the budget when `need`
    /// bytes for `what` do not fit in the free GPU memory.
    pub fn ensure_fits(&self, need: u64, what: &str) -> Result<()> {
        match self.memory_headroom() {
            Some((budget, available, from_env)) if need > available => Err(Error::GpuMemory {
                what: what.to_string(),
                need,
                available,
                budget,
                from_env,
            }),
            _ => Ok(()),
        }
    }

    /// Number of validation warnings/errors reported so far.
    pub fn validation_messages(&self) -> usize {
        self.validation_log.count()
    }

    /// The first validation messages, for test failure output.
    pub fn validation_log(&self) -> Vec<String> {
        self.validation_log.messages()
    }

    /// Whether the validation layer is loaded.
    pub fn validation_enabled(&self) -> bool {
        self.validation_enabled
    }

    /// Gives a Vulkan object a debug name (shown by validation and tools).
    pub fn set_name<H: vk::Handle>(&self, handle: H, name: &str) {
        if let Some(du) = &self.debug_utils_device {
            if let Ok(cname) = CString::new(name) {
                let info = vk::DebugUtilsObjectNameInfoEXT::default()
                    .object_handle(handle)
                    .object_name(&cname);
                // SAFETY: the handle belongs to this device; the name outlives the call.
                let _ = unsafe { du.set_debug_utils_object_name(&info) };
            }
        }
    }

    /// Records `bytes` under `category` in the memory statistics.
    pub fn track_memory(&self, category: &'static str, bytes: i64) {
        if let Ok(mut m) = self.memory_by_category.lock() {
            let e = m.entry(category).or_insert(0);
            *e = (*e as i64 + bytes).max(0) as u64;
        }
    }

    /// Creates a command pool on the graphics queue family with one primary
    /// command buffer allocated from it.
    pub fn command_pool(&self, what: &str) -> Result<(vk::CommandPool, vk::CommandBuffer)> {
        let d = &self.device;
        let info = vk::CommandPoolCreateInfo::default().queue_family_index(self.queue_family);
        // SAFETY: plain object creation on a live device; the pool is
        // destroyed if the allocation fails.
        unsafe {
            let pool = d
                .create_command_pool(&info, None)
                .vk(&format!("creating the {what} command pool"))?;
            let alloc = vk::CommandBufferAllocateInfo::default()
                .command_pool(pool)
                .command_buffer_count(1);
            match d.allocate_command_buffers(&alloc) {
                Ok(cbs) => Ok((pool, cbs[0])),
                Err(e) => {
                    d.destroy_command_pool(pool, None);
                    Err(e).vk(&format!("allocating the {what} command buffer"))
                }
            }
        }
    }

    /// Runs `record` in a one-time command buffer and waits for it.
    pub fn one_shot(&self, record: impl FnOnce(vk::CommandBuffer)) -> Result<()> {
        let d = &self.device;
        // SAFETY: creating, recording, submitting and waiting on objects of
        // this device; everything is destroyed before returning.
        unsafe {
            let (pool, cb) = self.command_pool("upload")?;
            let recorded = d
                .begin_command_buffer(
                    cb,
                    &vk::CommandBufferBeginInfo::default()
                        .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
                )
                .vk("beginning an upload")
                .and_then(|()| {
                    record(cb);
                    d.end_command_buffer(cb).vk("ending an upload")
                });
            let fence = recorded.and_then(|()| {
                d.create_fence(&vk::FenceCreateInfo::default(), None)
                    .vk("creating a fence")
            });
            let fence = match fence {
                Ok(f) => f,
                Err(e) => {
                    // Never submitted: the pool goes at once.
                    d.destroy_command_pool(pool, None);
                    return Err(e);
                }
            };
            let cbs = [cb];
            let submit = vk::SubmitInfo::default().command_buffers(&cbs);
            let r = d
                .queue_submit(self.queue, &[submit], fence)
                .vk("submitting an upload");
            let w = r.and_then(|_| {
                d.wait_for_fences(&[fence], true, u64::MAX)
                    .vk("waiting for an upload")
            });
            d.destroy_fence(fence, None);
            d.destroy_command_pool(pool, None);
            w
        }
    }
}

impl Drop for Context {
    fn drop(&mut self) {
        // SAFETY: shutdown in reverse creation order after the device is idle;
        // every resource created from this context has been destroyed by its
        // owner (the renderer drops before the context).
        unsafe {
            let _ = self.device.device_wait_idle();
            if let Ok(mut a) = self.allocator.lock() {
                a.take();
            }
            self.device.destroy_device(None);
            if let Some((du, m)) = self.debug.take() {
                du.destroy_debug_utils_messenger(m, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}

struct PartialInstance {
    entry: ash::Entry,
    instance: ash::Instance,
    debug: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    validation_log: Box<ValidationLog>,
    validation_enabled: bool,
}

impl PartialInstance {
    fn destroy(&mut self) {
        // SAFETY: nothing was created from the instance except the messenger.
        unsafe {
            if let Some((du, m)) = self.debug.take() {
                du.destroy_debug_utils_messenger(m, None);
            }
            self.instance.destroy_instance(None);
        }
    }

    fn pick_device(
        &mut self,
        has_debug_utils: bool,
        factory: &dyn DeviceFactory,
        extra_device: &[&'static CStr],
    ) -> Result<Context> {
        let inst = &self.instance;
        let (pd, props) = pick::choose(inst, factory.required_physical_device(inst)?)?;
        let drv = pick::driver_info(inst, pd)?;
        let (queue_family, timestamps) = pick::graphics_queue(inst, pd)?;
        // SAFETY: enumeration on a valid physical device.
        let dev_exts = unsafe { inst.enumerate_device_extension_properties(pd) }
            .vk("enumerating device extensions")?;
        let has_ext = |name: &CStr| {
            dev_exts
                .iter()
                .any(|e| e.extension_name_as_c_str().ok() == Some(name))
        };
        let offered = pick::features(inst, pd, &has_ext)?;
        let exts = pick::extensions(&offered, &has_ext, extra_device)?;
        let device = pick::create_device(
            factory,
            &self.entry,
            inst,
            pd,
            queue_family,
            &offered,
            &exts,
        )?;
        // SAFETY: the family/index pair was requested at device creation.
        let queue = unsafe { device.get_device_queue(queue_family, 0) };
        let limits = (&offered, timestamps, drv.max_multiview_views);
        let caps = pick::capabilities(inst, pd, &props, limits, &has_ext)?;
        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance: inst.clone(),
            device: device.clone(),
            physical_device: pd,
            debug_settings: Default::default(),
            buffer_device_address: false,
            allocation_sizes: Default::default(),
        })
        .map_err(|e| Error::Gpu(format!("creating the memory allocator: {e}")))?;
        let device_name = props
            .device_name_as_c_str()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let driver = format!(
            "{} {}, Vulkan {}.{}.{}, driver version {:#x}, vendor {:#06x}",
            drv.name,
            drv.info,
            vk::api_version_major(props.api_version),
            vk::api_version_minor(props.api_version),
            vk::api_version_patch(props.api_version),
            props.driver_version,
            props.vendor_id
        );
        let debug_utils_device =
            has_debug_utils.then(|| ash::ext::debug_utils::Device::new(inst, &device));
        tracing::info!(
            "GPU: {device_name} ({driver}), validation {}",
            if self.validation_enabled { "on" } else { "off" }
        );
        Ok(Context {
            entry: self.entry.clone(),
            instance: self.instance.clone(),
            physical_device: pd,
            device,
            queue,
            queue_family,
            device_name,
            driver,
            driver_id: drv.id,
            caps,
            allocator: Mutex::new(Some(allocator)),
            memory_by_category: Mutex::new(BTreeMap::new()),
            debug_utils_device,
            debug: self.debug.take(),
            validation_log: std::mem::take(&mut self.validation_log),
            validation_enabled: self.validation_enabled,
        })
    }
}
