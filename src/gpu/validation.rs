//! Validation-layer plumbing: a debug-utils messenger that logs every message
//! through `tracing` and counts warnings and errors, so tests can fail on any.

use ash::vk;
use std::ffi::CStr;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// What the messenger has seen. Lives in a `Box` whose address is handed to
/// Vulkan as the callback's user data.
#[derive(Default)]
pub struct ValidationLog {
    count: AtomicUsize,
    messages: Mutex<Vec<String>>,
}

impl ValidationLog {
    /// Number of warnings and errors reported so far.
    pub fn count(&self) -> usize {
        self.count.load(Ordering::SeqCst)
    }

    /// The first messages (at most 32) reported so far.
    pub fn messages(&self) -> Vec<String> {
        self.messages.lock().map(|m| m.clone()).unwrap_or_default()
    }

    fn record(&self, text: String) {
        self.count.fetch_add(1, Ordering::SeqCst);
        if let Ok(mut m) = self.messages.lock() {
            if m.len() < 32 {
                m.push(text);
            }
        }
    }
}

/// The messenger callback.
///
/// # Safety
/// Called by the Vulkan loader with a valid callback-data pointer and the
/// `ValidationLog` pointer registered at messenger creation, which outlives
/// the messenger.
pub unsafe extern "system" fn callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    kind: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut std::ffi::c_void,
) -> vk::Bool32 {
    // SAFETY: the loader passes a valid pointer for the duration of the call.
    let msg = unsafe {
        data.as_ref()
            .and_then(|d| {
                (!d.p_message.is_null())
                    .then(|| CStr::from_ptr(d.p_message).to_string_lossy().into_owned())
            })
            .unwrap_or_default()
    };
    let counted = severity.intersects(
        vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
            | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
    ) && !kind.contains(vk::DebugUtilsMessageTypeFlagsEXT::GENERAL);
    if counted {
        tracing::error!(target: "vulkan", "{severity:?} {kind:?}: {msg}");
        // SAFETY: `user` is the Box<ValidationLog> registered with the messenger.
        if let Some(log) = unsafe { (user as *const ValidationLog).as_ref() } {
            log.record(msg);
        }
    } else {
        tracing::debug!(target: "vulkan", "{severity:?} {kind:?}: {msg}");
    }
    vk::FALSE
}
