//! Running the `bezchain` binary from the tests, and what every test expects of its answers.

use super::{bin, crate_root};
use std::path::Path;
use std::process::{Command, Output};

/// `bezchain ARGS` in the crate root.
pub fn run(args: &[&str]) -> Output {
    Command::new(bin())
        .args(args)
        .current_dir(crate_root())
        .output()
        .expect("run bezchain")
}

/// Standard error as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// `o`, after asserting that it succeeded.
pub fn ok(o: Output) -> Output {
    assert!(o.status.success(), "exit {:?}: {}", o.status.code(), stderr(&o));
    o
}

/// A JSON file, parsed.
pub fn json(path: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

/// Exit status 2, exactly one `error:` line of ours naming `needle`, and no panic.
pub fn assert_user_error(o: &Output, needle: &str) {
    assert_user_error_naming(o, &[needle]);
}

/// Exit status 2, exactly one `error:` line of ours containing every needle, and no panic.
/// The Vulkan loader's own complaint about `XDG_RUNTIME_DIR` is not ours.
pub fn assert_user_error_naming(o: &Output, needles: &[&str]) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(2), "stderr: {err}");
    let lines: Vec<&str> = err
        .lines()
        .filter(|l| l.starts_with("error:") && !l.contains("XDG_RUNTIME_DIR"))
        .collect();
    assert_eq!(lines.len(), 1, "one error line expected: {err}");
    for needle in needles {
        assert!(lines[0].contains(needle), "'{needle}' not in: {err}");
    }
    assert!(!err.contains("panicked"), "{err}");
}
