//! Every file vergence reads and writes goes through here.
//!
//! Reading ([`read_bounded`], [`read_text`]): the file is opened without
//! blocking (a FIFO must not hang the open), refused unless it is a regular
//! file (devices, FIFOs, sockets and folders give one error naming the
//! kind), refused when its size is over the caller's limit before anything
//! is allocated, and read through a `take(limit + 1)` so a file that grows
//! while it is read cannot exceed the limit either. Each file read is
//! remembered as an input of this process.
//!
//! Writing ([`write_output`], [`TempFile`]): output goes to a fresh file
//! created with `O_CREAT | O_EXCL` (which never follows a symbolic link) under
//! a unique hidden name beside the target, and is renamed over the target
//! at the end; `rename` replaces a planted link itself, never the file it
//! points to. A target that is a folder or one of this process's inputs is
//! refused. On failure only the temporary file vergence created is removed.

use crate::error::{Error, Result};
use std::fs::File;
use std::io::{self, Read as _, Write as _};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

/// Largest text input (scene manifest, HMD profile, rig JSON, bench plan,
/// config file).
pub const MAX_TEXT_FILE_BYTES: u64 = 16 << 20;
/// Largest top-level scene file (`.gltf`, `.glb`) or glTF resource file.
pub const MAX_SCENE_FILE_BYTES: u64 = 4 << 30;
/// Largest image file `vergence compare` reads.
pub const MAX_IMAGE_FILE_BYTES: u64 = 256 << 20;

/// Identity of a file read as an input: device and inode where the OS has
/// them, else the canonical path.
#[derive(Clone, Debug, PartialEq, Eq)]
enum FileId {
    #[cfg(unix)]
    Inode(u64, u64),
    #[cfg(not(unix))]
    Path(PathBuf),
}

static INPUTS: Mutex<Vec<FileId>> = Mutex::new(Vec::new());

#[cfg(unix)]
fn file_id(_path: &Path, meta: &std::fs::Metadata) -> Option<FileId> {
    use std::os::unix::fs::MetadataExt as _;
    Some(FileId::Inode(meta.dev(), meta.ino()))
}

#[cfg(not(unix))]
fn file_id(path: &Path, _meta: &std::fs::Metadata) -> Option<FileId> {
    std::fs::canonicalize(path).ok().map(FileId::Path)
}

fn remember_input(path: &Path, meta: &std::fs::Metadata) {
    if let (Some(id), Ok(mut inputs)) = (file_id(path, meta), INPUTS.lock()) {
        if !inputs.contains(&id) {
            inputs.push(id);
        }
    }
}

/// Stops treating `path` as an input: for a file vergence derives and
/// owns (the LOD cache), read and then replaced when stale.
pub fn forget_input(path: &Path) {
    let Ok(meta) = std::fs::symlink_metadata(path) else {
        return;
    };
    if let (Some(id), Ok(mut inputs)) = (file_id(path, &meta), INPUTS.lock()) {
        inputs.retain(|i| *i != id);
    }
}

/// Whether `path` (not following a final symbolic link, which an output
/// replaces rather than writes through) is a file this process read as an
/// input.
pub fn is_input(path: &Path) -> bool {
    let Ok(meta) = std::fs::symlink_metadata(path) else {
        return false;
    };
    match (file_id(path, &meta), INPUTS.lock()) {
        (Some(id), Ok(inputs)) => inputs.contains(&id),
        _ => false,
    }
}

/// What a non-regular file is, for the error message.
fn kind(meta: &std::fs::Metadata) -> &'static str {
    let t = meta.file_type();
    if t.is_dir() {
        return "a directory";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt as _;
        if t.is_fifo() {
            return "a FIFO";
        }
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    "not a regular file"
}

fn refused(message: String) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidInput, message)
}

/// Reads the regular file at `path`, at most `limit` bytes. The error says
/// why it was refused (not a regular file, over the limit) or what the OS
/// said; the caller names the path.
pub fn read_bounded(path: &Path, limit: u64) -> io::Result<Vec<u8>> {
    let mut opts = std::fs::OpenOptions::new();
    opts.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt as _;
        // A FIFO opened for reading blocks until a writer comes; a terminal
        // must not become the controlling one.
        opts.custom_flags(libc::O_NONBLOCK | libc::O_NOCTTY);
    }
    let file = opts.open(path)?;
    let meta = file.metadata()?;
    if !meta.is_file() {
        let k = kind(&meta);
        return Err(refused(if k == "not a regular file" {
            k.to_string()
        } else {
            format!("{k}, not a regular file")
        }));
    }
    if meta.len() > limit {
        return Err(refused(format!(
            "{} bytes, over the {limit}-byte limit for this kind of file",
            meta.len()
        )));
    }
    remember_input(path, &meta);
    let mut bytes = Vec::new();
    bytes
        .try_reserve_exact(meta.len() as usize)
        .map_err(|e| refused(format!("cannot allocate {} bytes: {e}", meta.len())))?;
    file.take(limit + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > limit {
        return Err(refused(format!(
            "grew past the {limit}-byte limit while being read"
        )));
    }
    Ok(bytes)
}

/// Like [`read_bounded`], as UTF-8 text.
pub fn read_text(path: &Path, limit: u64) -> io::Result<String> {
    String::from_utf8(read_bounded(path, limit)?)
        .map_err(|e| io::Error::new(io::ErrorKind::InvalidData, format!("not UTF-8 text: {e}")))
}

static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// A file vergence created under a fresh name (never an existing file or
/// link). Removed when dropped unless [`TempFile::persist`] renamed it.
#[derive(Debug)]
pub struct TempFile {
    path: PathBuf,
    file: File,
    kept: bool,
}

impl TempFile {
    /// Creates `.NAME.PID.N.tmp` in the folder of `target` (NAME: the
    /// target's file name), with `O_EXCL`, retrying under another N when
    /// that name exists.
    pub fn beside(target: &Path) -> io::Result<TempFile> {
        let name = target
            .file_name()
            .ok_or_else(|| refused("the path names no file".into()))?
            .to_string_lossy()
            .into_owned();
        let dir = target.parent().unwrap_or(Path::new(""));
        let mut last = None;
        for _ in 0..64 {
            let n = TEMP_COUNTER.fetch_add(1, Ordering::Relaxed);
            let path = dir.join(format!(".{name}.{}.{n}.tmp", std::process::id()));
            let mut opts = std::fs::OpenOptions::new();
            opts.read(true).write(true).create_new(true);
            #[cfg(unix)]
            {
                use std::os::unix::fs::OpenOptionsExt as _;
                opts.custom_flags(libc::O_NOFOLLOW).mode(0o644);
            }
            match opts.open(&path) {
                Ok(file) => {
                    return Ok(TempFile {
                        path,
                        file,
                        kept: false,
                    })
                }
                Err(e) if e.kind() == io::ErrorKind::AlreadyExists => last = Some(e),
                Err(e) => return Err(e),
            }
        }
        Err(last.unwrap_or_else(|| refused("no free temporary name".into())))
    }

    /// The open file.
    pub fn file(&self) -> &File {
        &self.file
    }

    /// Where it is.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Renames it over `target` (replacing a link there, never following
    /// it).
    pub fn persist(mut self, target: &Path) -> io::Result<()> {
        std::fs::rename(&self.path, target)?;
        self.kept = true;
        Ok(())
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        if !self.kept {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

/// Checks that `path` may be written as an output: it names a file, is not
/// a folder and is not one of this process's inputs. Creates its folder.
pub fn prepare_output(path: &Path) -> Result<()> {
    let out = |message: String| Error::Output {
        path: path.to_path_buf(),
        message,
    };
    if path.file_name().is_none() {
        return Err(out("the path names no file".into()));
    }
    if let Ok(meta) = std::fs::symlink_metadata(path) {
        if meta.is_dir() {
            return Err(out("is a directory".into()));
        }
    }
    if is_input(path) {
        return Err(out(
            "is one of this command's inputs; vergence never writes over an input".into(),
        ));
    }
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| Error::Output {
            path: dir.to_path_buf(),
            message: e.to_string(),
        })?;
    }
    Ok(())
}

/// Writes an output file: `write` fills a fresh temporary file beside
/// `path` (buffered), which is then renamed over `path`. Refuses what
/// [`prepare_output`] refuses; on failure nothing but the temporary file is
/// removed and `path` is left as it was.
pub fn write_output(
    path: &Path,
    write: impl FnOnce(&mut dyn io::Write) -> io::Result<()>,
) -> Result<()> {
    let out = |e: io::Error| Error::Output {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    prepare_output(path)?;
    let tmp = TempFile::beside(path).map_err(out)?;
    let mut w = io::BufWriter::new(tmp.file());
    write(&mut w).map_err(out)?;
    w.flush().map_err(out)?;
    drop(w);
    tmp.persist(path).map_err(out)
}

/// [`write_output`] of a byte string.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<()> {
    write_output(path, |w| w.write_all(bytes))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("vergence-fsio-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn limits_and_kinds_are_refused() {
        let d = scratch("read");
        let f = d.join("a.txt");
        std::fs::write(&f, b"0123456789").unwrap();
        assert_eq!(read_bounded(&f, 10).unwrap(), b"0123456789");
        let e = read_bounded(&f, 9).unwrap_err().to_string();
        assert!(e.contains("10 bytes, over the 9-byte limit"), "{e}");
        let e = read_bounded(&d, 100).unwrap_err().to_string();
        assert!(e.contains("a directory"), "{e}");
        #[cfg(unix)]
        {
            let e = read_bounded(Path::new("/dev/zero"), 100)
                .unwrap_err()
                .to_string();
            assert!(e.contains("a character device"), "{e}");
            let fifo = d.join("fifo");
            let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
            // SAFETY: a valid NUL-terminated path.
            assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
            let e = read_bounded(&fifo, 100).unwrap_err().to_string();
            assert!(e.contains("a FIFO"), "{e}");
        }
    }

    #[cfg(unix)]
    #[test]
    fn outputs_replace_planted_links_and_spare_inputs() {
        let d = scratch("write");
        let victim = d.join("victim.txt");
        std::fs::write(&victim, b"keep me").unwrap();
        let out = d.join("out.json");
        std::os::unix::fs::symlink(&victim, &out).unwrap();
        write_bytes(&out, b"new").unwrap();
        assert_eq!(std::fs::read(&victim).unwrap(), b"keep me");
        assert_eq!(std::fs::read(&out).unwrap(), b"new");
        assert!(!std::fs::symlink_metadata(&out).unwrap().is_symlink());
        read_bounded(&victim, 100).unwrap();
        let e = write_bytes(&victim, b"x").unwrap_err().to_string();
        assert!(e.contains("never writes over an input"), "{e}");
        assert_eq!(std::fs::read(&victim).unwrap(), b"keep me");
        let e = write_bytes(&d, b"x").unwrap_err().to_string();
        assert!(e.contains("is a directory"), "{e}");
        let left: Vec<_> = std::fs::read_dir(&d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".tmp"))
            .collect();
        assert!(left.is_empty(), "temporary files left: {left:?}");
    }
}
