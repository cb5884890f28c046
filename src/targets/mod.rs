//! Where frames go: headless images (`render`) and the application loop
//! (`run`: an OpenXR session, or headless on an HMD profile), and the
//! desktop window (`view`: the preview with a fly camera).

pub mod desk_controllers;
pub mod downsample;
pub mod error_probe;
pub mod framing;
pub mod headless;
pub mod hud;
pub mod keep_pose;
pub mod kiosk;
pub mod mirror;
pub mod panel;
pub mod rehearse;
pub mod run;
pub mod session;
pub mod toggles;
pub mod view;
pub mod viewpoints;
pub mod window;
pub mod xr_panel;
pub mod xr_session;
