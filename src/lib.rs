//! vergence: a stereo VR renderer for very large enterprise scenes, whose
//! stereo optimizations are switchable, combinable and measured.
//!
//! The library is organised as DESIGN.md describes: `view` and `cull` are
//! pure math, `scene` loads content, `gpu` wraps Vulkan, `render` draws,
//! `targets` writes images, `bench` measures.

pub mod error;
pub mod scene;
pub mod view;

pub use error::{Error, Result};
pub mod bench;
pub mod config;
pub mod cull;
pub mod gpu;
pub mod quit;
pub mod render;
pub mod targets;
pub mod xr;
