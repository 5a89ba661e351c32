//! A user's files: every file a user names is read by [`read_text`] and
//! every file a command will write is checked by [`check_output`] before
//! the work starts, so bad paths fail at once, alike, on one line
//! ([`InputError::Unreadable`]).
//!
//! # Reading ([`read_text`])
//!
//! * Each kind of file has a size cap ([`Cap`]: [`ROBOT_FILE`],
//!   [`SCENE_FILE`], [`MEASUREMENT_FILE`], [`PLAN_FILE`]); at most one byte
//!   past it is read, so a device that never ends (`/dev/zero`) is refused
//!   at once.
//! * The text must be UTF-8 without NUL bytes (the message gives the byte
//!   offset of the first bad byte); a leading UTF-8 byte-order mark, which
//!   some editors write, is dropped.
//! * A directory, a missing file, a file that cannot be opened: refused,
//!   saying which.
//! * Nothing waits forever. Opening a named pipe (FIFO) with no writer
//!   blocks, so a FIFO reached by a name is refused; a pipe given as an open
//!   descriptor (`/dev/stdin`, `/dev/fd/N`, `/proc/self/fd/N`, as a shell's
//!   `<(...)` does) is read like a file, its writer deciding when it ends.
//!   Devices (`/dev/null` reads as an empty file, `/dev/zero` as a file too
//!   long) are opened non-blocking: one with nothing to read now (a
//!   terminal) is refused rather than waited on.
//!
//! # Writing ([`check_output`])
//!
//! The path must not be a directory nor a named pipe; a new file's
//! directory must exist; the file must be writable, which is tried without
//! clobbering anything: an existing file is opened for writing without
//! truncation, a new one is created and removed again. An extension, when
//! given, must end the name (ASCII case ignored): `--png` writes PNG only
//! to a `.png` name, the name choosing the format.

use std::io::Read;
use std::path::Path;

use crate::error::{clip, InputError, MESSAGE_CHARS};

/// The size cap of one kind of file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cap {
    /// Most bytes read.
    pub bytes: usize,
    /// The kind of file, as messages name what is allowed (`robot file`).
    pub kind: &'static str,
}

/// Robot files (TOML): a real one has a few kB.
pub const ROBOT_FILE: Cap = Cap { bytes: 1 << 20, kind: "robot file" };

/// Scene and scenario files (TOML), as [`crate::scene::MAX_SCENE_BYTES`].
pub const SCENE_FILE: Cap = Cap { bytes: crate::scene::MAX_SCENE_BYTES, kind: "scene or scenario file" };

/// Measurement files (CSV): room for [`crate::calibration::MAX_ROWS`] long rows.
pub const MEASUREMENT_FILE: Cap = Cap { bytes: 16 << 20, kind: "measurement file" };

/// Plan files (JSON, from `leech climb --json`).
pub const PLAN_FILE: Cap = Cap { bytes: 16 << 20, kind: "plan file" };

/// A byte count as messages print it: `1 MiB`, `16 MiB`, `512 bytes`.
fn size(bytes: usize) -> String {
    match bytes {
        b if b >= 1 << 20 && b % (1 << 20) == 0 => format!("{} MiB", b >> 20),
        b if b >= 1 << 10 && b % (1 << 10) == 0 => format!("{} KiB", b >> 10),
        b => format!("{b} bytes"),
    }
}

/// A path as messages quote it: escaped, and clipped only at
/// [`MESSAGE_CHARS`], since the user typed it and its end names the file.
pub fn shown(path: &Path) -> String {
    format!("'{}'", clip(&path.to_string_lossy(), MESSAGE_CHARS).replace('\'', "\\'"))
}

/// The house message for `path`: `FIELD: got PATH, PROBLEM; expected ALLOWED`.
fn unreadable(field: &str, path: &Path, problem: impl Into<String>, allowed: impl Into<String>) -> InputError {
    InputError::Unreadable { field: field.into(), file: shown(path), problem: problem.into(), allowed: allowed.into() }
}

/// Whether `path` names a descriptor this process already has open (a
/// shell's pipe): opening it cannot wait for a writer.
fn open_descriptor(path: &Path) -> bool {
    path == Path::new("/dev/stdin") || path.starts_with("/dev/fd") || path.starts_with("/proc/self/fd")
}

/// Why an I/O error stopped reading a file of `kind`, and what is allowed.
fn why(e: &std::io::Error, kind: &str) -> (String, String) {
    use std::io::ErrorKind;
    match e.kind() {
        ErrorKind::NotFound => ("which does not exist".into(), format!("an existing {kind}")),
        ErrorKind::PermissionDenied => {
            ("which cannot be opened (permission denied)".into(), format!("a {kind} this user may read"))
        }
        ErrorKind::WouldBlock => ("which has nothing to read now (a terminal or device)".into(), format!("a {kind}")),
        _ => (format!("which cannot be read ({e})"), format!("a readable {kind}")),
    }
}

/// The text of the file at `path`, a user's `field` (`--robot`) naming it
/// in errors, read under the rules of the module doc: at most `cap.bytes`,
/// UTF-8 without NUL bytes, a leading byte-order mark dropped.
///
/// ```
/// use leech::files::{read_text, ROBOT_FILE};
/// let e = read_text("/no/such/robot.toml".as_ref(), "--robot", ROBOT_FILE).unwrap_err();
/// assert_eq!(
///     e.to_string(),
///     "--robot: got '/no/such/robot.toml', which does not exist; expected an existing robot file"
/// );
/// ```
pub fn read_text(path: &Path, field: &str, cap: Cap) -> Result<String, InputError> {
    let failed = |e: std::io::Error| {
        let (problem, allowed) = why(&e, cap.kind);
        unreadable(field, path, problem, allowed)
    };
    let meta = std::fs::metadata(path).map_err(failed)?;
    let kind = meta.file_type();
    if kind.is_dir() {
        return Err(unreadable(field, path, "which is a directory", format!("a {}", cap.kind)));
    }
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    if !kind.is_file() && !open_descriptor(path) {
        #[cfg(unix)]
        {
            use std::os::unix::fs::{FileTypeExt, OpenOptionsExt};
            if kind.is_fifo() || kind.is_socket() {
                return Err(unreadable(
                    field,
                    path,
                    "which is a named pipe or socket",
                    format!("a regular {} (or a pipe on /dev/stdin)", cap.kind),
                ));
            }
            options.custom_flags(libc::O_NONBLOCK);
        }
    }
    let mut bytes = Vec::new();
    options.open(path).and_then(|f| f.take(cap.bytes as u64 + 1).read_to_end(&mut bytes)).map_err(failed)?;
    if bytes.len() > cap.bytes {
        let cap_text = size(cap.bytes);
        return Err(unreadable(
            field,
            path,
            format!("which is larger than {cap_text}"),
            format!("a {} of at most {cap_text}", cap.kind),
        ));
    }
    text(bytes).map_err(|problem| unreadable(field, path, problem, "UTF-8 text without NUL bytes"))
}

/// The text of a file's bytes: a leading byte-order mark dropped, then
/// UTF-8 without NUL bytes, or why not, as a clause on the path (offsets
/// count the file's bytes).
fn text(mut bytes: Vec<u8>) -> Result<String, String> {
    const BOM: &[u8] = b"\xef\xbb\xbf";
    let skipped = if bytes.starts_with(BOM) { BOM.len() } else { 0 };
    bytes.drain(..skipped);
    if let Some(at) = bytes.iter().position(|b| *b == 0) {
        return Err(format!("which has a NUL byte at byte offset {}", at + skipped));
    }
    String::from_utf8(bytes).map_err(|e| {
        format!("which is not UTF-8 (a bad byte at byte offset {})", e.utf8_error().valid_up_to() + skipped)
    })
}

/// Checks a command can write `path` (its output flag `field`) before it
/// works, under the rules of the module doc; `extension` (`"png"`), when
/// given, must end the name.
pub fn check_output(path: &Path, field: &str, extension: Option<&str>) -> Result<(), InputError> {
    if let Some(ext) = extension {
        if !path.extension().is_some_and(|e| e.eq_ignore_ascii_case(ext)) {
            return Err(unreadable(
                field,
                path,
                format!("which does not end in .{ext}"),
                format!("a name ending in .{ext}"),
            ));
        }
    }
    let cannot = |e: std::io::Error| match e.kind() {
        std::io::ErrorKind::PermissionDenied => {
            unreadable(field, path, "which cannot be written (permission denied)", "a path this user may write")
        }
        _ => unreadable(field, path, format!("which cannot be written ({e})"), "a writable path"),
    };
    match std::fs::metadata(path) {
        Ok(meta) if meta.is_dir() => Err(unreadable(field, path, "which is a directory", "a file name")),
        Ok(meta) => {
            #[cfg(unix)]
            {
                use std::os::unix::fs::FileTypeExt;
                // Opening a FIFO for writing waits for a reader.
                if (meta.file_type().is_fifo() || meta.file_type().is_socket()) && !open_descriptor(path) {
                    return Err(unreadable(field, path, "which is a named pipe or socket", "a regular file"));
                }
            }
            std::fs::OpenOptions::new().write(true).open(path).map(drop).map_err(cannot)
        }
        Err(_) => {
            let parent = match path.parent() {
                Some(p) if !p.as_os_str().is_empty() => p,
                _ => Path::new("."),
            };
            if !parent.is_dir() {
                return Err(unreadable(
                    field,
                    path,
                    "whose directory does not exist",
                    "a path in an existing directory",
                ));
            }
            std::fs::OpenOptions::new().write(true).create_new(true).open(path).map_err(cannot)?;
            std::fs::remove_file(path).map_err(cannot)
        }
    }
}

/// Checks a command can write files into the directory `path` (its flag
/// `field`), creating it (and its parents) if it does not exist.
pub fn check_output_dir(path: &Path, field: &str) -> Result<(), InputError> {
    if path.exists() && !path.is_dir() {
        return Err(unreadable(field, path, "which is not a directory", "a directory"));
    }
    std::fs::create_dir_all(path).map_err(|e| {
        unreadable(field, path, format!("which cannot be created ({e})"), "a directory that can be created")
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("leech-files-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn text_rules() {
        assert_eq!(text(b"\xef\xbb\xbfname = 1".to_vec()).unwrap(), "name = 1");
        assert_eq!(text(b"ab\0c".to_vec()).unwrap_err(), "which has a NUL byte at byte offset 2");
        let e = text(b"\xef\xbb\xbfab\xffc".to_vec()).unwrap_err();
        assert!(e.contains("byte offset 5"), "{e}");
        assert_eq!(text(Vec::new()).unwrap(), "");
    }

    #[test]
    fn caps_and_kinds() {
        let d = dir("read");
        let big = d.join("big.toml");
        std::fs::write(&big, vec![b'#'; 2049]).unwrap();
        let cap = Cap { bytes: 2048, kind: "test file" };
        let e = read_text(&big, "--x", cap).unwrap_err().to_string();
        assert_eq!(
            e,
            format!("--x: got {}, which is larger than 2 KiB; expected a test file of at most 2 KiB", shown(&big))
        );
        assert!(read_text(&big, "--x", Cap { bytes: 2049, kind: "test file" }).is_ok());
        let e = read_text(&d, "--x", cap).unwrap_err().to_string();
        assert!(e.ends_with("which is a directory; expected a test file"), "{e}");
        #[cfg(target_os = "linux")]
        {
            assert_eq!(read_text("/dev/null".as_ref(), "--x", cap).unwrap(), "");
            let e = read_text("/dev/zero".as_ref(), "--robot", ROBOT_FILE).unwrap_err().to_string();
            assert_eq!(
                e,
                "--robot: got '/dev/zero', which is larger than 1 MiB; expected a robot file of at most 1 MiB"
            );
        }
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn outputs_checked_without_clobbering() {
        let d = dir("write");
        let kept = d.join("kept.svg");
        std::fs::write(&kept, "old").unwrap();
        check_output(&kept, "--svg", None).unwrap();
        assert_eq!(std::fs::read_to_string(&kept).unwrap(), "old");
        let new = d.join("new.png");
        check_output(&new, "--png", Some("png")).unwrap();
        assert!(!new.exists());
        let e = check_output(&d.join("a.svg"), "--png", Some("png")).unwrap_err().to_string();
        assert!(e.contains("expected a name ending in .png"), "{e}");
        let e = check_output(&d, "--svg", None).unwrap_err().to_string();
        assert!(e.ends_with("which is a directory; expected a file name"), "{e}");
        let e = check_output(&d.join("no/x.csv"), "--csv", None).unwrap_err().to_string();
        assert!(e.ends_with("whose directory does not exist; expected a path in an existing directory"), "{e}");
        let e = check_output_dir(&kept, "--out").unwrap_err().to_string();
        assert!(e.contains("is not a directory"), "{e}");
        std::fs::remove_dir_all(&d).unwrap();
    }
}
