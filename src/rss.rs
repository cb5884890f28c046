//! The process's resident set size, per operating system.

/// The process's resident set size in bytes: on Linux from
/// `/proc/self/statm` (None on Unixes without it), on Windows the working
/// set from `GetProcessMemoryInfo`, None elsewhere.
pub fn process_rss_bytes() -> Option<u64> {
    os::rss_bytes()
}

#[cfg(unix)]
mod os {
    /// Resident pages from `/proc/self/statm` times the page size.
    pub fn rss_bytes() -> Option<u64> {
        let statm = crate::fsio::read_system_text(std::path::Path::new("/proc/self/statm")).ok()?;
        let pages: u64 = statm.split_whitespace().nth(1)?.parse().ok()?;
        // SAFETY: sysconf has no preconditions.
        let page = unsafe { libc::sysconf(libc::_SC_PAGESIZE) };
        Some(pages * u64::try_from(page).ok().filter(|&p| p > 0)?)
    }
}

#[cfg(windows)]
mod os {
    use windows_sys::Win32::System::ProcessStatus::{
        GetProcessMemoryInfo, PROCESS_MEMORY_COUNTERS,
    };
    use windows_sys::Win32::System::Threading::GetCurrentProcess;

    /// The working set of this process.
    pub fn rss_bytes() -> Option<u64> {
        let mut counters = PROCESS_MEMORY_COUNTERS {
            cb: std::mem::size_of::<PROCESS_MEMORY_COUNTERS>() as u32,
            ..Default::default()
        };
        // SAFETY: the pseudo-handle of the current process needs no
        // closing; `counters` is a correctly sized, writable struct.
        let ok = unsafe { GetProcessMemoryInfo(GetCurrentProcess(), &mut counters, counters.cb) };
        (ok != 0).then_some(counters.WorkingSetSize as u64)
    }
}

#[cfg(not(any(unix, windows)))]
mod os {
    /// Not measured on this platform.
    pub fn rss_bytes() -> Option<u64> {
        None
    }
}
