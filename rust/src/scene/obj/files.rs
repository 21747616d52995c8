//! Opening the files a load reads, safely: only regular files (a FIFO or a device would hang
//! the load or never end), at most [`MAX_OBJ_BYTES`], and an MTL file only if the file
//! actually opened lies in the OBJ's folder. The check is made on the opened descriptor, so
//! that a symbolic link swapped between a check and the read cannot lead outside.
use crate::budget;
use crate::error::{Error, Result};
use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};

/// The largest OBJ or MTL file a load reads (bytes): 1 GiB. A load also needs about
/// [`BYTES_PER_FILE_BYTE`] times the file's size in memory, within the memory limit.
pub const MAX_OBJ_BYTES: u64 = 1 << 30;

/// Memory a load needs per byte of OBJ text (the text, its cleaned copy for tobj, tobj's
/// models, the pre-scan's corners and names).
pub const BYTES_PER_FILE_BYTE: f64 = 8.0;

/// Open `path` for reading without blocking (a FIFO opens at once) and, when `no_follow`, not
/// through a symbolic link in its last component.
fn open(path: &Path, no_follow: bool) -> std::io::Result<File> {
    let mut o = std::fs::OpenOptions::new();
    o.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        let follow = if no_follow { libc::O_NOFOLLOW } else { 0 };
        o.custom_flags(libc::O_NONBLOCK | follow);
    }
    #[cfg(not(unix))]
    let _ = no_follow;
    o.open(path)
}

/// The path the open descriptor `f` names, where the system says (Linux: /proc/self/fd).
fn opened_path(f: &File) -> Option<PathBuf> {
    #[cfg(target_os = "linux")]
    {
        use std::os::fd::AsRawFd;
        std::fs::read_link(format!("/proc/self/fd/{}", f.as_raw_fd())).ok()
    }
    #[cfg(not(target_os = "linux"))]
    {
        let _ = f;
        None
    }
}

/// Read the whole of an opened regular file of at most `MAX_OBJ_BYTES` bytes.
fn read_regular(mut f: File, what: &str) -> std::result::Result<Vec<u8>, String> {
    let meta = f
        .metadata()
        .map_err(|e| format!("cannot inspect it: {e}"))?;
    if !meta.is_file() {
        return Err(format!(
            "it is not a regular file (a folder, FIFO, socket or device); {what} must be a \
             file"
        ));
    }
    let size = meta.len();
    if size > MAX_OBJ_BYTES {
        return Err(format!(
            "it is {}, larger than the largest file a load reads ({}; \
             batecho.trees.objfile.MAX_OBJ_BYTES); split the mesh into several files",
            budget::human(size as f64),
            budget::human(MAX_OBJ_BYTES as f64)
        ));
    }
    budget::check(
        size as f64 * BYTES_PER_FILE_BYTE,
        || format!("loading a {} file", budget::human(size as f64)),
        "split the mesh into several files",
    )
    .map_err(|e| e.to_string())?;
    let mut bytes =
        budget::with_capacity(size as usize + 1, "the file's text").map_err(|e| e.to_string())?;
    // At most one byte more than its size said: a file that grows while read is refused.
    (&mut f)
        .take(size + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| format!("cannot read it: {e}"))?;
    if bytes.len() as u64 > size {
        return Err("it grew while being read".into());
    }
    Ok(bytes)
}

/// The bytes of the OBJ file at `path` (a regular file, within the size limits).
pub(super) fn read_obj(path: &Path, file: &str) -> Result<Vec<u8>> {
    let f = open(path, false)
        .map_err(|e| Error::Obj(format!("{file}: cannot read the OBJ file: {e}")))?;
    read_regular(f, "an OBJ")
        .map_err(|why| Error::Obj(format!("{file}: cannot read the OBJ file: {why}")))
}

/// The bytes of the MTL file at `full`, opened only if what is opened is a regular file
/// inside `obj_dir` (whose canonical form is `dir`); `Err(NotFound)` when it does not exist,
/// `Err(Other)` with the reason otherwise.
pub(super) fn read_mtl(full: &Path, dir: &Path) -> std::result::Result<Vec<u8>, MtlRefusal> {
    let f = open(full, true).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => MtlRefusal::NotFound,
        _ if is_symlink_error(&e) => MtlRefusal::Outside(
            "it is a symbolic link (refused: only regular files in the OBJ's folder are read)"
                .into(),
        ),
        _ => MtlRefusal::Unreadable(e.to_string()),
    })?;
    if let Some(real) = opened_path(&f) {
        if !real.starts_with(dir) {
            return Err(MtlRefusal::Outside(format!(
                "it resolves to {}, outside the OBJ's folder",
                real.display()
            )));
        }
    }
    read_regular(f, "a material library").map_err(MtlRefusal::Unreadable)
}

/// Why an MTL file was not read.
pub(super) enum MtlRefusal {
    NotFound,
    /// It leads outside the OBJ's folder: an error of the load, not a warning.
    Outside(String),
    Unreadable(String),
}

fn is_symlink_error(e: &std::io::Error) -> bool {
    #[cfg(unix)]
    {
        e.raw_os_error() == Some(libc::ELOOP)
    }
    #[cfg(not(unix))]
    {
        let _ = e;
        false
    }
}
