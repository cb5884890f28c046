//! Quit requests: Ctrl-C (SIGINT on Unix, CTRL_C_EVENT and
//! CTRL_BREAK_EVENT on Windows) and SIGTERM set a flag the frame loops poll,
//! so they end the session in order (xrRequestExitSession, then teardown).
//! A second request exits at once with status 130.

use std::sync::atomic::{AtomicBool, Ordering};

static REQUESTED: AtomicBool = AtomicBool::new(false);

/// Records a quit request; true when one was already pending (the caller
/// then exits at once).
fn request() -> bool {
    REQUESTED.swap(true, Ordering::SeqCst)
}

#[cfg(unix)]
mod os {
    extern "C" fn on_signal(_sig: libc::c_int) {
        // Only async-signal-safe work here: an atomic swap and _exit.
        if super::request() {
            // SAFETY: _exit is async-signal-safe.
            unsafe { libc::_exit(130) };
        }
    }

    /// Installs the SIGINT and SIGTERM handlers.
    pub fn install() {
        let handler = on_signal as extern "C" fn(libc::c_int) as libc::sighandler_t;
        // SAFETY: installing a handler that only touches an atomic and _exit.
        unsafe {
            libc::signal(libc::SIGINT, handler);
            libc::signal(libc::SIGTERM, handler);
        }
    }
}

#[cfg(windows)]
mod os {
    use windows_sys::core::BOOL;
    use windows_sys::Win32::System::Console::{
        SetConsoleCtrlHandler, CTRL_BREAK_EVENT, CTRL_C_EVENT,
    };

    /// Runs on a thread the system starts for each console control event.
    /// Ctrl-C and Ctrl-Break are quit requests; closing the console,
    /// logging off and shutting down keep the default (the process ends).
    unsafe extern "system" fn on_ctrl(event: u32) -> BOOL {
        if event != CTRL_C_EVENT && event != CTRL_BREAK_EVENT {
            return 0;
        }
        if super::request() {
            // SAFETY: ends the process; no Rust state is touched after it.
            unsafe { windows_sys::Win32::System::Threading::ExitProcess(130) };
        }
        1
    }

    /// Adds the console control handler.
    pub fn install() {
        // SAFETY: registers a handler that only touches an atomic and
        // ExitProcess; adding the same handler twice is harmless.
        unsafe { SetConsoleCtrlHandler(Some(on_ctrl), 1) };
    }
}

#[cfg(not(any(unix, windows)))]
mod os {
    /// No quit handler on this platform: the default signal action applies.
    pub fn install() {}
}

/// Installs the handlers (idempotent).
pub fn install() {
    os::install();
}

/// Whether a quit was requested.
pub fn requested() -> bool {
    REQUESTED.load(Ordering::SeqCst)
}
