//! The library's error type. Every expected failure (bad file, bad profile,
//! missing device) becomes one of these with a message naming the input and
//! the problem; `main` prints it and exits non-zero.

use std::path::PathBuf;

/// Errors produced by the vergence library.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be read.
    #[error("{path}: cannot read file: {source}")]
    Io {
        /// The file that failed.
        path: PathBuf,
        /// The underlying I/O error.
        source: std::io::Error,
    },
    /// A scene file (glTF, GLB, manifest) is malformed or unsupported.
    #[error("{path}: {message}")]
    Scene {
        /// The scene file (or the resource it references).
        path: PathBuf,
        /// What is wrong with it.
        message: String,
    },
    /// An HMD profile is unknown or malformed.
    #[error("HMD profile {name}: {message}")]
    Profile {
        /// The profile name or path.
        name: String,
        /// What is wrong with it.
        message: String,
    },
    /// A command-line or configuration value is invalid.
    #[error("invalid {what}: {message}")]
    Config {
        /// Which option or setting.
        what: String,
        /// What is wrong with it.
        message: String,
    },
    /// A Vulkan call failed.
    #[error("Vulkan: {context}: {result}")]
    Vulkan {
        /// What vergence was doing.
        context: String,
        /// The Vulkan result code.
        result: ash::vk::Result,
    },
    /// The GPU layer could not be set up (no loader, no device, missing feature).
    #[error("GPU: {0}")]
    Gpu(String),
    /// A desktop window could not be opened or used.
    #[error("window: {0}")]
    Window(String),
    /// No OpenXR runtime or headset is available (the `--xr auto` fallback
    /// applies).
    #[error("OpenXR unavailable: {0}")]
    XrUnavailable(String),
    /// An OpenXR call failed during a session.
    #[error("OpenXR: {context}: {result}")]
    Xr {
        /// What vergence was doing.
        context: String,
        /// The OpenXR result code.
        result: openxr::sys::Result,
    },
    /// The GPU was lost (hung, reset or removed): the device cannot be used
    /// again.
    #[error("the GPU device was lost while {context} (VK_ERROR_DEVICE_LOST); the last pass recorded in that frame was '{pass}'; vergence cannot continue")]
    DeviceLost {
        /// What vergence was waiting for or submitting.
        context: String,
        /// The last render pass recorded in the lost frame.
        pass: String,
    },
    /// Not enough GPU memory for what is being loaded.
    #[error("not enough GPU memory for {what}: it needs {} MiB but {} MiB of the {} MiB budget are free{}", mib(*need), mib(*available), mib(*budget), if *from_env { " (budget capped by VERGENCE_GPU_MEMORY_BUDGET_MB)" } else { "" })]
    GpuMemory {
        /// What needed the memory.
        what: String,
        /// Bytes needed.
        need: u64,
        /// Bytes free within the budget.
        available: u64,
        /// The budget in bytes.
        budget: u64,
        /// Whether the budget came from VERGENCE_GPU_MEMORY_BUDGET_MB.
        from_env: bool,
    },
    /// Writing an output file failed.
    #[error("{path}: cannot write: {message}")]
    Output {
        /// The output file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
}

/// Result alias used throughout the library.
pub type Result<T, E = Error> = std::result::Result<T, E>;

fn mib(bytes: u64) -> String {
    format!("{:.1}", bytes as f64 / (1u64 << 20) as f64)
}

impl Error {
    /// Shorthand for a scene error about `path`.
    pub fn scene(path: impl Into<PathBuf>, message: impl Into<String>) -> Error {
        Error::Scene {
            path: path.into(),
            message: message.into(),
        }
    }

    /// Shorthand for a configuration error.
    pub fn config(what: impl Into<String>, message: impl Into<String>) -> Error {
        Error::Config {
            what: what.into(),
            message: message.into(),
        }
    }
}

/// Adds context to an OpenXR result.
pub trait XrContext<T> {
    /// Wraps an `XrResult` error with what vergence was doing.
    fn xr(self, context: &str) -> Result<T>;
}

impl<T> XrContext<T> for std::result::Result<T, openxr::sys::Result> {
    fn xr(self, context: &str) -> Result<T> {
        self.map_err(|result| Error::Xr {
            context: context.to_string(),
            result,
        })
    }
}

/// Adds context to a raw Vulkan result.
pub trait VkContext<T> {
    /// Wraps a `vk::Result` error with what vergence was doing.
    fn vk(self, context: &str) -> Result<T>;
}

impl Error {
    /// Whether the OpenXR runtime went away mid-session (instance or
    /// session lost, runtime failure) or cannot be reached: what
    /// `vergence run --reconnect` waits out.
    pub fn is_runtime_loss(&self) -> bool {
        use openxr::sys::Result as R;
        match self {
            Error::XrUnavailable(_) => true,
            Error::Xr { result, .. } => matches!(
                *result,
                R::ERROR_INSTANCE_LOST
                    | R::ERROR_SESSION_LOST
                    | R::ERROR_RUNTIME_FAILURE
                    | R::ERROR_RUNTIME_UNAVAILABLE
            ),
            _ => false,
        }
    }
}

impl<T> VkContext<T> for std::result::Result<T, ash::vk::Result> {
    fn vk(self, context: &str) -> Result<T> {
        self.map_err(|result| Error::Vulkan {
            context: context.to_string(),
            result,
        })
    }
}

/// Unicode's bidirectional embedding, override and isolate controls
/// (U+202A–U+202E, U+2066–U+2069), which reorder what a terminal shows.
fn is_bidi_control(c: char) -> bool {
    matches!(c, '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}')
}

/// `text` as one line safe to print on a terminal: line breaks become
/// spaces and every other control character (an escape sequence from a
/// file's text or a path, a bidirectional override) is written escaped
/// (`\u{1b}`).
pub fn one_safe_line(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '\n' | '\r' => out.push(' '),
            c if c.is_control() || is_bidi_control(c) => out.extend(c.escape_default()),
            c => out.push(c),
        }
    }
    out
}
