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

/// The inputs read so far: each file's identity and the path it was read
/// through.
static INPUTS: Mutex<Vec<(FileId, PathBuf)>> = Mutex::new(Vec::new());

/// Whether `id` is an input still there: registered, and its path still
/// names that file (an input deleted since may have left its inode
/// number to a new file, which is not the input).
fn registered(id: &FileId) -> bool {
    let Ok(inputs) = INPUTS.lock() else {
        return false;
    };
    inputs.iter().any(|(i, path)| {
        i == id
            && std::fs::metadata(path)
                .ok()
                .and_then(|m| file_id(path, &m))
                .as_ref()
                == Some(id)
    })
}

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
        if !inputs.iter().any(|(i, p)| *i == id && p == path) {
            inputs.push((id, path.to_path_buf()));
        }
    }
}

/// Whether `path` (not following a final symbolic link, which an output
/// replaces rather than writes through) is a file this process read as an
/// input.
pub fn is_input(path: &Path) -> bool {
    let Ok(meta) = std::fs::symlink_metadata(path) else {
        return false;
    };
    file_id(path, &meta).is_some_and(|id| registered(&id))
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

/// Opens `path` for reading without blocking (a FIFO must not hang the
/// open, a terminal must not become the controlling one), then checks the
/// open file itself: a regular file of at most `limit` bytes. The file is
/// switched back to blocking reads before it is returned.
fn open_checked(path: &Path, limit: u64) -> io::Result<(File, std::fs::Metadata)> {
    let mut opts = std::fs::OpenOptions::new();
    opts.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt as _;
        opts.custom_flags(libc::O_NONBLOCK | libc::O_NOCTTY);
    }
    let file = opts.open(path)?;
    let meta = file.metadata()?;
    if !meta.is_file() {
        return Err(refused(not_regular(&meta)));
    }
    if meta.len() > limit {
        return Err(refused(format!(
            "{} bytes, over the {limit}-byte limit for this kind of file",
            meta.len()
        )));
    }
    #[cfg(unix)]
    {
        use std::os::unix::io::AsRawFd as _;
        let fd = file.as_raw_fd();
        // SAFETY: fcntl on a descriptor this function owns; F_GETFL and
        // F_SETFL take and return plain integers.
        let flags = unsafe { libc::fcntl(fd, libc::F_GETFL) };
        // SAFETY: as above.
        if flags < 0 || unsafe { libc::fcntl(fd, libc::F_SETFL, flags & !libc::O_NONBLOCK) } < 0 {
            return Err(io::Error::last_os_error());
        }
    }
    Ok((file, meta))
}

/// The refusal of a file that is not a regular one, naming its kind.
fn not_regular(meta: &std::fs::Metadata) -> String {
    let k = kind(meta);
    if k == "not a regular file" {
        k.to_string()
    } else {
        format!("{k}, not a regular file")
    }
}

/// Opens the regular file at `path` (at most `limit` bytes) for streaming
/// reads, as [`read_bounded`] checks it, and remembers it as an input;
/// returns the file and its size.
pub fn open_read(path: &Path, limit: u64) -> io::Result<(File, u64)> {
    let (file, meta) = open_checked(path, limit)?;
    remember_input(path, &meta);
    Ok((file, meta.len()))
}

/// Reads the regular file at `path`, at most `limit` bytes. The error says
/// why it was refused (not a regular file, over the limit) or what the OS
/// said; the caller names the path.
pub fn read_bounded(path: &Path, limit: u64) -> io::Result<Vec<u8>> {
    let (file, meta) = open_checked(path, limit)?;
    remember_input(path, &meta);
    read_all(file, meta.len(), limit)
}

/// Reads a file vergence derives and owns (a cache) as [`read_bounded`]
/// does, without making it an input: the cache may be replaced later,
/// while a file some other part of the command reads (a glTF buffer or a
/// point file that happens to share the cache's name) stays protected.
pub fn read_cache(path: &Path, limit: u64) -> io::Result<Vec<u8>> {
    let (file, meta) = open_checked(path, limit)?;
    read_all(file, meta.len(), limit)
}

/// The first `n` bytes (fewer when the file is shorter) of the regular
/// file at `path`, without making it an input.
pub fn read_prefix(path: &Path, n: usize) -> io::Result<Vec<u8>> {
    let (file, _) = open_checked(path, u64::MAX)?;
    let mut bytes = Vec::with_capacity(n);
    file.take(n as u64).read_to_end(&mut bytes)?;
    Ok(bytes)
}

/// The most bytes [`read_system_text`] reads.
const MAX_SYSTEM_FILE_BYTES: u64 = 1 << 20;

/// Text the operating system provides (`/proc/self/statm`,
/// `/proc/cpuinfo`): opened and checked as every read is, at most 1 MiB
/// (their size reads as 0, so the bound holds while reading), not an
/// input of the command.
pub fn read_system_text(path: &Path) -> io::Result<String> {
    let (file, meta) = open_checked(path, MAX_SYSTEM_FILE_BYTES)?;
    let bytes = read_all(file, meta.len(), MAX_SYSTEM_FILE_BYTES)?;
    String::from_utf8(bytes)
        .map_err(|e| io::Error::new(io::ErrorKind::InvalidData, format!("not UTF-8 text: {e}")))
}

/// Whether the open `file` is still the file at `path` (not following a
/// final link): a log about to be renamed must be the one being written.
pub fn is_same_file(file: &File, path: &Path) -> bool {
    match (file.metadata(), std::fs::symlink_metadata(path)) {
        (Ok(a), Ok(b)) => file_id(path, &a).is_some() && file_id(path, &a) == file_id(path, &b),
        _ => false,
    }
}

fn read_all(file: File, len: u64, limit: u64) -> io::Result<Vec<u8>> {
    let mut bytes = Vec::new();
    bytes
        .try_reserve_exact(len as usize)
        .map_err(|e| refused(format!("cannot allocate {len} bytes: {e}")))?;
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
        // A device, FIFO or socket is never replaced by a file; nor is a
        // link to one (`/dev/stdout`), which the rename would remove.
        let resolved = if meta.file_type().is_symlink() {
            std::fs::metadata(path).ok()
        } else {
            Some(meta)
        };
        if let Some(m) = resolved.filter(|m| !m.is_file() && !m.is_dir()) {
            return Err(out(format!(
                "is {}; vergence writes outputs only as regular files",
                kind(&m)
            )));
        }
    }
    if is_input(path) {
        return Err(out(
            "is one of this command's inputs; vergence never writes over an input".into(),
        ));
    }
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        if std::fs::metadata(dir).is_ok_and(|m| !m.is_dir()) {
            return Err(Error::Output {
                path: dir.to_path_buf(),
                message: "is a file, not a folder to write into".into(),
            });
        }
        std::fs::create_dir_all(dir).map_err(|e| Error::Output {
            path: dir.to_path_buf(),
            message: crate::error::plain(&e),
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
    let tmp = filled_temp(path, write)?;
    tmp.persist(path).map_err(|e| Error::Output {
        path: path.to_path_buf(),
        message: crate::error::plain(&e),
    })
}

/// A checked output's temporary file beside `path`, filled by `write`.
fn filled_temp(
    path: &Path,
    write: impl FnOnce(&mut dyn io::Write) -> io::Result<()>,
) -> Result<TempFile> {
    let out = |e: io::Error| Error::Output {
        path: path.to_path_buf(),
        message: crate::error::plain(&e),
    };
    prepare_output(path)?;
    let tmp = TempFile::beside(path).map_err(out)?;
    let mut w = io::BufWriter::new(tmp.file());
    write(&mut w).map_err(out)?;
    w.flush().map_err(out)?;
    drop(w);
    Ok(tmp)
}

/// Outputs written as a set (a render's images and statistics): each file
/// is filled in a fresh temporary file beside its target, and only
/// [`OutputSet::commit`] renames them all into place. Dropped without a
/// commit (a later write failed), every temporary file is removed and no
/// target has changed.
#[derive(Debug, Default)]
pub struct OutputSet {
    pending: Vec<(PathBuf, TempFile)>,
}

impl OutputSet {
    /// Fills `path`'s temporary file with `write`, as [`write_output`]
    /// checks and writes it, without renaming it yet.
    pub fn write(
        &mut self,
        path: &Path,
        write: impl FnOnce(&mut dyn io::Write) -> io::Result<()>,
    ) -> Result<()> {
        let tmp = filled_temp(path, write)?;
        self.pending.push((path.to_path_buf(), tmp));
        Ok(())
    }

    /// Renames every file of the set into place, in the order written.
    pub fn commit(self) -> Result<()> {
        for (path, tmp) in self.pending {
            tmp.persist(&path).map_err(|e| Error::Output {
                path: path.clone(),
                message: crate::error::plain(&e),
            })?;
        }
        Ok(())
    }
}

/// [`write_output`] of a byte string.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<()> {
    write_output(path, |w| w.write_all(bytes))
}

/// Opens `path` to append to (a log vergence keeps), creating it when
/// missing: never through a link (`O_NOFOLLOW`), never blocking on a FIFO,
/// and refused unless the open file is a regular one that is not one of
/// this process's inputs.
pub fn open_append(path: &Path) -> Result<File> {
    let out = |message: String| Error::Output {
        path: path.to_path_buf(),
        message,
    };
    prepare_output(path)?;
    let mut opts = std::fs::OpenOptions::new();
    opts.create(true).append(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt as _;
        opts.custom_flags(libc::O_NOFOLLOW | libc::O_NONBLOCK | libc::O_NOCTTY)
            .mode(0o644);
    }
    let file = opts.open(path).map_err(|e| {
        out(if is_link(path) {
            "is a symbolic link; vergence does not write through one".into()
        } else {
            crate::error::plain(&e)
        })
    })?;
    let meta = file.metadata().map_err(|e| out(crate::error::plain(&e)))?;
    if !meta.is_file() {
        return Err(out(not_regular(&meta)));
    }
    if file_id(path, &meta).is_some_and(|id| registered(&id)) {
        return Err(out(
            "is one of this command's inputs; vergence never writes over an input".into(),
        ));
    }
    Ok(file)
}

/// Whether `a` and `b` name the same existing file (links followed).
pub fn same_file(a: &Path, b: &Path) -> bool {
    match (std::fs::metadata(a), std::fs::metadata(b)) {
        (Ok(ma), Ok(mb)) => file_id(a, &ma).is_some() && file_id(a, &ma) == file_id(b, &mb),
        _ => false,
    }
}

/// Whether `path` itself is a symbolic link.
pub fn is_link(path: &Path) -> bool {
    std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink())
}

/// The names (without the extension) of the regular files ending in
/// `.ext` in folder `dir`, sorted; links and other kinds are left out, and
/// a missing or unreadable folder lists nothing.
pub fn list_files(dir: &Path, ext: &str) -> Vec<String> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut names: Vec<String> = entries
        .filter_map(|e| e.ok())
        .filter(|e| e.file_type().is_ok_and(|t| t.is_file()))
        .filter_map(|e| {
            let p = e.path();
            (p.extension()? == ext).then(|| p.file_stem()?.to_str().map(String::from))?
        })
        .collect();
    names.sort();
    names
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An input's inode number passed on to a new file (the input deleted,
    /// the number reused) is not the input: the registry checks that the
    /// path an input was read through still names that file.
    #[cfg(unix)]
    #[test]
    fn a_reused_inode_number_is_not_an_input() {
        let dir = std::env::temp_dir().join(format!("vergence-fsio-reuse-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let (gone, other) = (dir.join("gone.txt"), dir.join("other.txt"));
        std::fs::write(&gone, "read once").unwrap();
        std::fs::write(&other, "a new file").unwrap();
        let meta = std::fs::symlink_metadata(&other).unwrap();
        let id = file_id(&other, &meta).unwrap();
        // As if `gone` had been read with `other`'s inode number, then
        // deleted and the number reused by `other`.
        INPUTS.lock().unwrap().push((id.clone(), gone.clone()));
        std::fs::remove_file(&gone).unwrap();
        assert!(!is_input(&other));
        assert!(write_bytes(&other, b"replaced").is_ok());
        // While the path still names the file, it is one (the write above
        // replaced the file: its identity now).
        let now = file_id(&other, &std::fs::symlink_metadata(&other).unwrap()).unwrap();
        INPUTS.lock().unwrap().push((now, other.clone()));
        assert!(is_input(&other));
        let _ = std::fs::remove_dir_all(&dir);
    }
    #[cfg(unix)]
    use std::os::unix::fs::FileTypeExt as _;

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
    fn outputs_never_replace_fifos_devices_or_links_to_them() {
        let d = scratch("special");
        let fifo = d.join("fifo");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        // SAFETY: a valid NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        let e = write_bytes(&fifo, b"x").unwrap_err().to_string();
        assert!(e.contains("is a FIFO"), "{e}");
        assert!(std::fs::symlink_metadata(&fifo)
            .unwrap()
            .file_type()
            .is_fifo());
        // A link to a device (as /dev/stdout is): the rename would remove
        // the link, so it is refused as the device is.
        let null = d.join("null");
        std::os::unix::fs::symlink("/dev/null", &null).unwrap();
        let e = write_bytes(&null, b"x").unwrap_err().to_string();
        assert!(e.contains("a character device"), "{e}");
        assert!(std::fs::symlink_metadata(&null)
            .unwrap()
            .file_type()
            .is_symlink());
        let e = open_append(&fifo).unwrap_err().to_string();
        assert!(e.contains("is a FIFO"), "{e}");
    }

    #[test]
    fn an_output_set_lands_whole_or_not_at_all() {
        let d = scratch("set");
        std::fs::write(d.join("a.txt"), b"old a").unwrap();
        let mut set = OutputSet::default();
        set.write(&d.join("a.txt"), |w| w.write_all(b"new a"))
            .unwrap();
        let e = set
            .write(&d.join("b.txt"), |_| Err(io::Error::other("disk full")))
            .unwrap_err()
            .to_string();
        assert!(e.contains("disk full"), "{e}");
        drop(set);
        assert_eq!(std::fs::read(d.join("a.txt")).unwrap(), b"old a");
        assert!(!d.join("b.txt").exists());
        let mut set = OutputSet::default();
        set.write(&d.join("a.txt"), |w| w.write_all(b"new a"))
            .unwrap();
        set.write(&d.join("b.txt"), |w| w.write_all(b"b")).unwrap();
        assert_eq!(std::fs::read(d.join("a.txt")).unwrap(), b"old a");
        set.commit().unwrap();
        assert_eq!(std::fs::read(d.join("a.txt")).unwrap(), b"new a");
        assert_eq!(std::fs::read(d.join("b.txt")).unwrap(), b"b");
        let tmp = std::fs::read_dir(&d)
            .unwrap()
            .filter(|e| {
                e.as_ref()
                    .unwrap()
                    .file_name()
                    .to_string_lossy()
                    .ends_with(".tmp")
            })
            .count();
        assert_eq!(tmp, 0);
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
