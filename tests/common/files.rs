//! Temporary files for tests that read and write real files.
//!
//! They live under Cargo's scratch folder for integration tests (`target/tmp`, which
//! `cargo clean` removes), one folder per call named after the test binary and a counter: a
//! later run of the same binary empties and reuses the same names, so nothing piles up. (Two runs
//! of the same test binary at the same time would share them; Cargo runs a crate's test binaries
//! one after the other.)

use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

/// A fresh, empty folder, unique to this test binary and call.
pub fn temp_dir() -> PathBuf {
    static COUNTER: AtomicUsize = AtomicUsize::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("{}-{n}", env!("CARGO_CRATE_NAME")));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Writes `content` to a file `name` in a fresh temp folder and returns its path.
pub fn write(name: &str, content: &[u8]) -> PathBuf {
    let path = temp_dir().join(name);
    std::fs::write(&path, content).unwrap();
    path
}
