//! The on-disk cache of precomputed tables (Mie optics, cumulus shapes).

use std::path::PathBuf;
use std::sync::RwLock;

/// The directory given by [`set_cache_dir`], if any.
static CHOSEN: RwLock<Option<PathBuf>> = RwLock::new(None);

/// Sets where this process caches precomputed tables (e.g. an application's
/// own cache directory), before [`cache_dir`]'s environment variables;
/// `None` goes back to them. Takes effect for tables loaded afterwards.
pub fn set_cache_dir(dir: Option<PathBuf>) {
    *CHOSEN.write().unwrap_or_else(|e| e.into_inner()) = dir;
}

/// Where precomputed tables are cached: the directory of [`set_cache_dir`],
/// else `$NIMBUS_CACHE_DIR`, else
/// `$XDG_CACHE_HOME/nimbus`, else `$HOME/.cache/nimbus`, else the system's
/// temporary directory.
pub fn cache_dir() -> PathBuf {
    if let Some(dir) = CHOSEN.read().unwrap_or_else(|e| e.into_inner()).clone() {
        return dir;
    }
    if let Some(dir) = std::env::var_os("NIMBUS_CACHE_DIR") {
        return PathBuf::from(dir);
    }
    if let Some(dir) = std::env::var_os("XDG_CACHE_HOME") {
        return PathBuf::from(dir).join("nimbus");
    }
    if let Some(home) = std::env::var_os("HOME") {
        return PathBuf::from(home).join(".cache/nimbus");
    }
    std::env::temp_dir().join("nimbus")
}
