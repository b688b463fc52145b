//! Scaffolding for tests that drive the `bearing-sweep` binary: scratch folders, JSON files
//! in and out, runs with their exit status and stderr.
#![allow(dead_code)] // each test crate uses its own subset

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

/// The binary under test.
pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_bearing-sweep"))
}

/// A fresh, empty scratch folder for one test (`tag` keeps test crates apart).
pub fn scratch(tag: &str, name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("bearing-sweep-{tag}-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Writes `v` as pretty JSON to `dir/name`.
pub fn write(dir: &Path, name: &str, v: &Value) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, serde_json::to_string_pretty(v).unwrap()).unwrap();
    p
}

/// Reads a JSON file.
pub fn read(p: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

/// A result without its `run` section (timings, machine): what must be reproducible.
pub fn deterministic(mut v: Value) -> Value {
    v.as_object_mut().unwrap().remove("run");
    v
}

/// Runs the binary with `args`: (success, stderr).
pub fn run(args: &[&str]) -> (bool, String) {
    let out = bin().args(args).output().unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}
