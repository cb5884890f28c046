//! The renderer's descriptors: one set layout (set 0, declared in
//! `shaders/common.glsl` and the pass shaders), the pipeline layout every
//! pipeline shares (that set plus 16 bytes of push constants), a pool and
//! one set per frame slot, and the writes that point a slot's set at its
//! buffers and images.

use super::scene_gpu::SceneGpu;
use super::uniforms;
use crate::error::{Result, VkContext};
use crate::gpu::memory::Buffer;
use crate::gpu::Context;
use ash::vk;

/// Binding of the frame uniforms (`FrameData`).
pub const FRAME: u32 = 0;
/// Binding of the per-instance transforms.
pub const INSTANCES: u32 = 1;
/// Binding of the frame's visible instance ids.
pub const VISIBLE: u32 = 2;
/// Binding of the materials.
pub const MATERIALS: u32 = 3;
/// Binding of the scene's textures.
pub const TEXTURES: u32 = 4;
/// Binding of the hidden-area triangles (stencil mask).
pub const HIDDEN: u32 = 5;
/// Binding of the frames the RDM fill samples (one per attachment set).
pub const FILLED: u32 = 6;
/// Binding of the far-field images the MFFR composite samples.
pub const FAR_FIELD: u32 = 7;
/// Binding of the point cloud's per-pixel keys (the points composite).
pub const POINTS: u32 = 8;

/// Stages that see the descriptors and push constants.
const STAGES: vk::ShaderStageFlags = vk::ShaderStageFlags::from_raw(
    vk::ShaderStageFlags::VERTEX.as_raw() | vk::ShaderStageFlags::FRAGMENT.as_raw(),
);

/// What one slot's set points at.
pub struct SetContents<'a> {
    /// The slot's frame uniform buffer.
    pub frame: &'a Buffer,
    /// The scene (instances, materials, textures).
    pub scene: &'a SceneGpu,
    /// The slot's visible instance ids.
    pub visible: &'a Buffer,
    /// The slot's hidden-area triangles (None: no stencil mask).
    pub hidden: Option<vk::Buffer>,
    /// The frames the RDM fill samples (None: no fill).
    pub filled: Option<[vk::DescriptorImageInfo; 2]>,
    /// The far-field images (None: no monoscopic far field).
    pub far_field: Option<[vk::DescriptorImageInfo; 2]>,
    /// The slot's point keys (None: no point cloud).
    pub points: Option<vk::Buffer>,
}

/// Set layout, pipeline layout, pool and one set per frame slot.
pub struct Descriptors {
    /// The layout of set 0.
    pub set_layout: vk::DescriptorSetLayout,
    /// The pipeline layout of every pipeline.
    pub layout: vk::PipelineLayout,
    pool: vk::DescriptorPool,
    /// One set per frame slot.
    pub sets: Vec<vk::DescriptorSet>,
}

impl Descriptors {
    /// Creates the layouts and `slots` sets for a scene of `texture_count`
    /// textures; `extra` is set 1 of the pipeline layout when given (the
    /// per-draw records of `--per-draw ubo|ssbo`).
    pub fn new(
        ctx: &Context,
        texture_count: u32,
        slots: usize,
        extra: Option<vk::DescriptorSetLayout>,
    ) -> Result<Descriptors> {
        let d = &ctx.device;
        let binding = |i: u32, ty, count: u32, stages| {
            vk::DescriptorSetLayoutBinding::default()
                .binding(i)
                .descriptor_type(ty)
                .descriptor_count(count)
                .stage_flags(stages)
        };
        let storage = vk::DescriptorType::STORAGE_BUFFER;
        let sampler = vk::DescriptorType::COMBINED_IMAGE_SAMPLER;
        let fragment = vk::ShaderStageFlags::FRAGMENT;
        let bindings = [
            binding(FRAME, vk::DescriptorType::UNIFORM_BUFFER, 1, STAGES),
            binding(INSTANCES, storage, 1, STAGES),
            binding(VISIBLE, storage, 1, STAGES),
            binding(MATERIALS, storage, 1, STAGES),
            binding(TEXTURES, sampler, texture_count, fragment),
            binding(HIDDEN, storage, 1, vk::ShaderStageFlags::VERTEX),
            binding(FILLED, sampler, 2, fragment),
            binding(FAR_FIELD, sampler, 2, fragment),
            binding(POINTS, storage, 1, fragment),
        ];
        // SAFETY: plain object creation on a live device; the objects are
        // owned by the returned value and destroyed by `destroy`.
        unsafe {
            let set_layout = d
                .create_descriptor_set_layout(
                    &vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings),
                    None,
                )
                .vk("creating the descriptor set layout")?;
            let ranges = [vk::PushConstantRange {
                stage_flags: STAGES,
                offset: 0,
                size: 16,
            }];
            let set_layouts: Vec<_> = std::iter::once(set_layout).chain(extra).collect();
            let layout = d
                .create_pipeline_layout(
                    &vk::PipelineLayoutCreateInfo::default()
                        .set_layouts(&set_layouts)
                        .push_constant_ranges(&ranges),
                    None,
                )
                .vk("creating the pipeline layout")?;
            let n = slots as u32;
            let sizes = [
                vk::DescriptorPoolSize {
                    ty: vk::DescriptorType::UNIFORM_BUFFER,
                    descriptor_count: n,
                },
                vk::DescriptorPoolSize {
                    ty: storage,
                    descriptor_count: 5 * n,
                },
                vk::DescriptorPoolSize {
                    ty: sampler,
                    descriptor_count: (texture_count + 4) * n,
                },
            ];
            let pool = d
                .create_descriptor_pool(
                    &vk::DescriptorPoolCreateInfo::default()
                        .max_sets(n)
                        .pool_sizes(&sizes),
                    None,
                )
                .vk("creating the descriptor pool")?;
            let layouts = vec![set_layout; slots];
            let sets = d
                .allocate_descriptor_sets(
                    &vk::DescriptorSetAllocateInfo::default()
                        .descriptor_pool(pool)
                        .set_layouts(&layouts),
                )
                .vk("allocating descriptor sets")?;
            Ok(Descriptors {
                set_layout,
                layout,
                pool,
                sets,
            })
        }
    }

    /// Points `slot`'s set at `c`. The set must not be in use by a pending
    /// frame (its slot's fence was waited on, or it was never submitted).
    pub fn write(&self, ctx: &Context, slot: usize, c: &SetContents) {
        let whole = |buffer: vk::Buffer| {
            [vk::DescriptorBufferInfo {
                buffer,
                offset: 0,
                range: vk::WHOLE_SIZE,
            }]
        };
        let frame = [vk::DescriptorBufferInfo {
            buffer: c.frame.buffer,
            offset: 0,
            range: uniforms::SIZE,
        }];
        let instances = whole(c.scene.instances.buffer);
        let visible = whole(c.visible.buffer);
        let materials = whole(c.scene.materials.buffer);
        let hidden = c.hidden.map(whole);
        let points = c.points.map(whole);
        let textures: Vec<vk::DescriptorImageInfo> = c
            .scene
            .textures
            .iter()
            .zip(&c.scene.texture_samplers)
            .map(|(t, &s)| vk::DescriptorImageInfo {
                sampler: s,
                image_view: t.view,
                image_layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
            })
            .collect();
        let set = self.sets[slot];
        let w = |b: u32, ty| {
            vk::WriteDescriptorSet::default()
                .dst_set(set)
                .dst_binding(b)
                .descriptor_type(ty)
        };
        let storage = vk::DescriptorType::STORAGE_BUFFER;
        let sampler = vk::DescriptorType::COMBINED_IMAGE_SAMPLER;
        let mut writes = vec![
            w(FRAME, vk::DescriptorType::UNIFORM_BUFFER).buffer_info(&frame),
            w(INSTANCES, storage).buffer_info(&instances),
            w(VISIBLE, storage).buffer_info(&visible),
            w(MATERIALS, storage).buffer_info(&materials),
            w(TEXTURES, sampler).image_info(&textures),
        ];
        if let Some(hidden) = &hidden {
            writes.push(w(HIDDEN, storage).buffer_info(hidden));
        }
        if let Some(filled) = &c.filled {
            writes.push(w(FILLED, sampler).image_info(filled));
        }
        if let Some(far) = &c.far_field {
            writes.push(w(FAR_FIELD, sampler).image_info(far));
        }
        if let Some(points) = &points {
            writes.push(w(POINTS, storage).buffer_info(points));
        }
        // SAFETY: every handle written is alive; the caller guarantees the
        // set is not in use by a pending frame.
        unsafe { ctx.device.update_descriptor_sets(&writes, &[]) };
    }

    /// Destroys the pool (and with it the sets) and the layouts; the device
    /// must be idle.
    pub fn destroy(&self, ctx: &Context) {
        // SAFETY: the device is idle; these objects belong to `self`.
        unsafe {
            ctx.device.destroy_descriptor_pool(self.pool, None);
            ctx.device.destroy_pipeline_layout(self.layout, None);
            ctx.device
                .destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}
