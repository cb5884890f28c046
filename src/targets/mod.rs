//! Where frames go: headless images (`render`) and the application loop
//! (`run`: an OpenXR session, or headless on an HMD profile).

pub mod headless;
pub mod run;
pub mod session;
pub mod xr_session;
