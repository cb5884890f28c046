//! HMD stencil mask (`stencil-mask`): at the start of each forward scope
//! (both layers at once under multiview) the hidden-area triangles are drawn
//! into stencil bit 0 only, and every later draw tests stencil = 0, so the
//! pixels the lens hides are never shaded. The mesh of each view is a
//! triangle list in tangent space (the z = -1 plane, as
//! XR_KHR_visibility_mask gives it); `shaders/hidden.vert` maps it to NDC
//! with the view's FOV tangents like the projection does:
//! `x_ndc = (2 tx − (r + l)) / (r − l)`, `y_ndc = −(2 ty − (u + d)) / (u − d)`.
//! Valve reports 17 % of the Vive's pixels hidden; the lens-ellipse default
//! (`view::lens`) hides 1 − π/4 ≈ 21.5 %.
//!
//! Except with RDM, MFFR, or where the frame's depth is handed on, the mask is
//! marked in depth instead (`Renderer`'s `mask_in_depth`): the triangles
//! are drawn at the near plane (reverse-Z depth 1, written always) in
//! opaque black, so every later draw fails its depth test there just as
//! it failed stencil = 0 (the scene and overlay test GREATER, which depth
//! 1 never passes; the sky and the floors test GREATER_OR_EQUAL at depth
//! 0), the
//! frame needs no stencil aspect, and with the sky writing every other
//! sample it needs no colour clear either.
//!
//! With lens-matched shading the mask is drawn once per quadrant, through
//! the quadrant's w scaling, so it lands where the scene's hidden pixels
//! land in the LMS image.
//!
//! Each frame slot has its own vertex buffer, rewritten only when the rig's
//! meshes change (a runtime may send new ones).

use super::technique::{self, ScopeHook, Technique};
use super::{destroy_pipelines, stencil_write, PipelineSetup, Recorder};
use crate::error::{Error, Result};
use crate::gpu::memory::{as_bytes, Buffer, BufferDesc};
use crate::gpu::pipeline::GraphicsPipelineDesc;
use crate::gpu::shaders;
use crate::gpu::Context;
use crate::render::attachments::Attachments;
use crate::render::descriptors::SetContents;
use crate::render::plan::PlanInput;
use crate::render::FrameStats;
use crate::view::{HiddenArea, StereoRig};
use ash::vk;
use gpu_allocator::MemoryLocation;
use std::sync::Arc;

/// Most hidden-area vertices per view (a triangle list).
pub const MAX_HIDDEN_VERTICES: usize = 3 * 4096;

/// Views the buffer holds: the eyes, then the eyes again for `inset`'s
/// wide views in layers 2 and 3 (`shaders/hidden.vert` maps them with those
/// views' FOV tangents, so the same mesh lands on the wide view's region).
const VIEWS: usize = 4;

/// One frame slot's hidden-area vertices.
struct HiddenSlot {
    buffer: Buffer,
    /// The meshes the buffer holds.
    source: Option<Arc<Vec<HiddenArea>>>,
    /// Vertices per view (the stride between views in the buffer).
    per_view: u32,
}

/// The hidden-area stencil pipeline and each slot's vertices.
pub struct StencilMask {
    pipeline: vk::Pipeline,
    slots: Vec<HiddenSlot>,
}

impl StencilMask {
    /// The hidden-area pipeline for views drawn with `setup` (its samples,
    /// views and depth format): marks in depth or in stencil as `setup`
    /// says. The caller destroys it.
    pub fn pipeline(setup: &PipelineSetup) -> Result<vk::Pipeline> {
        let (vs, fs) = (shaders::HIDDEN_VERT.words(), shaders::HIDDEN_FRAG.words());
        // With `resolved-sky` the hidden area is marked covered (alpha 1
        // over the transparent clear) so the sky added after the resolve
        // leaves it black, as the sky in the scope does.
        let color_write = if setup.resolved_sky {
            vk::ColorComponentFlags::A
        } else if setup.mask_in_depth {
            vk::ColorComponentFlags::RGBA
        } else {
            vk::ColorComponentFlags::empty()
        };
        let desc = if setup.mask_in_depth {
            // At the near plane (reverse-Z depth 1), written always: every
            // later draw tests GREATER or GREATER_OR_EQUAL against it and
            // fails, as it would fail stencil = 0.
            GraphicsPipelineDesc {
                depth_test: true,
                depth_write: true,
                depth_compare: vk::CompareOp::ALWAYS,
                color_write,
                stencil: None,
                ..setup.fullscreen_desc("hidden-area depth", &vs, &fs)
            }
        } else {
            GraphicsPipelineDesc {
                depth_test: false,
                depth_write: false,
                color_write,
                stencil: Some(stencil_write(1)),
                ..setup.fullscreen_desc("hidden-area stencil", &vs, &fs)
            }
        };
        desc.build(setup.ctx)
    }

    /// Builds the pipeline and `slots` vertex buffers (room for
    /// [`MAX_HIDDEN_VERTICES`] per view).
    pub fn new(setup: &PipelineSetup, slots: usize) -> Result<StencilMask> {
        let mut made = StencilMask {
            pipeline: Self::pipeline(setup)?,
            slots: Vec::new(),
        };
        for i in 0..slots {
            let buffer = Buffer::new(
                setup.ctx,
                &BufferDesc {
                    name: &format!("hidden area {i}"),
                    size: (VIEWS * MAX_HIDDEN_VERTICES * 8) as u64,
                    usage: vk::BufferUsageFlags::STORAGE_BUFFER,
                    location: MemoryLocation::CpuToGpu,
                    category: "per-frame",
                },
            );
            match buffer {
                Ok(buffer) => made.slots.push(HiddenSlot {
                    buffer,
                    source: None,
                    per_view: 0,
                }),
                Err(e) => {
                    made.destroy(setup.ctx);
                    return Err(e);
                }
            }
        }
        Ok(made)
    }

    /// `slot`'s vertex buffer (for the descriptor set).
    pub fn buffer(&self, slot: usize) -> vk::Buffer {
        self.slots[slot].buffer.buffer
    }

    /// Writes `rig`'s hidden-area meshes (expanded to triangle lists) into
    /// `slot`'s buffer when they changed since that slot last saw them.
    pub fn upload(&mut self, slot: usize, rig: &StereoRig) -> Result<()> {
        let areas = rig.hidden_area.clone().ok_or_else(|| {
            Error::config(
                "--opt stencil-mask",
                "needs a hidden-area mesh (from the OpenXR runtime or the HMD profile)",
            )
        })?;
        let h = &mut self.slots[slot];
        if h.source
            .as_ref()
            .is_some_and(|s| Arc::ptr_eq(s, &areas) || **s == *areas)
        {
            return Ok(());
        }
        let lists: Vec<Vec<[f32; 2]>> = (0..VIEWS)
            .map(|v| {
                areas.get(v % 2).map_or(Vec::new(), |a| {
                    a.indices
                        .chunks_exact(3)
                        .filter(|t| t.iter().all(|&i| (i as usize) < a.vertices.len()))
                        .flatten()
                        .map(|&i| a.vertices[i as usize])
                        .collect()
                })
            })
            .collect();
        let per_view = lists.iter().map(Vec::len).max().unwrap_or(0);
        if per_view > MAX_HIDDEN_VERTICES {
            return Err(Error::config(
                "hidden-area mesh",
                format!("{per_view} vertices per view; at most {MAX_HIDDEN_VERTICES}"),
            ));
        }
        let mut data = vec![[0.0f32; 2]; VIEWS * per_view];
        for (v, list) in lists.iter().enumerate() {
            data[v * per_view..v * per_view + list.len()].copy_from_slice(list);
        }
        if !data.is_empty() {
            h.buffer.write(0, as_bytes(&data))?;
        }
        h.per_view = per_view as u32;
        h.source = Some(areas);
        Ok(())
    }

    /// Draws `slot`'s hidden area of view `eye` into stencil (or depth) inside the open
    /// scope (nothing when the meshes are empty). Returns the draw calls.
    pub fn record(&self, rec: &Recorder, slot: usize, eye: u32) -> u64 {
        self.record_using(rec, self.pipeline, slot, eye)
    }

    /// [`StencilMask::record`] with `pipeline`, one from
    /// [`StencilMask::pipeline`] for views of another sample count.
    pub fn record_using(
        &self,
        rec: &Recorder,
        pipeline: vk::Pipeline,
        slot: usize,
        eye: u32,
    ) -> u64 {
        let per_view = self.slots[slot].per_view;
        if per_view == 0 {
            return 0;
        }
        rec.bind(pipeline);
        rec.push_draw(per_view, eye);
        rec.draw(per_view);
        1
    }

    /// Destroys the pipeline and buffers; the device must be idle.
    pub fn destroy(self, ctx: &Context) {
        destroy_pipelines(ctx, [&self.pipeline]);
        for s in self.slots {
            s.buffer.destroy(ctx);
        }
    }
}

/// Builds the mask with `stencil-mask`.
pub fn build(b: &technique::Build) -> Result<Option<Box<dyn Technique>>> {
    if !b.config.effort.stencil_mask {
        return Ok(None);
    }
    Ok(Some(Box::new(StencilMask::new(b.setup, b.slots)?)))
}

impl Technique for StencilMask {
    fn name(&self) -> &'static str {
        "stencil-mask"
    }

    fn plan(&self, input: &mut PlanInput) {
        input.stencil_mask = true;
    }

    fn prepare(&mut self, p: &technique::Prepare, _: &mut FrameStats) -> Result<()> {
        self.upload(p.slot, p.rig)
    }

    fn bind(&self, slot: usize, _: Option<&Attachments>, set: &mut SetContents) {
        set.hidden = Some(self.buffer(slot));
    }

    /// Through each LMS quadrant's w scaling, as the scene is drawn.
    fn in_scope(&self, s: &ScopeHook) -> u64 {
        let lms = s.lms.filter(|_| s.quadrants > 1);
        let mut draw_calls = 0;
        for k in 0..s.quadrants {
            if let Some(l) = lms {
                l.set_quadrant(s.rec, Some(k));
            }
            draw_calls += match s.twins.and_then(|w| w.hidden) {
                Some(pipeline) => self.record_using(s.rec, pipeline, s.slot, s.eye),
                None => self.record(s.rec, s.slot, s.eye),
            };
        }
        if let Some(l) = lms {
            l.set_quadrant(s.rec, None);
        }
        draw_calls
    }

    fn destroy(self: Box<Self>, ctx: &Context) {
        StencilMask::destroy(*self, ctx);
    }
}
