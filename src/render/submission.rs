//! How the CPU hands draws to the GPU, the two knobs the submission
//! benchmark turns:
//!
//! - **Per-draw data** (`--per-draw`): each draw's material and the start of
//!   its instances in the visible list reach the vertex shader either as
//!   push constants written before the draw (`push`), as a uniform-buffer
//!   record selected by a dynamic offset bound before the draw (`ubo`), or
//!   as a storage-buffer record the shader indexes with the draw's
//!   `firstInstance` (`ssbo`, through `gl_BaseInstance`; nothing is bound
//!   per draw). [`DrawRecords`] holds the records and their descriptor set
//!   (set 1); the three paths draw identical images.
//! - **Parallel recording** (`--record-threads N`): the forward views'
//!   draw list is cut into N contiguous runs, each recorded into its own
//!   secondary command buffer by its own thread (the frame's own thread
//!   records the first run, a rayon pool of N − 1 threads the others; one
//!   command pool per thread and frame slot, as Vulkan requires command
//!   pools to be used by one thread at a time), and the frame's primary
//!   command buffer executes them in order inside the rendering scope
//!   ([`ParallelRecording`]). The order of draws, and so the image, is the
//!   same as recording on one thread.

use super::batches::Draw;
use crate::config::PerDraw;
use crate::error::{Result, VkContext};
use crate::gpu::memory::{Buffer, BufferDesc};
use crate::gpu::pipeline::DescriptorSets;
use crate::gpu::ring::{FrameRing, Garbage};
use crate::gpu::Context;
use ash::vk;
use gpu_allocator::MemoryLocation;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// Bytes of one record: material, first visible slot, two unused words
/// (std140 `uvec4` for the uniform path; the storage path reads the first
/// two words as a `uvec2` at an 8-byte stride).
const UBO_RECORD: u64 = 16;
/// Stride of the storage path's records (std430 `uvec2`).
const SSBO_RECORD: u64 = 8;

/// What a recorder needs to pass per-draw data: the mode, and for `ubo` and
/// `ssbo` the slot's set 1 and the record stride.
#[derive(Clone, Copy, Debug)]
pub struct DrawBinding {
    /// How per-draw data is passed.
    pub mode: PerDraw,
    /// The slot's set 1 (null for `push`).
    pub set: vk::DescriptorSet,
    /// Bytes between consecutive records (the dynamic-offset step for
    /// `ubo`).
    pub stride: u32,
}

impl DrawBinding {
    /// Push constants only: nothing to bind.
    pub fn push() -> DrawBinding {
        DrawBinding {
            mode: PerDraw::Push,
            set: vk::DescriptorSet::null(),
            stride: 0,
        }
    }
}

/// The per-draw records of `--per-draw ubo|ssbo`: one host-visible buffer
/// per frame slot (grown as the draw count needs) and its set 1.
pub struct DrawRecords {
    mode: PerDraw,
    sets: DescriptorSets,
    buffers: Vec<Option<Buffer>>,
    stride: u64,
}

impl DrawRecords {
    /// The records for `mode` over `slots` frame slots (None for `push`,
    /// which needs no buffer). `ssbo` needs the shaderDrawParameters
    /// feature; without it this is one error naming it.
    pub fn new(ctx: &Context, mode: PerDraw, slots: usize) -> Result<Option<DrawRecords>> {
        let (ty, stride) = match mode {
            PerDraw::Push => return Ok(None),
            PerDraw::Ubo => {
                let align = ctx.caps.min_uniform_offset_alignment.max(1);
                (
                    vk::DescriptorType::UNIFORM_BUFFER_DYNAMIC,
                    UBO_RECORD.div_ceil(align) * align,
                )
            }
            PerDraw::Ssbo => {
                if !ctx.caps.shader_draw_parameters {
                    return Err(crate::error::Error::config(
                        "--per-draw",
                        format!(
                            "ssbo indexes records with gl_BaseInstance, and {} lacks the shaderDrawParameters feature; use push or ubo",
                            ctx.device_name
                        ),
                    ));
                }
                (vk::DescriptorType::STORAGE_BUFFER, SSBO_RECORD)
            }
        };
        let sets = DescriptorSets::new(
            ctx,
            &[(ty, 1, vk::ShaderStageFlags::VERTEX)],
            vk::ShaderStageFlags::VERTEX,
            4,
            slots,
            "per-draw records",
        )?;
        Ok(Some(DrawRecords {
            mode,
            sets,
            buffers: (0..slots).map(|_| None).collect(),
            stride,
        }))
    }

    /// The layout of set 1, for the renderer's pipeline layout.
    pub fn set_layout(&self) -> vk::DescriptorSetLayout {
        self.sets.set_layout
    }

    /// How slot `slot`'s draws pass their data.
    pub fn binding(&self, slot: usize) -> DrawBinding {
        DrawBinding {
            mode: self.mode,
            set: self.sets.sets[slot],
            stride: self.stride as u32,
        }
    }

    /// Slot `slot`'s records for `draws` draws, to be filled: its buffer
    /// grown (and its set rewritten) when it is too small, the old buffer
    /// destroyed once the frames using it are done. The slot's previous
    /// frame must be done.
    pub fn space(
        &mut self,
        ctx: &Context,
        ring: &mut FrameRing,
        slot: usize,
        draws: usize,
    ) -> Result<RecordSpace<'_>> {
        let need = (draws.max(1) as u64) * self.stride;
        if self.buffers[slot].as_ref().is_none_or(|b| b.size < need) {
            self.grow(ctx, ring, slot, need)?;
        }
        let stride = self.stride as usize;
        let buffer = self.buffers[slot].as_mut().expect("allocated above");
        let bytes = buffer.mapped().ok_or_else(|| {
            crate::error::Error::Gpu("the per-draw record buffer is not host-visible".into())
        })?;
        Ok(RecordSpace {
            bytes: &mut bytes[..draws * stride],
            stride,
        })
    }

    fn grow(&mut self, ctx: &Context, ring: &mut FrameRing, slot: usize, need: u64) -> Result<()> {
        let usage = match self.mode {
            PerDraw::Ubo => vk::BufferUsageFlags::UNIFORM_BUFFER,
            _ => vk::BufferUsageFlags::STORAGE_BUFFER,
        };
        let buffer = Buffer::new(
            ctx,
            &BufferDesc {
                name: "per-draw records",
                size: need.next_power_of_two().max(4096),
                usage,
                location: MemoryLocation::CpuToGpu,
                category: "per-frame",
            },
        )?;
        let (ty, range) = match self.mode {
            PerDraw::Ubo => (vk::DescriptorType::UNIFORM_BUFFER_DYNAMIC, UBO_RECORD),
            _ => (vk::DescriptorType::STORAGE_BUFFER, vk::WHOLE_SIZE),
        };
        let info = [vk::DescriptorBufferInfo {
            buffer: buffer.buffer,
            offset: 0,
            range,
        }];
        let write = vk::WriteDescriptorSet::default()
            .dst_set(self.sets.sets[slot])
            .dst_binding(0)
            .descriptor_type(ty)
            .buffer_info(&info);
        // SAFETY: the set belongs to this slot, whose previous frame is done
        // (the caller's contract); the buffer is alive.
        unsafe { ctx.device.update_descriptor_sets(&[write], &[]) };
        if let Some(old) = self.buffers[slot].replace(buffer) {
            ring.defer(Garbage::Buffer(old));
        }
        Ok(())
    }

    /// Destroys the buffers and the sets; the device must be idle.
    pub fn destroy(self, ctx: &Context) {
        for b in self.buffers.into_iter().flatten() {
            b.destroy(ctx);
        }
        self.sets.destroy(ctx);
    }
}

/// Room for the records of a run of draws, to be filled by one thread.
pub struct RecordSpace<'a> {
    bytes: &'a mut [u8],
    stride: usize,
}

impl<'a> RecordSpace<'a> {
    /// Writes the records of `draws` (as many as this space holds):
    /// `material_of` gives a draw's material, the instances start at its
    /// `first`.
    pub fn fill(&mut self, draws: &[Draw], material_of: impl Fn(&Draw) -> u32) {
        debug_assert_eq!(
            self.bytes.len() / self.stride,
            draws.len(),
            "one record per draw"
        );
        for (record, d) in self.bytes.chunks_exact_mut(self.stride).zip(draws) {
            record[..4].copy_from_slice(&material_of(d).to_le_bytes());
            record[4..8].copy_from_slice(&d.first.to_le_bytes());
        }
    }

    /// Cuts the space into the `runs` runs [`run_of`] makes of its draws,
    /// one per recording thread.
    pub fn split(self, runs: usize) -> Vec<RecordSpace<'a>> {
        let len = self.bytes.len() / self.stride;
        let mut rest = self.bytes;
        let mut out = Vec::with_capacity(runs);
        for t in 0..runs {
            let (head, tail) = rest.split_at_mut(run_of(len, runs, t).len() * self.stride);
            out.push(RecordSpace {
                bytes: head,
                stride: self.stride,
            });
            rest = tail;
        }
        out
    }
}

/// The formats and state a rendering scope has, which the secondary
/// command buffers executed inside it must declare.
#[derive(Clone, Copy, Debug)]
pub struct ScopeFormat {
    /// Multiview mask (0: one view).
    pub view_mask: u32,
    /// The colour attachment's format.
    pub color: vk::Format,
    /// The depth-stencil attachment's format.
    pub depth: vk::Format,
    /// Samples per pixel.
    pub samples: u32,
    /// The pipeline statistics of the query active around the scope.
    pub stats: Option<vk::QueryPipelineStatisticFlags>,
}

/// How long the recording threads of one frame worked, in milliseconds:
/// their own times summed (what one thread would take if nothing slowed
/// down in company) and the slowest one's (what the frame waits for).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct ThreadTimes {
    /// The threads' recording times, summed.
    pub sum: f64,
    /// The slowest thread's recording time.
    pub slowest: f64,
}

/// One recording thread's command pool for one frame slot, and its
/// secondary command buffers (one per rendering scope: two in two-pass).
struct ThreadBuffers {
    pool: vk::CommandPool,
    cmds: [vk::CommandBuffer; 2],
}

/// Longest time the recording threads spin after [`ParallelRecording::wake`]
/// waiting for [`ParallelRecording::record`] before going back to sleep: a
/// cap for frames whose preparation takes that long (they stop as soon as
/// the recording starts, or the frame fails).
const WAKE_SPIN: std::time::Duration = std::time::Duration::from_millis(20);

/// Recording threads woken by [`ParallelRecording::wake`]: dropping it
/// lets them stop spinning.
pub struct Woken(Arc<AtomicBool>);

impl Drop for Woken {
    fn drop(&mut self) {
        self.0.store(true, Ordering::Release);
    }
}

/// Parallel recording of a frame's forward draws into secondary command
/// buffers (see the module documentation): thread t records run t of the
/// draw list for every scope; thread 0 is the caller's, the others are
/// pool threads.
pub struct ParallelRecording {
    threads: usize,
    /// The threads besides the caller's (None with one thread).
    workers: Option<rayon::ThreadPool>,
    /// Set when the draws are ready: the threads woken early stop spinning.
    ready: Arc<AtomicBool>,
    /// Per frame slot, per thread.
    slots: Vec<Vec<ThreadBuffers>>,
    /// Per frame slot, per scope: the secondaries in execution order.
    by_scope: Vec<[Vec<vk::CommandBuffer>; 2]>,
}

/// What a run's recording needs to know: which scope, which run of draws,
/// whether it is the scope's first or last.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Chunk {
    /// The recording thread (and run).
    pub thread: usize,
    /// The rendering scope (0, or the eye in two-pass).
    pub scope: usize,
    /// The run of the frame's draw list.
    pub run: std::ops::Range<usize>,
    /// The scope's first run (it also draws the passes that precede the
    /// scene: stencil mask, RDM checkerboard).
    pub first: bool,
    /// The scope's last run (the sky when it comes after every draw, and
    /// the passes that follow the scene).
    pub last: bool,
}

impl ParallelRecording {
    /// `threads` recording threads (the caller's and `threads` − 1 pool
    /// threads) with their command pools for `slots` frame slots.
    pub fn new(ctx: &Context, threads: usize, slots: usize) -> Result<ParallelRecording> {
        let threads = threads.max(1);
        let workers = if threads > 1 {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads - 1)
                .thread_name(|i| format!("vergence-record-{}", i + 1))
                .build()
                .map_err(|e| {
                    crate::error::Error::Gpu(format!("starting recording threads: {e}"))
                })?;
            Some(pool)
        } else {
            None
        };
        let mut made = ParallelRecording {
            threads,
            workers,
            ready: Arc::new(AtomicBool::new(true)),
            slots: Vec::new(),
            by_scope: Vec::new(),
        };
        for _ in 0..slots {
            let mut per_thread = Vec::new();
            for _ in 0..threads {
                match Self::thread_buffers(ctx) {
                    Ok(t) => per_thread.push(t),
                    Err(e) => {
                        made.slots.push(per_thread);
                        made.destroy(ctx);
                        return Err(e);
                    }
                }
            }
            made.by_scope
                .push([0, 1].map(|scope| per_thread.iter().map(|t| t.cmds[scope]).collect()));
            made.slots.push(per_thread);
        }
        Ok(made)
    }

    fn thread_buffers(ctx: &Context) -> Result<ThreadBuffers> {
        let d = &ctx.device;
        // SAFETY: plain object creation on a live device; the pool is
        // destroyed if allocating from it fails.
        unsafe {
            let pool = d
                .create_command_pool(
                    &vk::CommandPoolCreateInfo::default().queue_family_index(ctx.queue_family),
                    None,
                )
                .vk("creating a recording thread's command pool")?;
            let cmds = d.allocate_command_buffers(
                &vk::CommandBufferAllocateInfo::default()
                    .command_pool(pool)
                    .level(vk::CommandBufferLevel::SECONDARY)
                    .command_buffer_count(2),
            );
            match cmds {
                Ok(c) => Ok(ThreadBuffers {
                    pool,
                    cmds: [c[0], c[1]],
                }),
                Err(r) => {
                    d.destroy_command_pool(pool, None);
                    Err(crate::error::Error::Vulkan {
                        context: "allocating secondary command buffers".into(),
                        result: r,
                    })
                }
            }
        }
    }

    /// Recording threads (and runs of draws per scope).
    pub fn threads(&self) -> usize {
        self.threads
    }

    /// The secondary command buffers of slot `slot`'s scope `scope`, in
    /// execution order.
    pub fn commands(&self, slot: usize, scope: usize) -> &[vk::CommandBuffer] {
        &self.by_scope[slot][scope]
    }

    /// Wakes the pool's recording threads ahead of
    /// [`ParallelRecording::record`] (call it when the frame begins, before
    /// batching): each spins until
    /// the draws are ready, at most [`WAKE_SPIN`], so the recording does not
    /// wait for threads the OS has to wake first. Their cores are busy
    /// meanwhile.
    /// The returned guard lets them go when dropped (as
    /// [`ParallelRecording::record`] does), so a frame that fails before
    /// recording does not keep them spinning.
    pub fn wake(&self) -> Woken {
        self.ready.store(false, Ordering::Release);
        let ready = self.ready.clone();
        if let Some(workers) = &self.workers {
            workers.spawn_broadcast(move |_| {
                let t = Instant::now();
                while !ready.load(Ordering::Acquire) && t.elapsed() < WAKE_SPIN {
                    std::hint::spin_loop();
                }
            });
        }
        Woken(self.ready.clone())
    }

    /// Records slot `slot`'s secondaries: for each rendering scope of
    /// format `format[scope]`, `draws` draws cut into one run per thread,
    /// and on thread t `f(chunk, cmd)` records run t into `cmd` (begun to
    /// continue the scope, ended after). Run 0 is recorded on the calling
    /// thread while the pool records the others, and the caller then spins
    /// (yielding) until they are done rather than sleeping on a lock it
    /// would have to be woken from. The slot's previous frame must be done.
    /// Returns the draw calls `f` reports, summed, and the threads' timing.
    pub fn record<F>(
        &self,
        ctx: &Context,
        slot: usize,
        format: &[ScopeFormat],
        draws: usize,
        f: F,
    ) -> Result<(u64, ThreadTimes)>
    where
        F: Fn(&Chunk, vk::CommandBuffer) -> u64 + Sync,
    {
        self.ready.store(true, Ordering::Release);
        let buffers = &self.slots[slot];
        let threads = self.threads;
        let run = |t: usize| -> Result<(u64, f64)> {
            let t_start = Instant::now();
            let tb = &buffers[t];
            let d = &ctx.device;
            // SAFETY: the pool belongs to this thread for this slot, whose
            // previous frame is done (the caller's contract).
            unsafe { d.reset_command_pool(tb.pool, vk::CommandPoolResetFlags::empty()) }
                .vk("resetting a recording thread's command pool")?;
            let mut calls = 0;
            for (scope, fmt) in format.iter().enumerate() {
                let colors = [fmt.color];
                let mut rendering = vk::CommandBufferInheritanceRenderingInfo::default()
                    .view_mask(fmt.view_mask)
                    .color_attachment_formats(&colors)
                    .depth_attachment_format(fmt.depth)
                    .stencil_attachment_format(crate::gpu::pipeline::stencil_format(fmt.depth))
                    .rasterization_samples(vk::SampleCountFlags::from_raw(fmt.samples));
                let inheritance = vk::CommandBufferInheritanceInfo::default()
                    .pipeline_statistics(fmt.stats.unwrap_or_default())
                    .push_next(&mut rendering);
                let begin = vk::CommandBufferBeginInfo::default()
                    .flags(
                        vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT
                            | vk::CommandBufferUsageFlags::RENDER_PASS_CONTINUE,
                    )
                    .inheritance_info(&inheritance);
                let cmd = tb.cmds[scope];
                // SAFETY: the buffer was reset with its pool above and is
                // used by this thread only.
                unsafe { d.begin_command_buffer(cmd, &begin) }
                    .vk("beginning a secondary command buffer")?;
                let chunk = Chunk {
                    thread: t,
                    scope,
                    run: run_of(draws, threads, t),
                    first: t == 0,
                    last: t + 1 == threads,
                };
                calls += f(&chunk, cmd);
                // SAFETY: begun above.
                unsafe { d.end_command_buffer(cmd) }.vk("ending a secondary command buffer")?;
            }
            Ok((calls, t_start.elapsed().as_secs_f64() * 1e3))
        };
        // Every run adds its outcome to one tally: no per-frame allocation.
        let tally: Mutex<(u64, ThreadTimes, Option<crate::error::Error>)> =
            Mutex::new((0, ThreadTimes::default(), None));
        let keep = |r: Result<(u64, f64)>| {
            let mut t = tally.lock().unwrap_or_else(|e| e.into_inner());
            match r {
                Ok((c, ms)) => {
                    t.0 += c;
                    t.1.sum += ms;
                    t.1.slowest = t.1.slowest.max(ms);
                }
                Err(e) => {
                    t.2.get_or_insert(e);
                }
            }
        };
        match &self.workers {
            None => keep(run(0)),
            Some(workers) => {
                let done = AtomicUsize::new(0);
                workers.in_place_scope(|scope| {
                    // One call per pool thread, all started at once (a
                    // broadcast), rather than a parallel iterator whose
                    // work splitting starts the threads one after another.
                    scope.spawn_broadcast(|_, b| {
                        let _counted = Finished(&done);
                        keep(run(b.index() + 1));
                    });
                    keep(run(0));
                    wait_for(&done, threads - 1);
                });
            }
        }
        let (calls, times, error) = tally.into_inner().unwrap_or_else(|e| e.into_inner());
        if let Some(e) = error {
            return Err(e);
        }
        Ok((calls, times))
    }

    /// Destroys the command pools (and their buffers); the device must be
    /// idle.
    pub fn destroy(self, ctx: &Context) {
        for t in self.slots.into_iter().flatten() {
            // SAFETY: the device is idle; the pool belongs to `self`.
            unsafe { ctx.device.destroy_command_pool(t.pool, None) };
        }
    }
}

/// Counts a pool thread's run as finished when dropped, also when the run
/// panics (rayon then passes the panic on when the scope ends), so
/// [`wait_for`] cannot wait forever.
struct Finished<'a>(&'a AtomicUsize);

impl Drop for Finished<'_> {
    fn drop(&mut self) {
        self.0.fetch_add(1, Ordering::Release);
    }
}

/// Spins until `done` reaches `n`, yielding the core after the first
/// microseconds so that on a machine with fewer cores than recording
/// threads the ones still recording get to run.
fn wait_for(done: &AtomicUsize, n: usize) {
    let mut spins = 0u32;
    while done.load(Ordering::Acquire) < n {
        if spins < 2048 {
            spins += 1;
            std::hint::spin_loop();
        } else {
            std::thread::yield_now();
        }
    }
}

/// Run `t` of `len` draws cut into `threads` runs: contiguous and as even
/// as the division allows, so the runs in order are the draw list in order.
pub fn run_of(len: usize, threads: usize, t: usize) -> std::ops::Range<usize> {
    let (q, r) = (len / threads, len % threads);
    let start = t * q + t.min(r);
    start..start + q + usize::from(t < r)
}

/// Where the sky, due before draw `at` of a list of `len` draws (`at` =
/// `len`: after the last), falls in the run `run` of that list: its index
/// inside the run, or None when another run draws it. The `last` run draws
/// it when it comes after every draw.
pub fn sky_in_run(
    at: usize,
    len: usize,
    run: &std::ops::Range<usize>,
    last: bool,
) -> Option<usize> {
    let owns = run.contains(&at) || (at >= len && last);
    owns.then(|| at.min(len) - run.start)
}

#[cfg(test)]
mod tests {
    use super::{run_of, sky_in_run, RecordSpace};
    use crate::render::batches::Draw;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn records_written_per_run_equal_records_written_at_once(
            len in 0usize..700,
            runs in 1usize..20,
            stride in prop::sample::select(vec![8usize, 16, 64, 256]),
        ) {
            let draws: Vec<Draw> = (0..len as u32)
                .map(|i| Draw { primitive: i % 13, first: 3 * i, count: 1 })
                .collect();
            let material = |d: &Draw| d.primitive * 7 + 1;
            let mut whole = vec![0u8; len * stride];
            RecordSpace { bytes: &mut whole, stride }.fill(&draws, material);
            let mut parts = vec![0u8; len * stride];
            let spaces = RecordSpace { bytes: &mut parts, stride }.split(runs);
            prop_assert_eq!(spaces.len(), runs);
            for (t, mut space) in spaces.into_iter().enumerate() {
                space.fill(&draws[run_of(len, runs, t)], material);
            }
            prop_assert!(whole == parts);
            if len > 0 {
                let last = (len - 1) * stride;
                prop_assert_eq!(&whole[last..last + 4], &material(&draws[len - 1]).to_le_bytes());
                prop_assert_eq!(&whole[last + 4..last + 8], &(3 * (len as u32 - 1)).to_le_bytes());
            }
        }

        #[test]
        fn exactly_one_run_draws_the_sky_where_it_belongs(
            len in 0usize..3000,
            chunks in 1usize..40,
            pick in 0.0f64..=1.0,
        ) {
            let at = ((len as f64) * pick) as usize;
            let owners: Vec<(usize, usize)> = (0..chunks)
                .filter_map(|c| {
                    let run = run_of(len, chunks, c);
                    sky_in_run(at, len, &run, c + 1 == chunks).map(|i| (c, run.start + i))
                })
                .collect();
            prop_assert_eq!(owners.len(), 1, "at {} of {}: {:?}", at, len, owners);
            prop_assert_eq!(owners[0].1, at);
        }

        #[test]
        fn runs_partition_the_list_in_order(len in 0usize..5000, threads in 1usize..65) {
            let mut next = 0;
            let mut sizes = Vec::new();
            for t in 0..threads {
                let r = run_of(len, threads, t);
                prop_assert_eq!(r.start, next);
                next = r.end;
                sizes.push(r.len());
            }
            prop_assert_eq!(next, len);
            let (lo, hi) = (sizes.iter().min().unwrap(), sizes.iter().max().unwrap());
            prop_assert!(hi - lo <= 1);
        }
    }
}
