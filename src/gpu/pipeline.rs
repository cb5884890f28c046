//! Graphics pipelines described as plain data and created at init, never
//! inside a measured frame. Pipelines target dynamic rendering, so a
//! description names its attachment formats and multiview mask.

use super::Context;
use crate::error::{Error, Result, VkContext};
use ash::vk;

/// Everything needed to build one graphics pipeline.
#[derive(Clone)]
pub struct GraphicsPipelineDesc<'a> {
    /// Debug name.
    pub name: &'a str,
    /// Vertex shader SPIR-V.
    pub vertex: &'a [u32],
    /// Fragment shader SPIR-V.
    pub fragment: &'a [u32],
    /// Specialization constants (id, value) shared by both stages.
    pub specialization: Vec<(u32, u32)>,
    /// Vertex buffer bindings.
    pub bindings: Vec<vk::VertexInputBindingDescription>,
    /// Vertex attributes.
    pub attributes: Vec<vk::VertexInputAttributeDescription>,
    /// Face culling.
    pub cull_mode: vk::CullModeFlags,
    /// Depth test on.
    pub depth_test: bool,
    /// Depth writes on.
    pub depth_write: bool,
    /// Depth comparison (GREATER for reverse-Z).
    pub depth_compare: vk::CompareOp,
    /// Stencil test state for both faces (None: stencil off).
    pub stencil: Option<vk::StencilOpState>,
    /// How fragments blend with the attachment.
    pub blend: Blend,
    /// The colour channels written (empty: colour writes off).
    pub color_write: vk::ColorComponentFlags,
    /// Rasterization samples.
    pub samples: vk::SampleCountFlags,
    /// Colour attachment format.
    pub color_format: vk::Format,
    /// Depth-stencil attachment format.
    pub depth_format: vk::Format,
    /// Multiview mask (0 = no multiview).
    pub view_mask: u32,
    /// Pipeline layout.
    pub layout: vk::PipelineLayout,
    /// Used with a fragment-shading-rate attachment (the attachment's rate
    /// replaces the pipeline's 1×1).
    pub shading_rate_attachment: bool,
    /// Clip-space w scaling (VK_NV_clip_space_w_scaling) on viewport 0,
    /// its coefficients dynamic state (`lms` on the native path).
    pub w_scaling: bool,
    /// Point-list topology instead of triangle lists.
    pub points: bool,
}

/// Colour blending of a pipeline's fragments with the attachment.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Blend {
    /// Written as they are.
    Off,
    /// "Over" with straight (not premultiplied) source alpha: colour
    /// `a·src + (1 − a)·dst`; alpha `a + (1 − a)·dst.a`, so the
    /// attachment's alpha accumulates the coverage of what was drawn.
    Over,
    /// "Under" (Porter and Duff 1984): the source goes behind what the
    /// attachment holds, whose alpha is its coverage: colour
    /// `dst + (1 − dst.a)·src`, alpha `dst.a + (1 − dst.a)·src.a`.
    Under,
}

fn module(ctx: &Context, code: &[u32], what: &str) -> Result<vk::ShaderModule> {
    if code.is_empty() {
        return Err(Error::Gpu(format!("{what}: empty SPIR-V")));
    }
    // SAFETY: SPIR-V words validated by the build (spirv-val in tests).
    unsafe {
        ctx.device
            .create_shader_module(&vk::ShaderModuleCreateInfo::default().code(code), None)
    }
    .vk(&format!("creating shader module for {what}"))
}

impl GraphicsPipelineDesc<'_> {
    /// The specialization constants' map entries (4 bytes each, in
    /// order) and their data.
    fn specialization_data(&self) -> (Vec<vk::SpecializationMapEntry>, Vec<u8>) {
        let entries = self
            .specialization
            .iter()
            .enumerate()
            .map(|(i, (id, _))| vk::SpecializationMapEntry {
                constant_id: *id,
                offset: 4 * i as u32,
                size: 4,
            })
            .collect();
        let data = self
            .specialization
            .iter()
            .flat_map(|(_, v)| v.to_ne_bytes())
            .collect();
        (entries, data)
    }

    /// The depth test and write, and the stencil test when there is one
    /// (the same on both faces).
    fn depth_state(&self) -> vk::PipelineDepthStencilStateCreateInfo<'static> {
        let stencil = self.stencil.unwrap_or_default();
        vk::PipelineDepthStencilStateCreateInfo::default()
            .depth_test_enable(self.depth_test)
            .depth_write_enable(self.depth_write)
            .depth_compare_op(self.depth_compare)
            .stencil_test_enable(self.stencil.is_some())
            .front(stencil)
            .back(stencil)
    }

    /// The colour attachment's blending: off, over (premultiplied alpha
    /// on top) or under (the new colour behind what is there).
    fn blend_attachment(&self) -> vk::PipelineColorBlendAttachmentState {
        // (source colour, destination colour, source alpha, destination
        // alpha) factors.
        let (sc, dc, sa, da) = match self.blend {
            Blend::Off | Blend::Over => (
                vk::BlendFactor::SRC_ALPHA,
                vk::BlendFactor::ONE_MINUS_SRC_ALPHA,
                vk::BlendFactor::ONE,
                vk::BlendFactor::ONE_MINUS_SRC_ALPHA,
            ),
            Blend::Under => (
                vk::BlendFactor::ONE_MINUS_DST_ALPHA,
                vk::BlendFactor::ONE,
                vk::BlendFactor::ONE_MINUS_DST_ALPHA,
                vk::BlendFactor::ONE,
            ),
        };
        vk::PipelineColorBlendAttachmentState::default()
            .blend_enable(self.blend != Blend::Off)
            .src_color_blend_factor(sc)
            .dst_color_blend_factor(dc)
            .color_blend_op(vk::BlendOp::ADD)
            .src_alpha_blend_factor(sa)
            .dst_alpha_blend_factor(da)
            .alpha_blend_op(vk::BlendOp::ADD)
            .color_write_mask(self.color_write)
    }

    /// Creates the pipeline.
    pub fn build(&self, ctx: &Context) -> Result<vk::Pipeline> {
        let vs = module(ctx, self.vertex, self.name)?;
        let fs = match module(ctx, self.fragment, self.name) {
            Ok(m) => m,
            Err(e) => {
                // SAFETY: unused module.
                unsafe { ctx.device.destroy_shader_module(vs, None) };
                return Err(e);
            }
        };
        let (entries, data) = self.specialization_data();
        let spec = vk::SpecializationInfo::default()
            .map_entries(&entries)
            .data(&data);
        let stages = [
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::VERTEX)
                .module(vs)
                .name(c"main")
                .specialization_info(&spec),
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::FRAGMENT)
                .module(fs)
                .name(c"main")
                .specialization_info(&spec),
        ];
        let vertex_input = vk::PipelineVertexInputStateCreateInfo::default()
            .vertex_binding_descriptions(&self.bindings)
            .vertex_attribute_descriptions(&self.attributes);
        let input_assembly =
            vk::PipelineInputAssemblyStateCreateInfo::default().topology(if self.points {
                vk::PrimitiveTopology::POINT_LIST
            } else {
                vk::PrimitiveTopology::TRIANGLE_LIST
            });
        let mut w_scaling = vk::PipelineViewportWScalingStateCreateInfoNV::default()
            .viewport_w_scaling_enable(true);
        w_scaling.viewport_count = 1;
        let mut viewport = vk::PipelineViewportStateCreateInfo::default()
            .viewport_count(1)
            .scissor_count(1);
        if self.w_scaling {
            viewport = viewport.push_next(&mut w_scaling);
        }
        let raster = vk::PipelineRasterizationStateCreateInfo::default()
            .polygon_mode(vk::PolygonMode::FILL)
            .cull_mode(self.cull_mode)
            .front_face(vk::FrontFace::COUNTER_CLOCKWISE)
            .line_width(1.0);
        let multisample =
            vk::PipelineMultisampleStateCreateInfo::default().rasterization_samples(self.samples);
        let depth = self.depth_state();
        let attachment = [self.blend_attachment()];
        let blend = vk::PipelineColorBlendStateCreateInfo::default().attachments(&attachment);
        let dynamic = [
            vk::DynamicState::VIEWPORT,
            vk::DynamicState::SCISSOR,
            vk::DynamicState::VIEWPORT_W_SCALING_NV,
        ];
        let dynamic = vk::PipelineDynamicStateCreateInfo::default()
            .dynamic_states(&dynamic[..if self.w_scaling { 3 } else { 2 }]);
        let formats = [self.color_format];
        let mut rendering = vk::PipelineRenderingCreateInfo::default()
            .view_mask(self.view_mask)
            .color_attachment_formats(&formats)
            .depth_attachment_format(self.depth_format)
            .stencil_attachment_format(stencil_format(self.depth_format));
        let mut fsr = vk::PipelineFragmentShadingRateStateCreateInfoKHR::default()
            .fragment_size(vk::Extent2D {
                width: 1,
                height: 1,
            })
            .combiner_ops([
                vk::FragmentShadingRateCombinerOpKHR::KEEP,
                vk::FragmentShadingRateCombinerOpKHR::REPLACE,
            ]);
        let mut info = vk::GraphicsPipelineCreateInfo::default()
            .stages(&stages)
            .vertex_input_state(&vertex_input)
            .input_assembly_state(&input_assembly)
            .viewport_state(&viewport)
            .rasterization_state(&raster)
            .multisample_state(&multisample)
            .depth_stencil_state(&depth)
            .color_blend_state(&blend)
            .dynamic_state(&dynamic)
            .layout(self.layout)
            .push_next(&mut rendering);
        if self.shading_rate_attachment {
            info = info
                .flags(vk::PipelineCreateFlags::RENDERING_FRAGMENT_SHADING_RATE_ATTACHMENT_KHR)
                .push_next(&mut fsr);
        }
        create_graphics(ctx, &info, [vs, fs], self.name)
    }
}

/// Creates the graphics pipeline `info` (named `name`) and destroys its
/// shader modules, which Vulkan permits once the pipeline exists.
fn create_graphics(
    ctx: &Context,
    info: &vk::GraphicsPipelineCreateInfo,
    modules: [vk::ShaderModule; 2],
    name: &str,
) -> Result<vk::Pipeline> {
    // SAFETY: all state `info` references lives until the call returns.
    let result = unsafe {
        ctx.device.create_graphics_pipelines(
            vk::PipelineCache::null(),
            std::slice::from_ref(info),
            None,
        )
    };
    for m in modules {
        // SAFETY: modules are no longer needed once the pipeline exists.
        unsafe { ctx.device.destroy_shader_module(m, None) };
    }
    let pipeline = result
        .map_err(|(_, e)| e)
        .vk(&format!("creating pipeline {name}"))?[0];
    ctx.set_name(pipeline, name);
    Ok(pipeline)
}

/// The stencil attachment format that goes with depth format `depth`:
/// the same format when it has a stencil aspect, else none.
pub fn stencil_format(depth: vk::Format) -> vk::Format {
    if crate::gpu::has_stencil(depth) {
        depth
    } else {
        vk::Format::UNDEFINED
    }
}

/// Creates a compute pipeline of `code` (entry point `main`) over
/// `layout`, named `name` for debuggers.
pub fn compute_pipeline(
    ctx: &Context,
    layout: vk::PipelineLayout,
    code: &[u32],
    name: &str,
) -> Result<vk::Pipeline> {
    // SAFETY: SPIR-V embedded at build time (spirv-val in tests); the
    // module is destroyed once the pipeline holds it.
    unsafe {
        let module = ctx
            .device
            .create_shader_module(&vk::ShaderModuleCreateInfo::default().code(code), None)
            .vk("creating a compute shader module")?;
        let stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(module)
            .name(c"main");
        let info = [vk::ComputePipelineCreateInfo::default()
            .stage(stage)
            .layout(layout)];
        let made = ctx
            .device
            .create_compute_pipelines(vk::PipelineCache::null(), &info, None);
        ctx.device.destroy_shader_module(module, None);
        let pipeline = made.map_err(|(_, r)| r).vk("creating a compute pipeline")?;
        ctx.set_name(pipeline[0], name);
        Ok(pipeline[0])
    }
}

/// One descriptor-set layout, a pool with `count` sets of it, and a
/// pipeline layout over it with one push-constant range: what the compute
/// passes (depth pyramid, GPU culling; one set per frame slot) and the tools
/// that run outside the frame (distortion preview, timewarp; one set) bind.
pub struct DescriptorSets {
    /// The sets' layout.
    pub set_layout: vk::DescriptorSetLayout,
    /// The pipeline layout (the set, then the push constants).
    pub layout: vk::PipelineLayout,
    /// The pool the sets come from.
    pub pool: vk::DescriptorPool,
    /// The sets.
    pub sets: Vec<vk::DescriptorSet>,
}

impl DescriptorSets {
    /// Creates `count` sets for `bindings` (binding i: `n` descriptors of
    /// the given type, seen by the given stages) and a pipeline layout with
    /// `push` bytes of push constants for `push_stages`; `what` names it in
    /// errors. On a failure, what was made is destroyed again.
    pub fn new(
        ctx: &Context,
        bindings: &[(vk::DescriptorType, u32, vk::ShaderStageFlags)],
        push_stages: vk::ShaderStageFlags,
        push: u32,
        count: usize,
        what: &str,
    ) -> Result<DescriptorSets> {
        let layout_bindings: Vec<_> = bindings
            .iter()
            .enumerate()
            .map(|(i, &(ty, n, stages))| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(i as u32)
                    .descriptor_type(ty)
                    .descriptor_count(n)
                    .stage_flags(stages)
            })
            .collect();
        let mut sizes: Vec<vk::DescriptorPoolSize> = Vec::new();
        for &(ty, n, _) in bindings {
            let n = n * count as u32;
            match sizes.iter_mut().find(|s| s.ty == ty) {
                Some(s) => s.descriptor_count += n,
                None => sizes.push(vk::DescriptorPoolSize {
                    ty,
                    descriptor_count: n,
                }),
            }
        }
        let mut made = DescriptorSets {
            set_layout: vk::DescriptorSetLayout::null(),
            layout: vk::PipelineLayout::null(),
            pool: vk::DescriptorPool::null(),
            sets: Vec::new(),
        };
        let d = &ctx.device;
        // SAFETY: plain object creation on a live device; every handle is
        // stored in `made` at once, so a failure destroys what exists.
        let result = unsafe {
            (|| -> Result<()> {
                made.set_layout = d
                    .create_descriptor_set_layout(
                        &vk::DescriptorSetLayoutCreateInfo::default().bindings(&layout_bindings),
                        None,
                    )
                    .vk(&format!("creating the {what} set layout"))?;
                let ranges = [vk::PushConstantRange {
                    stage_flags: push_stages,
                    offset: 0,
                    size: push,
                }];
                let one = [made.set_layout];
                made.layout = d
                    .create_pipeline_layout(
                        &vk::PipelineLayoutCreateInfo::default()
                            .set_layouts(&one)
                            .push_constant_ranges(&ranges),
                        None,
                    )
                    .vk(&format!("creating the {what} pipeline layout"))?;
                made.pool = d
                    .create_descriptor_pool(
                        &vk::DescriptorPoolCreateInfo::default()
                            .max_sets(count as u32)
                            .pool_sizes(&sizes),
                        None,
                    )
                    .vk(&format!("creating the {what} descriptor pool"))?;
                let layouts = vec![made.set_layout; count];
                made.sets = d
                    .allocate_descriptor_sets(
                        &vk::DescriptorSetAllocateInfo::default()
                            .descriptor_pool(made.pool)
                            .set_layouts(&layouts),
                    )
                    .vk(&format!("allocating the {what} descriptor sets"))?;
                Ok(())
            })()
        };
        match result {
            Ok(()) => Ok(made),
            Err(e) => {
                made.destroy(ctx);
                Err(e)
            }
        }
    }

    /// Writes image descriptors into set `index`: per entry a binding, its
    /// type and its array elements. Only before a frame uses the set.
    pub fn write_images(
        &self,
        ctx: &Context,
        index: usize,
        bindings: &[(u32, vk::DescriptorType, &[vk::DescriptorImageInfo])],
    ) {
        let set = self.sets[index];
        let writes: Vec<vk::WriteDescriptorSet> = bindings
            .iter()
            .map(|&(binding, ty, infos)| {
                vk::WriteDescriptorSet::default()
                    .dst_set(set)
                    .dst_binding(binding)
                    .descriptor_type(ty)
                    .image_info(infos)
            })
            .collect();
        // SAFETY: the caller writes the set before any frame uses it; the
        // views and samplers are live.
        unsafe { ctx.device.update_descriptor_sets(&writes, &[]) };
    }

    /// Destroys the pool (and its sets) and the layouts; the device must be
    /// done with them. Null handles are skipped by Vulkan.
    pub fn destroy(&self, ctx: &Context) {
        // SAFETY: the caller guarantees the GPU no longer uses them.
        unsafe {
            ctx.device.destroy_descriptor_pool(self.pool, None);
            ctx.device.destroy_pipeline_layout(self.layout, None);
            ctx.device
                .destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}
