//! The depth pyramid of `occlusion` (timed as `depth-pyramid`): after the
//! early forward views, each eye's depth (every sample) is reduced to a
//! pyramid of farthest depths in a storage buffer per frame slot, level by
//! level, as `cull::hiz` defines it (`shaders/hiz_init*.comp` for level 0,
//! `shaders/hiz_reduce.comp` for the rest). The late cull reads it.

use super::super::attachments::AttachmentSet;
use crate::cull::hiz::{self, Level};
use crate::error::{Result, VkContext};
use crate::gpu::barrier::{self, Use};
use crate::gpu::memory::{as_bytes, Buffer, BufferDesc, Image};
use crate::gpu::pipeline::{compute_pipeline, DescriptorSets};
use crate::gpu::query::Queries;
use crate::gpu::shaders;
use crate::gpu::Context;
use crate::render::scene_gpu::upload;
use ash::vk;
use gpu_allocator::MemoryLocation;

/// Threads per workgroup side (local_size_x and _y of the hiz shaders).
const GROUP: u32 = 8;

/// The pyramid pass, its per-slot buffers and the views it samples.
pub struct DepthPyramid {
    levels: Vec<Level>,
    level_buffer: Buffer,
    pyramids: Vec<Buffer>,
    /// Depth-only views of the depth image of each eye (the same 2-layer
    /// image twice under multiview).
    views: Vec<vk::ImageView>,
    /// The depth images (one per attachment set).
    images: Vec<(vk::Image, u32)>,
    /// Their aspects (depth, and stencil when the format has one).
    aspect: vk::ImageAspectFlags,
    extent: vk::Extent2D,
    samples: u32,
    layered: bool,
    sampler: vk::Sampler,
    set_layout: vk::DescriptorSetLayout,
    layout: vk::PipelineLayout,
    pool: vk::DescriptorPool,
    sets: Vec<vk::DescriptorSet>,
    init: vk::Pipeline,
    reduce: vk::Pipeline,
}

impl DepthPyramid {
    /// Creates the pass for the attachment sets `targets` (one 2-layer set
    /// under multiview, one per eye in two-pass; eyes of `extent`,
    /// `samples` per pixel) with `slots` frame slots; their depth images
    /// must be sampleable (created for occlusion).
    pub fn new(
        ctx: &Context,
        targets: &[AttachmentSet],
        extent: vk::Extent2D,
        samples: u32,
        slots: usize,
    ) -> Result<DepthPyramid> {
        if targets.is_empty() {
            return Err(crate::error::Error::config(
                "--opt",
                "occlusion needs the depth of the views it culls for, and these targets have none of their own",
            ));
        }
        let levels = hiz::levels(extent.width, extent.height);
        let words: Vec<u32> = levels
            .iter()
            .flat_map(|l| [l.width, l.height, l.offset, 0])
            .collect();
        let level_buffer = upload(
            ctx,
            "depth pyramid levels",
            vk::BufferUsageFlags::STORAGE_BUFFER,
            "per-frame",
            as_bytes(&words),
        )?;
        let mut p = DepthPyramid {
            levels,
            level_buffer,
            pyramids: Vec::new(),
            views: Vec::new(),
            images: targets
                .iter()
                .map(|s| (s.depth.image, s.depth.layers))
                .collect(),
            aspect: crate::gpu::depth_aspect(targets[0].depth.format),
            extent,
            samples,
            layered: targets.len() == 1,
            sampler: vk::Sampler::null(),
            set_layout: vk::DescriptorSetLayout::null(),
            layout: vk::PipelineLayout::null(),
            pool: vk::DescriptorPool::null(),
            sets: Vec::new(),
            init: vk::Pipeline::null(),
            reduce: vk::Pipeline::null(),
        };
        match p.build(ctx, targets, slots) {
            Ok(()) => Ok(p),
            Err(e) => {
                p.destroy(ctx);
                Err(e)
            }
        }
    }

    /// Points each slot's set at both eyes' depth views (sampled through
    /// the pass's sampler) and the slot's pyramid buffer.
    fn write_sets(&self, ctx: &Context) {
        let images: Vec<vk::DescriptorImageInfo> = self
            .views
            .iter()
            .map(|&v| {
                vk::DescriptorImageInfo::default()
                    .sampler(self.sampler)
                    .image_view(v)
                    .image_layout(vk::ImageLayout::DEPTH_STENCIL_READ_ONLY_OPTIMAL)
            })
            .collect();
        for (set, pyramid) in self.sets.iter().zip(&self.pyramids) {
            let buffer = [vk::DescriptorBufferInfo::default()
                .buffer(pyramid.buffer)
                .range(vk::WHOLE_SIZE)];
            let writes = [
                vk::WriteDescriptorSet::default()
                    .dst_set(*set)
                    .dst_binding(0)
                    .descriptor_type(vk::DescriptorType::COMBINED_IMAGE_SAMPLER)
                    .image_info(&images),
                vk::WriteDescriptorSet::default()
                    .dst_set(*set)
                    .dst_binding(1)
                    .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                    .buffer_info(&buffer),
            ];
            // SAFETY: the set is not in use yet; the views, sampler and
            // buffer are live and owned by this pass.
            unsafe { ctx.device.update_descriptor_sets(&writes, &[]) };
        }
    }

    fn build(&mut self, ctx: &Context, targets: &[AttachmentSet], slots: usize) -> Result<()> {
        let texels = 2 * hiz::texels(&self.levels) as u64;
        for i in 0..slots {
            self.pyramids.push(Buffer::new(
                ctx,
                &BufferDesc {
                    name: &format!("depth pyramid {i}"),
                    size: 4 * texels,
                    usage: vk::BufferUsageFlags::STORAGE_BUFFER,
                    location: MemoryLocation::GpuOnly,
                    category: "per-frame",
                },
            )?);
        }
        for eye in 0..2 {
            let set = &targets[eye.min(targets.len() - 1)];
            let img: &Image = &set.depth;
            self.views.push(Image::make_view(
                ctx,
                img.image,
                img.format,
                vk::ImageAspectFlags::DEPTH,
                vk::ImageViewType::TYPE_2D_ARRAY,
                0,
                img.layers,
                1,
            )?);
        }
        let d = &ctx.device;
        // SAFETY: object creation on a live device; the handle is stored in
        // `self` at once, so `destroy` frees it on a later failure.
        unsafe {
            self.sampler = d
                .create_sampler(
                    &vk::SamplerCreateInfo::default()
                        .mag_filter(vk::Filter::NEAREST)
                        .min_filter(vk::Filter::NEAREST)
                        .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
                        .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
                        .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE),
                    None,
                )
                .vk("creating the depth pyramid sampler")?;
        }
        let compute = vk::ShaderStageFlags::COMPUTE;
        let made = DescriptorSets::new(
            ctx,
            &[
                (vk::DescriptorType::COMBINED_IMAGE_SAMPLER, 2, compute),
                (vk::DescriptorType::STORAGE_BUFFER, 1, compute),
            ],
            compute,
            32,
            slots,
            "depth pyramid",
        )?;
        self.set_layout = made.set_layout;
        self.layout = made.layout;
        self.pool = made.pool;
        self.sets = made.sets;
        self.write_sets(ctx);
        let init = if self.samples > 1 {
            shaders::HIZ_INIT_MS_COMP.words()
        } else {
            shaders::HIZ_INIT_COMP.words()
        };
        self.init = compute_pipeline(ctx, self.layout, &init, "depth pyramid level 0")?;
        self.reduce = compute_pipeline(
            ctx,
            self.layout,
            &shaders::HIZ_REDUCE_COMP.words(),
            "depth pyramid reduce",
        )?;
        Ok(())
    }

    /// The pyramid buffer of `slot` (both eyes, eye 1 after eye 0).
    pub fn buffer(&self, slot: usize) -> &Buffer {
        &self.pyramids[slot]
    }

    /// The levels' shape (width, height, offset per level) as the cull
    /// shader reads it.
    pub fn level_buffer(&self) -> &Buffer {
        &self.level_buffer
    }

    /// How many levels the pyramid has.
    pub fn level_count(&self) -> u32 {
        self.levels.len() as u32
    }

    /// The size of the views the pyramid is built from.
    pub fn extent(&self) -> vk::Extent2D {
        self.extent
    }

    /// Texels of one eye's pyramid.
    pub fn eye_stride(&self) -> u32 {
        hiz::texels(&self.levels)
    }

    /// Records the pyramid of `slot` from the depth the early views wrote:
    /// the depth images go to a read-only layout, level 0 reads them, each
    /// further level the one before, and the depth goes back to the
    /// attachment layout for the late views; the pyramid is made visible to
    /// the late cull.
    pub fn record(&self, ctx: &Context, cmd: vk::CommandBuffer, q: &mut Queries, slot: usize) {
        let d = &ctx.device;
        let ds = self.aspect;
        let to_read: Vec<_> = self
            .images
            .iter()
            .map(|&(img, layers)| {
                barrier::image(
                    img,
                    ds,
                    layers,
                    Use::DEPTH_ATTACHMENT,
                    Use::DEPTH_COMPUTE_READ,
                )
            })
            .collect();
        let back: Vec<_> = self
            .images
            .iter()
            .map(|&(img, layers)| {
                barrier::image(
                    img,
                    ds,
                    layers,
                    Use::DEPTH_COMPUTE_READ,
                    Use::DEPTH_ATTACHMENT,
                )
            })
            .collect();
        let storage = [vk::MemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
            .src_access_mask(vk::AccessFlags2::SHADER_STORAGE_WRITE)
            .dst_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
            .dst_access_mask(
                vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE,
            )];
        let stride = self.eye_stride();
        // One dispatch over `level`'s texels, both eyes, with `push`.
        // SAFETY (of the calls inside): recorded into the frame's command
        // buffer outside any rendering scope, with this pass's pipeline
        // layout bound.
        let dispatch = |push: &[u32; 8], level: &Level| unsafe {
            d.cmd_push_constants(
                cmd,
                self.layout,
                vk::ShaderStageFlags::COMPUTE,
                0,
                as_bytes(push),
            );
            d.cmd_dispatch(
                cmd,
                level.width.div_ceil(GROUP),
                level.height.div_ceil(GROUP),
                2,
            );
        };
        q.begin_pass(ctx, cmd, "depth-pyramid");
        // SAFETY: recording outside any rendering scope into the frame's
        // command buffer; the depth images were last written by the early
        // views (the barrier orders it), the pyramid buffer belongs to this
        // slot, whose previous frame has finished.
        unsafe {
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().image_memory_barriers(&to_read),
            );
            d.cmd_bind_descriptor_sets(
                cmd,
                vk::PipelineBindPoint::COMPUTE,
                self.layout,
                0,
                &[self.sets[slot]],
                &[],
            );
            let l0 = self.levels[0];
            d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, self.init);
            let push = [
                self.extent.width,
                self.extent.height,
                self.samples,
                self.layered as u32,
                l0.width,
                l0.height,
                stride,
                0,
            ];
            dispatch(&push, &l0);
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default()
                    .memory_barriers(&storage)
                    .image_memory_barriers(&back),
            );
            d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, self.reduce);
            for w in self.levels.windows(2) {
                let (src, dst) = (w[0], w[1]);
                let push = [
                    src.width, src.height, src.offset, stride, dst.width, dst.height, dst.offset, 0,
                ];
                dispatch(&push, &dst);
                d.cmd_pipeline_barrier2(
                    cmd,
                    &vk::DependencyInfo::default().memory_barriers(&storage),
                );
            }
        }
        q.end_pass(ctx, cmd);
    }

    /// Destroys the pass; the device must be idle.
    pub fn destroy(self, ctx: &Context) {
        let d = &ctx.device;
        // SAFETY: the device is idle; null handles are ignored by Vulkan.
        unsafe {
            d.destroy_pipeline(self.init, None);
            d.destroy_pipeline(self.reduce, None);
            d.destroy_descriptor_pool(self.pool, None);
            d.destroy_pipeline_layout(self.layout, None);
            d.destroy_descriptor_set_layout(self.set_layout, None);
            d.destroy_sampler(self.sampler, None);
            for &v in &self.views {
                d.destroy_image_view(v, None);
            }
        }
        for b in self.pyramids {
            b.destroy(ctx);
        }
        self.level_buffer.destroy(ctx);
    }
}
