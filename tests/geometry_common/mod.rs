//! Helpers shared by the geometry integration tests: where the shared aerofoil files live.

#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// The crate root.
pub fn crate_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The folder of real aerofoil files: `$BEZCHAIN_SHARED/data/airfoils` when that variable is
/// set, otherwise the first `shared/data/airfoils` found beside the crate root or one of its
/// ancestors (CI keeps `shared/` beside the clone). Panics with directions when absent.
pub fn airfoils_dir() -> PathBuf {
    if let Some(shared) = std::env::var_os("BEZCHAIN_SHARED") {
        let dir = Path::new(&shared).join("data/airfoils");
        assert!(
            dir.is_dir(),
            "BEZCHAIN_SHARED is set but {} is not a folder",
            dir.display()
        );
        return dir;
    }
    let root = crate_root();
    root.ancestors()
        .map(|a| a.join("shared/data/airfoils"))
        .find(|d| d.is_dir())
        .unwrap_or_else(|| {
            panic!(
                "no shared/data/airfoils beside {} or any folder above it; \
                 set BEZCHAIN_SHARED to the shared folder",
                root.display()
            )
        })
}

/// One of the shared aerofoil files.
pub fn airfoil(name: &str) -> PathBuf {
    airfoils_dir().join(name)
}

/// A fresh empty folder under the system temporary directory, unique to this test.
pub fn scratch(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("bezchain-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create a scratch folder");
    dir
}
