//! Where frames go: headless images (here), an OpenXR swapchain or a mirror
//! window (later issues).

pub mod headless;
