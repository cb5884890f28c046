//! Temporal anti-aliasing of the inset's wide views (`inset-taa[=A]`; the
//! math and its sources are in [`crate::view::taa`], the shader is
//! `shaders/inset_taa.comp`).
//!
//! Each frame the wide scope is drawn with its depth kept and sampleable
//! (with `inset-taa-jitter`, its viewport moved by the frame's sub-pixel
//! jitter: [`InsetTaa::jitter`], through `Scope::jitter`). After the
//! scopes,
//! `inset-taa` (a compute dispatch per wide set and layer) reprojects each
//! wide pixel into the previous frame's wide view with its depth, reads
//! the history there, clamps it to the current neighbourhood and blends;
//! the result is this frame's history and what the composite reads as the
//! wide view ([`InsetTaa::infos`], layer [`InsetTaa::history_layer`]).
//!
//! With `inset-taau` (upsampling, [`crate::view::taau`],
//! `shaders/inset_taau.comp`) the history is at the eye's size instead,
//! the dispatch runs over eye pixels, and the jitter is always on: each
//! frame's wide samples are accumulated where they lie at the eye's
//! resolution, with the weight of the samples behind each pixel kept in
//! the history's alpha; the composite reads the history pixel for pixel.
//!
//! The history lives across frames, not per frame slot: one RGBA16F image
//! per wide set with two layers per eye, ping-ponged by frame parity
//! (read the previous frame's, write this frame's). Frames are recorded
//! and submitted in order on one queue, so the barriers at the start of
//! each frame's dispatch order it after the previous frame's writes and
//! reads of the same image, whatever the number of frames in flight.

use super::sampled::{pair, SampledSets};
use super::Recorder;
use crate::error::{Result, VkContext};
use crate::gpu::barrier::{self, Use};
use crate::gpu::memory::{Image, ImageDesc};
use crate::gpu::pipeline::{compute_pipeline, DescriptorSets};
use crate::gpu::query::Queries;
use crate::gpu::shaders;
use crate::gpu::Context;
use crate::view::View;
use ash::vk;
use std::sync::atomic::{AtomicU64, Ordering};

/// The history's format: linear colour in 16-bit float (8-bit steps would
/// stall an exponential average with α = 0.1 short of its target).
const HISTORY_FORMAT: vk::Format = vk::Format::R16G16B16A16_SFLOAT;

/// The shaders' push constants: the reprojection matrix (16 floats), then
/// size, set, layer, read layer, write layer, validity, α, the jitter (2
/// floats), and the eye size and the history filter (read by the
/// upsampling shader only).
const PUSH_WORDS: usize = 16 + 11;

/// What `inset-taa` and its variants ask of the pass.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TaaSettings {
    /// The blend weight α (`inset-taa=A`).
    pub alpha: f64,
    /// `inset-taa-jitter`: move the wide viewport by a sub-pixel offset
    /// each frame (`inset-taau` jitters whatever this says).
    pub jitter: bool,
    /// `inset-taau`: keep the history at the eyes' size.
    pub upsample: bool,
    /// `inset-taau-lanczos`: read the upsampled history through Lanczos-3
    /// ([`crate::view::lanczos`]) instead of Catmull-Rom.
    pub lanczos: bool,
}

/// What one frame's dispatch needs, set by [`InsetTaa::begin_frame`].
#[derive(Clone, Copy, Debug)]
struct FrameState {
    /// Per eye: the current view's (NDC, depth) to the previous view's
    /// clip coordinates.
    to_previous: [[f32; 16]; 2],
    /// Whether the previous frame's history may be read.
    valid: bool,
    /// The wide view's drawn size this frame.
    size: vk::Extent2D,
    /// This frame's history half (0 or 1).
    parity: u32,
    /// The wide viewport's offset this frame, pixels.
    jitter: [f32; 2],
    /// No frame has written the history yet: its layers are not in their
    /// layout.
    first: bool,
}

/// The history images, their views, the pass's pipeline and set, and the
/// frame-to-frame state.
pub struct InsetTaa {
    /// Per wide set: the history (2 × the set's layers).
    history: Vec<Image>,
    /// Per wide set: a depth-aspect view of its kept depth.
    depth_views: Vec<vk::ImageView>,
    /// Point sampling for the current frame's depth.
    nearest: vk::Sampler,
    /// Linear sampling for the history (the wide sets' sampler).
    linear: vk::Sampler,
    /// Layers per wide set (2 under multiview, else 1).
    layers: u32,
    alpha: f32,
    /// `inset-taa-jitter`: move the wide viewport by a sub-pixel offset
    /// each frame.
    jitter: bool,
    /// `inset-taau`: the eyes' size, at which the history is kept and
    /// written (None: at the wide view's).
    upsample: Option<vk::Extent2D>,
    /// `inset-taau-lanczos`: the upsampling shader reads the history
    /// through Lanczos-3.
    lanczos: bool,
    sets: DescriptorSets,
    pipeline: vk::Pipeline,
    /// The pass's barriers before its dispatches, in steady state and on
    /// the first frame (the history's contents discarded), and after.
    before: [Vec<vk::ImageMemoryBarrier2<'static>>; 2],
    after: Vec<vk::ImageMemoryBarrier2<'static>>,
    /// Frames begun so far (the jitter phase and the history parity).
    frame: u64,
    /// The previous frame's eye views and wide size.
    previous: Option<([View; 2], vk::Extent2D)>,
    /// The last begun frame whose dispatch was recorded (a frame without
    /// one, the bench's empty-frame floor, leaves no history to read).
    /// Stored as the frame's index + 1, 0 for none (an atomic: the
    /// renderer's passes are shared with its recording threads).
    written: AtomicU64,
    state: FrameState,
}

impl InsetTaa {
    /// The pass for `wide`'s sets (made with their depth kept) with
    /// `settings`; with `settings.upsample` the history is kept at `eyes`,
    /// the eyes' size. On failure, destroys what it made.
    pub fn new(
        ctx: &Context,
        wide: &SampledSets,
        settings: TaaSettings,
        eyes: vk::Extent2D,
    ) -> Result<InsetTaa> {
        let upsample = settings.upsample.then_some(eyes);
        let layers = wide.sets.first().map_or(1, |s| s.resolve.layers);
        let stage = vk::ShaderStageFlags::COMPUTE;
        let sets = DescriptorSets::new(
            ctx,
            &[
                (vk::DescriptorType::COMBINED_IMAGE_SAMPLER, 2, stage),
                (vk::DescriptorType::COMBINED_IMAGE_SAMPLER, 2, stage),
                (vk::DescriptorType::COMBINED_IMAGE_SAMPLER, 2, stage),
                (vk::DescriptorType::STORAGE_IMAGE, 2, stage),
            ],
            stage,
            (PUSH_WORDS * 4) as u32,
            1,
            "inset TAA",
        )?;
        let mut made = InsetTaa {
            history: Vec::new(),
            depth_views: Vec::new(),
            nearest: vk::Sampler::null(),
            linear: wide.sampler(),
            layers,
            alpha: settings.alpha as f32,
            jitter: settings.jitter || settings.upsample,
            upsample,
            lanczos: settings.lanczos,
            sets,
            pipeline: vk::Pipeline::null(),
            before: [Vec::new(), Vec::new()],
            after: Vec::new(),
            frame: 0,
            previous: None,
            written: AtomicU64::new(0),
            state: FrameState {
                to_previous: [[0.0; 16]; 2],
                valid: false,
                size: wide.extent,
                parity: 0,
                jitter: [0.0; 2],
                first: true,
            },
        };
        match made.finish(ctx, wide) {
            Ok(()) => Ok(made),
            Err(e) => {
                made.destroy(ctx);
                Err(e)
            }
        }
    }

    fn finish(&mut self, ctx: &Context, wide: &SampledSets) -> Result<()> {
        for set in &wide.sets {
            let Some(depth) = set.depth_output() else {
                return Err(crate::error::Error::Gpu(
                    "inset-taa's wide views keep no depth to reproject with".into(),
                ));
            };
            self.depth_views.push(Image::make_view(
                ctx,
                depth.image,
                depth.format,
                vk::ImageAspectFlags::DEPTH,
                vk::ImageViewType::TYPE_2D_ARRAY,
                0,
                depth.layers,
                1,
            )?);
            self.history.push(Image::new(
                ctx,
                &ImageDesc {
                    name: "inset TAA history",
                    format: HISTORY_FORMAT,
                    extent: self.upsample.unwrap_or(wide.extent),
                    layers: 2 * set.resolve.layers,
                    mips: 1,
                    samples: vk::SampleCountFlags::TYPE_1,
                    usage: vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::SAMPLED,
                    aspect: vk::ImageAspectFlags::COLOR,
                    category: "render target",
                    flags: vk::ImageCreateFlags::empty(),
                },
            )?);
        }
        let info = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::NEAREST)
            .min_filter(vk::Filter::NEAREST)
            .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE);
        // SAFETY: plain object creation; destroyed by `destroy`.
        self.nearest = unsafe { ctx.device.create_sampler(&info, None) }
            .vk("creating the inset TAA's sampler")?;
        let module = match self.upsample {
            Some(_) => &shaders::INSET_TAAU_COMP,
            None => &shaders::INSET_TAA_COMP,
        };
        self.pipeline = compute_pipeline(ctx, self.sets.layout, &module.words(), "inset TAA")?;
        let Some(colour) = wide.infos() else {
            return Err(crate::error::Error::Gpu(
                "inset-taa has no wide view to accumulate".into(),
            ));
        };
        self.write_set(ctx, colour);
        self.make_barriers(wide);
        Ok(())
    }

    /// The barriers of every frame: the wide sets' resolved colour and
    /// kept depth to compute reads; the history to read and write (the
    /// previous frame wrote one half and the one before the other: this
    /// frame reads the first and overwrites the second), and after the
    /// dispatches to the composite's reads.
    fn make_barriers(&mut self, wide: &SampledSets) {
        let colour = vk::ImageAspectFlags::COLOR;
        let written = Use {
            layout: vk::ImageLayout::GENERAL,
            stage: vk::PipelineStageFlags2::COMPUTE_SHADER,
            access: vk::AccessFlags2::SHADER_STORAGE_WRITE,
        };
        let read_write = Use {
            access: vk::AccessFlags2::SHADER_STORAGE_WRITE | vk::AccessFlags2::SHADER_SAMPLED_READ,
            ..written
        };
        for (first, before) in self.before.iter_mut().enumerate() {
            for (set, history) in wide.sets.iter().zip(&self.history) {
                before.push(barrier::image(
                    set.resolve.image,
                    colour,
                    set.resolve.layers,
                    Use::COLOR_ATTACHMENT,
                    Use::COMPUTE_SAMPLED,
                ));
                if let Some(depth) = set.depth_output() {
                    before.push(barrier::image(
                        depth.image,
                        crate::gpu::depth_aspect(depth.format),
                        depth.layers,
                        Use::DEPTH_OUTPUT,
                        Use::DEPTH_COMPUTE_READ,
                    ));
                }
                let from = match first {
                    1 => written.discarded(),
                    _ => written,
                };
                before.push(barrier::image(
                    history.image,
                    colour,
                    history.layers,
                    from,
                    read_write,
                ));
            }
        }
        let sampled = Use {
            layout: vk::ImageLayout::GENERAL,
            ..Use::COMPUTE_SAMPLED
        };
        self.after = self
            .history
            .iter()
            .map(|h| barrier::image(h.image, colour, h.layers, written, sampled))
            .collect();
    }

    /// Writes the one descriptor set: per wide set its colour (`colour`,
    /// the wide sets' own descriptors) and depth (point-sampled), its
    /// history (linear, for reading) and the same history as storage; the
    /// second element repeats the first under multiview.
    fn write_set(&self, ctx: &Context, colour: [vk::DescriptorImageInfo; 2]) {
        let general = vk::ImageLayout::GENERAL;
        let depth = pair(
            &self.depth_views,
            self.nearest,
            vk::ImageLayout::DEPTH_STENCIL_READ_ONLY_OPTIMAL,
        );
        let history_views: Vec<vk::ImageView> = self.history.iter().map(|h| h.view).collect();
        let storage = pair(&history_views, vk::Sampler::null(), general);
        let sampler = vk::DescriptorType::COMBINED_IMAGE_SAMPLER;
        // No frame has used the set yet.
        self.sets.write_images(
            ctx,
            0,
            &[
                (0, sampler, &colour),
                (1, sampler, &depth),
                (2, sampler, &self.infos()),
                (3, vk::DescriptorType::STORAGE_IMAGE, &storage),
            ],
        );
    }

    /// Starts a frame whose eyes are `views` (unjittered) with the wide
    /// view drawn at `size`: the jitter phase and history half advance,
    /// and each eye's map from this frame's wide pixels to the previous
    /// frame's is computed (`near` the projection's near plane). The
    /// history is not read on the first frame, after a frame that wrote
    /// none, nor after the wide view's size changed.
    pub fn begin_frame(&mut self, views: [View; 2], near: f64, size: vk::Extent2D) {
        let j = match self.jitter {
            true => crate::view::taa::jitter(self.frame),
            false => [0.0; 2],
        };
        let mut to_previous = [[0.0; 16]; 2];
        let last = self.frame.checked_sub(1);
        let written = self.written.load(Ordering::Relaxed).checked_sub(1);
        let valid = match &self.previous {
            Some((old, old_size)) if *old_size == size && written == last && last.is_some() => {
                for (eye, m) in to_previous.iter_mut().enumerate() {
                    let r = crate::view::reproject::reprojection(&views[eye], &old[eye], near);
                    *m = r.as_mat4().to_cols_array();
                }
                true
            }
            _ => false,
        };
        self.state = FrameState {
            to_previous,
            valid,
            size,
            parity: (self.frame % 2) as u32,
            jitter: [j[0] as f32, j[1] as f32],
            first: written.is_none(),
        };
        self.previous = Some((views, size));
        self.frame += 1;
    }

    /// Whether the history is at the eyes' size (`inset-taau`): the
    /// composite reads it pixel for pixel.
    pub fn upsamples(&self) -> bool {
        self.upsample.is_some()
    }

    /// This frame's sub-pixel offset of the wide views' viewport.
    pub fn jitter(&self) -> [f32; 2] {
        self.state.jitter
    }

    /// The history layer holding a wide set's layer 0 after this frame's
    /// dispatch (the composite adds the eye's layer).
    pub fn history_layer(&self) -> u32 {
        self.state.parity * self.layers
    }

    /// The histories as the composite reads them (linear sampler,
    /// general layout), one per attachment set, the second repeating the
    /// first under multiview.
    pub fn infos(&self) -> [vk::DescriptorImageInfo; 2] {
        let views: Vec<vk::ImageView> = self.history.iter().map(|h| h.view).collect();
        pair(&views, self.linear, vk::ImageLayout::GENERAL)
    }

    /// After the wide scopes: makes the wide sets' resolved colour and
    /// kept depth readable, writes this frame's history for every set and
    /// layer, and makes it readable by the composite (the barriers made
    /// once by [`InsetTaa::new`]).
    pub fn record(&self, rec: &Recorder, q: &mut Queries) {
        let s = &self.state;
        q.begin_pass(rec.ctx, rec.cmd, "inset-taa");
        rec.barriers(&self.before[usize::from(s.first)]);
        rec.bind_compute(self.pipeline, &self.sets);
        for set in 0..self.history.len() as u32 {
            for layer in 0..self.layers {
                // Two-pass: set i is eye i; multiview: layer i is.
                let eye = (set + layer) as usize % 2;
                let mut push = [0u32; PUSH_WORDS];
                for (w, v) in push.iter_mut().zip(s.to_previous[eye]) {
                    *w = v.to_bits();
                }
                let parity_layer = |p: u32| p * self.layers + layer;
                let out = self.upsample.unwrap_or(s.size);
                push[16..].copy_from_slice(&[
                    s.size.width | s.size.height << 16,
                    set,
                    layer,
                    parity_layer(1 - s.parity),
                    parity_layer(s.parity),
                    s.valid as u32,
                    self.alpha.to_bits(),
                    s.jitter[0].to_bits(),
                    s.jitter[1].to_bits(),
                    out.width | out.height << 16,
                    self.lanczos as u32,
                ]);
                let groups = [out.width.div_ceil(8), out.height.div_ceil(8), 1];
                rec.dispatch(self.sets.layout, &push, groups);
            }
        }
        rec.barriers(&self.after);
        q.end_pass(rec.ctx, rec.cmd);
        self.written.store(self.frame, Ordering::Relaxed);
    }

    /// Destroys the history, views, sampler, pipeline and set; the device
    /// must be idle. The linear sampler belongs to the wide sets.
    pub fn destroy(self, ctx: &Context) {
        // SAFETY: the device is idle; these objects belong to `self`.
        unsafe {
            if self.pipeline != vk::Pipeline::null() {
                ctx.device.destroy_pipeline(self.pipeline, None);
            }
            if self.nearest != vk::Sampler::null() {
                ctx.device.destroy_sampler(self.nearest, None);
            }
            for v in &self.depth_views {
                ctx.device.destroy_image_view(*v, None);
            }
        }
        for h in self.history {
            h.destroy(ctx);
        }
        self.sets.destroy(ctx);
    }
}
