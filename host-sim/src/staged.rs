//! Output files staged under temporary names and renamed into place only once a whole run
//! succeeded (`hollowpath plan`, `simulate`, `slice`).

use std::path::{Path, PathBuf};

/// `path` as it will be once written: its folder canonicalised (when it exists), its name kept.
fn resolved(path: &Path) -> Option<PathBuf> {
    if let Ok(p) = path.canonicalize() {
        return Some(p);
    }
    let name = path.file_name()?;
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    Some(parent.canonicalize().ok()?.join(name))
}

/// Output files, each written to a temporary name beside its final one and renamed into place
/// only by [`Staged::commit`], once everything succeeded; dropped uncommitted, it removes the
/// temporaries, so a failed run leaves nothing that looks like a result.
pub struct Staged {
    /// The input slice file (canonical), never to be overwritten.
    input: Option<PathBuf>,
    /// (temporary, final) paths written so far.
    files: Vec<(PathBuf, PathBuf)>,
    /// Folders whose files of a family this run owns (`layer-K.png` for every K): those it
    /// did not write this time are an earlier run's, removed at the commit.
    owned: Vec<(PathBuf, Family)>,
}

/// Which file names of a folder a run owns ([`Staged::own`]).
pub type Family = fn(&str) -> bool;

/// Whether `name` is `layer-` digits then one of `tails` (`.json`, `-deposit.png`, ...): the
/// names a run's per-layer files take.
pub fn layer_file(name: &str, tails: &[&str]) -> bool {
    name.strip_prefix("layer-").is_some_and(|rest| {
        let digits = rest.bytes().take_while(u8::is_ascii_digit).count();
        digits > 0 && tails.contains(&&rest[digits..])
    })
}

impl Staged {
    /// Nothing staged yet; `input` (the file read) is never overwritten.
    pub fn new(input: Option<&Path>) -> Staged {
        Staged {
            input: input.and_then(|p| p.canonicalize().ok()),
            files: Vec::new(),
            owned: Vec::new(),
        }
    }

    /// Claims the files of `dir` that `family` names (per-layer outputs): at the commit those
    /// this run did not write (an earlier run's with more layers) are removed, so the folder
    /// holds one run's layers only. The input file is never removed.
    pub fn own(&mut self, dir: &Path, family: Family) {
        self.owned.push((dir.to_path_buf(), family));
    }

    /// Refuses `path` if it names the input file, if something other than an ordinary file
    /// is there (a device, a pipe, a folder or a link, which the rename into place would
    /// replace instead of writing through), or if its folder does not exist.
    pub fn check(&self, path: &Path) -> Result<(), String> {
        self.check_making(path, None)
    }

    /// [`check`](Self::check), where the folder `making` (the run's output folder, made
    /// later) counts as existing.
    pub fn check_making(&self, path: &Path, making: Option<&Path>) -> Result<(), String> {
        if self.input.is_some() && resolved(path) == self.input {
            return Err(format!(
                "refusing to write {}: it is the input file",
                path.display()
            ));
        }
        if let Ok(meta) = std::fs::symlink_metadata(path) {
            let kind = meta.file_type();
            if !kind.is_file() {
                let what = if kind.is_dir() {
                    "a folder"
                } else if kind.is_symlink() {
                    "a link"
                } else {
                    "a device or a pipe"
                };
                return Err(format!(
                    "refusing to write {}: it is {what}, not an ordinary file (name a new file \
                     or an ordinary one to replace)",
                    path.display()
                ));
            }
        }
        let folder = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
        let made_later =
            making.is_some_and(|m| std::path::absolute(m).ok() == std::path::absolute(folder).ok());
        if !folder.is_dir() && !made_later {
            return Err(format!(
                "cannot write {}: the folder {} does not exist",
                path.display(),
                folder.display()
            ));
        }
        Ok(())
    }

    /// Writes `bytes` to a temporary name beside `path`.
    pub fn write(&mut self, path: &Path, bytes: &[u8]) -> Result<(), String> {
        self.check(path)?;
        // Two files of this run under one name (`--gcode` naming one of the run's own files):
        // the second would overwrite the first's temporary and the commit fail half-way.
        let here = resolved(path);
        if here.is_some() && self.files.iter().any(|(_, p)| resolved(p) == here) {
            return Err(format!(
                "refusing to write {} twice: --gcode names one of the run's own output files",
                path.display()
            ));
        }
        let name = path
            .file_name()
            .ok_or_else(|| format!("cannot write {}: not a file name", path.display()))?;
        let mut tmp_name = std::ffi::OsString::from(".");
        tmp_name.push(name);
        tmp_name.push(format!(".tmp-{}", std::process::id()));
        let tmp = path.with_file_name(tmp_name);
        std::fs::write(&tmp, bytes).map_err(|e| {
            let _ = std::fs::remove_file(&tmp);
            format!("cannot write {}: {e}", path.display())
        })?;
        self.files.push((tmp, path.to_path_buf()));
        Ok(())
    }

    /// Renames every temporary into place.
    pub fn commit(mut self) -> Result<(), String> {
        let files = std::mem::take(&mut self.files);
        let mut written: Vec<PathBuf> = Vec::with_capacity(files.len());
        let mut files = files.into_iter();
        while let Some((tmp, path)) = files.next() {
            if let Err(e) = std::fs::rename(&tmp, &path) {
                let _ = std::fs::remove_file(&tmp);
                for (t, _) in files {
                    let _ = std::fs::remove_file(t);
                }
                return Err(format!("cannot write {}: {e}", path.display()));
            }
            written.push(path);
        }
        for (dir, family) in std::mem::take(&mut self.owned) {
            let Ok(entries) = std::fs::read_dir(&dir) else {
                continue;
            };
            for entry in entries.flatten() {
                let path = entry.path();
                let name = entry.file_name();
                let stale = name.to_str().is_some_and(family)
                    && !written
                        .iter()
                        .any(|w| w.file_name() == Some(name.as_os_str()))
                    && resolved(&path) != self.input
                    && entry.file_type().is_ok_and(|t| t.is_file());
                if stale {
                    std::fs::remove_file(&path)
                        .map_err(|e| format!("cannot remove {}: {e}", path.display()))?;
                }
            }
        }
        Ok(())
    }
}

impl Drop for Staged {
    fn drop(&mut self) {
        for (tmp, _) in &self.files {
            let _ = std::fs::remove_file(tmp);
        }
    }
}
