//! GPU timestamps per pass and pipeline-statistics queries.

use super::Context;
use crate::error::{Result, VkContext};
use ash::vk;

/// Pipeline statistics collected per frame.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct PipelineStats {
    /// Primitives assembled.
    pub input_primitives: u64,
    /// Vertex shader invocations.
    pub vertex_invocations: u64,
    /// Primitives output by clipping.
    pub clipping_primitives: u64,
    /// Fragment shader invocations.
    pub fragment_invocations: u64,
}

const STATS: vk::QueryPipelineStatisticFlags = vk::QueryPipelineStatisticFlags::from_raw(
    vk::QueryPipelineStatisticFlags::INPUT_ASSEMBLY_PRIMITIVES.as_raw()
        | vk::QueryPipelineStatisticFlags::VERTEX_SHADER_INVOCATIONS.as_raw()
        | vk::QueryPipelineStatisticFlags::CLIPPING_PRIMITIVES.as_raw()
        | vk::QueryPipelineStatisticFlags::FRAGMENT_SHADER_INVOCATIONS.as_raw(),
);

/// GPU milliseconds per named pass and the frame's pipeline statistics.
pub type FrameQueries = (Vec<(&'static str, f64)>, Option<PipelineStats>);

/// Timestamp and statistics pools for one frame slot.
pub struct Queries {
    timestamps: Option<vk::QueryPool>,
    stats: Option<vk::QueryPool>,
    names: Vec<&'static str>,
    capacity: u32,
    period_ns: f64,
}

impl Queries {
    /// The name of the last pass timed in this frame ("none" before any).
    pub fn last_pass(&self) -> &'static str {
        self.names.last().copied().unwrap_or("none")
    }

    /// Pools for up to `max_passes` timed passes, and the frame's
    /// pipeline-statistics query when the device has them and `stats`.
    pub fn new(ctx: &Context, max_passes: u32, stats: bool) -> Result<Queries> {
        let capacity = max_passes * 2;
        let d = &ctx.device;
        let timestamps = if ctx.caps.timestamp_period_ns > 0.0 {
            let info = vk::QueryPoolCreateInfo::default()
                .query_type(vk::QueryType::TIMESTAMP)
                .query_count(capacity);
            // SAFETY: valid create info.
            Some(unsafe { d.create_query_pool(&info, None) }.vk("creating a timestamp pool")?)
        } else {
            None
        };
        let stats = if stats && ctx.caps.pipeline_statistics {
            let info = vk::QueryPoolCreateInfo::default()
                .query_type(vk::QueryType::PIPELINE_STATISTICS)
                .query_count(1)
                .pipeline_statistics(STATS);
            // SAFETY: the feature was enabled at device creation.
            match unsafe { d.create_query_pool(&info, None) }.vk("creating a statistics pool") {
                Ok(p) => Some(p),
                Err(e) => {
                    if let Some(t) = timestamps {
                        // SAFETY: just made, never used.
                        unsafe { d.destroy_query_pool(t, None) };
                    }
                    return Err(e);
                }
            }
        } else {
            None
        };
        Ok(Queries {
            timestamps,
            stats,
            names: Vec::new(),
            capacity,
            period_ns: ctx.caps.timestamp_period_ns as f64,
        })
    }

    /// The statistics the frame's pipeline-statistics query counts (None:
    /// no such query), which secondary command buffers executed inside it
    /// must declare.
    pub fn stats_flags(&self) -> Option<vk::QueryPipelineStatisticFlags> {
        self.stats.map(|_| STATS)
    }

    /// Resets the pools at the start of a frame (outside any rendering).
    pub fn reset(&mut self, ctx: &Context, cmd: vk::CommandBuffer) {
        self.names.clear();
        // SAFETY: pools of this device, recorded outside a render pass.
        unsafe {
            if let Some(p) = self.timestamps {
                ctx.device.cmd_reset_query_pool(cmd, p, 0, self.capacity);
            }
            if let Some(p) = self.stats {
                ctx.device.cmd_reset_query_pool(cmd, p, 0, 1);
            }
        }
    }

    /// Marks the start of a named pass.
    pub fn begin_pass(&mut self, ctx: &Context, cmd: vk::CommandBuffer, name: &'static str) {
        let i = self.names.len() as u32;
        if i >= self.capacity / 2 {
            return;
        }
        self.names.push(name);
        if let Some(p) = self.timestamps {
            // SAFETY: query index within the pool, reset this frame.
            unsafe {
                ctx.device.cmd_write_timestamp2(
                    cmd,
                    vk::PipelineStageFlags2::ALL_COMMANDS,
                    p,
                    2 * i,
                )
            };
        }
    }

    /// Marks the end of the pass begun last.
    pub fn end_pass(&mut self, ctx: &Context, cmd: vk::CommandBuffer) {
        let Some(i) = self.names.len().checked_sub(1) else {
            return;
        };
        if let Some(p) = self.timestamps {
            // SAFETY: query index within the pool, reset this frame.
            unsafe {
                ctx.device.cmd_write_timestamp2(
                    cmd,
                    vk::PipelineStageFlags2::BOTTOM_OF_PIPE,
                    p,
                    2 * i as u32 + 1,
                )
            };
        }
    }

    /// Begins the statistics query (outside any rendering).
    pub fn begin_stats(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        if let Some(p) = self.stats {
            // SAFETY: query reset this frame; recorded outside rendering.
            unsafe {
                ctx.device
                    .cmd_begin_query(cmd, p, 0, vk::QueryControlFlags::empty())
            };
        }
    }

    /// Ends the statistics query.
    pub fn end_stats(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        if let Some(p) = self.stats {
            // SAFETY: matches `begin_stats`.
            unsafe { ctx.device.cmd_end_query(cmd, p, 0) };
        }
    }

    /// Reads GPU milliseconds per pass and the statistics after the frame's
    /// fence has signalled.
    pub fn read(&self, ctx: &Context) -> Result<FrameQueries> {
        let mut passes = Vec::new();
        if let (Some(p), n) = (self.timestamps, self.names.len()) {
            if n > 0 {
                let mut data = vec![0u64; 2 * n];
                // SAFETY: the frame has completed; WAIT makes results available.
                unsafe {
                    ctx.device.get_query_pool_results(
                        p,
                        0,
                        &mut data,
                        vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
                    )
                }
                .vk("reading timestamps")?;
                for (i, name) in self.names.iter().enumerate() {
                    let ticks = data[2 * i + 1].saturating_sub(data[2 * i]);
                    passes.push((*name, ticks as f64 * self.period_ns / 1e6));
                }
            }
        }
        let stats = match self.stats {
            Some(p) => {
                let mut all = [[0u64; 4]; 1];
                // SAFETY: as above; four statistics were requested for one query.
                unsafe {
                    ctx.device.get_query_pool_results(
                        p,
                        0,
                        &mut all,
                        vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
                    )
                }
                .vk("reading pipeline statistics")?;
                let data = all[0];
                Some(PipelineStats {
                    input_primitives: data[0],
                    vertex_invocations: data[1],
                    clipping_primitives: data[2],
                    fragment_invocations: data[3],
                })
            }
            None => None,
        };
        Ok((passes, stats))
    }

    /// Destroys the pools.
    pub fn destroy(self, ctx: &Context) {
        // SAFETY: called after the device is idle.
        unsafe {
            if let Some(p) = self.timestamps {
                ctx.device.destroy_query_pool(p, None);
            }
            if let Some(p) = self.stats {
                ctx.device.destroy_query_pool(p, None);
            }
        }
    }
}

/// A pool of two timestamps, for timing one stretch of commands outside a
/// frame (the distortion preview, the timewarp simulation).
pub fn timestamp_pair(ctx: &Context) -> Result<vk::QueryPool> {
    // SAFETY: plain object creation on a live device; the caller destroys it.
    unsafe {
        ctx.device.create_query_pool(
            &vk::QueryPoolCreateInfo::default()
                .query_type(vk::QueryType::TIMESTAMP)
                .query_count(2),
            None,
        )
    }
    .vk("creating a timestamp query pool")
}

/// Milliseconds between the two timestamps of `pool`, once both are
/// written (waits for them).
pub fn timestamp_pair_ms(ctx: &Context, pool: vk::QueryPool) -> Result<f64> {
    let mut stamps = [0u64; 2];
    // SAFETY: both queries were written by a submission that finished or
    // will finish (WAIT).
    unsafe {
        ctx.device.get_query_pool_results(
            pool,
            0,
            &mut stamps,
            vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
        )
    }
    .vk("reading timestamps")?;
    let ns = stamps[1].wrapping_sub(stamps[0]) as f64 * ctx.caps.timestamp_period_ns as f64;
    Ok(ns / 1e6)
}
