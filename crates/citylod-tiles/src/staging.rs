//! Atomic output directories. Everything is written into a staging folder `<dir>.citylod-tmp-<pid>` beside `dir`,
//! and [`Staging::commit`] swaps it in: the old `dir` is renamed into the staging folder, the new content renamed to
//! `dir`, then the staging folder (with the old content) is deleted. Invariant: a run that fails or panics before
//! `commit` never leaves a partial tileset at `dir`.
//!
//! Where `dir` cannot be renamed — a mount point (a container's volume, `docker run -v $PWD/tiles:/out`) — or
//! nothing can be created beside it (its parent is not writable), the staging folder is `dir/.citylod-tmp-<pid>`
//! instead, and `commit` moves `dir`'s old entries into it, then the new ones into `dir`, `tileset.json` last; a
//! failure moves everything back. The invariant holds; only the swap itself is entry by entry.
//!
//! A staging folder is citylod's beyond doubt: its name, and a marker file ([`MARKER`]) written into it first thing
//! and kept locked while its build runs. It holds `new/` (what is written), during the swap `old/` (the previous
//! content) and, inside the destination, `swapping` (the names being moved in) and `done` (the swap is complete).
//! A build that was killed (Ctrl-C, SIGKILL, power loss) leaves its staging folder; [`Staging::recover`], run before
//! every build, tells from these what state the killed build left and undoes it: the previous content is put back
//! where the swap was cut short, an unfinished output deleted. Folders without the marker are never deleted (an
//! empty one excepted), nor those whose build still holds the lock.

use crate::TilesError;
use std::fs::File;
use std::path::{Path, PathBuf};

/// The prefix of the folders a [`Staging`] keeps inside its destination when it cannot stage beside it.
pub const INSIDE_PREFIX: &str = ".citylod-";

/// The staging folder's name after `<dest name>.` (beside) or `.` (inside), before the pid.
const TAG: &str = "citylod-tmp-";
/// The marker file of a staging folder, written first thing and locked while its build runs.
const MARKER: &str = ".citylod-staging";
/// Inside a staging folder: what is written; the previous content during the swap; the names moved into the
/// destination (inside only); the swap is complete (inside only).
const NEW: &str = "new";
const OLD: &str = "old";
const SWAPPING: &str = "swapping";
const DONE: &str = "done";

/// A staging directory that becomes `dest` on [`commit`](Staging::commit) and is deleted if dropped
/// uncommitted.
#[derive(Debug)]
pub struct Staging {
    dest: PathBuf,
    /// The staging folder (holding the marker, `new/` and during the swap `old/`).
    root: PathBuf,
    /// `root/new`, written into.
    tmp: PathBuf,
    /// Staged inside `dest` (see the module's documentation).
    inside: bool,
    committed: bool,
    /// The marker, open and locked while this build runs (a killed build's lock is released by the system); closed
    /// before the staging folder is deleted (an open file cannot be deleted everywhere).
    marker: Option<File>,
}

/// The previous content of the destination, moved away by [`Staging::commit`] but not deleted: its path and why.
#[derive(Debug)]
pub struct LeftBehind {
    pub path: PathBuf,
    pub error: std::io::Error,
}

/// `dest` with a last component (`.` and `..` made absolute).
fn named(dest: &Path) -> Result<PathBuf, TilesError> {
    if dest.file_name().is_none() {
        std::path::absolute(dest).map_err(TilesError::io(dest))
    } else {
        Ok(dest.to_path_buf())
    }
}

/// `<dest name>.citylod-tmp-` (beside `dest`), `.citylod-tmp-` (inside it).
fn prefix(dest: &Path, inside: bool) -> String {
    if inside {
        format!(".{TAG}")
    } else {
        let name = dest
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "tileset".into());
        format!("{name}.{TAG}")
    }
}

/// The folder that holds `dest`'s staging folders (beside) or `dest` (inside).
fn holder(dest: &Path, inside: bool) -> PathBuf {
    match dest.parent() {
        _ if inside => dest.to_path_buf(),
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

fn exists(p: &Path) -> bool {
    std::fs::symlink_metadata(p).is_ok()
}

fn is_real_dir(p: &Path) -> bool {
    std::fs::symlink_metadata(p).is_ok_and(|m| m.is_dir())
}

/// The staging folders of `dest` (beside it or inside it) with the pid in their names: real folders named
/// `<prefix><digits>`, sorted.
fn staging_folders(dest: &Path, inside: bool) -> Vec<(PathBuf, u32)> {
    let prefix = prefix(dest, inside);
    let Ok(entries) = std::fs::read_dir(holder(dest, inside)) else {
        return Vec::new();
    };
    let mut found: Vec<(PathBuf, u32)> = entries
        .flatten()
        .filter_map(|e| {
            let name = e.file_name();
            let pid = name.to_str()?.strip_prefix(&prefix)?;
            if pid.is_empty() || !pid.bytes().all(|b| b.is_ascii_digit()) {
                return None;
            }
            let pid = pid.parse::<u32>().ok()?;
            // Named as `dest` is (`tiles.citylod-tmp-…`, not `./tiles.citylod-tmp-…`), for messages.
            let path = if inside {
                dest.join(&name)
            } else {
                dest.with_file_name(&name)
            };
            is_real_dir(&path).then_some((path, pid))
        })
        .collect();
    found.sort();
    found
}

/// Whether the build that made the staging folder `folder` (pid `pid`) has ended: its marker's lock is free (the
/// system releases a dead process's locks, whoever has its pid now). Where locks are not supported, whether
/// `/proc/<pid>` is gone (our own pid: left by an earlier run in a container, where every run has the same pid);
/// `None` where that cannot be told either.
fn owner_gone(folder: &Path, pid: u32) -> Option<bool> {
    if let Ok(f) = std::fs::OpenOptions::new()
        .read(true)
        .open(folder.join(MARKER))
    {
        match f.try_lock() {
            Ok(()) => return Some(true),
            Err(std::fs::TryLockError::WouldBlock) => return Some(false),
            Err(std::fs::TryLockError::Error(_)) => {}
        }
    }
    if !Path::new("/proc/self").exists() {
        return None;
    }
    Some(pid == std::process::id() || !Path::new(&format!("/proc/{pid}")).exists())
}

/// The staging folder `folder` is citylod's and its build has ended; an empty folder without a marker (a build
/// killed as it made it) is removed.
fn abandoned(folder: &Path, pid: u32) -> bool {
    if !std::fs::symlink_metadata(folder.join(MARKER)).is_ok_and(|m| m.is_file()) {
        let _ = std::fs::remove_dir(folder);
        return false;
    }
    owner_gone(folder, pid) == Some(true)
}

/// Deletes an abandoned staging folder, saying why in `notes` (`what`: what it held), or that it could not.
fn remove_abandoned(folder: &Path, what: &str, notes: &mut Vec<String>) {
    match std::fs::remove_dir_all(folder) {
        Ok(()) if what.is_empty() => {}
        Ok(()) => notes.push(format!("note: removed {}: {what}", folder.display())),
        Err(e) => notes.push(format!(
            "warning: {} ({what}) could not be removed ({e}); delete it yourself",
            folder.display()
        )),
    }
}

/// Moves every entry of `from` into `to`; none may exist there.
fn move_back(from: &Path, to: &Path) -> Result<(), TilesError> {
    for e in std::fs::read_dir(from).map_err(TilesError::io(from))? {
        let n = e.map_err(TilesError::io(from))?.file_name();
        if exists(&to.join(&n)) {
            return Err(TilesError::File {
                path: to.join(&n),
                msg: format!(
                    "exists, so {} cannot be moved back there; the previous content is still in {}",
                    from.join(&n).display(),
                    from.display()
                ),
            });
        }
        std::fs::rename(from.join(&n), to.join(&n)).map_err(TilesError::io(from.join(&n)))?;
    }
    Ok(())
}

/// Sorted names of the entries of `dir`.
fn names(dir: &Path) -> Result<Vec<std::ffi::OsString>, TilesError> {
    let mut v = Vec::new();
    for e in std::fs::read_dir(dir).map_err(TilesError::io(dir))? {
        v.push(e.map_err(TilesError::io(dir))?.file_name());
    }
    v.sort();
    Ok(v)
}

/// `dest` is a folder on another file system than its parent's: a mount point, which cannot be renamed.
fn is_mount_point(dest: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        let parent = match dest.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
        match (std::fs::metadata(dest), std::fs::metadata(parent)) {
            (Ok(d), Ok(p)) => d.is_dir() && d.dev() != p.dev(),
            _ => false,
        }
    }
    #[cfg(not(unix))]
    {
        let _ = dest;
        false
    }
}

impl Staging {
    /// Undoes what builds killed while writing to `dest` left (see the module's documentation): a staging folder
    /// beside `dest` whose swap was cut short between its two renames gives `dest` back (when `dest` is missing);
    /// one inside `dest` moves the previous entries back; an unfinished output, or a previous one whose
    /// replacement was complete, is deleted. Returns what was done, one line each ("note: …" or "warning: …"), for
    /// the user to read. Only staging folders with citylod's marker whose build has ended are touched.
    pub fn recover(dest: &Path) -> Result<Vec<String>, TilesError> {
        let dest = named(dest)?;
        let mut notes = Vec::new();
        for (folder, pid) in staging_folders(&dest, false) {
            if abandoned(&folder, pid) {
                Self::recover_beside(&dest, &folder, pid, &mut notes)?;
            }
        }
        if is_real_dir(&dest) {
            for (folder, pid) in staging_folders(&dest, true) {
                if abandoned(&folder, pid) {
                    Self::recover_inside(&dest, &folder, pid, &mut notes)?;
                }
            }
        }
        Ok(notes)
    }

    fn recover_beside(
        dest: &Path,
        folder: &Path,
        pid: u32,
        notes: &mut Vec<String>,
    ) -> Result<(), TilesError> {
        let (old, new) = (folder.join(OLD), folder.join(NEW));
        if !exists(&old) {
            let what = format!("the unfinished output of a build (pid {pid}) that was stopped");
            remove_abandoned(folder, &what, notes);
        } else if !exists(dest) {
            std::fs::rename(&old, dest).map_err(TilesError::io(&old))?;
            notes.push(format!(
                "note: restored {} from {}, where a build (pid {pid}) that was stopped while replacing it had moved \
                 it",
                dest.display(),
                old.display()
            ));
            remove_abandoned(folder, "", notes);
        } else if exists(&new) {
            // Stopped between the renames, and `dest` made again since: which one is wanted is not ours to say.
            notes.push(format!(
                "warning: {} holds the previous content of {}, moved aside by a build (pid {pid}) that was stopped \
                 before it moved its output in; {} has been made again since, so both are left as they are: keep \
                 the one you want and delete {}",
                old.display(),
                dest.display(),
                dest.display(),
                folder.display()
            ));
        } else {
            let what = format!(
                "the previous content of {}, replaced by a build (pid {pid}) that was stopped before it deleted it",
                dest.display()
            );
            remove_abandoned(folder, &what, notes);
        }
        Ok(())
    }

    fn recover_inside(
        dest: &Path,
        folder: &Path,
        pid: u32,
        notes: &mut Vec<String>,
    ) -> Result<(), TilesError> {
        let (old, new) = (folder.join(OLD), folder.join(NEW));
        if exists(&folder.join(DONE)) {
            let what = format!(
                "the previous content of {}, replaced by a build (pid {pid}) that was stopped before it deleted it",
                dest.display()
            );
            remove_abandoned(folder, &what, notes);
            return Ok(());
        }
        if !exists(&old) {
            let what = format!("the unfinished output of a build (pid {pid}) that was stopped");
            remove_abandoned(folder, &what, notes);
            return Ok(());
        }
        // Stopped while swapping: the entries it had moved in go back to its staging folder, then the previous
        // ones back into `dest`.
        let swapping = folder.join(SWAPPING);
        if exists(&swapping) {
            let list = std::fs::read_to_string(&swapping).map_err(TilesError::io(&swapping))?;
            std::fs::create_dir_all(&new).map_err(TilesError::io(&new))?;
            for n in list.lines().filter(|n| !n.is_empty() && !n.contains('/')) {
                if exists(&dest.join(n)) && !exists(&new.join(n)) {
                    std::fs::rename(dest.join(n), new.join(n))
                        .map_err(TilesError::io(dest.join(n)))?;
                }
            }
        }
        let moved = !names(&old)?.is_empty();
        move_back(&old, dest)?;
        if moved {
            notes.push(format!(
                "note: restored the previous content of {} from {}, where a build (pid {pid}) that was stopped \
                 while replacing it had moved it",
                dest.display(),
                old.display()
            ));
        }
        let what = format!("the unfinished output of a build (pid {pid}) that was stopped");
        remove_abandoned(folder, if moved { "" } else { &what }, notes);
        Ok(())
    }

    /// The `old/` folders of staging folders inside `dest` (with citylod's marker) that still hold a previous
    /// content: saved by a build stopped while swapping, and not restored by [`recover`](Self::recover) because
    /// that build may still run (or whether it does cannot be told).
    pub fn saved_inside(dest: &Path) -> Vec<PathBuf> {
        if !is_real_dir(dest) {
            return Vec::new();
        }
        staging_folders(dest, true)
            .into_iter()
            .filter(|(f, _)| exists(&f.join(MARKER)) && !exists(&f.join(DONE)))
            .map(|(f, _)| f.join(OLD))
            .filter(|o| std::fs::read_dir(o).is_ok_and(|mut d| d.next().is_some()))
            .collect()
    }

    /// Creates an empty staging folder for `dest` (see the module's documentation) and the parent directories of
    /// `dest`, after [`recover`](Self::recover)ing what killed builds left; inside `dest` where `dest` is a mount
    /// point or nothing can be created beside it.
    pub fn create(dest: &Path) -> Result<Staging, TilesError> {
        let dest = named(dest)?;
        Self::recover(&dest)?;
        if is_mount_point(&dest) {
            return Self::create_inside(dest);
        }
        let root =
            holder(&dest, false).join(format!("{}{}", prefix(&dest, false), std::process::id()));
        if let Some(parent) = dest.parent().filter(|p| !p.as_os_str().is_empty()) {
            match std::fs::create_dir_all(parent) {
                Err(e) if e.kind() == std::io::ErrorKind::PermissionDenied && dest.is_dir() => {
                    return Self::create_inside(dest)
                }
                r => r.map_err(TilesError::io(parent))?,
            }
        }
        match std::fs::create_dir(&root) {
            Ok(()) => Self::init(dest, root, false),
            Err(e) if e.kind() == std::io::ErrorKind::PermissionDenied && dest.is_dir() => {
                Self::create_inside(dest)
            }
            Err(e) => Err(Self::in_use(&root, e)),
        }
    }

    /// Stages in `dest/.citylod-tmp-<pid>` (see the module's documentation).
    fn create_inside(dest: PathBuf) -> Result<Staging, TilesError> {
        let root = dest.join(format!("{}{}", prefix(&dest, true), std::process::id()));
        std::fs::create_dir(&root).map_err(|e| Self::in_use(&root, e))?;
        Self::init(dest, root, true)
    }

    /// The error of a staging folder that could not be made.
    fn in_use(root: &Path, e: std::io::Error) -> TilesError {
        if e.kind() == std::io::ErrorKind::AlreadyExists {
            TilesError::File {
                path: root.to_path_buf(),
                msg: "exists: another build in this process is writing to the same folder, or an earlier \
                      one left it (it lacks citylod's marker); delete it if no build is running"
                    .into(),
            }
        } else {
            TilesError::io(root)(e)
        }
    }

    /// Writes the marker (locked) and `new/` into the just made staging folder `root`; deletes it on failure.
    fn init(dest: PathBuf, root: PathBuf, inside: bool) -> Result<Staging, TilesError> {
        let made = (|| -> Result<File, TilesError> {
            let path = root.join(MARKER);
            let mut marker = std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&path)
                .map_err(TilesError::io(&path))?;
            // Unsupported locks (some network file systems) leave the pid to tell whether the build runs.
            let _ = marker.try_lock();
            use std::io::Write;
            writeln!(
                marker,
                "citylod staging folder of {} (pid {}): deleted when the build ends; the next build to the same \
                 folder cleans it up if that build was stopped",
                dest.display(),
                std::process::id()
            )
            .map_err(TilesError::io(&path))?;
            std::fs::create_dir(root.join(NEW)).map_err(TilesError::io(root.join(NEW)))?;
            Ok(marker)
        })();
        match made {
            Ok(marker) => Ok(Staging {
                dest,
                tmp: root.join(NEW),
                root,
                inside,
                committed: false,
                marker: Some(marker),
            }),
            Err(e) => {
                let _ = std::fs::remove_dir_all(&root);
                Err(e)
            }
        }
    }

    /// The staging directory to write into.
    pub fn path(&self) -> &Path {
        &self.tmp
    }

    /// The directory the output will have after `commit`.
    pub fn dest(&self) -> &Path {
        &self.dest
    }

    /// Writes `bytes` at `rel` (a relative path with `/` separators) inside the staging directory,
    /// creating parent directories.
    pub fn write_file(&self, rel: &str, bytes: &[u8]) -> Result<(), TilesError> {
        let path = self.tmp.join(rel);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent).map_err(TilesError::io(parent))?;
        }
        std::fs::write(&path, bytes).map_err(TilesError::io(path))
    }

    /// Replaces `dest` with the staged directory. On failure `dest` keeps its previous content. The previous
    /// content, if it could not be deleted afterwards, is [`LeftBehind`] (for the caller to say so).
    pub fn commit(mut self) -> Result<Option<LeftBehind>, TilesError> {
        if self.inside {
            return self.commit_inside();
        }
        let old = self.root.join(OLD);
        let had_old = exists(&self.dest);
        if had_old {
            std::fs::rename(&self.dest, &old).map_err(TilesError::io(&self.dest))?;
        }
        // A kill here leaves `dest` missing and its previous content in `old`: `recover` puts it back.
        if let Err(e) = std::fs::rename(&self.tmp, &self.dest) {
            if had_old {
                let _ = std::fs::rename(&old, &self.dest);
            }
            return Err(TilesError::io(&self.dest)(e));
        }
        self.committed = true;
        self.finish(had_old)
    }

    /// Deletes the previous content, then the staging folder.
    fn finish(&mut self, had_old: bool) -> Result<Option<LeftBehind>, TilesError> {
        let old = self.root.join(OLD);
        if had_old {
            if let Err(error) = std::fs::remove_dir_all(&old) {
                return Ok(Some(LeftBehind { path: old, error }));
            }
        }
        self.marker = None;
        let _ = std::fs::remove_dir_all(&self.root);
        Ok(None)
    }

    /// [`commit`](Self::commit) of a staging folder inside `dest`: entry by entry, undone on failure.
    fn commit_inside(mut self) -> Result<Option<LeftBehind>, TilesError> {
        let old = self.root.join(OLD);
        std::fs::create_dir(&old).map_err(TilesError::io(&old))?;
        let previous: Vec<_> = names(&self.dest)?
            .into_iter()
            .filter(|n| Some(n.as_os_str()) != self.root.file_name())
            .collect();
        let mut staged = names(&self.tmp)?;
        // Clients read tileset.json first: it comes last, when every tile it names is in place.
        staged.sort_by_key(|n| n == "tileset.json");
        // Moves `list` from `a` to `b` one by one; on a failure moves those already moved back and says why.
        let shift = |list: &[std::ffi::OsString], a: &Path, b: &Path| -> Result<(), TilesError> {
            for (k, n) in list.iter().enumerate() {
                if let Err(e) = std::fs::rename(a.join(n), b.join(n)) {
                    for m in &list[..k] {
                        let _ = std::fs::rename(b.join(m), a.join(m));
                    }
                    return Err(TilesError::io(a.join(n))(e));
                }
            }
            Ok(())
        };
        if let Err(e) = shift(&previous, &self.dest, &old) {
            let _ = std::fs::remove_dir(&old);
            return Err(e);
        }
        // From here a kill leaves `old` full: `recover` moves back what `swapping` names, then `old`'s entries.
        let swapping = self.root.join(SWAPPING);
        let list: String = staged
            .iter()
            .map(|n| format!("{}\n", n.to_string_lossy()))
            .collect();
        let part = self.root.join("swapping.part");
        let listed = std::fs::write(&part, list)
            .and_then(|()| std::fs::rename(&part, &swapping))
            .map_err(TilesError::io(&swapping));
        let undo_previous = |e: TilesError| {
            let _ = shift(&previous, &old, &self.dest);
            let _ = std::fs::remove_dir(&old);
            let _ = std::fs::remove_file(&swapping);
            Err(e)
        };
        if let Err(e) = listed {
            return undo_previous(e);
        }
        if let Err(e) = shift(&staged, &self.tmp, &self.dest) {
            return undo_previous(e);
        }
        // Complete: from here the previous content is only deleted.
        if let Err(e) = File::create(self.root.join(DONE)) {
            let _ = shift(&staged, &self.dest, &self.tmp);
            return undo_previous(TilesError::io(self.root.join(DONE))(e));
        }
        self.committed = true;
        self.finish(true)
    }
}

impl Drop for Staging {
    fn drop(&mut self) {
        // Uncommitted; a previous content that a failed swap could not put back stays for `recover`.
        if !self.committed && !exists(&self.root.join(OLD)) {
            self.marker = None;
            let _ = std::fs::remove_dir_all(&self.root);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pid that no process has: above the kernel's largest (2^22).
    const DEAD: u32 = 4194303;

    fn listing(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    /// A staging folder as a build killed at some point left it: the marker (unlocked, as the system leaves a dead
    /// process's lock) and `files` (relative path, content).
    fn killed(folder: &Path, files: &[(&str, &str)]) {
        std::fs::create_dir_all(folder).unwrap();
        std::fs::write(folder.join(MARKER), "citylod staging folder").unwrap();
        for (rel, text) in files {
            let p = folder.join(rel);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(p, text).unwrap();
        }
    }

    #[test]
    fn commit_replaces_the_whole_directory() {
        let root = tempfile::tempdir().unwrap();
        let dest = root.path().join("out");
        std::fs::create_dir_all(dest.join("tiles")).unwrap();
        std::fs::write(dest.join("tiles/stale.glb"), b"old").unwrap();
        let s = Staging::create(&dest).unwrap();
        assert_eq!(
            s.path().parent().unwrap(),
            root.path()
                .join(format!("out.citylod-tmp-{}", std::process::id()))
        );
        assert!(s.path().parent().unwrap().join(MARKER).is_file());
        s.write_file("a/b.txt", b"new").unwrap();
        assert!(s.commit().unwrap().is_none());
        assert_eq!(std::fs::read(dest.join("a/b.txt")).unwrap(), b"new");
        assert!(!dest.join("tiles").exists());
        assert_eq!(
            listing(root.path()),
            ["out"],
            "no staging folder left behind"
        );
        assert_eq!(listing(&dest), ["a"], "the marker stays out of the output");
    }

    /// Killed between the two renames: `out` is missing and the previous tileset sits in the staging folder's
    /// `old`; it is put back, the killed build's output deleted, and both said.
    #[test]
    fn a_build_killed_between_the_renames_gives_the_previous_output_back() {
        let root = tempfile::tempdir().unwrap();
        let dest = root.path().join("out");
        let folder = root.path().join(format!("out.citylod-tmp-{DEAD}"));
        killed(
            &folder,
            &[
                ("old/tileset.json", "previous"),
                ("old/tiles/0.glb", "previous glb"),
                ("new/tileset.json", "killed build's"),
            ],
        );
        let notes = Staging::recover(&dest).unwrap();
        assert_eq!(notes.len(), 1, "{notes:?}");
        assert!(
            notes[0].starts_with("note: restored ") && notes[0].contains(&format!("pid {DEAD}")),
            "{notes:?}"
        );
        assert_eq!(listing(root.path()), ["out"]);
        assert_eq!(
            std::fs::read_to_string(dest.join("tileset.json")).unwrap(),
            "previous"
        );
        assert_eq!(
            std::fs::read_to_string(dest.join("tiles/0.glb")).unwrap(),
            "previous glb"
        );
        // Done once: nothing is left to say.
        assert!(Staging::recover(&dest).unwrap().is_empty());
    }

    #[test]
    fn leftovers_of_killed_builds_are_cleaned_up_with_a_note() {
        let root = tempfile::tempdir().unwrap();
        let dest = root.path().join("out");
        std::fs::create_dir_all(&dest).unwrap();
        std::fs::write(dest.join("tileset.json"), "current").unwrap();
        // Killed after the swap, while deleting the previous content; killed while writing (two of them).
        killed(
            &root.path().join("out.citylod-tmp-4194301"),
            &[("old/tileset.json", "previous")],
        );
        killed(
            &root.path().join("out.citylod-tmp-4194302"),
            &[("new/tiles/0.glb", "half")],
        );
        killed(&root.path().join(format!("out.citylod-tmp-{DEAD}")), &[]);
        let notes = Staging::recover(&dest).unwrap();
        assert_eq!(notes.len(), 3, "{notes:?}");
        assert!(notes[0].contains("the previous content of") && notes[0].contains("pid 4194301"));
        assert!(
            notes[1].contains("the unfinished output of a build (pid 4194302) that was stopped")
        );
        assert!(
            notes.iter().all(|n| n.starts_with("note: removed ")),
            "{notes:?}"
        );
        assert_eq!(listing(root.path()), ["out"]);
        assert_eq!(
            std::fs::read_to_string(dest.join("tileset.json")).unwrap(),
            "current"
        );
    }

    /// Stopped between the renames, and `out` made again since: nothing is deleted, the user is told.
    #[test]
    fn a_saved_previous_output_is_never_deleted_when_out_was_made_again() {
        let root = tempfile::tempdir().unwrap();
        let dest = root.path().join("out");
        std::fs::create_dir_all(&dest).unwrap();
        let folder = root.path().join(format!("out.citylod-tmp-{DEAD}"));
        killed(
            &folder,
            &[("old/tileset.json", "previous"), ("new/tileset.json", "x")],
        );
        let notes = Staging::recover(&dest).unwrap();
        assert_eq!(notes.len(), 1);
        assert!(
            notes[0].starts_with("warning: ") && notes[0].contains("both are left"),
            "{notes:?}"
        );
        assert_eq!(
            std::fs::read_to_string(folder.join("old/tileset.json")).unwrap(),
            "previous"
        );
        // A build there goes ahead (the saved folder has another name than its own) and keeps it.
        let s = Staging::create(&dest).unwrap();
        s.write_file("tileset.json", b"new").unwrap();
        s.commit().unwrap();
        assert_eq!(
            std::fs::read_to_string(folder.join("old/tileset.json")).unwrap(),
            "previous"
        );
    }

    /// Folders that are not demonstrably a finished build's staging folder are kept: a user's backups named like
    /// the old scheme, one without the marker, one whose build still holds the lock.
    #[test]
    fn folders_that_are_not_a_dead_builds_are_kept() {
        let root = tempfile::tempdir().unwrap();
        let dest = root.path().join("out");
        let kept = [
            "out.old-2024".to_string(),
            format!("out.tmp-{DEAD}"),
            format!("out.old-{DEAD}"),
            "out.citylod-tmp-4194301".into(), // no marker, not empty
            format!("out.citylod-tmp-{DEAD}x"),
            format!("outer.citylod-tmp-{DEAD}"),
        ];
        for k in &kept {
            std::fs::create_dir_all(root.path().join(k).join("old")).unwrap();
            std::fs::write(root.path().join(k).join("old/survey.csv"), "precious").unwrap();
        }
        // Without the marker and empty: a build killed as it made it; removed without a word.
        std::fs::create_dir(root.path().join("out.citylod-tmp-4194302")).unwrap();
        // Its build still runs (holds the lock; here a handle of this process).
        let live = root.path().join("out.citylod-tmp-4194300");
        killed(&live, &[("old/tileset.json", "previous")]);
        let lock = File::open(live.join(MARKER)).unwrap();
        lock.try_lock().unwrap();
        assert!(Staging::recover(&dest).unwrap().is_empty());
        let mut expected: Vec<String> = kept.to_vec();
        expected.push("out.citylod-tmp-4194300".into());
        expected.sort();
        assert_eq!(listing(root.path()), expected);
        for k in &kept {
            assert_eq!(
                std::fs::read_to_string(root.path().join(k).join("old/survey.csv")).unwrap(),
                "precious"
            );
        }
        // Its lock released (the build ended), the previous content comes back.
        drop(lock);
        let notes = Staging::recover(&dest).unwrap();
        assert!(notes[0].starts_with("note: restored "), "{notes:?}");
        assert_eq!(
            std::fs::read_to_string(dest.join("tileset.json")).unwrap(),
            "previous"
        );
    }

    /// In a container every run may have the same pid: a folder named with this process's pid, not locked, is an
    /// earlier run's.
    #[test]
    fn a_leftover_with_our_own_pid_is_an_earlier_runs() {
        let root = tempfile::tempdir().unwrap();
        let dest = root.path().join("out");
        let folder = root
            .path()
            .join(format!("out.citylod-tmp-{}", std::process::id()));
        killed(&folder, &[("old/tileset.json", "previous")]);
        let s = Staging::create(&dest).unwrap();
        assert_eq!(
            std::fs::read_to_string(dest.join("tileset.json")).unwrap(),
            "previous"
        );
        s.write_file("tileset.json", b"new").unwrap();
        s.commit().unwrap();
        assert_eq!(
            std::fs::read_to_string(dest.join("tileset.json")).unwrap(),
            "new"
        );
        assert_eq!(listing(root.path()), ["out"]);
    }

    /// A destination that cannot be renamed (a mount point) or has no writable parent: staged inside it, the old
    /// entries swapped for the new ones, nothing of the staging left.
    #[test]
    fn staging_inside_the_destination_replaces_its_entries() {
        let root = tempfile::tempdir().unwrap();
        let dest = root.path().join("out");
        std::fs::create_dir_all(dest.join("tiles")).unwrap();
        std::fs::write(dest.join("tiles/stale.glb"), b"old").unwrap();
        std::fs::write(dest.join("tileset.json"), b"old").unwrap();
        // A killed run's staging folder goes too.
        killed(
            &dest.join(format!(".citylod-tmp-{DEAD}")),
            &[("new/tiles/0.glb", "half")],
        );
        Staging::recover(&dest).unwrap();
        let s = Staging::create_inside(dest.clone()).unwrap();
        assert!(s.path().starts_with(&dest));
        s.write_file("tileset.json", b"new").unwrap();
        s.write_file("tiles/0.glb", b"new").unwrap();
        assert!(s.commit().unwrap().is_none());
        assert_eq!(listing(&dest), ["tiles", "tileset.json"]);
        assert_eq!(std::fs::read(dest.join("tileset.json")).unwrap(), b"new");
        assert!(!dest.join("tiles/stale.glb").exists());
        // Uncommitted, the destination keeps what it had.
        let s = Staging::create_inside(dest.clone()).unwrap();
        s.write_file("tileset.json", b"newer").unwrap();
        drop(s);
        assert_eq!(std::fs::read(dest.join("tileset.json")).unwrap(), b"new");
        assert_eq!(listing(&dest), ["tiles", "tileset.json"]);
    }

    /// Killed while moving entries in or out of a destination it stages inside: every previous entry goes back,
    /// the killed build's go away, whichever of the two moves it was in; after a complete swap only the previous
    /// content is deleted.
    #[test]
    fn a_build_killed_mid_swap_inside_the_destination_is_undone() {
        let root = tempfile::tempdir().unwrap();
        let dest = root.path().join("out");
        let folder = dest.join(format!(".citylod-tmp-{DEAD}"));
        let previous = [
            ("tileset.json", "previous"),
            ("tiles/0.glb", "previous glb"),
            ("index.html", "html"),
        ];
        let check = |dest: &Path| {
            assert_eq!(listing(dest), ["index.html", "tiles", "tileset.json"]);
            for (rel, text) in previous {
                assert_eq!(std::fs::read_to_string(dest.join(rel)).unwrap(), text);
            }
        };
        // While moving the previous entries out: tileset.json and tiles moved, index.html not yet.
        std::fs::create_dir_all(&dest).unwrap();
        std::fs::write(dest.join("index.html"), "html").unwrap();
        killed(
            &folder,
            &[
                ("old/tileset.json", "previous"),
                ("old/tiles/0.glb", "previous glb"),
                ("new/tileset.json", "killed"),
                ("new/tiles/0.glb", "killed glb"),
            ],
        );
        let notes = Staging::recover(&dest).unwrap();
        assert!(
            notes[0].starts_with("note: restored the previous content of"),
            "{notes:?}"
        );
        check(&dest);
        // While moving the new ones in: tiles moved, tileset.json (always last) not.
        std::fs::remove_dir_all(&dest).unwrap();
        std::fs::create_dir_all(dest.join("tiles")).unwrap();
        std::fs::write(dest.join("tiles/1.glb"), "killed glb").unwrap();
        killed(
            &folder,
            &[
                ("old/tileset.json", "previous"),
                ("old/tiles/0.glb", "previous glb"),
                ("old/index.html", "html"),
                ("new/tileset.json", "killed"),
                (SWAPPING, "tiles\ntileset.json\n"),
            ],
        );
        let notes = Staging::recover(&dest).unwrap();
        assert_eq!(notes.len(), 1, "{notes:?}");
        check(&dest);
        assert!(!dest.join("tiles/1.glb").exists());
        // All moved in, `done` written, killed while deleting the previous content: the new output stays.
        killed(&folder, &[("old/tiles/0.glb", "previous"), (DONE, "")]);
        let notes = Staging::recover(&dest).unwrap();
        assert!(notes[0].contains("the previous content of"), "{notes:?}");
        check(&dest);
    }

    /// A previous content saved inside the destination by a build that may still run is found (for the build's
    /// refusal to name it) and kept.
    #[test]
    fn a_saved_previous_content_inside_is_named_while_its_build_may_run() {
        let root = tempfile::tempdir().unwrap();
        let dest = root.path().join("out");
        let folder = dest.join(".citylod-tmp-4194300");
        killed(&folder, &[("old/tileset.json", "previous")]);
        let lock = File::open(folder.join(MARKER)).unwrap();
        lock.try_lock().unwrap();
        assert!(Staging::recover(&dest).unwrap().is_empty());
        assert_eq!(Staging::saved_inside(&dest), [folder.join("old")]);
        drop(lock);
        Staging::recover(&dest).unwrap();
        assert!(Staging::saved_inside(&dest).is_empty());
        assert_eq!(listing(&dest), ["tileset.json"]);
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn a_mount_point_is_told_from_a_folder() {
        assert!(is_mount_point(Path::new("/proc")));
        let root = tempfile::tempdir().unwrap();
        assert!(!is_mount_point(root.path()) || root.path().parent() == Some(Path::new("/")));
        std::fs::create_dir(root.path().join("d")).unwrap();
        assert!(!is_mount_point(&root.path().join("d")));
    }

    #[test]
    fn dropping_uncommitted_leaves_dest_untouched() {
        let root = tempfile::tempdir().unwrap();
        let dest = root.path().join("out");
        std::fs::create_dir_all(&dest).unwrap();
        std::fs::write(dest.join("keep.txt"), b"keep").unwrap();
        {
            let s = Staging::create(&dest).unwrap();
            s.write_file("half.txt", b"x").unwrap();
        }
        assert_eq!(std::fs::read(dest.join("keep.txt")).unwrap(), b"keep");
        assert!(!dest.join("half.txt").exists());
        assert_eq!(std::fs::read_dir(root.path()).unwrap().count(), 1);
    }
}
