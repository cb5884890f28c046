//! Image layout transitions as data, and the buffer↔image copy region
//! vergence uses: each side of a barrier is a [`Use`]
//! (layout, pipeline stages, accesses), so a transition reads as
//! "from this use to that use".

use ash::vk;

/// How an image is used on one side of a barrier.
#[derive(Clone, Copy, Debug)]
pub struct Use {
    /// The layout during that use.
    pub layout: vk::ImageLayout,
    /// The stages that access it.
    pub stage: vk::PipelineStageFlags2,
    /// The accesses.
    pub access: vk::AccessFlags2,
}

impl Use {
    /// Written as a colour attachment.
    pub const COLOR_ATTACHMENT: Use = Use {
        layout: vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
        stage: vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT,
        access: vk::AccessFlags2::COLOR_ATTACHMENT_WRITE,
    };
    /// Sampled by fragment shaders.
    pub const SAMPLED: Use = Use {
        layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        stage: vk::PipelineStageFlags2::FRAGMENT_SHADER,
        access: vk::AccessFlags2::SHADER_SAMPLED_READ,
    };
    /// Sampled by compute shaders.
    pub const COMPUTE_SAMPLED: Use = Use {
        layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        stage: vk::PipelineStageFlags2::COMPUTE_SHADER,
        access: vk::AccessFlags2::SHADER_SAMPLED_READ,
    };
    /// Written by compute shaders as a storage image.
    pub const COMPUTE_STORAGE: Use = Use {
        layout: vk::ImageLayout::GENERAL,
        stage: vk::PipelineStageFlags2::COMPUTE_SHADER,
        access: vk::AccessFlags2::SHADER_STORAGE_WRITE,
    };
    /// Read and written in place by compute shaders as a storage image.
    pub const COMPUTE_STORAGE_RW: Use = Use {
        layout: vk::ImageLayout::GENERAL,
        stage: vk::PipelineStageFlags2::COMPUTE_SHADER,
        access: vk::AccessFlags2::from_raw(
            vk::AccessFlags2::SHADER_STORAGE_READ.as_raw()
                | vk::AccessFlags2::SHADER_STORAGE_WRITE.as_raw(),
        ),
    };
    /// Read by a copy or blit.
    pub const TRANSFER_SRC: Use = Use {
        layout: vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
        stage: vk::PipelineStageFlags2::ALL_TRANSFER,
        access: vk::AccessFlags2::TRANSFER_READ,
    };
    /// Written by a copy or blit.
    pub const TRANSFER_DST: Use = Use {
        layout: vk::ImageLayout::TRANSFER_DST_OPTIMAL,
        stage: vk::PipelineStageFlags2::ALL_TRANSFER,
        access: vk::AccessFlags2::TRANSFER_WRITE,
    };

    /// Written as a depth-stencil attachment.
    pub const DEPTH_ATTACHMENT: Use = Use {
        layout: vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
        stage: vk::PipelineStageFlags2::from_raw(
            vk::PipelineStageFlags2::EARLY_FRAGMENT_TESTS.as_raw()
                | vk::PipelineStageFlags2::LATE_FRAGMENT_TESTS.as_raw(),
        ),
        access: vk::AccessFlags2::from_raw(
            vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_READ.as_raw()
                | vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE.as_raw(),
        ),
    };
    /// A scope's finished depth: written as the attachment, or by its
    /// resolve (which runs in the colour-attachment-output stage).
    pub const DEPTH_OUTPUT: Use = Use {
        layout: vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
        stage: vk::PipelineStageFlags2::from_raw(
            vk::PipelineStageFlags2::LATE_FRAGMENT_TESTS.as_raw()
                | vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT.as_raw(),
        ),
        access: vk::AccessFlags2::from_raw(
            vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE.as_raw()
                | vk::AccessFlags2::COLOR_ATTACHMENT_WRITE.as_raw(),
        ),
    };
    /// Depth-stencil read by compute shaders (the depth pyramid).
    pub const DEPTH_COMPUTE_READ: Use = Use {
        layout: vk::ImageLayout::DEPTH_STENCIL_READ_ONLY_OPTIMAL,
        stage: vk::PipelineStageFlags2::COMPUTE_SHADER,
        access: vk::AccessFlags2::SHADER_SAMPLED_READ,
    };

    /// Read as a fragment-shading-rate attachment. The stage is
    /// ALL_COMMANDS rather than the shading-rate stage: older validation
    /// layers mistake that bit for the NV shading-rate-image stage it
    /// aliases (used for one-time uploads only).
    pub const SHADING_RATE: Use = Use {
        layout: vk::ImageLayout::FRAGMENT_SHADING_RATE_ATTACHMENT_OPTIMAL_KHR,
        stage: vk::PipelineStageFlags2::ALL_COMMANDS,
        access: vk::AccessFlags2::FRAGMENT_SHADING_RATE_ATTACHMENT_READ_KHR,
    };

    /// The same stages with the contents discarded (old layout UNDEFINED,
    /// no access to wait for): for images about to be overwritten.
    pub fn discarded(self) -> Use {
        Use {
            layout: vk::ImageLayout::UNDEFINED,
            access: vk::AccessFlags2::NONE,
            ..self
        }
    }
}

/// The barrier moving the first mip of `layers` layers of `image` (aspect
/// `aspect`) from use `from` to use `to`.
pub fn image(
    image: vk::Image,
    aspect: vk::ImageAspectFlags,
    layers: u32,
    from: Use,
    to: Use,
) -> vk::ImageMemoryBarrier2<'static> {
    image_level(image, aspect, 0, layers, from, to)
}

/// Like [`image`], for colour layer `layer` alone.
pub fn color_layer(
    image: vk::Image,
    layer: u32,
    from: Use,
    to: Use,
) -> vk::ImageMemoryBarrier2<'static> {
    let mut b = self::image(image, vk::ImageAspectFlags::COLOR, 1, from, to);
    b.subresource_range.base_array_layer = layer;
    b
}

/// Like [`image`], for mip level `level`.
pub fn image_level(
    image: vk::Image,
    aspect: vk::ImageAspectFlags,
    level: u32,
    layers: u32,
    from: Use,
    to: Use,
) -> vk::ImageMemoryBarrier2<'static> {
    vk::ImageMemoryBarrier2::default()
        .src_stage_mask(from.stage)
        .src_access_mask(from.access)
        .dst_stage_mask(to.stage)
        .dst_access_mask(to.access)
        .old_layout(from.layout)
        .new_layout(to.layout)
        .image(image)
        .subresource_range(vk::ImageSubresourceRange {
            aspect_mask: aspect,
            base_mip_level: level,
            level_count: 1,
            base_array_layer: 0,
            layer_count: layers,
        })
}

/// The colour aspect's first mip level over `count` layers from `first`.
pub fn color_range(first: u32, count: u32) -> vk::ImageSubresourceRange {
    vk::ImageSubresourceRange {
        aspect_mask: vk::ImageAspectFlags::COLOR,
        base_mip_level: 0,
        level_count: 1,
        base_array_layer: first,
        layer_count: count,
    }
}

/// A copy between a tightly packed buffer (from byte `offset`) and mip 0 of
/// `layers` layers of a `width`×`height` colour image.
pub fn color_copy(offset: u64, layers: u32, width: u32, height: u32) -> vk::BufferImageCopy {
    vk::BufferImageCopy::default()
        .buffer_offset(offset)
        .image_subresource(vk::ImageSubresourceLayers {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            mip_level: 0,
            base_array_layer: 0,
            layer_count: layers,
        })
        .image_extent(vk::Extent3D {
            width,
            height,
            depth: 1,
        })
}

/// The barrier that makes copies into host-visible memory readable by the
/// host once the submission's fence has signalled.
pub fn copies_to_host() -> vk::MemoryBarrier2<'static> {
    vk::MemoryBarrier2::default()
        .src_stage_mask(vk::PipelineStageFlags2::COPY)
        .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
        .dst_stage_mask(vk::PipelineStageFlags2::HOST)
        .dst_access_mask(vk::AccessFlags2::HOST_READ)
}

/// The barrier that makes copies into `buf` (all of it) readable by the
/// host once the submission's fence has signalled.
pub fn buffer_to_host(buf: vk::Buffer) -> vk::BufferMemoryBarrier2<'static> {
    vk::BufferMemoryBarrier2::default()
        .src_stage_mask(vk::PipelineStageFlags2::COPY)
        .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
        .dst_stage_mask(vk::PipelineStageFlags2::HOST)
        .dst_access_mask(vk::AccessFlags2::HOST_READ)
        .buffer(buf)
        .size(vk::WHOLE_SIZE)
}
