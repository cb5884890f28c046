//! Measurement: benchmark plans, the runner, statistics, image metrics,
//! reports with plots, and the tuner.

pub mod html;
pub mod metrics;
pub mod plan;
pub mod report;
pub mod runner;
pub mod tables;
pub mod tune;

/// The process's resident set size in bytes (Linux: /proc/self/statm;
/// None elsewhere).
pub fn process_rss_bytes() -> Option<u64> {
    let statm = std::fs::read_to_string("/proc/self/statm").ok()?;
    let pages: u64 = statm.split_whitespace().nth(1)?.parse().ok()?;
    // SAFETY: sysconf has no preconditions.
    let page = unsafe { libc::sysconf(libc::_SC_PAGESIZE) };
    Some(pages * u64::try_from(page).ok().filter(|&p| p > 0)?)
}
