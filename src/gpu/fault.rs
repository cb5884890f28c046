//! Fault injection for the error paths a working GPU cannot be made to take
//! on demand, so tests can check what a user would see:
//! - `VERGENCE_INJECT_FAULT=device-lost@N` makes the fence wait of the N-th
//!   rendered frame (counting from 1) report VK_ERROR_DEVICE_LOST;
//! - `VERGENCE_INJECT_FAULT=image@N` makes the N-th image the process
//!   creates (counting from 1) fail as out of device memory, so that every
//!   partial construction's clean-up can be swept;
//! - `VERGENCE_INJECT_FAULT=buffer@N`, the same for buffers.
//!
//! Nothing else reads the variable; unset, this costs one cached lookup
//! per frame, image and buffer.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::OnceLock;

/// What is injected.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Fault {
    DeviceLost(u64),
    Image(u64),
    Buffer(u64),
}

fn injected() -> Option<Fault> {
    static FAULT: OnceLock<Option<Fault>> = OnceLock::new();
    *FAULT.get_or_init(|| parse(std::env::var("VERGENCE_INJECT_FAULT").ok()?.as_str()))
}

/// The frame whose wait reports a lost device, if one is injected.
pub fn device_lost_frame() -> Option<u64> {
    match injected() {
        Some(Fault::DeviceLost(n)) => Some(n),
        _ => None,
    }
}

/// Counts an image about to be created; true when it is the one to fail.
pub fn image_fails() -> bool {
    static MADE: AtomicU64 = AtomicU64::new(0);
    match injected() {
        Some(Fault::Image(n)) => MADE.fetch_add(1, Ordering::Relaxed) + 1 == n,
        _ => false,
    }
}

/// Counts a buffer about to be created; true when it is the one to fail.
pub fn buffer_fails() -> bool {
    static MADE: AtomicU64 = AtomicU64::new(0);
    match injected() {
        Some(Fault::Buffer(n)) => MADE.fetch_add(1, Ordering::Relaxed) + 1 == n,
        _ => false,
    }
}

fn parse(spec: &str) -> Option<Fault> {
    let spec = spec.trim();
    let (kind, n) = spec.split_once('@')?;
    let n: u64 = n.parse().ok().filter(|&n| n > 0)?;
    match kind {
        "device-lost" => Some(Fault::DeviceLost(n)),
        "image" => Some(Fault::Image(n)),
        "buffer" => Some(Fault::Buffer(n)),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::{parse, Fault};

    #[test]
    fn specs() {
        assert_eq!(parse("device-lost@3"), Some(Fault::DeviceLost(3)));
        assert_eq!(parse("image@12"), Some(Fault::Image(12)));
        assert_eq!(parse("buffer@2"), Some(Fault::Buffer(2)));
        assert_eq!(parse("device-lost@0"), None);
        assert_eq!(parse("image@x"), None);
        assert_eq!(parse("oom"), None);
    }
}
