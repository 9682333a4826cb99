//! Every file the command writes: checked before any work starts
//! ([`check_writable`]), then written whole or not at all ([`stage`] and
//! [`Staged::commit`], or [`write_atomic`]).
//!
//! A file is first written to a temporary file in the target's folder (so
//! the final rename stays on one file system and is atomic), then renamed
//! over the target. A failure, a drop or an interrupt (see
//! [`remove_pending`]) removes the temporary file: no half-written output
//! is ever left behind.

use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use tempfile::NamedTempFile;

use crate::InputError;

/// Temporary files being written, removed by [`remove_pending`] when the
/// process is interrupted before they are renamed or dropped.
static PENDING: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// The folder `path` is written in (`.` for a bare file name).
fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Checks, before any work, that `path` can be written: it is not a
/// folder, its folder exists and we may create files in it. `what` names
/// the option in the message (`-o`, `--heatmap`, ...). One message per
/// cause, as an input error (exit status 2).
pub fn check_writable(path: &Path, what: &str) -> Result<(), InputError> {
    let fail = |cause: String| {
        Err(InputError(format!(
            "{}: cannot write: {cause}",
            path.display()
        )))
    };
    if path.as_os_str().is_empty() {
        return Err(InputError(format!("{what}: empty file name")));
    }
    if path.is_dir() {
        return fail(format!("it is a folder; {what} names a file"));
    }
    let folder = folder_of(path);
    if !folder.exists() {
        return fail(format!("the folder {} does not exist", folder.display()));
    }
    if !folder.is_dir() {
        return fail(format!("{} is not a folder", folder.display()));
    }
    // Creating (and at once removing) a temporary file is the one honest
    // test of permission: access bits say nothing of ACLs or read-only mounts.
    match NamedTempFile::new_in(folder) {
        Ok(_) => Ok(()),
        Err(e) => fail(format!("{} in {}", e.kind(), folder.display())),
    }
}

/// A file written to a temporary name beside its target, not yet in place.
pub struct Staged {
    file: NamedTempFile,
    target: PathBuf,
    _pending: Pending,
}

/// A temporary file's entry in [`PENDING`], dropped with it.
struct Pending(PathBuf);

impl Pending {
    fn new(temp: &Path) -> Pending {
        lock_pending().push(temp.to_path_buf());
        Pending(temp.to_path_buf())
    }
}

impl Drop for Pending {
    fn drop(&mut self) {
        lock_pending().retain(|p| p != &self.0);
    }
}

/// Writes a file through `fill` to a temporary name beside `path`; nothing
/// appears at `path` until [`Staged::commit`].
pub fn stage(
    path: &Path,
    fill: impl FnOnce(&mut BufWriter<&std::fs::File>) -> io::Result<()>,
) -> anyhow::Result<Staged> {
    let cannot = |e: io::Error| anyhow::anyhow!("{}: cannot write: {e}", path.display());
    let name = path.file_name().unwrap_or_default().to_string_lossy();
    let prefix = format!(".{name}.");
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(".tmp");
    // A temporary file is private (0600) by default; the output it becomes
    // gets what any new file gets (0666 less the umask), as before.
    #[cfg(unix)]
    builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o666));
    let file = builder.tempfile_in(folder_of(path)).map_err(cannot)?;
    let staged = Staged {
        target: path.to_path_buf(),
        _pending: Pending::new(file.path()),
        file,
    };
    let mut writer = BufWriter::new(staged.file.as_file());
    fill(&mut writer)
        .and_then(|()| writer.flush())
        .map_err(cannot)?;
    drop(writer);
    staged.file.as_file().sync_all().map_err(cannot)?;
    Ok(staged)
}

impl Staged {
    /// Renames the file into place.
    pub fn commit(self) -> anyhow::Result<()> {
        // Dropped without a commit (an error on the way), NamedTempFile
        // removes the file itself.
        self.file
            .persist(&self.target)
            .map(|_| ())
            .map_err(|e| anyhow::anyhow!("{}: cannot write: {}", self.target.display(), e.error))
    }
}

/// Renames every staged file into place; if one fails, those already
/// renamed are removed again, so a run leaves all its outputs or none.
pub fn commit_all(staged: Vec<Staged>) -> anyhow::Result<()> {
    let mut done: Vec<PathBuf> = Vec::new();
    for s in staged {
        let target = s.target.clone();
        if let Err(e) = s.commit() {
            for path in &done {
                let _ = std::fs::remove_file(path);
            }
            return Err(e);
        }
        done.push(target);
    }
    Ok(())
}

/// Writes `path` whole or not at all: [`stage`] then [`Staged::commit`].
pub fn write_atomic(
    path: &Path,
    fill: impl FnOnce(&mut BufWriter<&std::fs::File>) -> io::Result<()>,
) -> anyhow::Result<()> {
    stage(path, fill)?.commit()
}

/// Writes `text` to `path` atomically.
pub fn write_text(path: &Path, text: &str) -> anyhow::Result<()> {
    write_atomic(path, |w| w.write_all(text.as_bytes()))
}

/// Stages `film` as the picture `path` names (`.png` or `.exr`).
pub fn stage_film(
    path: &Path,
    film: &arbor::film::Film,
    variant: arbor::scene::Variant,
) -> anyhow::Result<Staged> {
    let format =
        arbor::film::ImageFormat::from_path(path).map_err(|e| InputError(e.to_string()))?;
    stage(path, |w| film.encode(format, variant, w))
}

/// Whether `path` ends in `.png` (any case), for outputs that are PNG only.
pub fn has_png_extension(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("png"))
}

/// Checks, before any work, that `path` (a file, or with `folder` a
/// folder) can be made where missing folders on the way are created: it is
/// not of the other kind, and its nearest existing ancestor is a folder we
/// may write in. For `arbor farm`, which creates its tree of folders.
pub fn check_creatable(path: &Path, folder: bool, what: &str) -> Result<(), InputError> {
    if folder && path.is_file() {
        return Err(InputError(format!(
            "{}: cannot write: it is a file; {what} names a folder here",
            path.display()
        )));
    }
    if !folder && path.is_dir() {
        return Err(InputError(format!(
            "{}: cannot write: it is a folder; {what} names a file",
            path.display()
        )));
    }
    let mut ancestor = folder_of(path);
    while !ancestor.exists() {
        ancestor = folder_of(ancestor);
    }
    if !ancestor.is_dir() {
        return Err(InputError(format!(
            "{}: cannot write: {} is not a folder",
            path.display(),
            ancestor.display()
        )));
    }
    match NamedTempFile::new_in(ancestor) {
        Ok(_) => Ok(()),
        Err(e) => Err(InputError(format!(
            "{}: cannot write: {} in {}",
            path.display(),
            e.kind(),
            ancestor.display()
        ))),
    }
}

/// Removes the temporary files still being written: for an interrupt
/// handler about to exit the process (drops would not run).
pub fn remove_pending() {
    for path in lock_pending().drain(..) {
        let _ = std::fs::remove_file(path);
    }
}

/// For commands with no interrupt handling of their own (the batch
/// queries): Ctrl-C removes the temporary files being written and exits
/// with status 130. (A process has one handler: `render` installs its own,
/// which also calls [`remove_pending`].)
pub fn remove_pending_on_interrupt() {
    let _ = ctrlc::set_handler(|| {
        remove_pending();
        std::process::exit(130);
    });
}

fn lock_pending() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    // A panic elsewhere while holding the lock leaves the list usable.
    PENDING.lock().unwrap_or_else(|e| e.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Outputs are not left private to the user as temporary files are:
    /// others may read them (under the usual umask 022 of tests and CI).
    #[cfg(unix)]
    #[test]
    fn outputs_get_ordinary_permissions() {
        use std::os::unix::fs::PermissionsExt;
        let _turn = serial();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.txt");
        write_text(&path, "x").unwrap();
        let mode = std::fs::metadata(&path).unwrap().permissions().mode();
        assert_eq!(mode & 0o044, 0o044, "mode {mode:o}");
    }

    /// The pending list is global: tests that look at it take turns.
    static SERIAL: Mutex<()> = Mutex::new(());

    fn serial() -> std::sync::MutexGuard<'static, ()> {
        SERIAL.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn entries(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn checks_name_one_cause() {
        let dir = tempfile::tempdir().unwrap();
        let ok = dir.path().join("a.png");
        assert!(check_writable(&ok, "-o").is_ok());
        let missing = dir.path().join("nosuchdir/a.png");
        let e = check_writable(&missing, "-o").unwrap_err().0;
        assert!(e.ends_with("does not exist"), "{e}");
        let e = check_writable(dir.path(), "-o").unwrap_err().0;
        assert!(e.contains("it is a folder; -o names a file"), "{e}");
        std::fs::write(dir.path().join("f"), "x").unwrap();
        let e = check_writable(&dir.path().join("f/a.png"), "--heatmap")
            .unwrap_err()
            .0;
        assert!(e.contains("is not a folder"), "{e}");
        // The check leaves nothing behind.
        assert_eq!(entries(dir.path()), ["f"]);
    }

    #[test]
    fn staged_files_appear_only_on_commit() {
        let _serial = serial();
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.txt");
        let staged = stage(&a, |w| w.write_all(b"hello")).unwrap();
        assert!(!a.exists());
        assert_eq!(lock_pending().len(), 1);
        staged.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&a).unwrap(), "hello");
        assert_eq!(entries(dir.path()), ["a.txt"]);
        assert!(lock_pending().is_empty());
    }

    #[test]
    fn failures_leave_nothing() {
        let _serial = serial();
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.txt");
        let e = write_atomic(&a, |_| Err(io::Error::other("boom"))).unwrap_err();
        assert_eq!(
            e.to_string(),
            format!("{}: cannot write: boom", a.display())
        );
        // A staged file that is dropped, and one removed as on an interrupt.
        drop(stage(&a, |w| w.write_all(b"x")).unwrap());
        let kept = stage(&a, |w| w.write_all(b"x")).unwrap();
        remove_pending();
        assert!(entries(dir.path()).is_empty());
        assert!(kept.commit().is_err());
        assert!(entries(dir.path()).is_empty());
    }

    #[test]
    fn commit_all_is_all_or_nothing() {
        let _serial = serial();
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.txt");
        let sub = dir.path().join("sub");
        std::fs::create_dir(&sub).unwrap();
        let b = sub.join("b.txt");
        let sa = stage(&a, |w| w.write_all(b"a")).unwrap();
        let sb = stage(&b, |w| w.write_all(b"b")).unwrap();
        // The second target becomes a folder: its rename fails.
        std::fs::create_dir(&b).unwrap();
        assert!(commit_all(vec![sa, sb]).is_err());
        assert_eq!(entries(dir.path()), ["sub"]);
        assert_eq!(entries(&sub), ["b.txt"]);
        assert!(b.is_dir());
    }
}
