//! Vulkan instance and device created through the runtime
//! (XR_KHR_vulkan_enable2: xrCreateVulkanInstanceKHR,
//! xrGetVulkanGraphicsDevice2KHR, xrCreateVulkanDeviceKHR), so the runtime
//! adds the extensions it needs and picks the GPU the headset is on.

use crate::error::{Error, Result, XrContext};
use crate::gpu::DeviceFactory;
use ash::vk;
use ash::vk::Handle;

/// Creates the Vulkan objects through an OpenXR instance for one system.
pub struct XrDeviceFactory<'a> {
    /// The OpenXR instance (with XR_KHR_vulkan_enable2 enabled).
    pub instance: &'a openxr::Instance,
    /// The HMD system.
    pub system: openxr::SystemId,
}

fn proc_addr(entry: &ash::Entry) -> openxr::sys::platform::VkGetInstanceProcAddr {
    // SAFETY: both types are `extern "system" fn(instance handle, name) ->
    // function pointer`; only the nominal handle types differ.
    unsafe {
        std::mem::transmute::<
            vk::PFN_vkGetInstanceProcAddr,
            openxr::sys::platform::VkGetInstanceProcAddr,
        >(entry.static_fn().get_instance_proc_addr)
    }
}

impl DeviceFactory for XrDeviceFactory<'_> {
    fn create_instance(
        &self,
        entry: &ash::Entry,
        info: &vk::InstanceCreateInfo,
    ) -> Result<ash::Instance> {
        // SAFETY: `info` and everything it points to outlive the call; the
        // runtime copies what it needs before returning.
        let raw = unsafe {
            self.instance.create_vulkan_instance(
                self.system,
                proc_addr(entry),
                info as *const vk::InstanceCreateInfo as *const _,
            )
        }
        .xr("xrCreateVulkanInstanceKHR")?
        .map_err(|r| Error::Vulkan {
            context: "creating the Vulkan instance through the OpenXR runtime".into(),
            result: vk::Result::from_raw(r),
        })?;
        let handle = vk::Instance::from_raw(raw as u64);
        // SAFETY: a valid instance handle just created with this loader.
        Ok(unsafe { ash::Instance::load(entry.static_fn(), handle) })
    }

    fn required_physical_device(
        &self,
        instance: &ash::Instance,
    ) -> Result<Option<vk::PhysicalDevice>> {
        // SAFETY: the instance was created by xrCreateVulkanInstanceKHR.
        let raw = unsafe {
            self.instance
                .vulkan_graphics_device(self.system, instance.handle().as_raw() as _)
        }
        .xr("xrGetVulkanGraphicsDevice2KHR")?;
        Ok(Some(vk::PhysicalDevice::from_raw(raw as u64)))
    }

    fn create_device(
        &self,
        entry: &ash::Entry,
        instance: &ash::Instance,
        pd: vk::PhysicalDevice,
        info: &vk::DeviceCreateInfo,
    ) -> Result<ash::Device> {
        // SAFETY: as for the instance; `pd` came from the runtime.
        let raw = unsafe {
            self.instance.create_vulkan_device(
                self.system,
                proc_addr(entry),
                pd.as_raw() as _,
                info as *const vk::DeviceCreateInfo as *const _,
            )
        }
        .xr("xrCreateVulkanDeviceKHR")?
        .map_err(|r| Error::Vulkan {
            context: "creating the Vulkan device through the OpenXR runtime".into(),
            result: vk::Result::from_raw(r),
        })?;
        // SAFETY: a valid device handle created on `pd`.
        Ok(unsafe { ash::Device::load(instance.fp_v1_0(), vk::Device::from_raw(raw as u64)) })
    }
}
