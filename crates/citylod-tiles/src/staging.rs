//! Atomic output directories: everything is written into `<dir>.tmp-<pid>` beside `dir`, and
//! [`Staging::commit`] swaps it in (old `dir` renamed away, new one renamed in, old one deleted).
//! Invariant: a run that fails or panics before `commit` never leaves a partial tileset at `dir`.
//!
//! Where `dir` cannot be renamed — a mount point (a container's volume, `docker run -v $PWD/tiles:/out`) — or
//! nothing can be created beside it (its parent is not writable), the staging folder is `dir/.citylod-tmp-<pid>`
//! instead, and `commit` moves `dir`'s old entries into `dir/.citylod-old-<pid>`, then the new ones into `dir`,
//! `tileset.json` last; a failure moves everything back. The invariant holds; only the swap itself is entry by
//! entry.

use crate::TilesError;
use std::path::{Path, PathBuf};

/// The prefix of the folders a [`Staging`] keeps inside its destination when it cannot stage beside it.
pub const INSIDE_PREFIX: &str = ".citylod-";

/// A staging directory that becomes `dest` on [`commit`](Staging::commit) and is deleted if dropped
/// uncommitted.
#[derive(Debug)]
pub struct Staging {
    dest: PathBuf,
    tmp: PathBuf,
    /// Staged inside `dest` (see the module's documentation).
    inside: bool,
    committed: bool,
}

/// The previous content of the destination, moved away by [`Staging::commit`] but not deleted: its path and why.
#[derive(Debug)]
pub struct LeftBehind {
    pub path: PathBuf,
    pub error: std::io::Error,
}

fn sibling(dest: &Path, tag: &str) -> PathBuf {
    let name = dest
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "tileset".into());
    dest.with_file_name(format!("{name}.{tag}-{}", std::process::id()))
}

fn inner(dest: &Path, tag: &str) -> PathBuf {
    dest.join(format!("{INSIDE_PREFIX}{tag}-{}", std::process::id()))
}

/// Removes the entries of `dir` named `<prefix>tmp-<pid>` or `<prefix>old-<pid>` whose process is gone (no
/// `/proc/<pid>`): left by runs that were killed. Where there is no `/proc`, or the process still runs (a concurrent
/// build), nothing is removed. Failures to remove are ignored: the leftovers only take space.
fn remove_stale(dir: &Path, prefix: &str) {
    if !Path::new("/proc/self").exists() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    }) else {
        return;
    };
    for entry in entries.flatten() {
        let file = entry.file_name();
        let file = file.to_string_lossy();
        let Some(rest) = file.strip_prefix(prefix) else {
            continue;
        };
        let pid = ["tmp", "old"]
            .iter()
            .find_map(|tag| rest.strip_prefix(&format!("{tag}-")))
            .and_then(|p| p.parse::<u32>().ok());
        if let Some(pid) = pid {
            if pid != std::process::id() && !Path::new(&format!("/proc/{pid}")).exists() {
                let _ = std::fs::remove_dir_all(entry.path());
            }
        }
    }
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
    /// Creates an empty `<dest>.tmp-<pid>` (removing a stale one left by a crashed run with the same
    /// pid, and those of killed runs) and the parent directories of `dest`; inside `dest` where `dest` is a mount
    /// point or nothing can be created beside it.
    pub fn create(dest: &Path) -> Result<Staging, TilesError> {
        let dest = if dest.file_name().is_none() {
            std::path::absolute(dest).map_err(TilesError::io(dest))?
        } else {
            dest.to_path_buf()
        };
        if let (Some(parent), Some(name)) = (dest.parent(), dest.file_name()) {
            remove_stale(parent, &format!("{}.", name.to_string_lossy()));
        }
        if dest.is_dir() {
            remove_stale(&dest, INSIDE_PREFIX);
        }
        if is_mount_point(&dest) {
            return Self::create_inside(dest);
        }
        let tmp = sibling(&dest, "tmp");
        if tmp.exists() {
            std::fs::remove_dir_all(&tmp).map_err(TilesError::io(&tmp))?;
        }
        match std::fs::create_dir_all(&tmp) {
            Ok(()) => Ok(Staging {
                dest,
                tmp,
                inside: false,
                committed: false,
            }),
            Err(e) if e.kind() == std::io::ErrorKind::PermissionDenied && dest.is_dir() => {
                Self::create_inside(dest)
            }
            Err(e) => Err(TilesError::io(&tmp)(e)),
        }
    }

    /// Stages in `dest/.citylod-tmp-<pid>` (see the module's documentation).
    fn create_inside(dest: PathBuf) -> Result<Staging, TilesError> {
        let tmp = inner(&dest, "tmp");
        if tmp.exists() {
            std::fs::remove_dir_all(&tmp).map_err(TilesError::io(&tmp))?;
        }
        std::fs::create_dir(&tmp).map_err(TilesError::io(&tmp))?;
        Ok(Staging {
            dest,
            tmp,
            inside: true,
            committed: false,
        })
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
        let old = sibling(&self.dest, "old");
        let had_old = self.dest.exists();
        if had_old {
            if old.exists() {
                std::fs::remove_dir_all(&old).map_err(TilesError::io(&old))?;
            }
            std::fs::rename(&self.dest, &old).map_err(TilesError::io(&self.dest))?;
        }
        if let Err(e) = std::fs::rename(&self.tmp, &self.dest) {
            if had_old {
                let _ = std::fs::rename(&old, &self.dest);
            }
            return Err(TilesError::io(&self.dest)(e));
        }
        self.committed = true;
        Ok(had_old
            .then(|| std::fs::remove_dir_all(&old).err())
            .flatten()
            .map(|error| LeftBehind { path: old, error }))
    }

    /// [`commit`](Self::commit) of a staging folder inside `dest`: entry by entry, undone on failure.
    fn commit_inside(mut self) -> Result<Option<LeftBehind>, TilesError> {
        let old = inner(&self.dest, "old");
        if old.exists() {
            std::fs::remove_dir_all(&old).map_err(TilesError::io(&old))?;
        }
        std::fs::create_dir(&old).map_err(TilesError::io(&old))?;
        let names = |dir: &Path| -> Result<Vec<std::ffi::OsString>, TilesError> {
            let mut v = Vec::new();
            for e in std::fs::read_dir(dir).map_err(TilesError::io(dir))? {
                v.push(e.map_err(TilesError::io(dir))?.file_name());
            }
            v.sort();
            Ok(v)
        };
        let ours = |n: &std::ffi::OsString| {
            Some(n.as_os_str()) == self.tmp.file_name() || Some(n.as_os_str()) == old.file_name()
        };
        let previous: Vec<_> = names(&self.dest)?
            .into_iter()
            .filter(|n| !ours(n))
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
        if let Err(e) = shift(&staged, &self.tmp, &self.dest) {
            let _ = shift(&previous, &old, &self.dest);
            let _ = std::fs::remove_dir(&old);
            return Err(e);
        }
        self.committed = true;
        let _ = std::fs::remove_dir(&self.tmp);
        Ok(std::fs::remove_dir_all(&old)
            .err()
            .map(|error| LeftBehind { path: old, error }))
    }
}

impl Drop for Staging {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_dir_all(&self.tmp);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commit_replaces_the_whole_directory() {
        let root = tempfile::tempdir().unwrap();
        let dest = root.path().join("out");
        std::fs::create_dir_all(dest.join("tiles")).unwrap();
        std::fs::write(dest.join("tiles/stale.glb"), b"old").unwrap();
        let s = Staging::create(&dest).unwrap();
        s.write_file("a/b.txt", b"new").unwrap();
        s.commit().unwrap();
        assert_eq!(std::fs::read(dest.join("a/b.txt")).unwrap(), b"new");
        assert!(!dest.join("tiles").exists());
        let left: Vec<_> = std::fs::read_dir(root.path()).unwrap().collect();
        assert_eq!(left.len(), 1, "no tmp or old directory left behind");
    }

    #[test]
    fn leftovers_of_killed_runs_are_removed_and_those_of_running_ones_kept() {
        let root = tempfile::tempdir().unwrap();
        let dest = root.path().join("out");
        // A pid above the kernel's limit (2^22) never runs; pid 1 always does.
        let dead = root.path().join("out.tmp-4194999");
        let dead_old = root.path().join("out.old-4194999");
        let alive = root.path().join("out.tmp-1");
        let other = root.path().join("outer.tmp-4194999");
        for d in [&dead, &dead_old, &alive, &other] {
            std::fs::create_dir_all(d.join("tiles")).unwrap();
        }
        let s = Staging::create(&dest).unwrap();
        assert!(!dead.exists() && !dead_old.exists());
        assert!(alive.exists() && other.exists());
        drop(s);
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
        // A killed run's staging folder (its pid above the kernel's limit) goes too.
        std::fs::create_dir_all(dest.join(".citylod-tmp-4194999/tiles")).unwrap();
        let s = Staging::create_inside(dest.clone()).unwrap();
        assert!(s.path().starts_with(&dest));
        s.write_file("tileset.json", b"new").unwrap();
        s.write_file("tiles/0.glb", b"new").unwrap();
        assert!(s.commit().unwrap().is_none());
        let mut left: Vec<String> = std::fs::read_dir(&dest)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        assert_eq!(left, ["tiles", "tileset.json"]);
        assert_eq!(std::fs::read(dest.join("tileset.json")).unwrap(), b"new");
        assert!(!dest.join("tiles/stale.glb").exists());
        // Uncommitted, the destination keeps what it had.
        let s = Staging::create_inside(dest.clone()).unwrap();
        s.write_file("tileset.json", b"newer").unwrap();
        drop(s);
        assert_eq!(std::fs::read(dest.join("tileset.json")).unwrap(), b"new");
        assert_eq!(std::fs::read_dir(&dest).unwrap().count(), 2);
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
