//! Atomic output directories: everything is written into `<dir>.tmp-<pid>` beside `dir`, and
//! [`Staging::commit`] swaps it in (old `dir` renamed away, new one renamed in, old one deleted).
//! Invariant: a run that fails or panics before `commit` never leaves a partial tileset at `dir`.

use crate::TilesError;
use std::path::{Path, PathBuf};

/// A staging directory that becomes `dest` on [`commit`](Staging::commit) and is deleted if dropped
/// uncommitted.
#[derive(Debug)]
pub struct Staging {
    dest: PathBuf,
    tmp: PathBuf,
    committed: bool,
}

fn sibling(dest: &Path, tag: &str) -> PathBuf {
    let name = dest
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "tileset".into());
    dest.with_file_name(format!("{name}.{tag}-{}", std::process::id()))
}

/// Removes `<dest>.tmp-<pid>` and `<dest>.old-<pid>` left beside `dest` by runs that were killed (their process
/// is gone: no `/proc/<pid>`). Where there is no `/proc`, or the process still runs (a concurrent build), nothing
/// is removed. Failures to remove are ignored: the leftovers only take space.
fn remove_stale_siblings(dest: &Path) {
    let (Some(parent), Some(name)) = (dest.parent(), dest.file_name()) else {
        return;
    };
    if !Path::new("/proc/self").exists() {
        return;
    }
    let name = name.to_string_lossy();
    let Ok(entries) = std::fs::read_dir(if parent.as_os_str().is_empty() {
        Path::new(".")
    } else {
        parent
    }) else {
        return;
    };
    for entry in entries.flatten() {
        let file = entry.file_name();
        let file = file.to_string_lossy();
        let Some(rest) = file.strip_prefix(&*name) else {
            continue;
        };
        let pid = ["tmp", "old"]
            .iter()
            .find_map(|tag| rest.strip_prefix(&format!(".{tag}-")))
            .and_then(|p| p.parse::<u32>().ok());
        if let Some(pid) = pid {
            if pid != std::process::id() && !Path::new(&format!("/proc/{pid}")).exists() {
                let _ = std::fs::remove_dir_all(entry.path());
            }
        }
    }
}

impl Staging {
    /// Creates an empty `<dest>.tmp-<pid>` (removing a stale one left by a crashed run with the same
    /// pid, and those of killed runs) and the parent directories of `dest`.
    pub fn create(dest: &Path) -> Result<Staging, TilesError> {
        let dest = if dest.file_name().is_none() {
            std::path::absolute(dest).map_err(TilesError::io(dest))?
        } else {
            dest.to_path_buf()
        };
        remove_stale_siblings(&dest);
        let tmp = sibling(&dest, "tmp");
        if tmp.exists() {
            std::fs::remove_dir_all(&tmp).map_err(TilesError::io(&tmp))?;
        }
        std::fs::create_dir_all(&tmp).map_err(TilesError::io(&tmp))?;
        Ok(Staging {
            dest,
            tmp,
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

    /// Replaces `dest` with the staged directory. On failure `dest` keeps its previous content.
    pub fn commit(mut self) -> Result<(), TilesError> {
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
        if had_old {
            let _ = std::fs::remove_dir_all(&old);
        }
        Ok(())
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
