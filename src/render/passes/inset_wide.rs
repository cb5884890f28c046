//! `inset-wide-1x`: the wide views of `inset` drawn at one sample per
//! pixel while the insets keep the frame's MSAA. The wide views have their
//! own targets and scope (two scopes only), so only the pipelines that draw
//! into that scope need a one-sample twin — the scene and sky (forward),
//! the interaction overlay and the hidden-area mask; the composite reads
//! the one-sample wide image as it reads the resolved one.
//!
//! Why it pays: the wide view is upsampled from a quarter of the eye's
//! pixels (at the default scale 0.5), so its edges are already softer than
//! MSAA makes them, while its samples are most of the inset frame's cost
//! on a raster-bound GPU (H200, factory:100000: `forward-wide` 5.62 ms at
//! 4×, 3.36 ms at 1×, `bench/results/2026-12-03-h200-inset-four-view-final.md`).
//! What it costs is aliasing in the periphery, which the bench's flicker
//! column measures.

use super::forward::Forward;
use super::overlay::Overlay;
use super::stencil_mask::StencilMask;
use super::{destroy_pipelines, PipelineSetup};
use crate::error::Result;
use crate::gpu::Context;
use ash::vk;

/// The wide views' pipelines at one sample.
#[derive(Default)]
pub struct WidePipelines {
    /// Scene and sky.
    pub forward: Forward,
    /// The interaction overlay.
    pub overlay: Overlay,
    /// The hidden-area mask's pipeline, with `stencil-mask`.
    pub hidden: Option<vk::Pipeline>,
}

impl WidePipelines {
    /// Builds the one-sample twins of `setup`'s forward, overlay and (with
    /// `stencil_mask`) hidden-area pipelines; on failure, destroys what it
    /// built.
    pub fn new(setup: &PipelineSetup, stencil_mask: bool) -> Result<WidePipelines> {
        let one = PipelineSetup {
            samples: 1,
            ..*setup
        };
        let mut made = WidePipelines::default();
        match made.build(&one, stencil_mask) {
            Ok(()) => Ok(made),
            Err(e) => {
                made.destroy(setup.ctx);
                Err(e)
            }
        }
    }

    fn build(&mut self, one: &PipelineSetup, stencil_mask: bool) -> Result<()> {
        self.forward = Forward::new(one)?;
        self.overlay = Overlay::new(one)?;
        if stencil_mask {
            self.hidden = Some(StencilMask::pipeline(one)?);
        }
        Ok(())
    }

    /// Builds the forward pipelines that clip against the section plane,
    /// unless they exist (at one sample: `setup`'s samples are replaced).
    pub fn ensure_clipped(&mut self, setup: &PipelineSetup) -> Result<()> {
        self.forward.ensure_clipped(&PipelineSetup {
            samples: 1,
            ..*setup
        })
    }

    /// Destroys the pipelines; the device must be idle.
    pub fn destroy(self, ctx: &Context) {
        self.forward.destroy(ctx);
        self.overlay.destroy(ctx);
        destroy_pipelines(ctx, self.hidden.iter());
    }
}
