//! `bench loads` and `bench all` end to end on tiny problems: they write their files and
//! the reports are consistent (no timing is checked: timings belong to BENCHMARKS.md).

use std::path::PathBuf;

use bearing_sweep::bench::backend::BenchOptions;
use bearing_sweep::bench::BenchRotorOptions;
use bearing_sweep::bench::{bench_all, bench_loads, BenchAllOptions, BenchLoadsOptions};

fn gpu_required() -> bool {
    std::env::var("BEARING_SWEEP_REQUIRE_GPU").is_ok_and(|v| v == "1")
}

fn temp_dir(tag: &str) -> PathBuf {
    std::env::temp_dir().join(format!("bearing-sweep-{tag}-{}", std::process::id()))
}

#[test]
fn bench_loads_writes_json_markdown_and_svg() {
    let out = temp_dir("bench-smoke");
    let report = bench_loads(&BenchLoadsOptions {
        threads: Some(2),
        states: 40,
        out: out.clone(),
        baseline_grids: vec![16, 32, 64],
        min_time_s: 0.001,
        gpu_batch: 0,
    })
    .expect("bench runs");
    assert_eq!(report.rows.len(), 4 + 3);
    for r in &report.rows {
        assert!(
            r.evals_per_s_1thread.is_some_and(|x| x > 0.0) && r.evals_per_s_parallel > 0.0,
            "{r:?}"
        );
        assert!(r.max_rel_error.is_finite() && r.median_rel_error <= r.max_rel_error);
    }
    // The rule's levels keep their promise on the benchmark states too.
    for (r, level) in report.rows.iter().zip([1e-3, 1e-6, 1e-9, 1e-12]) {
        assert_eq!(r.method, "rule");
        assert!(r.max_rel_error <= level, "{r:?}");
    }
    // The baseline's error falls as its grid refines.
    let b: Vec<f64> = report.rows[4..].iter().map(|r| r.max_rel_error).collect();
    assert!(b[1] < b[0] && b[2] < b[1], "{b:?}");
    assert!(report.speedup_at_1e6.is_finite() && report.speedup_at_1e6 > 0.0);
    assert!(report.speedup_note.contains("extrapolated"));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("bench-loads.json")).unwrap())
            .unwrap();
    assert_eq!(json["rows"].as_array().unwrap().len(), 7);
    let md = std::fs::read_to_string(out.join("bench-loads.md")).unwrap();
    assert!(md.contains("| rule | 1e-6 |") && md.contains("times faster"));
    assert!(md.contains("GPU rows not run"), "{md}");
    let svg = std::fs::read_to_string(out.join("bench-loads.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("baseline"));
    let _ = std::fs::remove_dir_all(&out);
}

/// `bench all` on tiny settings: every part's files and the index exist; the GPU rows of
/// the loads benchmark are there when an adapter is (required under
/// `BEARING_SWEEP_REQUIRE_GPU=1`), and the f64 kernel keeps each level's promise.
#[test]
fn bench_all_writes_every_part_and_an_index() {
    let out = temp_dir("bench-all-smoke");
    let mut opts = BenchAllOptions::quick(out.clone());
    opts.label = "tiny".into();
    opts.loads = BenchLoadsOptions {
        threads: Some(2),
        states: 20,
        out: PathBuf::new(),
        baseline_grids: vec![16, 32],
        min_time_s: 0.001,
        gpu_batch: 64,
    };
    opts.backend = BenchOptions {
        sizes: vec![1, 50],
        min_time_s: 0.001,
        max_reps: 2,
        ..BenchOptions::default()
    };
    opts.rotor = BenchRotorOptions {
        t_end: 0.003,
        accuracy: 1e-6,
        repeats: 1,
        out: PathBuf::new(),
        viscosity: None,
    };
    opts.rotor_stiff = true;
    opts.rotor_batch = vec![2];
    opts.rotor_batch_t_end = 0.003;
    let report = bench_all(&opts).expect("bench all runs");
    for f in [
        "index.md",
        "loads/bench-loads.json",
        "loads/bench-loads.md",
        "loads/bench-loads.svg",
        "backend/bench-backend.md",
        "backend/bench-backend.json",
        "backend/bench-backend.svg",
        "rotor/bench-rotor.md",
        "rotor/rotor-work-precision-time.svg",
        "rotor/rotor-work-precision-loads.svg",
        "rotor/rotor-stiff-work-precision-time.svg",
        "rotor/rotor-stiff-work-precision-loads.svg",
    ] {
        let p = out.join(f);
        assert!(p.is_file(), "missing {}", p.display());
        assert!(report.files.contains(&p), "{} not listed", p.display());
        let text = std::fs::read_to_string(&p).unwrap();
        assert!(!text.is_empty(), "{f} is empty");
        if f.ends_with(".svg") {
            assert!(text.starts_with("<svg"), "{f}");
        }
    }
    let index = std::fs::read_to_string(out.join("index.md")).unwrap();
    assert_eq!(index, report.index);
    for needle in [
        "## Headline figures",
        "Machine:",
        "| film loads, rule at level 1e-6 |",
        "vs adaptive reference 1e-14",
        "| rotor, dopri5 at rtol = atol = 1e-6",
        "vs dopri5 at 1e-13",
        "[rotor/bench-rotor.md](rotor/bench-rotor.md)",
    ] {
        assert!(index.contains(needle), "index lacks {needle:?}:\n{index}");
    }
    let rotor = std::fs::read_to_string(out.join("rotor/bench-rotor.md")).unwrap();
    assert!(rotor.contains("Stiff variant") && rotor.contains("Lockstep batches"));
    let loads: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("loads/bench-loads.json")).unwrap())
            .unwrap();
    let rows = loads["rows"].as_array().unwrap();
    let gpu64: Vec<&serde_json::Value> = rows
        .iter()
        .filter(|r| r["method"] == "rule-gpu-f64")
        .collect();
    let gpu32 = rows
        .iter()
        .filter(|r| r["method"] == "rule-gpu-f32")
        .count();
    if gpu_required() {
        assert_eq!((gpu64.len(), gpu32), (4, 4), "GPU rows: {rows:?}");
    }
    if gpu64.is_empty() {
        eprintln!("notice: no GPU rows (no adapter)");
        assert!(index.contains("skipped"), "{index}");
    }
    for (k, (r, level)) in gpu64.iter().zip([1e-3, 1e-6, 1e-9, 1e-12]).enumerate() {
        let err = r["max_rel_error"].as_f64().unwrap();
        assert!(
            err <= level,
            "GPU f64 row {k}: max rel. error {err:e} above its level {level:e}"
        );
        assert_eq!(r["batch_states"].as_u64(), Some(64));
    }
    let _ = std::fs::remove_dir_all(&out);
}

/// Without a usable adapter (here: `WGPU_ADAPTER_NAME` matching none) `bench loads` still
/// writes its CPU rows and says why the GPU rows are missing. Runs the binary, so the
/// environment variable stays in that process.
#[test]
fn bench_loads_without_adapter_skips_gpu_rows_with_a_note() {
    let out = temp_dir("bench-no-adapter");
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_bearing-sweep"))
        .args(["bench", "loads", "--states", "10", "--grids", "8,16"])
        .args([
            "--gpu-batch",
            "16",
            "--threads",
            "1",
            "--min-time",
            "0.001",
            "--out",
        ])
        .arg(&out)
        .env("WGPU_ADAPTER_NAME", "no-such-adapter-bearing-sweep")
        .output()
        .expect("the binary runs");
    assert!(
        run.status.success(),
        "status {:?}, stderr: {}",
        run.status,
        String::from_utf8_lossy(&run.stderr)
    );
    let md = std::fs::read_to_string(out.join("bench-loads.md")).unwrap();
    assert!(md.contains("GPU f64 rows skipped"), "{md}");
    assert!(md.contains("GPU f32 rows skipped"), "{md}");
    assert!(!md.contains("rule-gpu"), "{md}");
    assert!(md.contains("| rule | 1e-6 |"), "{md}");
    let _ = std::fs::remove_dir_all(&out);
}

/// Issue 23 item 8: the GPU rows' timing batch holds distinct states only, so the
/// evaluator's dedupe (which integrates each distinct state once) removes nothing and the
/// headline rate is measured on distinct work: no two states are equal bit for bit, and a
/// dedupe-on evaluator run over the batch reports zero states served from another's
/// integrals.
#[test]
fn bench_gpu_timing_batch_has_no_duplicate_states() {
    use bearing_sweep::backend::{CpuBackend, LoadEvaluator};
    use bearing_sweep::bearing::{Accuracy, BearingParams};
    let params = BearingParams::paper_table2();
    let n = 4000;
    let batch = bearing_sweep::bench::gpu_timing_batch(&params, n);
    assert_eq!(batch.len(), n);
    let key = |s: &bearing_sweep::bearing::BearingState| {
        [s.xi, s.yi, s.xj, s.yj, s.vxi, s.vyi, s.vxj, s.vyj, s.omega].map(f64::to_bits)
    };
    let mut seen = std::collections::HashMap::new();
    for (k, r) in batch.iter().enumerate() {
        if let Some(first) = seen.insert(key(&r.state), k) {
            panic!("states {first} and {k} are equal: {:?}", r.state);
        }
    }
    // Its first states are the benchmark states (the error rows use those).
    let states = bearing_sweep::bench::bench_states(&params, 100);
    for (k, s) in states.iter().enumerate() {
        assert_eq!(key(s), key(&batch[k].state), "state {k}");
    }
    let acc = Accuracy::new(1e-3).unwrap();
    let mut ev = LoadEvaluator::new(Box::new(CpuBackend::new(acc, Some(2))));
    let mut out = Vec::new();
    ev.evaluate(&[params], &batch, &mut out);
    let stats = ev.stats();
    assert_eq!(
        stats.deduplicated, 0,
        "dedupe removed {} of {n} states: the timing would not be of distinct work",
        stats.deduplicated
    );
}
