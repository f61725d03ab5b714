//! The on-disk cache of precomputed tables (Mie optics, cumulus shapes).

use std::path::PathBuf;

/// Where precomputed tables are cached: `$NIMBUS_CACHE_DIR`, else
/// `$XDG_CACHE_HOME/nimbus`, else `$HOME/.cache/nimbus`, else the system's
/// temporary directory.
pub fn cache_dir() -> PathBuf {
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
