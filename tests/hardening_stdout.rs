//! Issue 13 item 5: a closed or full standard output is an error, never a panic. A reader
//! that goes away (`… | head -c 10`) ends the command quietly with status 0; a write error
//! (`… > /dev/full`) prints one message and exits non-zero.

use std::io::Read;
use std::process::Stdio;

use serde_json::json;

mod cli_support;
use cli_support::*;

/// An eval input with `n` states: its pretty output is far larger than a pipe buffer.
fn eval_input(n: usize) -> serde_json::Value {
    let states: Vec<_> = (0..n)
        .map(|k| {
            json!({"xi": 1e-4 * (k % 7) as f64 / 7.0, "yi": 0.0, "xj": 1e-4, "yj": 0.0,
                    "vxi": 0.0, "vyi": 0.0, "vxj": 0.0, "vyj": 0.0, "omega": 100.0})
        })
        .collect();
    json!({"bearing": {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242},
           "states": states})
}

#[test]
fn broken_pipe_exits_quietly() {
    let dir = scratch("hardening-stdout", "pipe");
    let input = write(&dir, "in.json", &eval_input(5000));
    let mut child = bin()
        .args(["eval", input.to_str().unwrap()])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut head = [0u8; 10];
    child.stdout.take().unwrap().read_exact(&mut head).unwrap(); // dropped: pipe closed
    let mut err = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    let status = child.wait().unwrap();
    assert_eq!(&head[..2], b"{\n", "stdout starts with the document");
    assert!(!err.contains("panicked"), "panic on a closed pipe: {err}");
    assert_eq!(status.code(), Some(0), "status {status:?}, stderr: {err}");
    assert!(
        err.trim().is_empty(),
        "a closed pipe is not an error worth a message: {err}"
    );
}

#[test]
fn full_disk_is_a_message_and_a_non_zero_status() {
    let Ok(full) = std::fs::OpenOptions::new().write(true).open("/dev/full") else {
        eprintln!("skipped: no /dev/full on this system");
        return;
    };
    let dir = scratch("hardening-stdout", "full");
    let input = write(&dir, "in.json", &eval_input(20));
    for args in [
        vec!["eval", input.to_str().unwrap()],
        vec!["bench", "rotor", "--help"], // clap prints help itself: must not panic either
    ] {
        let out = bin()
            .args(&args)
            .stdout(full.try_clone().unwrap())
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !err.contains("panicked"),
            "{args:?}: panic on /dev/full: {err}"
        );
        if args[0] == "eval" {
            assert_eq!(out.status.code(), Some(2), "{args:?}: stderr {err}");
            assert!(
                err.contains("writing to standard output") && err.contains("No space left"),
                "{args:?}: expected a write error message, got: {err}"
            );
        }
    }
}
