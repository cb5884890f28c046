//! Measurement: benchmark plans, the runner, statistics, image metrics,
//! reports with plots, and the tuner.

pub mod html;
pub mod metrics;
pub mod plan;
pub mod report;
pub mod runner;
pub mod stats;
pub mod tune;

mod rss;

pub use rss::process_rss_bytes;
