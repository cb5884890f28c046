//! Measurement: image metrics now; runner, statistics and reports later.

pub mod metrics;
