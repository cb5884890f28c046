//! Measurement: benchmark plans, the runner, image metrics, reports with
//! plots, and the tuner.

pub mod cull;
pub mod flicker;
pub mod flicker_floor;
pub mod foveated;
pub mod gaze;
pub mod html;
pub mod lens;
pub mod metrics;
pub mod plan;
pub mod raster_floors;
pub mod report;
pub mod runner;
pub mod tables;
pub mod timewarp;
pub mod tune;
