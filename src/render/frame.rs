//! One frame's CPU side: moving instances, batching, writing the slot's
//! uniforms and lists, recording (the plan, the recording threads'
//! secondaries, the read-back and the output copy) and submitting.

use super::*;

impl Renderer {
    /// Moves instances for the next recorded frame: each of `moved` (its
    /// transform, and its world bounds in `bounds`, one per entry) replaces
    /// the instance's record on the GPU (and its box with `gpu-cull`) by a
    /// copy at the start of that frame; the others are not touched.
    pub fn move_instances(
        &mut self,
        moved: &[crate::scene::motion::Moved],
        bounds: &[crate::scene::WorldBounds],
    ) -> Result<()> {
        if moved.len() != bounds.len() {
            return Err(Error::config(
                "scene motion",
                format!(
                    "{} moved instances with {} bounds",
                    moved.len(),
                    bounds.len()
                ),
            ));
        }
        for (m, b) in moved.iter().zip(bounds) {
            instance_updates::check_index(m.index, self.instance_count)?;
            self.batcher.move_instance(m.index, b.center, b.radius);
        }
        if let Some(blended) = self.blended.as_mut() {
            let boxes: Vec<_> = moved
                .iter()
                .zip(bounds)
                .map(|(m, b)| (m.index, (b.min, b.max)))
                .collect();
            blended.move_instances(&boxes)?;
        }
        let gpu = self.passes.gpu_cull.as_ref();
        let boxes = |m: &crate::scene::motion::Moved, b: &crate::scene::WorldBounds| {
            gpu.map_or([0.0; instance_updates::BOX_FLOATS], |g| {
                g.box_of(m.mesh, b, &m.transform)
            })
        };
        self.updates
            .stage(moved, bounds, gpu.is_some().then_some(&boxes as _));
        Ok(())
    }

    /// Builds the scene pipelines that clip against the section plane (the
    /// first frame with a plane; later ones find them).
    pub(super) fn ensure_section_pipelines(&mut self) -> Result<()> {
        let mut passes = std::mem::take(&mut self.passes);
        let setup = self.pipeline_setup();
        let mut built = passes.forward.ensure_clipped(&setup);
        if let (Ok(()), Some(wide)) = (&built, passes.inset_wide.as_mut()) {
            built = wide.ensure_clipped(&setup);
        }
        if let (Ok(()), Some(far)) = (&built, passes.far.as_mut()) {
            built = far.ensure_clipped(&setup);
        }
        self.passes = passes;
        built
    }

    /// Batches and records one stereo frame of `rig` (the command buffer
    /// stays open); [`Renderer::submit_frame`] completes it. With
    /// `gpu-cull` the GPU culls and `visible` must be None.
    pub fn record_frame(&mut self, rig: &StereoRig, visible: Option<&[u32]>) -> Result<()> {
        for v in &rig.views {
            v.pose
                .validate()
                .map_err(|m| Error::config("view pose", m))?;
            v.fov.validate().map_err(|m| Error::config("view fov", m))?;
        }
        self.check_frame(rig, visible)?;
        self.place_inset(rig);
        // The slot's previous frame must be done before its buffers are
        // written: with N frames in flight, this waits for frame n - N.
        let t_wait = Instant::now();
        let slot = self.slot;
        let cmd = self.begin_slot(slot)?;
        let mut stats = FrameStats::default();
        self.prepare_slot(slot, cmd, &mut stats)?;
        // Released (the threads stop spinning) when this frame's recording
        // ends, whether it gets to the threads or not.
        let _woken = self.parallel.as_ref().map(ParallelRecording::wake);
        let t0 = Instant::now();
        stats.cpu_ms.wait = ms(t_wait, t0) + std::mem::take(&mut self.slot_wait_ms);
        let mut batches = std::mem::take(&mut self.batches);
        self.batch(rig, visible, &mut batches)?;
        self.count_drawn(&batches, &mut stats);
        self.upload_lists(slot, rig, &batches)?;
        self.frame_index += 1;
        let data = self.frame_data(rig);
        self.per_slot[slot]
            .ubo
            .write(0, as_bytes(std::slice::from_ref(&data)))?;
        let prepare = passes::technique::Prepare {
            slot,
            rig,
            config: &self.config,
        };
        for t in &mut self.passes.techniques {
            t.prepare(&prepare, &mut stats)?;
        }
        let t1 = Instant::now();
        stats.cpu_ms.batch = ms(t0, t1);

        let mut queries = self.per_slot[slot]
            .queries
            .take()
            .expect("queries present until drop");
        // The per-draw records are written by whoever records the draws:
        // the recording threads their runs' records, else this thread.
        let mut records = self.draw_records.take();
        let recorded = (|| -> Result<(u64, Option<submission::ThreadTimes>)> {
            let binding = records
                .as_ref()
                .map_or(DrawBinding::push(), |r| r.binding(slot));
            let space = match records.as_mut() {
                Some(r) => {
                    let ring = self.ring.as_mut().expect("ring present until drop");
                    Some(r.space(&self.ctx, ring, slot, batches.draws.len())?)
                }
                None => None,
            };
            match &self.parallel {
                Some(par) => {
                    let stats_flags = queries.stats_flags();
                    let (n, times) =
                        self.record_secondaries(par, &batches, stats_flags, binding, space)?;
                    Ok((n, Some(times)))
                }
                None => {
                    if let Some(mut space) = space {
                        let ranges = &self.scene().ranges;
                        space.fill(&batches.draws, |d| ranges[d.primitive as usize].material);
                    }
                    Ok((0, None))
                }
            }
        })();
        self.draw_records = records;
        let secondary_calls = match recorded {
            Ok((n, times)) => {
                stats.cpu_ms.record_threads = times;
                n
            }
            Err(e) => {
                self.per_slot[slot].queries = Some(queries);
                self.batches = batches;
                return Err(e);
            }
        };
        queries.reset(&self.ctx, cmd);
        stats.draw_calls = secondary_calls + self.record(cmd, &batches, &mut queries, None);
        stats.cpu_ms.record = ms(t1, Instant::now());
        self.pending = Some(Pending {
            stats,
            queries,
            batches,
            cmd,
        });
        Ok(())
    }

    /// The frame's preconditions: two views, no frame pending, no CPU
    /// list for a GPU-culled renderer.
    fn check_frame(&self, rig: &StereoRig, visible: Option<&[u32]>) -> Result<()> {
        if rig.views.len() != 2 {
            return Err(Error::config(
                "views",
                format!("the stereo renderer takes 2 views, got {}", rig.views.len()),
            ));
        }
        if self.pending.is_some() {
            return Err(Error::Gpu(
                "a frame was recorded but never submitted".into(),
            ));
        }
        if self.passes.gpu_cull.is_some() && visible.is_some() {
            return Err(Error::config(
                "--opt",
                "a gpu-cull renderer culls on the GPU and draws no CPU visible list (e.g. the bench's empty-frame floor): make a CPU-culled configuration the baseline",
            ));
        }
        Ok(())
    }

    /// Places the inset for this frame's views and starts the wide views'
    /// frame (their accumulation's reprojection).
    fn place_inset(&mut self, rig: &StereoRig) {
        if let Some(i) = self.config.effort.inset {
            // Two views (checked above): no allocation in the frame.
            let fovs = [rig.views[0].fov, rig.views[1].fov];
            self.inset_rect = match &self.focus {
                Some(focus) => crate::view::inset::focus_rect(
                    &fovs,
                    focus,
                    self.extent.width,
                    self.extent.height,
                ),
                None => crate::view::inset::inset_rect(
                    &fovs,
                    self.config.effort.gaze,
                    i.half_angle_deg,
                    self.extent.width,
                    self.extent.height,
                ),
            };
            if let Some(pass) = self.passes.inset.as_mut() {
                self.wide_region = pass.wide_region(&self.inset_rect, self.extent);
                pass.begin_frame(
                    [rig.views[0], rig.views[1]],
                    self.config.frame.near,
                    self.extent,
                );
            }
        }
    }

    /// Before the slot's buffers are written: the foveation patterns for
    /// the sizes drawn, the section plane's pipelines, moved instances.
    fn prepare_slot(
        &mut self,
        slot: usize,
        cmd: vk::CommandBuffer,
        stats: &mut FrameStats,
    ) -> Result<()> {
        if let Some(rates) = self.shading_rate.as_mut() {
            // The foveation pattern for the sizes drawn this frame (with
            // lms, the LMS image's only: every scope draws into it).
            match self.passes.lms.as_ref() {
                Some(lms) => {
                    let (layout, c) = lms.geometry();
                    rates.ensure_lms(&self.ctx, layout, c)?;
                }
                None => rates.ensure(&self.ctx, self.extent)?,
            }
            if let Some(inset) = self.passes.inset.as_ref() {
                rates.ensure(&self.ctx, inset.wide_extent(self.extent))?;
            }
        }
        if self.extras.section.is_some() {
            self.ensure_section_pipelines()?;
        }
        if !self.updates.is_empty() {
            let instances = self.scene().instances.buffer;
            let boxes = self.passes.gpu_cull.as_ref().map(GpuCull::boxes);
            let ring = self.ring.as_mut().expect("ring present until drop");
            stats.motion = Some(
                self.updates
                    .record(&self.ctx, ring, slot, cmd, instances, boxes)?,
            );
        }
        Ok(())
    }

    /// This frame's CPU batches into `batches`: with `gpu-cull` only the
    /// blended draws (and the far split's or the inset lists' plan for the
    /// cull); else the far field's split, the inset's two lists, or one
    /// list of `visible`.
    fn batch(
        &mut self,
        rig: &StereoRig,
        visible: Option<&[u32]>,
        batches: &mut Batches,
    ) -> Result<()> {
        let gpu_cull = self.passes.gpu_cull.is_some();
        match self.passes.far.as_mut() {
            // The GPU splits near from far: only the plan is made here.
            Some(far) if gpu_cull => {
                *batches = Batches::default();
                let split = if !far.plan(rig, self.extent.width, self.frame_index) {
                    self.mffr_fallbacks += 1;
                    FarSplit::AllNear
                } else if !self.mffr_partition {
                    FarSplit::Both
                } else {
                    far.split_axes(rig).map_or(FarSplit::AllNear, FarSplit::At)
                };
                if let Some(gpu) = self.passes.gpu_cull.as_mut() {
                    gpu.set_far_split(split);
                }
            }
            _ if gpu_cull => {
                *batches = Batches::default();
                // The blended draws, after the opaque ones (the cull's).
                if let (Some(b), Some(gpu)) = (self.blended.as_mut(), self.passes.gpu_cull.as_mut())
                {
                    let base = gpu.blended_base();
                    b.batch(rig, self.frame_index, &mut self.batcher, base, batches)?;
                    gpu.set_blended(&batches.ids);
                }
                // The cull divides the instances between the wide views and
                // the inset as the batcher would.
                let lists = self
                    .inset_volumes(rig)
                    .map(|v| crate::cull::gpu::InsetLists {
                        inset: v.inset,
                        core: v.core,
                    });
                // The wide views' density: the larger of their axes' scales.
                let scale = self.passes.inset.as_ref().map_or(1.0, |pass| {
                    let w = pass.wide_extent(self.extent);
                    let (e, f) = (self.extent, |a: u32, b: u32| a as f64 / b.max(1) as f64);
                    f(w.width, e.width).max(f(w.height, e.height))
                });
                if let Some(gpu) = self.passes.gpu_cull.as_mut() {
                    gpu.set_inset_lists(lists, scale);
                }
            }
            Some(far) => {
                if !far.plan(rig, self.extent.width, self.frame_index) {
                    self.mffr_fallbacks += 1;
                }
                far.build_batches(
                    &mut self.batcher,
                    rig,
                    visible,
                    self.mffr_partition,
                    batches,
                );
            }
            None => match self.inset_volumes(rig) {
                // The inset views draw what their narrower volumes keep;
                // the wide views all but what both cores contain.
                Some(v) => self.batcher.build_inset(
                    visible,
                    rig.head.position,
                    v.core.map(|core| {
                        move |c, r| !core.iter().all(|f| f.planes.contains_sphere(c, r))
                    }),
                    |c, r| v.inset.iter().any(|f| f.planes.keeps_sphere(c, r)),
                    batches,
                ),
                None => self.batcher.build(visible, rig.head.position, batches),
            },
        }
        Ok(())
    }

    /// The instances, triangles and far passes the batches draw.
    fn count_drawn(&self, batches: &Batches, stats: &mut FrameStats) {
        // Counted once per pass family: with a far field its pass draws too
        // (the split batches already hold near + far; unsplit, the far pass
        // draws every batch again).
        let far_field = self
            .passes
            .far
            .as_ref()
            .is_some_and(|f| f.frame().is_some());
        let passes = if far_field && batches.far_start.is_none() {
            2
        } else {
            1
        };
        stats.instances_drawn = passes * batches.instances_drawn;
        stats.triangles = passes * batches.triangles;
        stats.far_passes = self
            .passes
            .far
            .as_ref()
            .and_then(|f| f.frame())
            .map_or(0, |f| f.render.iter().filter(|&&r| r).count() as u64);
    }

    /// The slot's lists: with `gpu-cull` the cull's volumes and LOD
    /// density, else the visible instance ids.
    fn upload_lists(&mut self, slot: usize, rig: &StereoRig, batches: &Batches) -> Result<()> {
        if let Some(gpu) = self.passes.gpu_cull.as_mut() {
            let strategy = self
                .config
                .culling
                .cull
                .strategy()
                .ok_or_else(|| Error::config("--opt", "gpu-cull needs a culling strategy"))?;
            let params = crate::cull::CullParams {
                near: self.config.frame.near,
                draw_distance: self.config.culling.draw_distance,
                ..crate::cull::CullParams::default()
            };
            // The volumes relative to the frame uniform's render origin.
            let (data, _) = crate::cull::gpu::volume_data(
                strategy,
                rig,
                self.frame_index,
                &params,
                rig.head.position,
            )
            .map_err(|e| Error::config("view for culling", e.to_string()))?;
            let lod = match self.config.culling.lod {
                Some(bound) => {
                    let e = (self.extent.width, self.extent.height);
                    let eyes: Vec<_> = rig.views.iter().map(|v| (v.fov, e)).collect();
                    let slack = rig
                        .views
                        .iter()
                        .map(|v| (v.pose.position - rig.head.position).length())
                        .fold(0.0, f64::max);
                    LodFrame {
                        k: crate::view::lod::pixel_density(&eyes) / bound,
                        eye_slack: slack,
                    }
                }
                None => LodFrame::default(),
            };
            let drawn = match self.passes.inset.as_ref() {
                Some(inset) => inset.wide_extent(self.extent),
                None => self.extent,
            };
            gpu.set_occlusion_size(drawn);
            gpu.upload(slot, data, lod, rig.head.position)?;
        } else {
            self.ensure_visible_capacity(slot, batches.ids.len())?;
            let ids: &[u8] = as_bytes(&batches.ids);
            self.per_slot[slot]
                .visible
                .as_mut()
                .expect("allocated above")
                .write(0, ids)?;
        }
        Ok(())
    }

    /// Completes the recorded frame: copies it into `output` (the images of
    /// the [`OutputSpec`] given at creation), optionally reads it back (from
    /// `output` when given) and submits it without waiting. Returns the
    /// frame's number ([`FrameStats::frame`]); its statistics come out of
    /// [`Renderer::take_completed`] once the GPU has finished it.
    pub fn submit_frame(&mut self, output: Option<&FrameOutput>, readback: bool) -> Result<u64> {
        let Some(Pending {
            mut stats,
            queries,
            batches,
            cmd,
        }) = self.pending.take()
        else {
            return Err(Error::Gpu("submit_frame without a recorded frame".into()));
        };
        let t1 = Instant::now();
        let slot = self.slot;
        self.per_slot[slot].queries = Some(queries);
        self.batches = batches;
        if let Some(out) = output {
            self.record_output(cmd, out)?;
        }
        if readback {
            self.record_readback(cmd, output)?;
        }
        let t2 = Instant::now();
        stats.cpu_ms.record += ms(t1, t2);
        let submit = self
            .ring
            .as_mut()
            .expect("ring present until drop")
            .submit(&self.ctx);
        let t3 = Instant::now();
        stats.cpu_ms.submit = ms(t2, t3);
        let last_pass = self.per_slot[slot]
            .queries
            .as_ref()
            .map_or("none", |q| q.last_pass());
        submit.map_err(|e| device_lost(e, "submitting a frame", last_pass))?;
        // Only a submitted slot moves on (the ring moves with it).
        self.slot = (slot + 1) % self.slots;
        if crate::gpu::fault::device_lost_frame() == Some(self.frame_index) {
            let injected = Error::Vulkan {
                context: "waiting for frames (injected by VERGENCE_INJECT_FAULT)".into(),
                result: vk::Result::ERROR_DEVICE_LOST,
            };
            return Err(device_lost(
                injected,
                "waiting for the frame to finish",
                last_pass,
            ));
        }
        stats.frame = self.frame_index;
        self.per_slot[slot].in_flight = Some(stats);
        Ok(self.frame_index)
    }

    /// Renders a floor frame (clear only, or one full-screen triangle with a
    /// trivial shader) and returns its GPU milliseconds.
    pub fn render_floor(&mut self, kind: FloorKind) -> Result<f64> {
        self.finish()?;
        let slot = self.slot;
        let cmd = self.begin_slot(slot)?;
        let mut queries = self.per_slot[slot]
            .queries
            .take()
            .expect("queries present until drop");
        queries.reset(&self.ctx, cmd);
        self.record(cmd, &Batches::default(), &mut queries, Some(kind));
        self.ring
            .as_mut()
            .expect("ring present until drop")
            .submit(&self.ctx)?;
        self.ring
            .as_mut()
            .expect("ring present until drop")
            .wait_all(&self.ctx)?;
        let (passes, _) = queries.read(&self.ctx)?;
        self.per_slot[slot].queries = Some(queries);
        self.slot = (slot + 1) % self.slots;
        Ok(passes.iter().map(|p| p.1).sum())
    }

    /// A recorder of this frame slot's draws into `cmd`.
    pub(super) fn recorder(&self, cmd: vk::CommandBuffer) -> Recorder<'_> {
        let draw = self
            .draw_records
            .as_ref()
            .map_or(DrawBinding::push(), |r| r.binding(self.slot));
        self.recorder_with(cmd, draw)
    }

    /// A recorder of this frame slot's draws into `cmd` passing per-draw
    /// data as `draw` says.
    pub(super) fn recorder_with(&self, cmd: vk::CommandBuffer, draw: DrawBinding) -> Recorder<'_> {
        Recorder {
            ctx: &self.ctx,
            cmd,
            layout: self.descriptors.layout,
            set: self.descriptors.sets[self.slot],
            scene: self.scene(),
            keys: &self.batcher.keys,
            vertices: &self.vertices,
            draw,
            section: self.extras.section.is_some(),
            lms: std::cell::Cell::new(None),
        }
    }

    /// Records the forward scopes' contents of this frame slot on the
    /// recording threads, each its run of the draws into its own secondary
    /// per scope (a scope's first run also the stencil mask and the RDM
    /// checkerboard, its last the overlay), for the frame's statistics
    /// query `stats`, passing per-draw data as `draw` says; each thread
    /// first writes its run's records into its part of `space`. Returns the
    /// draw calls and the threads' timing.
    pub(super) fn record_secondaries(
        &self,
        par: &ParallelRecording,
        batches: &Batches,
        stats: Option<vk::QueryPipelineStatisticFlags>,
        draw: DrawBinding,
        space: Option<submission::RecordSpace>,
    ) -> Result<(u64, submission::ThreadTimes)> {
        // (view mask, eye) per scope.
        let scopes: &[(u32, u32)] = match self.config.frame.stereo {
            StereoMode::Multiview => &[(0b11, 0)],
            StereoMode::TwoPass => &[(0, 0), (0, 1)],
        };
        let format = |&(view_mask, _): &(u32, u32)| ScopeFormat {
            view_mask,
            color: attachments::COLOR_FORMAT,
            depth: self.depth_format,
            samples: self.config.frame.msaa,
            stats,
        };
        let formats: Vec<ScopeFormat> = scopes.iter().map(format).collect();
        debug_assert!(batches.far_start.is_none(), "refused with mffr");
        let draws = batches.near_draws();
        // Where the sky goes, found once for every thread.
        let sky = passes::sky_slot(&self.batcher.keys, draws);
        let passes = &self.passes;
        let boxes = self.extras.overlay.len();
        let (extent, slot) = (self.extent, self.slot);
        let spaces: Vec<std::sync::Mutex<submission::RecordSpace>> = space
            .map(|s| s.split(par.threads()))
            .unwrap_or_default()
            .into_iter()
            .map(std::sync::Mutex::new)
            .collect();
        let ranges = &self.scene().ranges;
        par.record(&self.ctx, slot, &formats, draws.len(), |chunk, cmd| {
            if let (0, Some(space)) = (chunk.scope, spaces.get(chunk.thread)) {
                let mut space = space.lock().unwrap_or_else(|e| e.into_inner());
                space.fill(&draws[chunk.run.clone()], |d| {
                    ranges[d.primitive as usize].material
                });
            }
            let rec = self.recorder_with(cmd, draw);
            rec.set_state(extent);
            let eye = scopes[chunk.scope].1;
            let mut calls = 0;
            if chunk.first {
                let hook = passes::technique::ScopeHook {
                    rec: &rec,
                    slot,
                    eye,
                    extent,
                    checkerboard: true,
                    quadrants: 1,
                    lms: None,
                    twins: None,
                    floor: false,
                };
                calls += passes
                    .techniques
                    .iter()
                    .map(|t| t.in_scope(&hook))
                    .sum::<u64>();
            }
            let run = chunk.run.clone();
            calls += passes
                .forward
                .record_run(&rec, draws, run, sky, chunk.last, eye);
            if chunk.last {
                calls += passes.overlay.record(&rec, boxes, eye);
            }
            calls
        })
    }

    pub(super) fn record_readback(
        &mut self,
        cmd: vk::CommandBuffer,
        output: Option<&FrameOutput>,
    ) -> Result<()> {
        if let (true, Some(out)) = (self.quad, output) {
            let sizes = (self.output_extent(), self.inset_extent());
            let ring = self.ring.as_mut().expect("ring present until drop");
            return self.readback.record_quad(&self.ctx, ring, cmd, out, sizes);
        }
        let ring = self.ring.as_mut().expect("ring present until drop");
        let targets = self.targets.as_ref().expect("targets present until drop");
        self.readback.record(
            &self.ctx,
            ring,
            cmd,
            targets,
            (self.extent, self.allocated),
            output,
        )
    }

    /// Copies the resolved colour (and depth) of every set into `out`'s
    /// images, leaving them in the attachment layouts the runtime expects.
    pub(super) fn record_output(
        &mut self,
        cmd: vk::CommandBuffer,
        out: &FrameOutput,
    ) -> Result<()> {
        let copy = self
            .output
            .as_ref()
            .ok_or_else(|| Error::Gpu("the renderer was created without an output".into()))?;
        if self.quad {
            let targets = self.targets();
            let wide = match self.passes.inset.as_ref() {
                Some(p) if p.four_view() => targets
                    .sets
                    .iter()
                    .map(|s| (s.resolve.image, 2, s.resolve.layers))
                    .collect(),
                Some(p) => p
                    .wide
                    .sets
                    .iter()
                    .map(|s| (s.resolve.image, 0, s.resolve.layers))
                    .collect(),
                None => return Err(Error::Gpu("a quad output without the inset pass".into())),
            };
            let src = passes::output::QuadSource {
                wide,
                region: self.wide_region,
                rect: self.inset_rect,
            };
            return copy.record_quad(&self.ctx, cmd, targets, &src, out);
        }
        copy.record(&self.ctx, cmd, self.targets(), self.extent, out)
    }

    pub(super) fn ensure_visible_capacity(&mut self, slot: usize, ids: usize) -> Result<()> {
        let need = (ids.max(1) * 4) as u64;
        if self.per_slot[slot]
            .visible
            .as_ref()
            .is_some_and(|b| b.size >= need)
        {
            return Ok(());
        }
        let size = need.next_power_of_two().max(1024);
        let buf = Buffer::new(
            &self.ctx,
            &BufferDesc {
                name: "visible instances",
                size,
                usage: vk::BufferUsageFlags::STORAGE_BUFFER,
                location: MemoryLocation::CpuToGpu,
                category: "per-frame",
            },
        )?;
        if let Some(old) = self.per_slot[slot].visible.replace(buf) {
            match self.ring.as_mut() {
                Some(r) => r.defer(Garbage::Buffer(old)),
                None => old.destroy(&self.ctx),
            }
        }
        self.write_descriptors(slot);
        Ok(())
    }

    pub(super) fn write_descriptors(&self, slot: usize) {
        let visible = match (&self.passes.gpu_cull, &self.per_slot[slot].visible) {
            (Some(gpu), _) => gpu.visible(slot),
            (None, Some(v)) => v,
            (None, None) => return,
        };
        let mut contents = SetContents {
            frame: &self.per_slot[slot].ubo,
            scene: self.scene(),
            visible,
            hidden: None,
            filled: None,
            far_field: self.passes.far.as_ref().map(FarField::images).or(self
                .passes
                .lms
                .as_ref()
                .and_then(|l| l.images())),
            points: None,
        };
        for t in &self.passes.techniques {
            t.bind(slot, self.targets.as_ref(), &mut contents);
        }
        self.descriptors.write(&self.ctx, slot, &contents);
    }

    pub(super) fn frame_data(&self, rig: &StereoRig) -> FrameUniforms {
        // Views 2 and 3 are the far-field cameras; their near plane is the
        // split distance, so everything nearer is clipped from the far field.
        // With inset's four views they are the wide views: the eyes' poses
        // with the FOVs that put each eye on its region of the layer.
        let (far_views, far_near) = match (&self.passes.far, self.four_view_region()) {
            (Some(f), _) => f.cameras(self.config.frame.near),
            (None, Some(region)) => {
                let wide = |v: &crate::view::View| crate::view::View {
                    fov: crate::view::inset::layer_fov(
                        &v.fov,
                        &region,
                        self.extent.width,
                        self.extent.height,
                    ),
                    ..*v
                };
                let left = &rig.views[0];
                let right = rig.views.get(1).unwrap_or(left);
                (
                    [Some(wide(left)), Some(wide(right))],
                    self.config.frame.near,
                )
            }
            (None, None) => ([None, None], self.config.frame.near),
        };
        let mut u = FrameUniforms::new(rig, self.config.frame.near, far_views, far_near);
        if let Some(sun) = &self.sun {
            u.sun_dir = sun.direction.as_vec3().extend(0.0);
            u.sun_color = glam::Vec3::from_array(sun.color).extend(0.0);
        }
        self.extras.apply(&mut u, rig.head.position);
        u
    }

    /// With `inset`'s four views: where the wide views lie in their layers
    /// this frame (around the inset).
    pub(super) fn four_view_region(&self) -> Option<crate::view::inset::PixelRect> {
        self.four_view.then_some(self.wide_region)
    }

    /// With `inset` (two scopes), each eye's volume through this frame's
    /// inset rectangle: the inset views draw only what one of them keeps
    /// (the rectangle's pixels are all they rasterize); and, where this
    /// renderer composites, each eye's volume through the inset's core:
    /// the wide views skip what both contain (the wide views' hole,
    /// [`crate::view::inset_hole`]). The CPU batcher tests spheres against
    /// them, `gpu-cull` boxes.
    pub(super) fn inset_volumes(&self, rig: &StereoRig) -> Option<InsetVolumes> {
        let inset = self.config.effort.inset?;
        // Four views share one scope and so one list.
        if self.four_view {
            return None;
        }
        let (w, h) = (self.extent.width, self.extent.height);
        let (near, far) = (self.config.frame.near, self.config.culling.draw_distance);
        let volume = |v: &crate::view::View| {
            let t = crate::view::inset::rect_tangents(&v.fov, &self.inset_rect, w, h);
            crate::view::frustum::Frustum::from_tangents(&v.pose, t, near, far).ok()
        };
        let (left, right) = (rig.views.first()?, rig.views.get(1)?);
        // The runtime shows submitted wide views as it likes: no hole then.
        let core = match (&self.passes.inset, self.quad || inset.wide_all) {
            (Some(pass), false) => {
                let wide = pass.wide_extent(self.extent);
                crate::view::inset_hole::core_rect(
                    &self.inset_rect,
                    (w, h),
                    (wide.width, wide.height),
                    crate::view::inset::FEATHER_PX,
                    inset.read_reach(),
                )
                .and_then(|c| {
                    let vol = |v| crate::view::inset_hole::core_volume(v, &c, w, h, near, far);
                    Some([vol(left)?, vol(right)?])
                })
            }
            _ => None,
        };
        Some(InsetVolumes {
            inset: [volume(left)?, volume(right)?],
            core,
        })
    }
}
