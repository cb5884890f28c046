//! The frame ring: N frames in flight, each with its own command buffer,
//! fence and list of resources whose destruction was deferred until the GPU
//! has finished that frame.

use super::memory::{Buffer, Image};
use super::Context;
use crate::error::{Result, VkContext};
use ash::vk;

/// A resource waiting for its frame's fence before destruction.
#[derive(Debug)]
pub enum Garbage {
    /// A buffer.
    Buffer(Buffer),
    /// An image.
    Image(Image),
    /// An image view.
    View(vk::ImageView),
}

/// One frame slot.
pub struct Frame {
    /// Signalled when the GPU has finished the frame's submission.
    pub fence: vk::Fence,
    /// Command pool reset each time the slot is reused.
    pub pool: vk::CommandPool,
    /// The frame's primary command buffer.
    pub cmd: vk::CommandBuffer,
    garbage: Vec<Garbage>,
    submitted: bool,
}

/// Frames in flight.
pub struct FrameRing {
    frames: Vec<Frame>,
    current: usize,
}

impl FrameRing {
    /// Creates `count` frame slots.
    pub fn new(ctx: &Context, count: usize) -> Result<FrameRing> {
        let d = &ctx.device;
        let mut frames = Vec::new();
        for i in 0..count.max(1) {
            // SAFETY: creating per-frame objects on a live device; on a
            // failure what was made, never used, is destroyed.
            unsafe {
                let made = ctx.command_pool("frame").and_then(|(pool, cmd)| {
                    match d
                        .create_fence(&vk::FenceCreateInfo::default(), None)
                        .vk("creating a frame fence")
                    {
                        Ok(fence) => Ok((pool, cmd, fence)),
                        Err(e) => {
                            d.destroy_command_pool(pool, None);
                            Err(e)
                        }
                    }
                });
                let (pool, cmd, fence) = match made {
                    Ok(m) => m,
                    Err(e) => {
                        FrameRing { frames, current: 0 }.destroy(ctx);
                        return Err(e);
                    }
                };
                ctx.set_name(cmd, &format!("frame {i} commands"));
                frames.push(Frame {
                    fence,
                    pool,
                    cmd,
                    garbage: Vec::new(),
                    submitted: false,
                });
            }
        }
        Ok(FrameRing { frames, current: 0 })
    }

    /// Waits for the current slot's previous use, frees its garbage and
    /// begins its command buffer.
    pub fn begin(&mut self, ctx: &Context) -> Result<vk::CommandBuffer> {
        let f = &mut self.frames[self.current];
        // SAFETY: the fence and pool belong to this device; after the wait the
        // GPU no longer uses the slot's command buffer or garbage.
        unsafe {
            if f.submitted {
                ctx.device
                    .wait_for_fences(&[f.fence], true, u64::MAX)
                    .vk("waiting for a frame fence")?;
                ctx.device
                    .reset_fences(&[f.fence])
                    .vk("resetting a frame fence")?;
                f.submitted = false;
            }
            for g in f.garbage.drain(..) {
                destroy_garbage(ctx, g);
            }
            ctx.device
                .reset_command_pool(f.pool, vk::CommandPoolResetFlags::empty())
                .vk("resetting a command pool")?;
            ctx.device
                .begin_command_buffer(
                    f.cmd,
                    &vk::CommandBufferBeginInfo::default()
                        .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
                )
                .vk("beginning a frame")?;
        }
        Ok(f.cmd)
    }

    /// Ends and submits the current slot, then moves to the next slot.
    pub fn submit(&mut self, ctx: &Context) -> Result<()> {
        let f = &mut self.frames[self.current];
        let cbs = [f.cmd];
        // SAFETY: the command buffer was begun by `begin`; the fence is unsignalled.
        unsafe {
            ctx.device.end_command_buffer(f.cmd).vk("ending a frame")?;
            let submit = vk::SubmitInfo::default().command_buffers(&cbs);
            ctx.device
                .queue_submit(ctx.queue, &[submit], f.fence)
                .vk("submitting a frame")?;
        }
        f.submitted = true;
        self.current = (self.current + 1) % self.frames.len();
        Ok(())
    }

    /// Waits until the current slot's previous submission (if any) has
    /// finished; [`FrameRing::begin`] then finds it done.
    pub fn wait_current(&mut self, ctx: &Context) -> Result<()> {
        let f = &self.frames[self.current];
        if f.submitted {
            // SAFETY: fence of this device.
            unsafe { ctx.device.wait_for_fences(&[f.fence], true, u64::MAX) }
                .vk("waiting for a frame fence")?;
        }
        Ok(())
    }

    /// Whether slot `i`'s last submission has finished (true when nothing
    /// was submitted from it), without waiting.
    pub fn is_done(&self, ctx: &Context, i: usize) -> Result<bool> {
        let f = &self.frames[i];
        if !f.submitted {
            return Ok(true);
        }
        // SAFETY: fence of this device.
        unsafe { ctx.device.get_fence_status(f.fence) }.vk("polling a frame fence")
    }

    /// Waits until every submitted frame has finished.
    pub fn wait_all(&mut self, ctx: &Context) -> Result<()> {
        for f in &mut self.frames {
            if f.submitted {
                // SAFETY: fence of this device.
                unsafe { ctx.device.wait_for_fences(&[f.fence], true, u64::MAX) }
                    .vk("waiting for frames")?;
            }
        }
        Ok(())
    }

    /// Defers destruction of `g` until the current slot is next reused.
    pub fn defer(&mut self, g: Garbage) {
        self.frames[self.current].garbage.push(g);
    }

    /// Destroys all slots (waits for the device first).
    pub fn destroy(self, ctx: &Context) {
        // SAFETY: after device idle, nothing is in use.
        unsafe {
            let _ = ctx.device.device_wait_idle();
            for f in self.frames {
                for g in f.garbage {
                    destroy_garbage(ctx, g);
                }
                ctx.device.destroy_fence(f.fence, None);
                ctx.device.destroy_command_pool(f.pool, None);
            }
        }
    }
}

fn destroy_garbage(ctx: &Context, g: Garbage) {
    match g {
        Garbage::Buffer(b) => b.destroy(ctx),
        Garbage::Image(i) => i.destroy(ctx),
        // SAFETY: the view's frame has completed.
        Garbage::View(v) => unsafe { ctx.device.destroy_image_view(v, None) },
    }
}
