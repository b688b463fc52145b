//! The runner behind `run` and the service, through the `run` command: a second run into
//! the same folder refuses and names the first one's pid; a directory in place of
//! result.json is found before anything runs; a stream from the FNV-hash era is refused
//! with a clear message.

mod service_support;

use std::time::{Duration, Instant};

use service_support::*;

fn spec_file(dir: &std::path::Path, n: usize, cost_ms: u64) -> std::path::PathBuf {
    let p = dir.join("lockme.json");
    std::fs::write(&p, synthetic_spec(n, cost_ms).to_string()).unwrap();
    p
}

#[test]
fn a_second_run_into_the_same_folder_refuses_naming_the_holders_pid() {
    let dir = scratch("lock");
    let spec = spec_file(&dir, 10, 300);
    let out = dir.join("out");
    let mut first = bin()
        .arg("run")
        .arg(&spec)
        .arg("--out")
        .arg(&out)
        .arg("--quiet")
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // Wait until the first run holds the lock (its pid is in the lock file).
    let lock = out.join("lockme/result.lock");
    let start = Instant::now();
    while std::fs::read_to_string(&lock)
        .map(|t| t.trim().is_empty())
        .unwrap_or(true)
    {
        assert!(start.elapsed() < Duration::from_secs(30), "no lock file");
        std::thread::sleep(Duration::from_millis(20));
    }
    let second = bin()
        .arg("run")
        .arg(&spec)
        .arg("--out")
        .arg(&out)
        .arg("--quiet")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&second.stderr);
    assert!(!second.status.success(), "second run accepted: {err}");
    let pid = first.id().to_string();
    assert!(
        err.contains(&format!("process {pid}")),
        "stderr `{err}` lacks pid {pid}"
    );
    assert!(first.wait().unwrap().success());
    // The first run's result is whole: every variant once.
    let result: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("lockme/result.json")).unwrap())
            .unwrap();
    let ids: Vec<u64> = result["variants"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v["id"].as_u64().unwrap())
        .collect();
    assert_eq!(ids, (0..10).collect::<Vec<_>>());
    // Released: a third run resumes everything and succeeds.
    let third = bin()
        .arg("run")
        .arg(&spec)
        .arg("--out")
        .arg(&out)
        .arg("--quiet")
        .output()
        .unwrap();
    assert!(
        third.status.success(),
        "{}",
        String::from_utf8_lossy(&third.stderr)
    );
}

#[test]
fn a_directory_named_result_json_is_refused_before_the_run() {
    let dir = scratch("resultdir");
    let spec = spec_file(&dir, 3, 2000);
    let out = dir.join("out");
    std::fs::create_dir_all(out.join("lockme/result.json")).unwrap();
    let t = Instant::now();
    let o = bin()
        .arg("run")
        .arg(&spec)
        .arg("--out")
        .arg(&out)
        .arg("--quiet")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(err.contains("is a directory"), "{err}");
    // 3 variants of 2 s each were not run first.
    assert!(
        t.elapsed() < Duration::from_secs(2),
        "took {:?}",
        t.elapsed()
    );
    assert!(!out.join("lockme/result.jsonl").exists());
}

#[test]
fn a_stream_written_with_the_old_fnv_hash_is_refused_with_a_clear_message() {
    let dir = scratch("oldhash");
    let spec = spec_file(&dir, 3, 0);
    let out = dir.join("out");
    let o = bin()
        .arg("run")
        .arg(&spec)
        .arg("--out")
        .arg(&out)
        .arg("--quiet")
        .output()
        .unwrap();
    assert!(o.status.success());
    let stream = out.join("lockme/result.jsonl");
    let text = std::fs::read_to_string(&stream).unwrap();
    let (head, rest) = text.split_once('\n').unwrap();
    let mut h: serde_json::Value = serde_json::from_str(head).unwrap();
    assert_eq!(
        h["spec_hash"].as_str().unwrap().len(),
        64,
        "sha2-256 hex: {h}"
    );
    h["spec_hash"] = serde_json::json!("0123456789abcdef");
    std::fs::write(&stream, format!("{h}\n{rest}")).unwrap();
    let o = bin()
        .arg("run")
        .arg(&spec)
        .arg("--out")
        .arg(&out)
        .arg("--quiet")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        err.contains("older version") && err.contains("move it away"),
        "{err}"
    );
}
