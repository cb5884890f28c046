//! A guard against a runtime that stops answering: while an OpenXR call is
//! in flight, a background thread watches the clock; past the limit it
//! prints one error line and ends the process with status 1. Without it, a
//! killed runtime service could leave xrWaitFrame blocked forever.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

struct Shared {
    /// Milliseconds since `epoch` when the current call began, +1 (0: idle).
    since: AtomicU64,
    what: Mutex<&'static str>,
    stop: AtomicBool,
    epoch: Instant,
}

/// Watches OpenXR calls for hangs.
pub struct Watchdog {
    shared: Arc<Shared>,
    thread: Option<std::thread::JoinHandle<()>>,
}

/// Marks one call in flight; dropping it ends the watch.
pub struct Watch<'a>(&'a Watchdog);

impl Watchdog {
    /// Starts the watcher with a time limit per call.
    pub fn start(limit: Duration) -> Watchdog {
        let shared = Arc::new(Shared {
            since: AtomicU64::new(0),
            what: Mutex::new(""),
            stop: AtomicBool::new(false),
            epoch: Instant::now(),
        });
        let s = shared.clone();
        let thread = std::thread::Builder::new()
            .name("xr-watchdog".into())
            .spawn(move || {
                while !s.stop.load(Ordering::SeqCst) {
                    std::thread::sleep(Duration::from_millis(50));
                    let since = s.since.load(Ordering::SeqCst);
                    if since == 0 {
                        continue;
                    }
                    let now = s.epoch.elapsed().as_millis() as u64 + 1;
                    if now.saturating_sub(since) > limit.as_millis() as u64 {
                        let what = s.what.lock().map(|w| *w).unwrap_or("an OpenXR call");
                        eprintln!(
                            "error: the OpenXR runtime did not return from {what} within {:.1} s; it has stopped responding (was the runtime service killed?)",
                            limit.as_secs_f64()
                        );
                        // SAFETY: ends the process without running atexit
                        // handlers, which could block on the same runtime.
                        unsafe { libc::_exit(1) };
                    }
                }
            })
            .ok();
        Watchdog { shared, thread }
    }

    /// Watches the call named `what` until the returned guard drops.
    pub fn watch(&self, what: &'static str) -> Watch<'_> {
        self.arm(what);
        Watch(self)
    }

    /// Watches `what` from now until the watchdog itself drops (teardown).
    pub fn arm(&self, what: &'static str) {
        if let Ok(mut w) = self.shared.what.lock() {
            *w = what;
        }
        let now = self.shared.epoch.elapsed().as_millis() as u64 + 1;
        self.shared.since.store(now, Ordering::SeqCst);
    }
}

impl Drop for Watch<'_> {
    fn drop(&mut self) {
        self.0.shared.since.store(0, Ordering::SeqCst);
    }
}

impl Drop for Watchdog {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
