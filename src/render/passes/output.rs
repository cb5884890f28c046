//! Where a finished frame goes after the passes: copied into the images of
//! an output (an OpenXR session's swapchains: a copy in the renderer's own
//! colour format, a blit otherwise; depth copied too when the output takes
//! it), and read back into host memory for [`Readback::images`] (from the
//! output's images when there is one, so what is read is what was
//! delivered).

use crate::error::{Error, Result};
use crate::gpu::barrier::{self, Use};
use crate::gpu::memory::{Buffer, BufferDesc};
use crate::gpu::ring::{FrameRing, Garbage};
use crate::gpu::Context;
use crate::render::attachments::{Attachments, COLOR_FORMAT};
use crate::view::inset::PixelRect;
use ash::vk;
use gpu_allocator::MemoryLocation;

/// What a frame is delivered to besides the renderer's own targets (an
/// OpenXR session's swapchains), fixed when the renderer is created.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OutputSpec {
    /// Format of the colour images (copied when it is the renderer's own
    /// format, blitted otherwise).
    pub color_format: vk::Format,
    /// Whether depth images receive the frame's depth (same format as the
    /// renderer's depth).
    pub depth: bool,
    /// With `inset`: the four views go out as they are, for a runtime that
    /// composites them (`XR_VARJO_quad_views`): the wide views into
    /// [`FrameOutput::color`], the insets into [`FrameOutput::inset`], and
    /// the renderer does not composite.
    pub quad: bool,
}

/// The images one frame is copied into: one per attachment set (a 2-layer
/// image under multiview, one image per eye in two-pass). Colour images
/// arrive and are left in COLOR_ATTACHMENT_OPTIMAL, depth images in
/// DEPTH_STENCIL_ATTACHMENT_OPTIMAL, as XR_KHR_vulkan_enable2 requires.
#[derive(Clone, Debug, Default)]
pub struct FrameOutput {
    /// Colour images, per set.
    pub color: Vec<vk::Image>,
    /// Depth images, per set (empty without a depth output).
    pub depth: Vec<vk::Image>,
    /// With a quad output: the insets' images, per set (each inset at the
    /// top left).
    pub inset: Vec<vk::Image>,
}

/// Where a quad output's views lie in the renderer's images this frame.
#[derive(Clone, Debug)]
pub struct QuadSource {
    /// Per attachment set: the image holding the wide views, the layer of
    /// the first, and the image's layers.
    pub wide: Vec<(vk::Image, u32, u32)>,
    /// The wide views' region of that image.
    pub region: PixelRect,
    /// The inset rectangle of the eyes' resolve images.
    pub rect: PixelRect,
}

/// The copy of each frame into an output's images.
pub struct OutputCopy {
    spec: OutputSpec,
}

impl OutputCopy {
    /// The copy into outputs of `spec`.
    pub fn new(spec: OutputSpec) -> OutputCopy {
        OutputCopy { spec }
    }

    /// Copies the resolved colour (and depth) of every set of `targets`
    /// (`extent` pixels per eye) into `out`'s images, leaving them in the
    /// attachment layouts the runtime expects. Recorded after the passes.
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        targets: &Attachments,
        extent: vk::Extent2D,
        out: &FrameOutput,
    ) -> Result<()> {
        let spec = self.spec;
        if out.color.len() != targets.sets.len()
            || (spec.depth && out.depth.len() != targets.sets.len())
        {
            return Err(Error::Gpu(format!(
                "frame output has {} colour / {} depth images for {} attachment sets",
                out.color.len(),
                out.depth.len(),
                targets.sets.len()
            )));
        }
        let d = &ctx.device;
        let (w, h) = (extent.width, extent.height);
        let barrier = barrier::image;
        let color_out = Use::COLOR_ATTACHMENT;
        let depth_out = Use::DEPTH_OUTPUT;
        let (src, dst) = (Use::TRANSFER_SRC, Use::TRANSFER_DST);
        let mut before = Vec::new();
        let mut after = Vec::new();
        for (i, set) in targets.sets.iter().enumerate() {
            let layers = set.output_image().layers;
            let c = vk::ImageAspectFlags::COLOR;
            before.push(barrier(set.output_image().image, c, layers, color_out, src));
            before.push(barrier(out.color[i], c, layers, color_out.discarded(), dst));
            after.push(barrier(out.color[i], c, layers, dst, color_out));
            if let (true, Some(depth)) = (spec.depth, set.depth_output()) {
                // The renderer keeps the depth-stencil format when its
                // depth goes out, so both images share these aspects.
                let ds = crate::gpu::depth_aspect(depth.format);
                before.push(barrier(depth.image, ds, layers, depth_out, src));
                before.push(barrier(
                    out.depth[i],
                    ds,
                    layers,
                    depth_out.discarded(),
                    dst,
                ));
                after.push(barrier(out.depth[i], ds, layers, dst, depth_out));
            }
        }
        // SAFETY: recording after the rendering scopes into the open command
        // buffer; the output images belong to the session and are acquired.
        unsafe {
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().image_memory_barriers(&before),
            );
            for (i, set) in targets.sets.iter().enumerate() {
                let layers = set.output_image().layers;
                let sub = |aspect| vk::ImageSubresourceLayers {
                    aspect_mask: aspect,
                    mip_level: 0,
                    base_array_layer: 0,
                    layer_count: layers,
                };
                let extent = vk::Extent3D {
                    width: w,
                    height: h,
                    depth: 1,
                };
                let whole = PixelRect {
                    x0: 0,
                    y0: 0,
                    x1: w,
                    y1: h,
                };
                let source = (set.output_image().image, 0, layers);
                self.copy_color(d, cmd, source, &whole, out.color[i]);
                if let (true, Some(depth)) = (spec.depth, set.depth_output()) {
                    let region = vk::ImageCopy::default()
                        .src_subresource(sub(vk::ImageAspectFlags::DEPTH))
                        .dst_subresource(sub(vk::ImageAspectFlags::DEPTH))
                        .extent(extent);
                    d.cmd_copy_image(
                        cmd,
                        depth.image,
                        src.layout,
                        out.depth[i],
                        dst.layout,
                        &[region],
                    );
                }
            }
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().image_memory_barriers(&after),
            );
        }
        Ok(())
    }
}

impl OutputCopy {
    /// Copies (in the renderer's own format) or blits (into another)
    /// `layers` layers of `src` from its layer `first`, rectangle `r`, to
    /// the top left of `dst`'s first layers; both images in the transfer
    /// layouts.
    fn copy_color(
        &self,
        d: &ash::Device,
        cmd: vk::CommandBuffer,
        (src, first, layers): (vk::Image, u32, u32),
        r: &PixelRect,
        dst: vk::Image,
    ) {
        let sub = |base| vk::ImageSubresourceLayers {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            mip_level: 0,
            base_array_layer: base,
            layer_count: layers,
        };
        let at = |x: u32, y: u32, z: i32| vk::Offset3D {
            x: x as i32,
            y: y as i32,
            z,
        };
        let (from, to) = (Use::TRANSFER_SRC.layout, Use::TRANSFER_DST.layout);
        // SAFETY: recording into the open command buffer; both images are
        // in the transfer layouts (the caller's barriers) and the region
        // lies inside both.
        unsafe {
            if self.spec.color_format == COLOR_FORMAT {
                let region = vk::ImageCopy::default()
                    .src_subresource(sub(first))
                    .src_offset(at(r.x0, r.y0, 0))
                    .dst_subresource(sub(0))
                    .extent(vk::Extent3D {
                        width: r.width(),
                        height: r.height(),
                        depth: 1,
                    });
                d.cmd_copy_image(cmd, src, from, dst, to, &[region]);
            } else {
                let region = vk::ImageBlit::default()
                    .src_subresource(sub(first))
                    .dst_subresource(sub(0))
                    .src_offsets([at(r.x0, r.y0, 0), at(r.x1, r.y1, 1)])
                    .dst_offsets([at(0, 0, 0), at(r.width(), r.height(), 1)]);
                d.cmd_blit_image(cmd, src, from, dst, to, &[region], vk::Filter::NEAREST);
            }
        }
    }

    /// A quad output's copies: per set, the wide views from `src.region`
    /// of their image into `out.color` and the insets from `src.rect` of
    /// `targets`' resolve images into `out.inset`, each at the top left,
    /// the output images left in the attachment layout the runtime
    /// expects. `layers` is the eyes' layers per set (2 under multiview,
    /// else 1). Recorded after the passes, instead of [`OutputCopy::record`].
    pub fn record_quad(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        targets: &Attachments,
        src: &QuadSource,
        out: &FrameOutput,
    ) -> Result<()> {
        let n = targets.sets.len();
        if out.color.len() != n || out.inset.len() != n || src.wide.len() != n {
            return Err(Error::Gpu(format!(
                "quad output has {} wide / {} inset images for {} attachment sets",
                out.color.len(),
                out.inset.len(),
                n
            )));
        }
        let c = vk::ImageAspectFlags::COLOR;
        let (color_out, from, to) = (Use::COLOR_ATTACHMENT, Use::TRANSFER_SRC, Use::TRANSFER_DST);
        // Each source image once (with four views the wide views are
        // layers of the eyes' own image).
        let mut sources: Vec<(vk::Image, u32)> = Vec::new();
        for (set, &(wide, _, wide_layers)) in targets.sets.iter().zip(&src.wide) {
            for img in [(set.resolve.image, set.resolve.layers), (wide, wide_layers)] {
                if !sources.iter().any(|s| s.0 == img.0) {
                    sources.push(img);
                }
            }
        }
        let mut before: Vec<_> = sources
            .iter()
            .map(|&(img, layers)| barrier::image(img, c, layers, color_out, from))
            .collect();
        let mut after = Vec::new();
        // The eyes' layers (with four views the resolve has 4: the wide
        // views are layers 2 and 3).
        let eyes = |i: usize| targets.sets[i].resolve.layers.min(2);
        for i in 0..n {
            for dst in [out.color[i], out.inset[i]] {
                before.push(barrier::image(dst, c, eyes(i), color_out.discarded(), to));
                after.push(barrier::image(dst, c, eyes(i), to, color_out));
            }
        }
        let d = &ctx.device;
        // SAFETY: recording after the rendering scopes into the open
        // command buffer; the output images belong to the session and are
        // acquired.
        unsafe {
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().image_memory_barriers(&before),
            );
        }
        for (i, set) in targets.sets.iter().enumerate() {
            let (wide, first, _) = src.wide[i];
            self.copy_color(d, cmd, (wide, first, eyes(i)), &src.region, out.color[i]);
            self.copy_color(
                d,
                cmd,
                (set.resolve.image, 0, eyes(i)),
                &src.rect,
                out.inset[i],
            );
        }
        // SAFETY: as above.
        unsafe {
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().image_memory_barriers(&after),
            );
        }
        Ok(())
    }
}

/// The host-visible buffer frames are read back into (grown on demand).
#[derive(Default)]
pub struct Readback {
    buffer: Option<Buffer>,
    /// Whether the last read-back frame's depth follows its colours.
    depth: bool,
    /// The last read-back frame's size per eye.
    extent: vk::Extent2D,
    /// With a quad output: the last read-back frame's wide view and inset
    /// sizes.
    quad: Option<(vk::Extent2D, vk::Extent2D)>,
}

impl Readback {
    /// No buffer until the first read-back.
    pub fn new() -> Readback {
        Readback::default()
    }

    /// The last read-back frame's size per eye.
    pub fn extent(&self) -> vk::Extent2D {
        self.extent
    }

    /// The buffer, grown to `size` bytes when smaller (the old one handed
    /// to `ring` for deferred destruction).
    fn ensure(&mut self, ctx: &Context, ring: &mut FrameRing, size: u64) -> Result<vk::Buffer> {
        if self.buffer.as_ref().is_none_or(|b| b.size < size) {
            if let Some(old) = self.buffer.take() {
                ring.defer(Garbage::Buffer(old));
            }
            self.buffer = Some(Buffer::new(
                ctx,
                &BufferDesc {
                    name: "readback",
                    size,
                    usage: vk::BufferUsageFlags::TRANSFER_DST,
                    location: MemoryLocation::GpuToCpu,
                    category: "readback",
                },
            )?);
        }
        Ok(self.buffer.as_ref().expect("made above").buffer)
    }

    /// Copies the frame (both eyes, RGBA8, left then right, `extent` per
    /// eye) into the buffer, from `output`'s colour images when given, else
    /// from `targets`' own. The buffer is sized for `capacity` per eye (the
    /// targets' size), so a frame rendered smaller (`aq`) reuses it; an old
    /// buffer too small is handed to `ring` for deferred destruction.
    pub fn record(
        &mut self,
        ctx: &Context,
        ring: &mut FrameRing,
        cmd: vk::CommandBuffer,
        targets: &Attachments,
        (extent, capacity): (vk::Extent2D, vk::Extent2D),
        output: Option<&FrameOutput>,
    ) -> Result<()> {
        let (w, h) = (extent.width as u64, extent.height as u64);
        self.extent = extent;
        self.quad = None;
        // Headless frames whose depth is kept also read it back, after the
        // colours (4 bytes a texel for both depth formats).
        let depth = output.is_none() && targets.sets.iter().all(|s| s.depth_output().is_some());
        let (cw, ch) = (
            capacity.width.max(extent.width) as u64,
            capacity.height.max(extent.height) as u64,
        );
        let size = cw * ch * 4 * 2 * if depth { 2 } else { 1 };
        let buf = self.ensure(ctx, ring, size)?;
        let mut to_src = Vec::new();
        let mut copies = Vec::new();
        let mut back = Vec::new();
        let mut offset = 0u64;
        for (i, set) in targets.sets.iter().enumerate() {
            let layers = set.output_image().layers;
            // The frame was last written by the output copy (swapchain
            // image) or by rendering (own image); both end in the colour
            // attachment layout.
            let (image, src_access) = match output.and_then(|o| o.color.get(i)) {
                Some(&img) => (img, vk::AccessFlags2::TRANSFER_WRITE),
                None => (
                    set.output_image().image,
                    vk::AccessFlags2::COLOR_ATTACHMENT_WRITE,
                ),
            };
            let written = Use {
                layout: vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
                stage: vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT
                    | vk::PipelineStageFlags2::ALL_TRANSFER,
                access: src_access,
            };
            let read = Use {
                layout: vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                stage: vk::PipelineStageFlags2::COPY,
                access: vk::AccessFlags2::TRANSFER_READ,
            };
            let c = vk::ImageAspectFlags::COLOR;
            to_src.push(barrier::image(image, c, layers, written, read));
            if output.is_some() {
                let done = Use {
                    access: vk::AccessFlags2::NONE,
                    ..read
                };
                let handed_back = Use {
                    access: vk::AccessFlags2::NONE,
                    ..Use::COLOR_ATTACHMENT
                };
                back.push(barrier::image(image, c, layers, done, handed_back));
            }
            let copy = barrier::color_copy(offset, layers, w as u32, h as u32);
            copies.push((image, copy));
            offset += w * h * 4 * layers as u64;
        }
        self.depth = depth;
        if depth {
            // Written by the depth tests (kept depth at 1 sample) or by the
            // depth resolve, which runs in the colour-output stage with
            // colour-attachment writes.
            let rendered = Use {
                layout: vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
                stage: vk::PipelineStageFlags2::EARLY_FRAGMENT_TESTS
                    | vk::PipelineStageFlags2::LATE_FRAGMENT_TESTS
                    | vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT,
                access: vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE
                    | vk::AccessFlags2::COLOR_ATTACHMENT_WRITE,
            };
            let read = Use {
                layout: vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                stage: vk::PipelineStageFlags2::COPY,
                access: vk::AccessFlags2::TRANSFER_READ,
            };
            for set in &targets.sets {
                let img = set.depth_output().expect("checked above");
                let ds = crate::gpu::depth_aspect(img.format);
                let layers = set.output_image().layers;
                to_src.push(barrier::image(img.image, ds, layers, rendered, read));
                let done = Use {
                    access: vk::AccessFlags2::NONE,
                    ..read
                };
                let again = Use {
                    access: vk::AccessFlags2::NONE,
                    ..rendered
                };
                back.push(barrier::image(img.image, ds, layers, done, again));
                let mut copy = barrier::color_copy(offset, layers, w as u32, h as u32);
                copy.image_subresource.aspect_mask = vk::ImageAspectFlags::DEPTH;
                copies.push((img.image, copy));
                offset += w * h * 4 * layers as u64;
            }
        }
        record_copies(&ctx.device, cmd, buf, (&to_src, &back), copies);
        Ok(())
    }

    /// Copies a quad output's four views (RGBA8: the wide views, left then
    /// right, at `wide` pixels, then the insets at `inset`) from `out`'s
    /// images into the buffer, grown when they do not fit (the old one
    /// handed to `ring`); the images are left as the output copy left them.
    pub fn record_quad(
        &mut self,
        ctx: &Context,
        ring: &mut FrameRing,
        cmd: vk::CommandBuffer,
        out: &FrameOutput,
        (wide, inset): (vk::Extent2D, vk::Extent2D),
    ) -> Result<()> {
        let per_image = (2 / out.color.len().max(1)) as u32;
        let texels = |e: vk::Extent2D| e.width as u64 * e.height as u64;
        let size = (texels(wide) + texels(inset)) * 4 * 2;
        let buf = self.ensure(ctx, ring, size)?;
        self.quad = Some((wide, inset));
        self.depth = false;
        let c = vk::ImageAspectFlags::COLOR;
        // Written by the output copy, whose last barrier handed the image
        // on to the colour-attachment stage: the chain continues there.
        let written = Use {
            layout: vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
            stage: vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT
                | vk::PipelineStageFlags2::ALL_TRANSFER,
            access: vk::AccessFlags2::TRANSFER_WRITE,
        };
        let read = Use {
            layout: vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
            stage: vk::PipelineStageFlags2::COPY,
            access: vk::AccessFlags2::TRANSFER_READ,
        };
        let back_to = Use {
            access: vk::AccessFlags2::NONE,
            ..Use::COLOR_ATTACHMENT
        };
        let done = Use {
            access: vk::AccessFlags2::NONE,
            ..read
        };
        let mut to_src = Vec::new();
        let mut back = Vec::new();
        let mut copies = Vec::new();
        let mut offset = 0u64;
        for (images, e) in [(&out.color, wide), (&out.inset, inset)] {
            for &img in images {
                to_src.push(barrier::image(img, c, per_image, written, read));
                back.push(barrier::image(img, c, per_image, done, back_to));
                copies.push((
                    img,
                    barrier::color_copy(offset, per_image, e.width, e.height),
                ));
                offset += texels(e) * 4 * per_image as u64;
            }
        }
        record_copies(&ctx.device, cmd, buf, (&to_src, &back), copies);
        Ok(())
    }

    /// The last read-back quad frame as four RGBA8 (sRGB) images: the
    /// wide views left and right, then the insets left and right.
    pub fn quad_images(&mut self) -> Result<[image::RgbaImage; 4]> {
        let (wide, inset) = self
            .quad
            .ok_or_else(|| Error::Gpu("no quad frame was read back".into()))?;
        let data = self
            .buffer
            .as_mut()
            .and_then(|b| b.mapped())
            .ok_or_else(|| Error::Gpu("no frame was read back".into()))?;
        let mut at = 0usize;
        let mut take = |e: vk::Extent2D| {
            let n = (e.width * e.height * 4) as usize;
            let img = data
                .get(at..at + n)
                .and_then(|b| image::RgbaImage::from_raw(e.width, e.height, b.to_vec()));
            at += n;
            img.ok_or_else(|| Error::Gpu("readback buffer too small".into()))
        };
        Ok([take(wide)?, take(wide)?, take(inset)?, take(inset)?])
    }

    /// The last read-back frame of `extent` pixels per eye as two RGBA8
    /// (sRGB) images, left then right.
    pub fn images(&mut self, extent: vk::Extent2D) -> Result<[image::RgbaImage; 2]> {
        let (w, h) = (extent.width, extent.height);
        let layer = (w * h * 4) as usize;
        let buf = self
            .buffer
            .as_mut()
            .ok_or_else(|| Error::Gpu("no frame was read back".into()))?;
        let data = buf
            .mapped()
            .ok_or_else(|| Error::Gpu("readback buffer is not mapped".into()))?;
        let left = image::RgbaImage::from_raw(w, h, data[..layer].to_vec());
        let right = image::RgbaImage::from_raw(w, h, data[layer..2 * layer].to_vec());
        match (left, right) {
            (Some(l), Some(r)) => Ok([l, r]),
            _ => Err(Error::Gpu("readback buffer too small".into())),
        }
    }

    /// The depth of the last read-back frame per eye (left, right), as
    /// reverse-Z values in [0, 1], when the renderer kept its depth
    /// (`format` is the depth-stencil format: D32 depth reads as floats,
    /// D24 as the low 24 bits of each texel).
    pub fn depth(&mut self, extent: vk::Extent2D, format: vk::Format) -> Result<[Vec<f32>; 2]> {
        if !self.depth {
            return Err(Error::Gpu("the frame's depth was not read back".into()));
        }
        let layer = (extent.width * extent.height) as usize;
        let data = self
            .buffer
            .as_mut()
            .and_then(|b| b.mapped())
            .ok_or_else(|| Error::Gpu("no frame was read back".into()))?;
        let start = layer * 4 * 2;
        let words = data
            .get(start..start + layer * 4 * 2)
            .ok_or_else(|| Error::Gpu("readback buffer too small".into()))?;
        let value = |c: &[u8]| {
            let bits = u32::from_le_bytes([c[0], c[1], c[2], c[3]]);
            if format == vk::Format::D24_UNORM_S8_UINT {
                (bits & 0x00FF_FFFF) as f32 / 16_777_215.0
            } else {
                f32::from_bits(bits)
            }
        };
        let eye = |i: usize| -> Vec<f32> {
            words[i * layer * 4..(i + 1) * layer * 4]
                .chunks_exact(4)
                .map(value)
                .collect()
        };
        Ok([eye(0), eye(1)])
    }

    /// Destroys the buffer; the device must be idle.
    pub fn destroy(self, ctx: &Context) {
        if let Some(b) = self.buffer {
            b.destroy(ctx);
        }
    }
}

/// Records a read-back's copies into `buf`: the images' barriers to
/// transfer source (`to_src`), the copies, then the buffer made readable
/// by the host and the images handed back (`back`).
fn record_copies(
    d: &ash::Device,
    cmd: vk::CommandBuffer,
    buf: vk::Buffer,
    (to_src, back): (&[vk::ImageMemoryBarrier2], &[vk::ImageMemoryBarrier2]),
    copies: Vec<(vk::Image, vk::BufferImageCopy)>,
) {
    let to_host = [crate::gpu::barrier::buffer_to_host(buf)];
    // SAFETY: recording into the open command buffer after the images were
    // written; the caller sized `buf` for every copy.
    unsafe {
        d.cmd_pipeline_barrier2(
            cmd,
            &vk::DependencyInfo::default().image_memory_barriers(to_src),
        );
        for (image, copy) in copies {
            d.cmd_copy_image_to_buffer(
                cmd,
                image,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                buf,
                &[copy],
            );
        }
        d.cmd_pipeline_barrier2(
            cmd,
            &vk::DependencyInfo::default()
                .buffer_memory_barriers(&to_host)
                .image_memory_barriers(back),
        );
    }
}
