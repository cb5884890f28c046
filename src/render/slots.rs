//! The frames in flight: rendering one frame whole, waiting for a slot,
//! collecting each finished frame's statistics and GPU times.

use super::*;

impl Renderer {
    /// Renders one stereo frame of `rig` drawing the instances in `visible`
    /// (None: all), waits for it and returns its statistics. With
    /// `readback`, the frame is copied for [`Renderer::read_images`].
    /// Statistics of earlier frames still waiting in
    /// [`Renderer::take_completed`] are dropped.
    pub fn render(
        &mut self,
        rig: &StereoRig,
        visible: Option<&[u32]>,
        readback: bool,
    ) -> Result<FrameStats> {
        self.record_frame(rig, visible)?;
        let frame = self.submit_frame(None, readback)?;
        let t = Instant::now();
        self.finish()?;
        let waited = ms(t, Instant::now());
        let mut mine = None;
        while let Some(s) = self.completed.pop_front() {
            if s.frame == frame {
                mine = Some(s);
            }
        }
        let mut stats =
            mine.ok_or_else(|| Error::Gpu("a finished frame has no statistics".into()))?;
        stats.cpu_ms.wait += waited;
        Ok(stats)
    }

    /// Frames in flight this renderer was built for.
    pub fn frames_in_flight(&self) -> usize {
        self.slots
    }

    /// The statistics of the oldest frame whose GPU work has finished and
    /// that was not taken yet (GPU times included). Polls the fences of the
    /// frames in flight, oldest first, without waiting.
    pub fn take_completed(&mut self) -> Option<FrameStats> {
        for k in 0..self.slots {
            let s = (self.slot + k) % self.slots;
            if self.per_slot[s].in_flight.is_none() {
                continue;
            }
            let ring = self.ring.as_ref().expect("ring present until drop");
            // A fence that cannot be polled is reported by the next wait.
            if !ring.is_done(&self.ctx, s).unwrap_or(false) || self.collect(s).is_err() {
                break;
            }
        }
        self.completed.pop_front()
    }

    /// Waits until the frame that last used the next frame's slot (frame
    /// n − N with N in flight) has finished, so that everything the next
    /// frame does (culling included) starts after it. Recording waits for
    /// it anyway; the loops call this first to keep culling out of the
    /// overlap with 1 frame in flight.
    pub fn wait_for_slot(&mut self) -> Result<()> {
        let t = Instant::now();
        let slot = self.slot;
        let pass = self.per_slot[slot]
            .queries
            .as_ref()
            .map_or("none", |q| q.last_pass());
        self.ring
            .as_mut()
            .expect("ring present until drop")
            .wait_current(&self.ctx)
            .map_err(|e| device_lost(e, "waiting for a frame slot", pass))?;
        self.collect(slot)?;
        self.slot_wait_ms += ms(t, Instant::now());
        Ok(())
    }

    /// Waits until every submitted frame has finished; their statistics
    /// join [`Renderer::take_completed`] in submission order.
    pub fn finish(&mut self) -> Result<()> {
        let newest = (self.slot + self.slots - 1) % self.slots;
        let pass = self.per_slot[newest]
            .queries
            .as_ref()
            .map_or("none", |q| q.last_pass());
        self.ring
            .as_mut()
            .expect("ring present until drop")
            .wait_all(&self.ctx)
            .map_err(|e| device_lost(e, "waiting for the frames in flight", pass))?;
        for k in 0..self.slots {
            self.collect((self.slot + k) % self.slots)?;
        }
        Ok(())
    }

    /// Waits for `slot`'s previous frame (the ring's fence), moves that
    /// frame's statistics with its GPU times to the completed queue, and
    /// begins the slot's command buffer.
    pub(super) fn begin_slot(&mut self, slot: usize) -> Result<vk::CommandBuffer> {
        let pass = self.per_slot[slot]
            .queries
            .as_ref()
            .map_or("none", |q| q.last_pass());
        let cmd = self
            .ring
            .as_mut()
            .expect("ring present until drop")
            .begin(&self.ctx)
            .map_err(|e| device_lost(e, "waiting for a frame slot", pass))?;
        self.collect(slot)?;
        Ok(cmd)
    }

    /// After `slot`'s fence has signalled: reads its timestamps and
    /// statistics into the frame submitted from it.
    pub(super) fn collect(&mut self, slot: usize) -> Result<()> {
        let Some(mut stats) = self.per_slot[slot].in_flight.take() else {
            return Ok(());
        };
        let queries = self.per_slot[slot]
            .queries
            .as_ref()
            .expect("queries present until drop");
        let (passes, pipeline) = queries.read(&self.ctx)?;
        for (name, ms) in passes {
            *stats.gpu_ms.entry(name.to_string()).or_insert(0.0) += ms;
        }
        stats.pipeline = pipeline;
        if let Some(gpu) = self.passes.gpu_cull.as_mut() {
            let drawn = gpu.read(slot)?;
            let view_sets = match self.config.frame.stereo {
                StereoMode::Multiview => 1,
                StereoMode::TwoPass => 2,
            };
            stats.draw_calls += view_sets * drawn.draws + stats.far_passes * drawn.far_draws;
            // Plus the blended draws batched on the CPU (none without).
            stats.instances_drawn += drawn.instances;
            stats.triangles += drawn.triangles;
            stats.gpu_cull = Some(drawn.cull);
        }
        for t in &mut self.passes.techniques {
            t.collect(slot, &mut stats)?;
        }
        self.completed.push_back(stats);
        Ok(())
    }
}
