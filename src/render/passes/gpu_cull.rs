//! GPU-driven culling (`--opt gpu-cull`): the instance boxes and their
//! meshes' primitive lists live on the GPU; each frame a compute pass
//! (`shaders/gpu_cull.comp`, timed as `cull-early`) tests every instance
//! against the strategy's stereo volumes ([`crate::cull::gpu`]), appends the
//! kept ones to each primitive's range of this frame slot's visible buffer
//! and counts them into one indexed indirect command per primitive. The
//! forward views then draw each primitive with
//! vkCmdDrawIndexedIndirectCount (a draw count of 0 or 1 the cull writes),
//! so the CPU records the same commands whatever the instance count.
//!
//! Every buffer the GPU writes per frame is per frame slot. The slot's
//! commands and counters are host-visible: once the slot's fence has
//! signalled, [`GpuCull::read`] turns them into what the GPU drew (draw
//! calls, instances, triangles) and the cull's counters.
//!
//! With `occlusion` (two-phase hierarchical Z, `cull::hiz`), the pass runs
//! twice: `cull-early` draws what was visible last frame, the forward views
//! draw it, [`DepthPyramid`] reduces their depth, and `cull-late` tests the
//! rest against it, draws what became visible after the early draws, and
//! keeps each instance's visibility for the next frame (one persistent
//! buffer: frame n reads what frame n − 1 wrote, ordered by the queue).
//! The late phase also lists the visible instances and sizes the next
//! early phase's indirect dispatch to that list, so the early phase costs
//! what was visible, not what the scene holds.

use super::depth_pyramid::DepthPyramid;

mod table;
use super::{PipelineSetup, Recorder};
use crate::cull::gpu::{FarSplitAxes, InsetLists, VolumeData, VOLUME_DATA_SIZE};
use crate::error::{Error, Result};
use crate::gpu::memory::{as_bytes, Buffer, BufferDesc, Pod};
use crate::gpu::pipeline::{compute_pipeline, DescriptorSets};
use crate::gpu::query::Queries;
use crate::gpu::shaders;
use crate::gpu::Context;
use crate::render::attachments::AttachmentSet;
use crate::render::batches::PipelineKey;
use crate::render::scene_gpu::{split_dvec3, upload};
use crate::scene::{Scene, WorldBounds};
use crate::view::lod::MAX_LEVELS;
use ash::vk;
use glam::DAffine3;
use gpu_allocator::MemoryLocation;
use std::collections::HashMap;

// SAFETY: repr(C) of u32 and f32 arrays whose sizes add up to the struct's
// (asserted in cull::gpu), so there is no padding.
unsafe impl Pod for VolumeData {}

/// Threads per workgroup (local_size_x in gpu_cull.comp).
const GROUP: u32 = 64;
/// Workgroups per dispatch row: Vulkan guarantees at least 65535 per
/// dimension (maxComputeWorkGroupCount), so larger scenes use rows.
const ROW: u32 = 65_535;
/// Workgroups per row of the early phase's indirect dispatch (EARLY_ROW in
/// gpu_cull_body.glsl): the late phase sets the rows to cover its list.
const EARLY_ROW: u32 = 256;
/// Bytes of one VkDrawIndexedIndirectCommand.
const COMMAND: u64 = std::mem::size_of::<vk::DrawIndexedIndirectCommand>() as u64;

/// Counters after the draw counts: tested, inside the volumes, drawn
/// early, drawn late, hidden, dropped by LOD, tested early.
const COUNTERS: u64 = 7;

/// What the GPU did in one frame, read back after its fence.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct GpuCullStats {
    /// Instances the compute pass tested (with occlusion: the late phase,
    /// which tests every instance).
    pub tested: u64,
    /// With occlusion: instances the early phase tested — those visible at
    /// the end of the last frame (every instance on the first frame).
    pub tested_early: u64,
    /// Instances inside the stereo volume.
    pub passed_frustum: u64,
    /// Instances drawn by the early phase: without occlusion, every one
    /// inside the volume; with it, those also visible last frame.
    pub drawn_early: u64,
    /// With occlusion: instances inside the volume that passed this
    /// frame's depth pyramid and were not drawn early (newly visible).
    pub drawn_late: u64,
    /// With occlusion: instances inside the volume hidden by the pyramid
    /// in both eyes.
    pub occluded: u64,
    /// With LOD: instances inside the volume not drawn because they project
    /// to at most the error bound.
    pub lod_dropped: u64,
    /// With LOD: triangles drawn per level (0: the original meshes).
    pub lod_triangles: [u64; MAX_LEVELS],
}

/// Whether compute shaders on `ctx` have subgroup ballots (Vulkan 1.1's
/// subgroup properties): the cull then aggregates its atomics per subgroup.
fn subgroup_ballots(ctx: &Context) -> bool {
    let mut sub = vk::PhysicalDeviceSubgroupProperties::default();
    let mut p2 = vk::PhysicalDeviceProperties2::default().push_next(&mut sub);
    // SAFETY: a valid physical device and a correctly chained query.
    unsafe {
        ctx.instance
            .get_physical_device_properties2(ctx.physical_device, &mut p2)
    };
    let ops = vk::SubgroupFeatureFlags::BASIC | vk::SubgroupFeatureFlags::BALLOT;
    sub.supported_stages.contains(vk::ShaderStageFlags::COMPUTE)
        && sub.supported_operations.contains(ops)
}

/// The LOD parameters of one frame.
#[derive(Clone, Copy, Debug, Default)]
pub struct LodFrame {
    /// Pixel density (pixels per radian, `view::lod::pixel_density`) over
    /// the error bound in pixels: a level is drawn when its world error
    /// times this is at most the selection distance.
    pub k: f64,
    /// The eyes' largest distance from the render origin.
    pub eye_slack: f64,
}

/// What the frame's stats take from the GPU.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Drawn {
    /// Indirect draws the GPU issued (non-empty primitives), per view set.
    pub draws: u64,
    /// With a far field: the far pass's indirect draws, per far camera
    /// rendered.
    pub far_draws: u64,
    /// Instance-primitive pairs drawn.
    pub instances: u64,
    /// Triangles drawn.
    pub triangles: u64,
    /// The cull's counters.
    pub cull: GpuCullStats,
}

/// What this pass cannot do: run without indirect count (one error
/// naming the device), or give its second command set to more than one
/// of occlusion's late phase, the far field and the inset's lists.
fn refuse_unsupported(
    ctx: &Context,
    occlusion: bool,
    (far_field, inset): (bool, bool),
) -> Result<()> {
    if !ctx.caps.draw_indirect_count {
        return Err(Error::config(
            "--opt",
            format!(
                "gpu-cull needs VK_KHR_draw_indirect_count (drawIndirectCount), which {} lacks",
                ctx.device_name
            ),
        ));
    }
    if far_field && occlusion {
        return Err(Error::config(
            "--opt",
            "occlusion and mffr cannot be combined: the depth pyramid would see only the near field's depth",
        ));
    }
    if inset && (far_field || occlusion) {
        return Err(Error::config(
            "--opt",
            "inset's own lists with gpu-cull take the second command set, which mffr and occlusion use: leave them out with inset",
        ));
    }
    Ok(())
}

/// The cull's descriptor bindings: volumes, instances, primitives,
/// commands, counts, visible list, frame uniforms, pyramid, pyramid
/// levels, visibility, LOD levels, LOD errors, early list.
const BINDINGS: u32 = 13;

/// The bindings that are uniform buffers (the cull volumes and the
/// frame's uniforms); the rest are storage buffers.
const UNIFORM_BINDINGS: [u32; 2] = [0, 6];

/// Frame slot `i`'s buffers: the cull volumes (host-written), the draw
/// commands and counts and the visible list in device memory (the cull's
/// atomics and the indirect reads would otherwise cross the bus), and
/// the host-visible copy the frame reads them back through. What was made
/// is freed when a later buffer fails.
fn make_slot(ctx: &Context, i: usize, n_cmds: usize, total: u64) -> Result<Slot> {
    let buffer = |name: &str, size: u64, usage, location| {
        Buffer::new(
            ctx,
            &BufferDesc {
                name: &format!("{name} {i}"),
                size,
                usage,
                location,
                category: "per-frame",
            },
        )
    };
    let indirect = vk::BufferUsageFlags::STORAGE_BUFFER
        | vk::BufferUsageFlags::INDIRECT_BUFFER
        | vk::BufferUsageFlags::TRANSFER_DST
        | vk::BufferUsageFlags::TRANSFER_SRC;
    let (commands_size, counts_size) = sizes(n_cmds);
    let gpu = MemoryLocation::GpuOnly;
    let uniform = vk::BufferUsageFlags::UNIFORM_BUFFER;
    let volumes = buffer(
        "cull volumes",
        VOLUME_DATA_SIZE as u64,
        uniform,
        MemoryLocation::CpuToGpu,
    )?;
    let commands = buffer("draw commands", commands_size, indirect, gpu);
    let counts = buffer("draw counts", counts_size, indirect, gpu);
    let to_host = vk::BufferUsageFlags::TRANSFER_DST;
    let readback = buffer(
        "gpu-cull readback",
        commands_size + counts_size,
        to_host,
        MemoryLocation::GpuToCpu,
    );
    let visible_usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST;
    let visible = buffer(
        "gpu visible instances",
        4 * total.max(1),
        visible_usage,
        gpu,
    );
    match (commands, counts, visible, readback) {
        (Ok(commands), Ok(counts), Ok(visible), Ok(readback)) => Ok(Slot {
            volumes,
            commands,
            counts,
            visible,
            readback,
            set: vk::DescriptorSet::null(),
        }),
        (a, b, c, r) => {
            volumes.destroy(ctx);
            let mut err = None;
            for r in [a, b, c, r] {
                match r {
                    Ok(buf) => buf.destroy(ctx),
                    Err(e) => err = err.or(Some(e)),
                }
            }
            Err(err.expect("one of them failed"))
        }
    }
}

/// Bytes of a slot's draw commands (early and late, or near and far) and
/// of its counts (a draw count per command, then [`COUNTERS`]) for
/// `n_cmds` commands per set.
fn sizes(n_cmds: usize) -> (u64, u64) {
    (
        2 * COMMAND * n_cmds.max(1) as u64,
        4 * (2 * n_cmds as u64 + COUNTERS),
    )
}

/// The early list before the first frame, when every one of `n` instances
/// counts as visible: the dispatch covering `n` threads in rows of
/// [`EARLY_ROW`] groups, the count, then `0..n`.
fn first_early_list(n: u32) -> Vec<u32> {
    let rows = n.div_ceil(EARLY_ROW * GROUP);
    [EARLY_ROW, rows, 1, n].into_iter().chain(0..n).collect()
}

/// The cull's record of an instance with world bounds `b` under
/// `transform` whose mesh's primitives are `slice` (first, count) of the
/// flat primitive list: the box centre as a two-float split (the vertex
/// shader's scheme) with the slice in the w lanes, the half-extents
/// rounded up so the f32 box contains the f64 one, and the largest axis
/// scale of the transform (LOD errors are object-space).
pub fn box_record(slice: (u32, u32), b: &WorldBounds, transform: &DAffine3) -> [f32; 12] {
    let (hi, lo) = split_dvec3(b.center);
    let e = (b.max - b.min) * 0.5;
    let up = |v: f64| {
        let f = v as f32;
        if (f as f64) < v {
            f.next_up()
        } else {
            f
        }
    };
    let (first, count) = slice;
    let m = transform.matrix3;
    let scale = m
        .x_axis
        .length()
        .max(m.y_axis.length())
        .max(m.z_axis.length());
    [
        hi[0],
        hi[1],
        hi[2],
        f32::from_bits(first),
        lo[0],
        lo[1],
        lo[2],
        f32::from_bits(count),
        up(e.x),
        up(e.y),
        up(e.z),
        up(scale),
    ]
}

/// Bytes of the cull's push constants (`Push` in gpu_cull.comp).
const PUSH_BYTES: u32 = 48;

struct Slot {
    volumes: Buffer,
    commands: Buffer,
    counts: Buffer,
    visible: Buffer,
    /// Host-visible copy of `commands` then `counts`, made at the end of
    /// the slot's cull.
    readback: Buffer,
    set: vk::DescriptorSet,
}

/// The GPU cull pass and its buffers.
pub struct GpuCull {
    instances: Buffer,
    prims: Buffer,
    template: Buffer,
    /// Per instance: 1 when visible at the end of the last frame
    /// (occlusion), else a 4-byte placeholder.
    visibility: Buffer,
    /// A placeholder bound for the pyramid and its levels without occlusion.
    placeholder: Buffer,
    /// With occlusion: the early phase's indirect dispatch (groups x, y,
    /// z), the listed count, then the instances visible at the end of the
    /// last frame (the late phase writes them); else 16 bytes.
    early: Buffer,
    /// Per primitive: its first draw command and level count (u32 pairs
    /// padded to uvec4).
    lod_levels: Buffer,
    /// Per draw command: the level's object-space error.
    lod_errors: Buffer,
    /// Whether LOD selection (and dropping sub-bound instances) runs.
    lod: bool,
    /// Pixel density over the error bound for the coming frame.
    lod_k: f32,
    /// The eyes' largest distance from the render origin this frame.
    eye_slack: f32,
    /// Per primitive: index of its level-0 draw command.
    cmd_first: Vec<u32>,
    /// Per draw command: triangles.
    cmd_tris: Vec<u64>,
    /// Per draw command: its LOD level.
    cmd_level: Vec<u8>,
    /// The depth pyramid (occlusion only).
    pyramid: Option<DepthPyramid>,
    near: f32,
    extent: vk::Extent2D,
    slots: Vec<Slot>,
    set_layout: vk::DescriptorSetLayout,
    layout: vk::PipelineLayout,
    pool: vk::DescriptorPool,
    pipeline: vk::Pipeline,
    instance_count: u32,
    /// Non-blended primitives in draw order (as the CPU batches them).
    order: Vec<u32>,
    /// Per mesh: its slice (first, count) of the flat primitive list.
    slices: Vec<(u32, u32)>,
    /// With a monoscopic far field (`mffr`): the second command set holds
    /// the far pass's draws.
    far_field: bool,
    /// This frame's split: 0 all near (the far field fell back to
    /// stereo), 1 split by `split_axes`, 2 every instance in both.
    far_mode: u32,
    split_axes: Option<FarSplitAxes>,
    /// With `inset` (two scopes): the second command set holds the inset
    /// views' draws, the first the wide views'.
    inset: bool,
    /// This frame's inset lists (None: every instance in both sets).
    inset_lists: Option<InsetLists>,
    /// Where the blended draws' instance ids start in each visible buffer
    /// (after the cull's ranges), and this frame's ids (written there by
    /// [`GpuCull::record`]).
    blended_base: u32,
    blended_ids: Vec<u32>,
    /// The wide views' scale this frame (their pixel density over the
    /// eyes'): with `lod` their list selects levels at that density.
    wide_scale: f32,
}

/// How the coming frame's visible instances divide between the near views
/// and the monoscopic far pass (`mffr` with `gpu-cull`).
// Made once per frame on the stack: boxing the axes would allocate each
// frame to save 200 bytes of stack.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FarSplit {
    /// No far pass this frame: every instance is near.
    AllNear,
    /// Split by these axes as the CPU path's batcher splits.
    At(FarSplitAxes),
    /// Every instance in both (`mffr-no-split`).
    Both,
}

/// The views occlusion's depth pyramid is built from: the eyes', or with
/// the inset its wide views' (which cover the whole field of view with the
/// eyes' projections, at their own size).
#[derive(Clone, Copy)]
pub struct OcclusionTargets<'a> {
    /// Their attachment sets (depth sampleable: made for occlusion).
    pub sets: &'a [AttachmentSet],
    /// Their size.
    pub extent: vk::Extent2D,
    /// Their samples per pixel.
    pub samples: u32,
    /// The near plane (m).
    pub near: f32,
}

/// The cull's buffers made from its tables: the instance boxes, the flat
/// primitive list, the command template, the visibility (every instance
/// visible, with occlusion), a placeholder, the LOD tables and the early
/// list; on failure, destroys what it made.
struct Tables {
    instances: Buffer,
    prims: Buffer,
    template: Buffer,
    visibility: Buffer,
    placeholder: Buffer,
    lod_levels: Buffer,
    lod_errors: Buffer,
    early: Buffer,
}

impl Tables {
    fn upload(ctx: &Context, scene: &Scene, t: &table::Table, occlusion: bool) -> Result<Tables> {
        let (slices, flat, lod_info, cmd_error) = (&t.slices, &t.flat, &t.lod_info, &t.cmd_error);
        let words = t.words();
        let mut boxes: Vec<f32> = Vec::with_capacity(scene.instances.len() * 12);
        for (b, inst) in scene.world_bounds().iter().zip(&scene.instances) {
            boxes.extend_from_slice(&box_record(slices[inst.mesh as usize], b, &inst.transform));
        }
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let instances = upload(
            ctx,
            "cull instances",
            storage,
            "instances",
            as_bytes(&boxes),
        )?;
        let prims = match upload(ctx, "cull primitives", storage, "instances", as_bytes(flat)) {
            Ok(b) => b,
            Err(e) => {
                instances.destroy(ctx);
                return Err(e);
            }
        };
        let template = match upload(
            ctx,
            "draw command template",
            vk::BufferUsageFlags::TRANSFER_SRC,
            "per-frame",
            as_bytes(&words),
        ) {
            Ok(b) => b,
            Err(e) => {
                instances.destroy(ctx);
                prims.destroy(ctx);
                return Err(e);
            }
        };
        // Every instance starts visible: the first frame draws all that is
        // inside the volumes early, so its late phase already knows what
        // is hidden.
        let ones = vec![1u32; if occlusion { scene.instances.len() } else { 1 }];
        let made = [
            ("instance visibility", as_bytes(&ones)),
            ("occlusion placeholder", as_bytes(&[0u32; 4])),
            ("lod levels", as_bytes(lod_info)),
            ("lod errors", as_bytes(cmd_error)),
        ]
        .map(|(name, bytes)| upload(ctx, name, storage, "instances", bytes));
        if made.iter().any(|b| b.is_err()) {
            let mut err = None;
            for b in made {
                match b {
                    Ok(b) => b.destroy(ctx),
                    Err(e) => err = err.or(Some(e)),
                }
            }
            for b in [instances, prims, template] {
                b.destroy(ctx);
            }
            return Err(err.expect("one upload failed"));
        }
        let [visibility, placeholder, lod_levels, lod_errors] =
            made.map(|b| b.expect("checked above"));
        let early = match upload(
            ctx,
            "early list",
            storage | vk::BufferUsageFlags::INDIRECT_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
            "instances",
            as_bytes(&first_early_list(if occlusion {
                scene.instances.len() as u32
            } else {
                0
            })),
        ) {
            Ok(b) => b,
            Err(e) => {
                for b in [
                    instances,
                    prims,
                    template,
                    visibility,
                    placeholder,
                    lod_levels,
                    lod_errors,
                ] {
                    b.destroy(ctx);
                }
                return Err(e);
            }
        };
        Ok(Tables {
            instances,
            prims,
            template,
            visibility,
            placeholder,
            lod_levels,
            lod_errors,
            early,
        })
    }
}

impl GpuCull {
    /// Uploads `scene`'s instance boxes and primitive lists and creates the
    /// pipeline and `slots` frame slots of buffers, reading each slot's
    /// view-projections from `frame_ubos`. `order` lists the non-blended
    /// primitives in draw order. With `occlusion` (the views whose depth the pyramid
    /// reduces, and the near plane), the two-phase scheme runs.
    /// With `far_field` the second command set is the far pass's, with
    /// `inset` the inset views' (at most one of the three). Blended
    /// primitives are left to the CPU: each visible buffer keeps room for
    /// `blended` instance ids after the cull's ranges
    /// ([`GpuCull::set_blended`]).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        setup: &PipelineSetup,
        scene: &Scene,
        order: &[u32],
        frame_ubos: &[&Buffer],
        occlusion: Option<OcclusionTargets<'_>>,
        lod: bool,
        (far_field, inset): (bool, bool),
        blended: u32,
    ) -> Result<GpuCull> {
        let slots = frame_ubos.len();
        let ctx = setup.ctx;
        refuse_unsupported(ctx, occlusion.is_some(), (far_field, inset))?;
        // A second command set: the late phase's (occlusion), the far
        // pass's (mffr) or the inset views' (inset).
        let phases = if occlusion.is_some() || far_field || inset {
            2
        } else {
            1
        };
        let t = table::Table::new(setup, scene, order, phases, blended)?;
        let Tables {
            instances,
            prims,
            template,
            visibility,
            placeholder,
            lod_levels,
            lod_errors,
            early,
        } = Tables::upload(ctx, scene, &t, occlusion.is_some())?;
        let (n_cmds, total) = (t.n_cmds, t.total);
        let table::Table {
            cmd_first,
            cmd_tris,
            cmd_level,
            slices,
            ..
        } = t;
        let mut pass = GpuCull {
            instances,
            prims,
            template,
            visibility,
            placeholder,
            early,
            lod_levels,
            lod_errors,
            lod,
            lod_k: 0.0,
            eye_slack: 0.0,
            cmd_first,
            cmd_tris,
            cmd_level,
            pyramid: None,
            near: occlusion.map_or(0.0, |o| o.near),
            extent: occlusion.map_or(vk::Extent2D::default(), |o| o.extent),
            slots: Vec::new(),
            set_layout: vk::DescriptorSetLayout::null(),
            layout: vk::PipelineLayout::null(),
            pool: vk::DescriptorPool::null(),
            pipeline: vk::Pipeline::null(),
            instance_count: scene.instances.len() as u32,
            order: order.to_vec(),
            slices,
            far_field,
            inset,
            inset_lists: None,
            blended_base: (phases as u64 * total) as u32,
            blended_ids: Vec::new(),
            wide_scale: 1.0,
            far_mode: 0,
            split_axes: None,
        };
        if let Some(o) = occlusion {
            match DepthPyramid::new(ctx, o.sets, o.extent, o.samples, slots) {
                Ok(p) => pass.pyramid = Some(p),
                Err(e) => {
                    pass.destroy(ctx);
                    return Err(e);
                }
            }
        }
        match pass.build(
            ctx,
            n_cmds,
            phases as u64 * total + blended as u64,
            frame_ubos,
        ) {
            Ok(()) => Ok(pass),
            Err(e) => {
                pass.destroy(ctx);
                Err(e)
            }
        }
    }

    fn build(
        &mut self,
        ctx: &Context,
        n_cmds: usize,
        total: u64,
        frame_ubos: &[&Buffer],
    ) -> Result<()> {
        let slots = frame_ubos.len();
        for i in 0..slots {
            let slot = make_slot(ctx, i, n_cmds, total)?;
            self.slots.push(slot);
        }
        let (uniform, storage) = (
            vk::DescriptorType::UNIFORM_BUFFER,
            vk::DescriptorType::STORAGE_BUFFER,
        );
        let compute = vk::ShaderStageFlags::COMPUTE;
        let bindings: Vec<_> = (0..BINDINGS)
            .map(|b| {
                (
                    if UNIFORM_BINDINGS.contains(&b) {
                        uniform
                    } else {
                        storage
                    },
                    1,
                    compute,
                )
            })
            .collect();
        let made = DescriptorSets::new(ctx, &bindings, compute, PUSH_BYTES, slots, "gpu-cull")?;
        self.set_layout = made.set_layout;
        self.layout = made.layout;
        self.pool = made.pool;
        for (slot, set) in self.slots.iter_mut().zip(made.sets) {
            slot.set = set;
        }
        for (i, slot) in self.slots.iter().enumerate() {
            self.write_set(ctx, i, slot, frame_ubos[i]);
        }
        let module = if subgroup_ballots(ctx) {
            &shaders::GPU_CULL_COMP
        } else {
            &shaders::GPU_CULL_PLAIN_COMP
        };
        self.pipeline = compute_pipeline(ctx, self.layout, &module.words(), "gpu-cull")?;
        Ok(())
    }

    /// Points slot `i`'s descriptor set at its buffers, the pass's shared
    /// ones and the frame's uniforms (`ubo`).
    fn write_set(&self, ctx: &Context, i: usize, slot: &Slot, ubo: &Buffer) {
        let info = |b: &Buffer| {
            [vk::DescriptorBufferInfo::default()
                .buffer(b.buffer)
                .range(vk::WHOLE_SIZE)]
        };
        let pyramid = self.pyramid.as_ref();
        let infos = [
            info(&slot.volumes),
            info(&self.instances),
            info(&self.prims),
            info(&slot.commands),
            info(&slot.counts),
            info(&slot.visible),
            info(ubo),
            info(pyramid.map_or(&self.placeholder, |p| p.buffer(i))),
            info(pyramid.map_or(&self.placeholder, |p| p.level_buffer())),
            info(&self.visibility),
            info(&self.lod_levels),
            info(&self.lod_errors),
            info(&self.early),
        ];
        let writes: Vec<vk::WriteDescriptorSet> = infos
            .iter()
            .enumerate()
            .map(|(b, buffer)| {
                let ty = match UNIFORM_BINDINGS.contains(&(b as u32)) {
                    true => vk::DescriptorType::UNIFORM_BUFFER,
                    false => vk::DescriptorType::STORAGE_BUFFER,
                };
                vk::WriteDescriptorSet::default()
                    .dst_set(slot.set)
                    .dst_binding(b as u32)
                    .descriptor_type(ty)
                    .buffer_info(buffer)
            })
            .collect();
        // SAFETY: the set is not in use (just created) and every buffer is
        // live and owned by this pass or the frame.
        unsafe { ctx.device.update_descriptor_sets(&writes, &[]) };
    }

    /// The visible buffer of `slot` (the scene vertex shader's binding 2 in
    /// place of the CPU-written list).
    pub fn visible(&self, slot: usize) -> &Buffer {
        &self.slots[slot].visible
    }

    /// Writes `slot`'s volumes for the coming frame (the slot's previous
    /// frame has finished: its fence was waited on).
    pub fn upload(
        &mut self,
        slot: usize,
        mut data: VolumeData,
        lod: LodFrame,
        origin: glam::DVec3,
    ) -> Result<()> {
        if let Some(axes) = &self.split_axes {
            axes.write(origin, &mut data);
        }
        if self.inset {
            match &self.inset_lists {
                Some(lists) => lists.write(origin, &mut data),
                None => data.inset_info = [2, 0, 0, 0],
            }
        }
        self.lod_k = lod.k as f32;
        self.eye_slack = lod.eye_slack as f32;
        let groups = self.instance_count.div_ceil(GROUP).max(1);
        data.counts = [self.instance_count, groups.min(ROW) * GROUP, 0, 0];
        self.slots[slot]
            .volumes
            .write(0, as_bytes(std::slice::from_ref(&data)))
    }

    /// Sets the size the views the pyramid is built from are drawn at this
    /// frame, within the size the pyramid was made for (`aq` draws from the
    /// targets' top-left corner at a smaller size). The pyramid still
    /// reduces the whole targets: past the drawn area lie older frames'
    /// depths, and since each texel keeps its footprint's farthest depth, a
    /// texel straddling the area's edge can only hide less than the drawn
    /// depths alone would, never more.
    pub fn set_occlusion_size(&mut self, size: vk::Extent2D) {
        if let Some(p) = &self.pyramid {
            let max = p.extent();
            self.extent = vk::Extent2D {
                width: size.width.clamp(1, max.width),
                height: size.height.clamp(1, max.height),
            };
        }
    }

    /// Whether the two-phase occlusion scheme runs.
    pub fn occlusion(&self) -> bool {
        self.pyramid.is_some()
    }

    /// Command sets per frame: two with occlusion (early, late), a far
    /// field (near, far) or the inset's lists (wide, inset), else one.
    fn sets(&self) -> usize {
        if self.occlusion() || self.far_field || self.inset {
            2
        } else {
            1
        }
    }

    /// Sets how the coming frame divides its instances between the near
    /// views and the far pass (only with a far field).
    pub fn set_far_split(&mut self, split: FarSplit) {
        (self.far_mode, self.split_axes) = match split {
            _ if !self.far_field => (0, None),
            FarSplit::AllNear => (0, None),
            FarSplit::At(axes) => (1, Some(axes)),
            FarSplit::Both => (2, None),
        };
    }

    /// Whether the inset views draw the second command set (`inset`).
    pub fn inset_lists(&self) -> bool {
        self.inset
    }

    /// Where the blended draws' instance ids start in the visible buffer
    /// (their draws' first instance is this plus their offset in the ids).
    pub fn blended_base(&self) -> u32 {
        self.blended_base
    }

    /// Sets the coming frame's blended instance ids (in draw order, at
    /// most the room made for them), which [`GpuCull::record`] writes
    /// after the cull's ranges of the slot's visible buffer.
    pub fn set_blended(&mut self, ids: &[u32]) {
        self.blended_ids.clear();
        self.blended_ids.extend_from_slice(ids);
    }

    /// Sets the coming frame's inset lists (only with `inset`; None: every
    /// instance in both sets) and the wide views' `scale` (their pixel
    /// density over the eyes', in (0, 1]): with `lod` the wide views' list
    /// selects its levels, and drops what projects under the bound, at that
    /// density (`view::lod` with the wide view's pixels).
    pub fn set_inset_lists(&mut self, lists: Option<InsetLists>, scale: f64) {
        self.inset_lists = lists.filter(|_| self.inset);
        self.wide_scale = if scale > 0.0 && scale.is_finite() {
            scale.min(1.0) as f32
        } else {
            1.0
        };
    }

    fn dispatch(&self, ctx: &Context, cmd: vk::CommandBuffer, slot: usize, phase: u32) {
        let d = &ctx.device;
        let groups = self.instance_count.div_ceil(GROUP).max(1);
        let (levels, stride) = self
            .pyramid
            .as_ref()
            .map_or((0, 0), |p| (p.level_count(), p.eye_stride()));
        let push = [
            self.cmd_tris.len() as u32,
            phase,
            levels,
            stride,
            self.extent.width,
            self.extent.height,
            self.near.to_bits(),
            self.lod as u32,
            self.lod_k.to_bits(),
            self.eye_slack.to_bits(),
            self.far_mode,
            (self.lod_k * self.wide_scale).to_bits(),
        ];
        let to_draw = [vk::MemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
            .src_access_mask(vk::AccessFlags2::SHADER_STORAGE_WRITE)
            .dst_stage_mask(
                vk::PipelineStageFlags2::DRAW_INDIRECT
                    | vk::PipelineStageFlags2::VERTEX_SHADER
                    | vk::PipelineStageFlags2::COMPUTE_SHADER
                    | vk::PipelineStageFlags2::ALL_TRANSFER,
            )
            .dst_access_mask(
                vk::AccessFlags2::INDIRECT_COMMAND_READ
                    | vk::AccessFlags2::SHADER_STORAGE_READ
                    | vk::AccessFlags2::SHADER_STORAGE_WRITE
                    | vk::AccessFlags2::TRANSFER_READ,
            )];
        // SAFETY: recording outside any rendering scope; the set's buffers
        // belong to this pass and slot (see `record`).
        unsafe {
            d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, self.pipeline);
            d.cmd_bind_descriptor_sets(
                cmd,
                vk::PipelineBindPoint::COMPUTE,
                self.layout,
                0,
                &[self.slots[slot].set],
                &[],
            );
            d.cmd_push_constants(
                cmd,
                self.layout,
                vk::ShaderStageFlags::COMPUTE,
                0,
                as_bytes(&push),
            );
            if phase == 1 {
                d.cmd_dispatch_indirect(cmd, self.early.buffer, 0);
            } else {
                d.cmd_dispatch(cmd, groups.min(ROW), groups.div_ceil(ROW), 1);
            }
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().memory_barriers(&to_draw),
            );
        }
    }

    /// Records the (early) cull for `slot`: resets its commands from the
    /// template and its counters to zero, dispatches one thread per
    /// instance, and makes the results visible to the indirect draws, the
    /// vertex shaders and (after the fence) the host. The barrier before
    /// the dispatch also orders the previous frame's late writes of the
    /// visibility buffer before this frame's reads.
    pub fn record(&self, ctx: &Context, cmd: vk::CommandBuffer, q: &mut Queries, slot: usize) {
        let s = &self.slots[slot];
        let d = &ctx.device;
        let phases = self.sets() as u64;
        let n_cmds = self.cmd_tris.len() as u64;
        q.begin_pass(ctx, cmd, "cull-early");
        // Also orders the blended ids' update before the vertex shaders
        // that read them.
        let to_compute = [vk::MemoryBarrier2::default()
            .src_stage_mask(
                vk::PipelineStageFlags2::ALL_TRANSFER | vk::PipelineStageFlags2::COMPUTE_SHADER,
            )
            .src_access_mask(
                vk::AccessFlags2::TRANSFER_WRITE | vk::AccessFlags2::SHADER_STORAGE_WRITE,
            )
            .dst_stage_mask(
                vk::PipelineStageFlags2::COMPUTE_SHADER | vk::PipelineStageFlags2::VERTEX_SHADER,
            )
            .dst_access_mask(
                vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE,
            )];
        // SAFETY: recording into the frame's open command buffer outside any
        // rendering scope; every buffer belongs to this pass and this
        // slot's were last used by the slot's previous frame, whose fence
        // the renderer has waited on.
        unsafe {
            d.cmd_copy_buffer(
                cmd,
                self.template.buffer,
                s.commands.buffer,
                &[vk::BufferCopy {
                    src_offset: 0,
                    dst_offset: 0,
                    size: COMMAND * (phases * n_cmds).max(1),
                }],
            );
            d.cmd_fill_buffer(cmd, s.counts.buffer, 0, vk::WHOLE_SIZE, 0);
            // vkCmdUpdateBuffer takes at most 65,536 bytes a call.
            for (k, chunk) in self.blended_ids.chunks(16_384).enumerate() {
                let at = 4 * (self.blended_base as u64 + 16_384 * k as u64);
                d.cmd_update_buffer(cmd, s.visible.buffer, at, as_bytes(chunk));
            }
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().memory_barriers(&to_compute),
            );
        }
        self.dispatch(ctx, cmd, slot, if self.occlusion() { 1 } else { 0 });
        if !self.occlusion() {
            self.copy_out(ctx, cmd, slot);
        }
        q.end_pass(ctx, cmd);
    }

    /// Copies `slot`'s commands and counters (complete after its last cull
    /// dispatch, whose barrier covers transfer reads) into its readback
    /// buffer for the host, which reads it after the frame's fence.
    fn copy_out(&self, ctx: &Context, cmd: vk::CommandBuffer, slot: usize) {
        let s = &self.slots[slot];
        let (commands_size, counts_size) = sizes(self.cmd_tris.len());
        let to_host = [vk::MemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::ALL_TRANSFER)
            .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
            .dst_stage_mask(vk::PipelineStageFlags2::HOST)
            .dst_access_mask(vk::AccessFlags2::HOST_READ)];
        // SAFETY: outside any rendering scope; the buffers belong to this
        // slot, the regions lie inside them, and the host reads the
        // readback only after the slot's fence.
        unsafe {
            let d = &ctx.device;
            let whole = |size| {
                [vk::BufferCopy {
                    src_offset: 0,
                    dst_offset: 0,
                    size,
                }]
            };
            d.cmd_copy_buffer(
                cmd,
                s.commands.buffer,
                s.readback.buffer,
                &whole(commands_size),
            );
            let counts = [vk::BufferCopy {
                dst_offset: commands_size,
                ..whole(counts_size)[0]
            }];
            d.cmd_copy_buffer(cmd, s.counts.buffer, s.readback.buffer, &counts);
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().memory_barriers(&to_host),
            );
        }
    }

    /// With occlusion, after the early views: builds `slot`'s depth
    /// pyramid and records the late cull (`cull-late`), whose draws the
    /// late views issue ([`GpuCull::record_draws`] with `late`).
    pub fn record_late(&self, ctx: &Context, cmd: vk::CommandBuffer, q: &mut Queries, slot: usize) {
        let Some(pyramid) = &self.pyramid else {
            return;
        };
        pyramid.record(ctx, cmd, q, slot);
        q.begin_pass(ctx, cmd, "cull-late");
        let read_done = [vk::MemoryBarrier2::default()
            .src_stage_mask(
                vk::PipelineStageFlags2::COMPUTE_SHADER | vk::PipelineStageFlags2::DRAW_INDIRECT,
            )
            .src_access_mask(
                vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::INDIRECT_COMMAND_READ,
            )
            .dst_stage_mask(vk::PipelineStageFlags2::ALL_TRANSFER)
            .dst_access_mask(vk::AccessFlags2::TRANSFER_WRITE)];
        let reset_done = [vk::MemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::ALL_TRANSFER)
            .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
            .dst_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
            .dst_access_mask(
                vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE,
            )];
        let header = [EARLY_ROW, 0, 1, 0];
        // SAFETY: outside any rendering scope; the early list belongs to
        // this pass, and the first barrier orders this frame's early
        // dispatch (its indirect read and list reads) before the reset.
        unsafe {
            let d = &ctx.device;
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().memory_barriers(&read_done),
            );
            d.cmd_update_buffer(cmd, self.early.buffer, 0, as_bytes(&header));
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().memory_barriers(&reset_done),
            );
        }
        self.dispatch(ctx, cmd, slot, 2);
        self.copy_out(ctx, cmd, slot);
        q.end_pass(ctx, cmd);
    }

    /// Draws every non-blended primitive for view `eye` inside the open
    /// scope with one indirect-count draw each (the count the cull wrote;
    /// the second set's with `late`: the late phase's with occlusion, the
    /// far pass's with a far field, the inset views' with the inset's lists), then the sky when given. Returns the
    /// draw calls recorded outside the indirect ones (the sky);
    /// [`GpuCull::read`] counts the rest.
    pub fn record_draws(
        &self,
        rec: &Recorder,
        pipelines: &HashMap<PipelineKey, vk::Pipeline>,
        sky: Option<vk::Pipeline>,
        eye: u32,
        slot: usize,
        late: bool,
    ) -> u64 {
        let s = &self.slots[slot];
        let n_cmds = self.cmd_tris.len();
        let shift = if late { n_cmds as u64 } else { 0 };
        rec.bind_scene_geometry();
        let mut bound = None;
        for &p in &self.order {
            let key = rec.keys[p as usize];
            if bound != Some(key) {
                rec.bind(pipelines[&key]);
                bound = Some(key);
            }
            rec.push_draw(rec.scene.ranges[p as usize].material, eye);
            let first = self.cmd_first[p as usize] as usize;
            let end = self
                .cmd_first
                .get(p as usize + 1)
                .map_or(n_cmds, |&c| c as usize);
            for c in first..end {
                let at = shift + c as u64;
                // SAFETY: inside a rendering scope with a scene pipeline and
                // the scene's buffers bound; the command and count lie inside
                // this slot's buffers, written by the cull and made visible to
                // the indirect stage by its barrier; VK_KHR_draw_indirect_count
                // is enabled.
                unsafe {
                    rec.ctx.device.cmd_draw_indexed_indirect_count(
                        rec.cmd,
                        s.commands.buffer,
                        COMMAND * at,
                        s.counts.buffer,
                        4 * at,
                        1,
                        COMMAND as u32,
                    )
                };
            }
        }
        match sky {
            Some(sky) => {
                rec.draw_fullscreen(sky, eye);
                1
            }
            None => 0,
        }
    }

    /// What `slot`'s last frame drew and counted; call once its fence has
    /// signalled.
    pub fn read(&mut self, slot: usize) -> Result<Drawn> {
        let s = &mut self.slots[slot];
        let words = |b: &mut Buffer| -> Result<Vec<u32>> {
            let m = b
                .mapped()
                .ok_or_else(|| Error::Gpu("gpu-cull readback is not mapped".into()))?;
            Ok(m.chunks_exact(4)
                .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                .collect())
        };
        let n = self.cmd_tris.len();
        let mut commands = words(&mut s.readback)?;
        let counts = commands.split_off(sizes(n).0 as usize / 4);
        let phases = self.sets();
        let mut out = Drawn::default();
        for c in 0..phases * n {
            let instances = commands[5 * c + 1] as u64;
            let tris = instances * self.cmd_tris[c % n];
            if self.far_field && c >= n {
                out.far_draws += counts[c] as u64;
            } else {
                out.draws += counts[c] as u64;
            }
            out.instances += instances;
            out.triangles += tris;
            out.cull.lod_triangles[self.cmd_level[c % n] as usize] += tris;
        }
        let c = |k: usize| counts[2 * n + k] as u64;
        out.cull = GpuCullStats {
            tested: c(0),
            tested_early: c(6),
            passed_frustum: c(1),
            drawn_early: c(2),
            drawn_late: c(3),
            occluded: c(4),
            lod_dropped: c(5),
            lod_triangles: out.cull.lod_triangles,
        };
        Ok(out)
    }

    /// The resident buffer of instance boxes (moved instances are copied
    /// into it).
    pub fn boxes(&self) -> vk::Buffer {
        self.instances.buffer
    }

    /// The box record of an instance of `mesh` with world bounds `b` under
    /// `transform` ([`box_record`] with the mesh's primitive slice).
    pub fn box_of(&self, mesh: u32, b: &WorldBounds, transform: &DAffine3) -> [f32; 12] {
        box_record(self.slices[mesh as usize], b, transform)
    }

    /// Destroys the pass; the device must be idle.
    pub fn destroy(self, ctx: &Context) {
        // SAFETY: the device is idle; null handles are ignored by Vulkan.
        unsafe {
            ctx.device.destroy_pipeline(self.pipeline, None);
            ctx.device.destroy_descriptor_pool(self.pool, None);
            ctx.device.destroy_pipeline_layout(self.layout, None);
            ctx.device
                .destroy_descriptor_set_layout(self.set_layout, None);
        }
        for s in self.slots {
            for b in [s.volumes, s.commands, s.counts, s.visible, s.readback] {
                b.destroy(ctx);
            }
        }
        for b in [
            self.instances,
            self.prims,
            self.template,
            self.visibility,
            self.placeholder,
            self.early,
            self.lod_levels,
            self.lod_errors,
        ] {
            b.destroy(ctx);
        }
        if let Some(p) = self.pyramid {
            p.destroy(ctx);
        }
    }
}
