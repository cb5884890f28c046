//! Buffers and images with their memory. Creation goes through a plain
//! description; destruction is explicit (`destroy`) so owners can defer it to
//! the frame ring.

use super::Context;
use crate::error::{Error, Result, VkContext};
use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;

/// Where a resource's memory lives.
#[derive(Debug)]
enum Memory {
    Allocator(Allocation),
    /// A dedicated LAZILY_ALLOCATED allocation (transient attachments).
    Lazy(vk::DeviceMemory),
}

/// A buffer and its memory.
#[derive(Debug)]
pub struct Buffer {
    /// The Vulkan buffer.
    pub buffer: vk::Buffer,
    /// Size in bytes.
    pub size: u64,
    memory: Memory,
    category: &'static str,
}

/// Description of a buffer to create.
pub struct BufferDesc<'a> {
    /// Debug name.
    pub name: &'a str,
    /// Size in bytes (> 0).
    pub size: u64,
    /// Usage flags.
    pub usage: vk::BufferUsageFlags,
    /// Memory location (GPU-only, CPU-to-GPU, GPU-to-CPU).
    pub location: MemoryLocation,
    /// Statistics category (e.g. "vertex", "texture").
    pub category: &'static str,
}

fn alloc_err(what: &str, e: gpu_allocator::AllocationError) -> Error {
    Error::Gpu(format!(
        "out of GPU memory or allocation failed for {what}: {e}"
    ))
}

impl Buffer {
    /// Creates a buffer as described.
    pub fn new(ctx: &Context, desc: &BufferDesc) -> Result<Buffer> {
        if crate::gpu::fault::buffer_fails() {
            return Err(Error::Vulkan {
                context: format!(
                    "creating buffer '{}' (injected by VERGENCE_INJECT_FAULT)",
                    desc.name
                ),
                result: vk::Result::ERROR_OUT_OF_DEVICE_MEMORY,
            });
        }
        let d = &ctx.device;
        let info = vk::BufferCreateInfo::default()
            .size(desc.size.max(4))
            .usage(desc.usage);
        // SAFETY: valid create info on a live device.
        let buffer = unsafe { d.create_buffer(&info, None) }
            .vk(&format!("creating buffer {}", desc.name))?;
        // SAFETY: buffer belongs to this device.
        let requirements = unsafe { d.get_buffer_memory_requirements(buffer) };
        let alloc = ctx.allocator.lock().ok().and_then(|mut a| {
            a.as_mut().map(|a| {
                a.allocate(&AllocationCreateDesc {
                    name: desc.name,
                    requirements,
                    location: desc.location,
                    linear: true,
                    allocation_scheme: AllocationScheme::GpuAllocatorManaged,
                })
            })
        });
        let alloc = match alloc {
            Some(Ok(a)) => a,
            other => {
                // SAFETY: the buffer is unused.
                unsafe { d.destroy_buffer(buffer, None) };
                return Err(match other {
                    Some(Err(e)) => alloc_err(desc.name, e),
                    _ => Error::Gpu("allocator unavailable".into()),
                });
            }
        };
        // SAFETY: memory from the allocator for this buffer's requirements.
        unsafe { d.bind_buffer_memory(buffer, alloc.memory(), alloc.offset()) }
            .vk("binding buffer memory")?;
        ctx.set_name(buffer, desc.name);
        ctx.track_memory(desc.category, alloc.size() as i64);
        Ok(Buffer {
            buffer,
            size: desc.size,
            memory: Memory::Allocator(alloc),
            category: desc.category,
        })
    }

    /// Creates a host-visible buffer and fills it with `data`.
    pub fn with_data(ctx: &Context, desc: &BufferDesc, data: &[u8]) -> Result<Buffer> {
        let mut b = Buffer::new(
            ctx,
            &BufferDesc {
                size: data.len().max(4) as u64,
                ..*desc
            },
        )?;
        match b.write(0, data) {
            Ok(()) => Ok(b),
            Err(e) => {
                b.destroy(ctx);
                Err(e)
            }
        }
    }

    /// The mapped bytes of a host-visible buffer.
    pub fn mapped(&mut self) -> Option<&mut [u8]> {
        match &mut self.memory {
            Memory::Allocator(a) => a.mapped_slice_mut(),
            Memory::Lazy(_) => None,
        }
    }

    /// Writes `data` at `offset` into a host-visible buffer.
    pub fn write(&mut self, offset: usize, data: &[u8]) -> Result<()> {
        let m = self
            .mapped()
            .ok_or_else(|| Error::Gpu("buffer is not host-visible".into()))?;
        let end = offset + data.len();
        if end > m.len() {
            return Err(Error::Gpu(format!(
                "buffer write of {end} bytes exceeds {} bytes",
                m.len()
            )));
        }
        m[offset..end].copy_from_slice(data);
        Ok(())
    }

    /// Destroys the buffer and frees its memory.
    pub fn destroy(self, ctx: &Context) {
        // SAFETY: the caller guarantees the GPU no longer uses the buffer
        // (frame ring fence passed or device idle).
        unsafe { ctx.device.destroy_buffer(self.buffer, None) };
        free(ctx, self.memory, self.category);
    }
}

fn free(ctx: &Context, memory: Memory, category: &'static str) {
    match memory {
        Memory::Allocator(a) => {
            ctx.track_memory(category, -(a.size() as i64));
            if let Ok(mut al) = ctx.allocator.lock() {
                if let Some(al) = al.as_mut() {
                    let _ = al.free(a);
                }
            }
        }
        // SAFETY: dedicated memory whose only user was destroyed.
        Memory::Lazy(m) => unsafe { ctx.device.free_memory(m, None) },
    }
}

/// An image, its memory and one view over all its layers (2D for one
/// layer, 2D array otherwise).
#[derive(Debug)]
pub struct Image {
    /// The Vulkan image.
    pub image: vk::Image,
    /// A view over all layers (2D array).
    pub view: vk::ImageView,
    /// Format.
    pub format: vk::Format,
    /// Size in pixels.
    pub extent: vk::Extent2D,
    /// Array layers.
    pub layers: u32,
    /// Mip levels.
    pub mips: u32,
    /// Whether the memory is lazily allocated (transient attachment).
    pub lazy: bool,
    memory: Memory,
    category: &'static str,
}

/// Description of an image to create.
pub struct ImageDesc<'a> {
    /// Debug name.
    pub name: &'a str,
    /// Format.
    pub format: vk::Format,
    /// Size in pixels.
    pub extent: vk::Extent2D,
    /// Array layers (2 for multiview targets).
    pub layers: u32,
    /// Mip levels.
    pub mips: u32,
    /// Samples per pixel.
    pub samples: vk::SampleCountFlags,
    /// Usage flags. With TRANSIENT_ATTACHMENT, lazily allocated memory is
    /// used when the device has it.
    pub usage: vk::ImageUsageFlags,
    /// Aspect of the view.
    pub aspect: vk::ImageAspectFlags,
    /// Statistics category.
    pub category: &'static str,
    /// Creation flags (e.g. MUTABLE_FORMAT with EXTENDED_USAGE for an sRGB
    /// image a compute shader writes through a UNORM view).
    pub flags: vk::ImageCreateFlags,
}

impl<'a> ImageDesc<'a> {
    /// An eye image a finished frame is copied or blitted into and a window
    /// blits from: one mip, one sample, colour attachment and transfer
    /// source and destination, `layers` layers.
    pub fn eye_copy(
        name: &'a str,
        format: vk::Format,
        extent: vk::Extent2D,
        layers: u32,
        category: &'static str,
    ) -> ImageDesc<'a> {
        ImageDesc {
            name,
            format,
            extent,
            layers,
            mips: 1,
            samples: vk::SampleCountFlags::TYPE_1,
            usage: vk::ImageUsageFlags::COLOR_ATTACHMENT
                | vk::ImageUsageFlags::TRANSFER_DST
                | vk::ImageUsageFlags::TRANSFER_SRC,
            aspect: vk::ImageAspectFlags::COLOR,
            category,
            flags: vk::ImageCreateFlags::empty(),
        }
    }
}

/// Memory for an image with requirements `req`: of the lazily allocated
/// type `lazy` when given (transient attachments on tile-based GPUs),
/// else from the allocator (counted in the image's category).
fn image_memory(
    ctx: &Context,
    desc: &ImageDesc,
    req: vk::MemoryRequirements,
    lazy: Option<u32>,
) -> Result<Memory> {
    if let Some(t) = lazy {
        let ai = vk::MemoryAllocateInfo::default()
            .allocation_size(req.size)
            .memory_type_index(t);
        // SAFETY: a memory type the image accepts.
        let m = unsafe { ctx.device.allocate_memory(&ai, None) }
            .vk("allocating lazily allocated memory")?;
        return Ok(Memory::Lazy(m));
    }
    let alloc = ctx
        .allocator
        .lock()
        .ok()
        .and_then(|mut a| {
            a.as_mut().map(|a| {
                a.allocate(&AllocationCreateDesc {
                    name: desc.name,
                    requirements: req,
                    location: MemoryLocation::GpuOnly,
                    linear: false,
                    allocation_scheme: AllocationScheme::GpuAllocatorManaged,
                })
            })
        })
        .ok_or_else(|| Error::Gpu("allocator unavailable".into()))
        .and_then(|r| r.map_err(|e| alloc_err(desc.name, e)))?;
    ctx.track_memory(desc.category, alloc.size() as i64);
    Ok(Memory::Allocator(alloc))
}

impl Image {
    /// Creates an image and a 2D-array view over all its layers and mips.
    pub fn new(ctx: &Context, desc: &ImageDesc) -> Result<Image> {
        if crate::gpu::fault::image_fails() {
            return Err(Error::Vulkan {
                context: format!(
                    "creating image '{}' (injected by VERGENCE_INJECT_FAULT)",
                    desc.name
                ),
                result: vk::Result::ERROR_OUT_OF_DEVICE_MEMORY,
            });
        }
        let d = &ctx.device;
        let info = vk::ImageCreateInfo::default()
            .flags(desc.flags)
            .image_type(vk::ImageType::TYPE_2D)
            .format(desc.format)
            .extent(vk::Extent3D {
                width: desc.extent.width,
                height: desc.extent.height,
                depth: 1,
            })
            .mip_levels(desc.mips)
            .array_layers(desc.layers)
            .samples(desc.samples)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(desc.usage)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        // SAFETY: valid create info on a live device.
        let image =
            unsafe { d.create_image(&info, None) }.vk(&format!("creating image {}", desc.name))?;
        // SAFETY: image belongs to this device.
        let req = unsafe { d.get_image_memory_requirements(image) };
        let lazy_type = if desc
            .usage
            .contains(vk::ImageUsageFlags::TRANSIENT_ATTACHMENT)
        {
            lazy_memory_type(ctx, req.memory_type_bits)
        } else {
            None
        };
        // From here a failure destroys the image (and frees its memory).
        let drop_image = || {
            // SAFETY: the image was never used.
            unsafe { d.destroy_image(image, None) }
        };
        let memory = match image_memory(ctx, desc, req, lazy_type) {
            Ok(m) => m,
            Err(e) => {
                drop_image();
                return Err(e);
            }
        };
        let (mem, offset) = match &memory {
            Memory::Lazy(m) => (*m, 0),
            Memory::Allocator(a) => (
                // SAFETY: the allocation's block outlives the image.
                unsafe { a.memory() },
                a.offset(),
            ),
        };
        // SAFETY: memory for this image's requirements.
        if let Err(e) =
            unsafe { d.bind_image_memory(image, mem, offset) }.vk("binding image memory")
        {
            drop_image();
            free(ctx, memory, desc.category);
            return Err(e);
        }
        let view = match Self::whole_view(ctx, image, desc) {
            Ok(v) => v,
            Err(e) => {
                drop_image();
                free(ctx, memory, desc.category);
                return Err(e);
            }
        };
        ctx.set_name(image, desc.name);
        Ok(Image {
            image,
            view,
            format: desc.format,
            extent: desc.extent,
            layers: desc.layers,
            mips: desc.mips,
            lazy: lazy_type.is_some(),
            memory,
            category: desc.category,
        })
    }

    /// The image's own view: 2D (one layer) or 2D array over every layer
    /// and mip. With extended usage it keeps only the uses its format has:
    /// storage goes through another view.
    fn whole_view(ctx: &Context, image: vk::Image, desc: &ImageDesc) -> Result<vk::ImageView> {
        let view_type = if desc.layers == 1 {
            vk::ImageViewType::TYPE_2D
        } else {
            vk::ImageViewType::TYPE_2D_ARRAY
        };
        let view_usage = desc
            .flags
            .contains(vk::ImageCreateFlags::EXTENDED_USAGE)
            .then(|| desc.usage & !vk::ImageUsageFlags::STORAGE);
        Self::view_for(
            ctx,
            image,
            desc.format,
            desc.aspect,
            view_type,
            (0, desc.layers),
            desc.mips,
            view_usage,
        )
    }

    /// Creates a view of `count` layers starting at `first`.
    #[allow(clippy::too_many_arguments)]
    pub fn make_view(
        ctx: &Context,
        image: vk::Image,
        format: vk::Format,
        aspect: vk::ImageAspectFlags,
        view_type: vk::ImageViewType,
        first: u32,
        count: u32,
        mips: u32,
    ) -> Result<vk::ImageView> {
        Self::view_for(
            ctx,
            image,
            format,
            aspect,
            view_type,
            (first, count),
            mips,
            None,
        )
    }

    /// Like [`Image::make_view`], the view's usage limited to `usage` when
    /// given (an image with extended usage has uses its own format lacks:
    /// each view keeps only what its format supports).
    #[allow(clippy::too_many_arguments)]
    pub fn view_for(
        ctx: &Context,
        image: vk::Image,
        format: vk::Format,
        aspect: vk::ImageAspectFlags,
        view_type: vk::ImageViewType,
        (first, count): (u32, u32),
        mips: u32,
        usage: Option<vk::ImageUsageFlags>,
    ) -> Result<vk::ImageView> {
        let mut limited = usage.map(|u| vk::ImageViewUsageCreateInfo::default().usage(u));
        let mut info = vk::ImageViewCreateInfo::default()
            .image(image)
            .view_type(view_type)
            .format(format)
            .subresource_range(vk::ImageSubresourceRange {
                aspect_mask: aspect,
                base_mip_level: 0,
                level_count: mips,
                base_array_layer: first,
                layer_count: count,
            });
        if let Some(l) = limited.as_mut() {
            info = info.push_next(l);
        }
        // SAFETY: valid view of a live image.
        unsafe { ctx.device.create_image_view(&info, None) }.vk("creating an image view")
    }

    /// Destroys the view, image and memory.
    pub fn destroy(self, ctx: &Context) {
        // SAFETY: the caller guarantees the GPU no longer uses the image.
        unsafe {
            ctx.device.destroy_image_view(self.view, None);
            ctx.device.destroy_image(self.image, None);
        }
        free(ctx, self.memory, self.category);
    }
}

fn lazy_memory_type(ctx: &Context, bits: u32) -> Option<u32> {
    // SAFETY: valid physical device.
    let mem = unsafe {
        ctx.instance
            .get_physical_device_memory_properties(ctx.physical_device)
    };
    (0..mem.memory_type_count).find(|&i| {
        bits & (1 << i) != 0
            && mem.memory_types[i as usize]
                .property_flags
                .contains(vk::MemoryPropertyFlags::LAZILY_ALLOCATED)
    })
}

/// Plain values whose bytes are uploaded as they are.
///
/// # Safety
///
/// Implementors have no padding bytes and no field that is not itself
/// plain (every byte is initialized, so viewing it as `u8` is sound).
pub unsafe trait Pod: Copy {}

// SAFETY: primitive numbers have no padding.
unsafe impl Pod for u32 {}
// SAFETY: primitive numbers have no padding.
unsafe impl Pod for f32 {}
// SAFETY: arrays of padding-free values have no padding.
unsafe impl<T: Pod, const N: usize> Pod for [T; N] {}

/// The bytes of `values` (what a buffer upload or push constant takes).
pub fn as_bytes<T: Pod>(values: &[T]) -> &[u8] {
    // SAFETY: `T: Pod` has no padding, so every byte of the slice is
    // initialized; u8 has no alignment requirement and the length is the
    // slice's size in bytes.
    unsafe {
        std::slice::from_raw_parts(values.as_ptr().cast::<u8>(), std::mem::size_of_val(values))
    }
}
