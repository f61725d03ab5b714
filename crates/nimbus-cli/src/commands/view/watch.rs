//! Change detection for hot reload: the stamps (modification time and
//! length, [`FileStamp`]) of a set of files, polled (a few stat calls twice
//! a second cost nothing and need no platform file-notification service).

use nimbus_render::scene::FileStamp;
use std::path::{Path, PathBuf};

/// Files and their last seen stamps.
#[derive(Debug, Default)]
pub struct FileWatch {
    files: Vec<(PathBuf, Option<FileStamp>)>,
}

impl FileWatch {
    /// Watches the given files from their present state.
    pub fn new(files: impl IntoIterator<Item = PathBuf>) -> Self {
        Self {
            files: files
                .into_iter()
                .map(|f| {
                    let stamp = FileStamp::of(&f);
                    (f, stamp)
                })
                .collect(),
        }
    }

    /// Watches every `.wgsl` file under `dir`.
    pub fn wgsl_under(dir: &Path) -> Self {
        fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
            let Ok(entries) = std::fs::read_dir(dir) else {
                return;
            };
            for entry in entries.flatten() {
                let path = entry.path();
                if path.is_dir() {
                    walk(&path, out);
                } else if path.extension().is_some_and(|e| e == "wgsl") {
                    out.push(path);
                }
            }
        }
        let mut files = Vec::new();
        walk(dir, &mut files);
        files.sort();
        Self::new(files)
    }

    /// Number of files watched.
    pub fn len(&self) -> usize {
        self.files.len()
    }

    /// Whether any file's modification time changed (or it appeared or
    /// vanished) since the last call; remembers the new times.
    pub fn changed(&mut self) -> bool {
        let mut changed = false;
        for (path, seen) in &mut self.files {
            let now = FileStamp::of(path);
            if now != *seen {
                *seen = now;
                changed = true;
            }
        }
        changed
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rewritten_file_is_seen_once() {
        let dir = std::env::temp_dir().join(format!("nimbus-watch-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("sub")).expect("dir");
        let file = dir.join("sub/a.wgsl");
        std::fs::write(&file, "1").expect("write");
        std::fs::write(dir.join("b.txt"), "x").expect("write");
        let mut watch = FileWatch::wgsl_under(&dir);
        assert_eq!(watch.len(), 1);
        assert!(!watch.changed());
        // Some file systems keep whole seconds: step the time explicitly.
        let later = std::time::SystemTime::now() + std::time::Duration::from_secs(5);
        std::fs::File::options()
            .write(true)
            .open(&file)
            .and_then(|f| f.set_modified(later))
            .expect("touch");
        assert!(watch.changed());
        assert!(!watch.changed());
        std::fs::remove_file(&file).expect("remove");
        assert!(watch.changed());
        std::fs::remove_dir_all(&dir).ok();
    }
}
