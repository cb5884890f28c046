//! Fault injection for the error paths a working GPU cannot be made to take
//! on demand, so tests can check what a user would see:
//! `VERGENCE_INJECT_FAULT=device-lost@N` makes the fence wait of the N-th
//! rendered frame (counting from 1) report VK_ERROR_DEVICE_LOST. Nothing
//! else reads the variable; unset, this costs one cached lookup per frame.

use std::sync::OnceLock;

/// The frame whose wait reports a lost device, if one is injected.
pub fn device_lost_frame() -> Option<u64> {
    static FRAME: OnceLock<Option<u64>> = OnceLock::new();
    *FRAME.get_or_init(|| parse(std::env::var("VERGENCE_INJECT_FAULT").ok()?.as_str()))
}

fn parse(spec: &str) -> Option<u64> {
    let n = spec.trim().strip_prefix("device-lost@")?.parse().ok()?;
    (n > 0).then_some(n)
}

#[cfg(test)]
mod tests {
    #[test]
    fn specs() {
        assert_eq!(super::parse("device-lost@3"), Some(3));
        assert_eq!(super::parse("device-lost@0"), None);
        assert_eq!(super::parse("oom"), None);
    }
}
