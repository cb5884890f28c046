//! The library's error type. Every expected failure (bad file, bad profile,
//! missing device) becomes one of these with a message naming the input and
//! the problem; `main` prints it and exits non-zero.

use std::path::PathBuf;

/// Errors produced by the vergence library.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be read.
    #[error("{path}: cannot read file: {}", plain(source))]
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

/// Prints `warning: {text}` on stderr the first time this process meets
/// `text`: a renderer built again for the same configuration (each bench
/// run, a kiosk scene switch) does not say the same thing twice.
pub fn warn_once(text: &str) {
    static SEEN: std::sync::Mutex<Vec<String>> = std::sync::Mutex::new(Vec::new());
    let mut seen = SEEN.lock().unwrap_or_else(|e| e.into_inner());
    if !seen.iter().any(|s| s == text) {
        seen.push(text.to_string());
        eprintln!("warning: {}", one_safe_line(text));
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

/// An I/O error as a reader can act on it: the operating system's reason in
/// plain words, without its error number (an error vergence made itself
/// keeps its message) (the path and the operation are
/// the caller's to name). The reasons a file layer meets get a sentence
/// that says what to change; others keep the system's own text.
pub fn plain(e: &std::io::Error) -> String {
    use std::io::ErrorKind as K;
    // vergence's own errors (a device or FIFO refused) say it already.
    if e.raw_os_error().is_none() {
        return e.to_string();
    }
    #[cfg(unix)]
    if e.raw_os_error() == Some(libc::ELOOP) {
        return "too many levels of links (a link loop, or a link where none is followed)".into();
    }
    let text = match e.kind() {
        K::InvalidInput => "the file system refused this name or operation (a character it does not allow in a name, or an operation it cannot do)",
        K::AlreadyExists => "something is already there under that name",
        K::NotFound => "no such file or folder",
        K::PermissionDenied => "permission denied",
        K::IsADirectory => "is a folder, not a file",
        K::NotADirectory => "a part of the path is a file, not a folder",
        K::ReadOnlyFilesystem => "the file system is read-only",
        K::StorageFull => "no space left on the device",
        K::QuotaExceeded => "the disk quota is used up",
        K::InvalidFilename => "the name is too long or not allowed by the file system",
        K::CrossesDevices => "it cannot be moved across file systems",
        K::FileTooLarge => "the file is too large for the file system",
        _ => return without_os_error_numbers(&e.to_string()),
    };
    text.to_string()
}

/// `text` with every " (os error N)" taken out (the numbers mean nothing
/// to a reader; the words before them stay).
pub fn without_os_error_numbers(text: &str) -> String {
    const MARK: &str = " (os error ";
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(i) = rest.find(MARK) {
        let after = &rest[i + MARK.len()..];
        let digits = after.bytes().take_while(u8::is_ascii_digit).count();
        if digits > 0 && after[digits..].starts_with(')') {
            out.push_str(&rest[..i]);
            rest = &after[digits + 1..];
        } else {
            out.push_str(&rest[..i + MARK.len()]);
            rest = after;
        }
    }
    out.push_str(rest);
    out
}

#[cfg(test)]
mod plain_tests {
    use super::*;
    use std::io;

    #[test]
    fn os_errors_read_without_their_numbers() {
        for code in [
            libc::EINVAL,
            libc::EEXIST,
            libc::ENOENT,
            libc::EIO,
            libc::EBUSY,
        ] {
            let e = io::Error::from_raw_os_error(code);
            let text = plain(&e);
            assert!(!text.contains("os error"), "{code}: {text}");
            assert!(!text.is_empty());
        }
        let invalid = plain(&io::Error::from_raw_os_error(libc::EINVAL));
        assert!(invalid.contains("name"), "{invalid}");
        assert_eq!(plain(&io::Error::other("short read")), "short read");
        let own = io::Error::new(io::ErrorKind::InvalidInput, "a FIFO, not a regular file");
        assert_eq!(plain(&own), "a FIFO, not a regular file");
        assert_eq!(
            without_os_error_numbers("a: Bad (os error 5): b (os error x) (os error 17)"),
            "a: Bad: b (os error x)"
        );
    }

    #[test]
    fn a_read_error_names_the_file_and_a_plain_reason() {
        let e = Error::Io {
            path: "/data/scan.las".into(),
            source: io::Error::from_raw_os_error(libc::EINVAL),
        };
        let text = e.to_string();
        assert!(
            text.starts_with("/data/scan.las: cannot read file: "),
            "{text}"
        );
        assert!(!text.contains("os error"), "{text}");
    }
}
