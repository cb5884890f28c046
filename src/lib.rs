//! vergence: stereo VR renderer for very large enterprise scenes.

pub mod cull;
pub mod view;
