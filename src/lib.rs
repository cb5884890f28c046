//! vergence: a stereo VR renderer for very large enterprise scenes, whose
//! stereo optimizations are switchable, combinable and measured.
//!
//! Layers, each importing only those below it (docs/architecture.md):
//! `main` and `bench` on top; `targets` (where frames go and the loops that
//! drive them); `xr` (the OpenXR wrapper); `render` (passes, the frame
//! driver); `scene` (content), `gpu` (Vulkan), `config`; `cull`, `view`
//! and `adaptive` (pure math and policy); `stats`, `quit`, `count`, `fsio` and `error` at the bottom.

pub mod error;
pub mod scene;
pub mod view;

pub use error::{Error, Result};
pub mod adaptive;
pub mod bench;
pub mod cli;
pub mod config;
pub mod count;
pub mod cull;
pub mod fsio;
pub mod fuzz_checks;
pub mod gpu;
pub mod interact;
pub mod quit;
pub mod render;
pub mod rss;
pub mod stats;
pub mod targets;
pub mod xr;
