//! A scene's GPU resources: vertex streams (only those the scene uses),
//! indices, per-instance transforms, materials and textures. Uploaded once at
//! load through staging buffers.

use crate::error::{Result, VkContext};
use crate::gpu::barrier::{self, Use};
use crate::gpu::memory::{Buffer, BufferDesc, Image, ImageDesc};
use crate::gpu::Context;
use crate::scene::lod::Chains;
use crate::scene::{AlphaMode, Scene, SceneFeatures};
use ash::vk;
use glam::{DAffine3, DVec3};
use gpu_allocator::MemoryLocation;

/// Per-primitive draw parameters.
#[derive(Clone, Copy, Debug)]
pub struct DrawRange {
    /// First index in the shared index buffer.
    pub first_index: u32,
    /// Index count.
    pub index_count: u32,
    /// Offset added to indices (first vertex in the shared streams).
    pub vertex_offset: i32,
    /// Material index.
    pub material: u32,
}

/// Vertex stream slots, in shader location order.
pub const STREAMS: [(&str, u32); 6] = [
    ("position", 12),
    ("normal", 12),
    ("tangent", 16),
    ("uv0", 8),
    ("uv1", 8),
    ("color", 16),
];

/// Which of [`STREAMS`] a scene with `f` needs; the others are bound to the
/// defaults buffer at stride 0.
pub fn used_streams(f: &SceneFeatures) -> [bool; 6] {
    [true, true, f.tangents, f.uv0 || f.uv1, f.uv1, f.colors]
}

/// GPU copy of a scene.
pub struct SceneGpu {
    /// One buffer per used vertex stream (None: bound to the default buffer).
    pub streams: [Option<Buffer>; 6],
    /// 64 bytes of default attribute values for unused streams, read with stride 0.
    pub defaults: Buffer,
    /// All indices (u32).
    pub indices: Buffer,
    /// Per-instance transforms (`InstanceData` in shaders/common.glsl).
    pub instances: Buffer,
    /// Materials (`MaterialData`).
    pub materials: Buffer,
    /// Textures (a 1×1 white texture when the scene has none).
    pub textures: Vec<Image>,
    /// One sampler per texture.
    pub texture_samplers: Vec<vk::Sampler>,
    samplers: Vec<vk::Sampler>,
    /// Draw range of each primitive.
    pub ranges: Vec<DrawRange>,
    /// With `lod`: per primitive, the draw ranges and object-space errors
    /// of its simplified levels (after the original; empty without).
    pub lod_ranges: Vec<Vec<(DrawRange, f32)>>,
    /// Features in use.
    pub features: SceneFeatures,
    /// First index of the triangle (0, 1, 2) used for full-screen draws.
    pub fullscreen_first_index: u32,
}

/// Splits a double into a high f32 and a low f32 remainder.
pub fn split_f64(v: f64) -> (f32, f32) {
    let hi = v as f32;
    (hi, (v - hi as f64) as f32)
}

/// Splits a vector into high and low f32 parts.
pub fn split_dvec3(v: DVec3) -> ([f32; 3], [f32; 3]) {
    let (x, y, z) = (split_f64(v.x), split_f64(v.y), split_f64(v.z));
    ([x.0, y.0, z.0], [x.1, y.1, z.1])
}

/// The vertex shader's record of an instance at `transform`
/// (`InstanceData` in shaders/common.glsl): the rows of the linear part
/// with the translation's high f32 part in w, then its low part.
pub fn instance_record(transform: &DAffine3) -> [f32; 16] {
    let m = transform.matrix3;
    let (hi, lo) = split_dvec3(transform.translation);
    let row = |r: usize| {
        [
            m.x_axis[r] as f32,
            m.y_axis[r] as f32,
            m.z_axis[r] as f32,
            hi[r],
        ]
    };
    let [a, b, c] = [row(0), row(1), row(2)];
    [
        a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3], c[0], c[1], c[2], c[3], lo[0], lo[1],
        lo[2], 0.0,
    ]
}

/// Uploads `bytes` into a new device-local buffer of `usage` (through a
/// staging buffer and a one-shot copy), named `name` and tracked under
/// `category`.
pub fn upload(
    ctx: &Context,
    name: &str,
    usage: vk::BufferUsageFlags,
    category: &'static str,
    bytes: &[u8],
) -> Result<Buffer> {
    let size = bytes.len().max(4) as u64;
    let staging = Buffer::with_data(
        ctx,
        &BufferDesc {
            name: "staging",
            size,
            usage: vk::BufferUsageFlags::TRANSFER_SRC,
            location: MemoryLocation::CpuToGpu,
            category: "staging",
        },
        bytes,
    )?;
    let dst = Buffer::new(
        ctx,
        &BufferDesc {
            name,
            size,
            usage: usage | vk::BufferUsageFlags::TRANSFER_DST,
            location: MemoryLocation::GpuOnly,
            category,
        },
    );
    let copied = dst.and_then(|dst| match copy_now(ctx, &staging, &dst, 0, size) {
        Ok(()) => Ok(dst),
        Err(e) => {
            dst.destroy(ctx);
            Err(e)
        }
    });
    staging.destroy(ctx);
    copied
}

/// Copies the first `size` bytes of `src` to `dst` at `dst_offset` in a
/// one-shot submission, waiting for it (uploads at load).
pub fn copy_now(
    ctx: &Context,
    src: &Buffer,
    dst: &Buffer,
    dst_offset: u64,
    size: u64,
) -> Result<()> {
    ctx.one_shot(|cb| {
        // SAFETY: both buffers are live; the caller keeps the region inside
        // each (`size` bytes of `src`, `dst_offset + size` of `dst`).
        unsafe {
            ctx.device.cmd_copy_buffer(
                cb,
                src.buffer,
                dst.buffer,
                &[vk::BufferCopy {
                    src_offset: 0,
                    dst_offset,
                    size,
                }],
            )
        };
    })
}

fn bytes_of<T: Copy>(v: &[T]) -> &[u8] {
    // SAFETY: plain-old-data arrays of f32/u32/i32 viewed as bytes.
    unsafe { std::slice::from_raw_parts(v.as_ptr() as *const u8, std::mem::size_of_val(v)) }
}

impl SceneGpu {
    /// Uploads `scene`, and with `lod` its primitives' simplified index
    /// lists after the originals.
    pub fn new(ctx: &Context, scene: &Scene, lod: Option<&Chains>) -> Result<SceneGpu> {
        let features = scene.features();
        let used = used_streams(&features);
        let (data, mut indices, ranges, vertex_count) = pack_vertices(scene, &used);
        ctx.ensure_fits(
            estimate_bytes(scene, &data, indices.len()),
            &format!(
                "scene {} ({} instances, {} vertices)",
                scene.name,
                scene.instances.len(),
                vertex_count
            ),
        )?;
        // What is uploaded so far: destroyed if a later upload fails.
        let mut u = Uploaded::default();
        let lod_ranges = append_lod_levels(lod, &ranges, &mut indices, scene.primitives.len());
        // Full-screen passes draw this indexed triangle: lavapipe (Mesa 22.3)
        // drops non-indexed draws from every view but the first under multiview.
        let fullscreen_first_index = indices.len() as u32;
        indices.extend_from_slice(&[0, 1, 2]);
        let made = u.upload_all(ctx, scene, (&used, &data), &indices);
        match (made, u) {
            (
                Ok(()),
                Uploaded {
                    streams,
                    defaults: Some(defaults),
                    indices: Some(indices),
                    instances: Some(instances),
                    materials: Some(materials),
                    textures,
                    texture_samplers,
                    samplers,
                },
            ) => Ok(SceneGpu {
                streams,
                defaults,
                indices,
                instances,
                materials,
                textures,
                texture_samplers,
                samplers,
                ranges,
                lod_ranges,
                features,
                fullscreen_first_index,
            }),
            (made, u) => {
                u.destroy(ctx);
                Err(made.err().unwrap_or_else(|| {
                    crate::error::Error::Gpu("a scene upload was left unfinished".into())
                }))
            }
        }
    }

    /// Destroys every resource (device must be idle).
    pub fn destroy(self, ctx: &Context) {
        Uploaded {
            streams: self.streams,
            defaults: Some(self.defaults),
            indices: Some(self.indices),
            instances: Some(self.instances),
            materials: Some(self.materials),
            textures: self.textures,
            texture_samplers: self.texture_samplers,
            samplers: self.samplers,
        }
        .destroy(ctx);
    }
}

/// A scene's GPU objects as they are uploaded (the buffers optional until
/// the upload is whole), so that an upload left half done is destroyed.
#[derive(Default)]
struct Uploaded {
    streams: [Option<Buffer>; 6],
    defaults: Option<Buffer>,
    indices: Option<Buffer>,
    instances: Option<Buffer>,
    materials: Option<Buffer>,
    textures: Vec<Image>,
    /// Copies of `samplers`' handles, per texture.
    texture_samplers: Vec<vk::Sampler>,
    samplers: Vec<vk::Sampler>,
}

impl Uploaded {
    /// Uploads the used vertex streams and their defaults, the indices,
    /// the instances, the materials, the samplers and the textures (a white
    /// one when the scene has none), stopping at the first failure.
    fn upload_all(
        &mut self,
        ctx: &Context,
        scene: &Scene,
        (used, data): (&[bool], &[Vec<f32>]),
        indices: &[u32],
    ) -> Result<()> {
        let vertex = vk::BufferUsageFlags::VERTEX_BUFFER;
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        for (i, (name, _)) in STREAMS.iter().enumerate() {
            if used[i] {
                let bytes = bytes_of(&data[i]);
                self.streams[i] = Some(upload(
                    ctx,
                    &format!("vertex {name}"),
                    vertex,
                    "vertex",
                    bytes,
                )?);
            }
        }
        // Defaults read at stride 0: tangent +X, uv 0, colour white.
        let defaults_data: [f32; 16] = [
            1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0,
        ];
        self.defaults = Some(upload(
            ctx,
            "vertex defaults",
            vertex,
            "vertex",
            bytes_of(&defaults_data),
        )?);
        let index = vk::BufferUsageFlags::INDEX_BUFFER;
        self.indices = Some(upload(ctx, "indices", index, "index", bytes_of(indices))?);
        let inst: Vec<f32> = scene
            .instances
            .iter()
            .flat_map(|i| instance_record(&i.transform))
            .collect();
        self.instances = Some(upload(
            ctx,
            "instances",
            storage,
            "instance",
            bytes_of(&inst),
        )?);
        let mats = material_records(scene);
        self.materials = Some(upload(
            ctx,
            "materials",
            storage,
            "material",
            bytes_of(&mats),
        )?);
        make_samplers(ctx, &mut self.samplers)?;
        if scene.textures.is_empty() {
            self.textures
                .push(upload_texture(ctx, "white", 1, 1, true, &[255; 4])?);
            self.texture_samplers.push(self.samplers[0]);
        }
        for t in &scene.textures {
            self.textures.push(upload_texture(
                ctx, &t.name, t.width, t.height, t.srgb, &t.rgba8,
            )?);
            self.texture_samplers
                .push(self.samplers[(t.repeat as usize) * 2 + t.linear as usize]);
        }
        Ok(())
    }

    /// Destroys what was uploaded; the device must be idle.
    fn destroy(self, ctx: &Context) {
        let buffers = [self.defaults, self.indices, self.instances, self.materials];
        for b in self.streams.into_iter().chain(buffers).flatten() {
            b.destroy(ctx);
        }
        for t in self.textures {
            t.destroy(ctx);
        }
        for s in self.samplers {
            // SAFETY: the device is idle.
            unsafe { ctx.device.destroy_sampler(s, None) };
        }
    }
}

fn mip_levels(w: u32, h: u32) -> u32 {
    32 - w.max(h).max(1).leading_zeros()
}

/// Uploads an RGBA8 texture and builds its mip chain with linear blits.
/// GPU bytes a scene's upload takes: vertex streams, indices, one 4×4
/// float matrix per instance, and RGBA8 textures with their mip chains
/// (a full chain adds a third).
fn estimate_bytes(scene: &Scene, streams: &[Vec<f32>; 6], indices: usize) -> u64 {
    let vertex: u64 = streams.iter().map(|d| d.len() as u64 * 4).sum();
    let textures: u64 = scene
        .textures
        .iter()
        .map(|t| t.width as u64 * t.height as u64 * 4 * 4 / 3)
        .sum();
    vertex + indices as u64 * 4 + scene.instances.len() as u64 * 64 + textures
}

/// Records the upload of `staging` into level 0 of `image` (of `w` × `h`
/// and `mips` levels), each further level blitted from the one before,
/// and every level made ready to sample.
fn record_texture_upload(
    d: &ash::Device,
    cb: vk::CommandBuffer,
    image: &Image,
    staging: &Buffer,
    (w, h, mips): (u32, u32, u32),
) {
    let barrier = |level: u32, from: Use, to: Use| {
        barrier::image_level(image.image, vk::ImageAspectFlags::COLOR, level, 1, from, to)
    };
    let pre: Vec<_> = (0..mips)
        .map(|l| barrier(l, Use::TRANSFER_DST.discarded(), Use::TRANSFER_DST))
        .collect();
    // Every level but the last was a blit source; the last was only
    // written.
    let post: Vec<_> = (0..mips)
        .map(|l| {
            let from = if l + 1 < mips {
                Use::TRANSFER_SRC
            } else {
                Use::TRANSFER_DST
            };
            barrier(l, from, Use::SAMPLED)
        })
        .collect();
    let sub = |level| vk::ImageSubresourceLayers {
        aspect_mask: vk::ImageAspectFlags::COLOR,
        mip_level: level,
        base_array_layer: 0,
        layer_count: 1,
    };
    let (src, dst) = (
        vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
        vk::ImageLayout::TRANSFER_DST_OPTIMAL,
    );
    // SAFETY: recording transfers on live objects; layouts tracked per level.
    unsafe {
        d.cmd_pipeline_barrier2(
            cb,
            &vk::DependencyInfo::default().image_memory_barriers(&pre),
        );
        let copy = barrier::color_copy(0, 1, w, h);
        d.cmd_copy_buffer_to_image(cb, staging.buffer, image.image, dst, &[copy]);
        let (mut mw, mut mh) = (w as i32, h as i32);
        for l in 1..mips {
            let b = [barrier(l - 1, Use::TRANSFER_DST, Use::TRANSFER_SRC)];
            d.cmd_pipeline_barrier2(cb, &vk::DependencyInfo::default().image_memory_barriers(&b));
            let (nw, nh) = ((mw / 2).max(1), (mh / 2).max(1));
            let blit = vk::ImageBlit::default()
                .src_subresource(sub(l - 1))
                .src_offsets([vk::Offset3D::default(), vk::Offset3D { x: mw, y: mh, z: 1 }])
                .dst_subresource(sub(l))
                .dst_offsets([vk::Offset3D::default(), vk::Offset3D { x: nw, y: nh, z: 1 }]);
            d.cmd_blit_image(
                cb,
                image.image,
                src,
                image.image,
                dst,
                &[blit],
                vk::Filter::LINEAR,
            );
            (mw, mh) = (nw, nh);
        }
        d.cmd_pipeline_barrier2(
            cb,
            &vk::DependencyInfo::default().image_memory_barriers(&post),
        );
    }
}

/// Appends the LOD chains' levels to `indices`: per primitive, each
/// level's draw range (the primitive's, over its own indices) and error.
fn append_lod_levels(
    lod: Option<&Chains>,
    ranges: &[DrawRange],
    indices: &mut Vec<u32>,
    primitives: usize,
) -> Vec<Vec<(DrawRange, f32)>> {
    let mut lod_ranges = vec![Vec::new(); primitives];
    let Some(chains) = lod else {
        return lod_ranges;
    };
    for (p, levels) in chains.levels.iter().enumerate() {
        for l in levels {
            let range = DrawRange {
                first_index: indices.len() as u32,
                index_count: l.indices.len() as u32,
                ..ranges[p]
            };
            indices.extend_from_slice(&l.indices);
            lod_ranges[p].push((range, l.error));
        }
    }
    lod_ranges
}

fn upload_texture(
    ctx: &Context,
    name: &str,
    w: u32,
    h: u32,
    srgb: bool,
    rgba: &[u8],
) -> Result<Image> {
    let format = if srgb {
        vk::Format::R8G8B8A8_SRGB
    } else {
        vk::Format::R8G8B8A8_UNORM
    };
    // SAFETY: valid physical device.
    let props = unsafe {
        ctx.instance
            .get_physical_device_format_properties(ctx.physical_device, format)
    };
    let can_blit = props.optimal_tiling_features.contains(
        vk::FormatFeatureFlags::BLIT_SRC
            | vk::FormatFeatureFlags::BLIT_DST
            | vk::FormatFeatureFlags::SAMPLED_IMAGE_FILTER_LINEAR,
    );
    let mips = if can_blit { mip_levels(w, h) } else { 1 };
    let image = Image::new(
        ctx,
        &ImageDesc {
            name,
            format,
            extent: vk::Extent2D {
                width: w,
                height: h,
            },
            layers: 1,
            mips,
            samples: vk::SampleCountFlags::TYPE_1,
            usage: vk::ImageUsageFlags::SAMPLED
                | vk::ImageUsageFlags::TRANSFER_DST
                | vk::ImageUsageFlags::TRANSFER_SRC,
            aspect: vk::ImageAspectFlags::COLOR,
            category: "texture",
            flags: vk::ImageCreateFlags::empty(),
        },
    )?;
    let staging = match Buffer::with_data(
        ctx,
        &BufferDesc {
            name: "texture staging",
            size: rgba.len() as u64,
            usage: vk::BufferUsageFlags::TRANSFER_SRC,
            location: MemoryLocation::CpuToGpu,
            category: "staging",
        },
        rgba,
    ) {
        Ok(b) => b,
        Err(e) => {
            image.destroy(ctx);
            return Err(e);
        }
    };
    let r =
        ctx.one_shot(|cb| record_texture_upload(&ctx.device, cb, &image, &staging, (w, h, mips)));
    staging.destroy(ctx);
    match r {
        Ok(()) => Ok(image),
        Err(e) => {
            image.destroy(ctx);
            Err(e)
        }
    }
}

/// Every primitive's vertex streams one after the other (the unused
/// streams empty; a primitive without a used stream gets its default),
/// their indices, each primitive's draw range, and the vertex count.
#[allow(clippy::type_complexity)]
fn pack_vertices(
    scene: &Scene,
    used: &[bool; 6],
) -> ([Vec<f32>; 6], Vec<u32>, Vec<DrawRange>, usize) {
    let mut data: [Vec<f32>; 6] = Default::default();
    let mut indices: Vec<u32> = Vec::new();
    let mut ranges = Vec::new();
    let mut vertex_count = 0usize;
    for p in &scene.primitives {
        let n = p.positions.len();
        ranges.push(DrawRange {
            first_index: indices.len() as u32,
            index_count: p.indices.len() as u32,
            vertex_offset: vertex_count as i32,
            material: p.material,
        });
        indices.extend_from_slice(&p.indices);
        data[0].extend(p.positions.iter().flatten());
        data[1].extend(p.normals.iter().flatten());
        if used[2] {
            match &p.tangents {
                Some(t) => data[2].extend(t.iter().flatten()),
                None => data[2].extend(std::iter::repeat_n([1.0, 0.0, 0.0, 1.0], n).flatten()),
            }
        }
        if used[3] {
            match &p.uv0 {
                Some(t) => data[3].extend(t.iter().flatten()),
                None => data[3].extend(std::iter::repeat_n(0.0, 2 * n)),
            }
        }
        if used[4] {
            match &p.uv1 {
                Some(t) => data[4].extend(t.iter().flatten()),
                None => data[4].extend(std::iter::repeat_n(0.0, 2 * n)),
            }
        }
        if used[5] {
            match &p.colors {
                Some(t) => data[5].extend(t.iter().flatten()),
                None => data[5].extend(std::iter::repeat_n(1.0, 4 * n)),
            }
        }
        vertex_count += n;
    }
    (data, indices, ranges, vertex_count)
}

/// Each material as the shaders read it: 16 words (base colour,
/// emissive and alpha cutoff, metallic, roughness and the normal and
/// occlusion strengths, the five textures, which read uv1, and flags).
fn material_records(scene: &Scene) -> Vec<u32> {
    let mut mats: Vec<u32> = Vec::new();
    for m in &scene.materials {
        let f = |v: f32| v.to_bits();
        let t = |r: Option<u32>| r.map_or(-1i32, |x| x as i32) as u32;
        mats.extend(m.base_color.map(f));
        mats.extend([
            f(m.emissive[0]),
            f(m.emissive[1]),
            f(m.emissive[2]),
            f(m.alpha_cutoff),
        ]);
        let ns = m.normal_tex.map_or(1.0, |(_, s)| s);
        let os = m.occlusion_tex.map_or(1.0, |(_, s)| s);
        mats.extend([f(m.metallic), f(m.roughness), f(ns), f(os)]);
        let slots = [
            m.base_color_tex,
            m.metallic_roughness_tex,
            m.normal_tex.map(|x| x.0),
            m.occlusion_tex.map(|x| x.0),
            m.emissive_tex,
        ];
        let uv_mask = slots.iter().enumerate().fold(0u32, |acc, (i, s)| {
            acc | (s.is_some_and(|s| s.tex_coord == 1) as u32) << i
        });
        let flags = (m.unlit as u32)
            | (m.double_sided as u32) << 1
            | ((m.alpha_mode == AlphaMode::Mask) as u32) << 2;
        mats.extend(slots[..4].iter().map(|s| t(s.map(|s| s.texture))));
        mats.extend([t(slots[4].map(|s| s.texture)), uv_mask, flags, 0]);
    }
    mats
}

/// The four samplers textures use (clamp or repeat, nearest or linear),
/// pushed onto `samplers` as they are made (so a failure leaves the made
/// ones there to destroy).
fn make_samplers(ctx: &Context, samplers: &mut Vec<vk::Sampler>) -> Result<()> {
    for (repeat, linear) in [(false, false), (false, true), (true, false), (true, true)] {
        let address = if repeat {
            vk::SamplerAddressMode::REPEAT
        } else {
            vk::SamplerAddressMode::CLAMP_TO_EDGE
        };
        let filter = if linear {
            vk::Filter::LINEAR
        } else {
            vk::Filter::NEAREST
        };
        let info = vk::SamplerCreateInfo::default()
            .mag_filter(filter)
            .min_filter(filter)
            .mipmap_mode(vk::SamplerMipmapMode::LINEAR)
            .address_mode_u(address)
            .address_mode_v(address)
            .address_mode_w(address)
            .max_lod(vk::LOD_CLAMP_NONE);
        // SAFETY: valid sampler create info.
        samplers.push(unsafe { ctx.device.create_sampler(&info, None) }.vk("creating a sampler")?);
    }
    Ok(())
}
