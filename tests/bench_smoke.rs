//! `bench loads` end to end on a tiny problem: it writes its three files and the report is
//! consistent (no timing is checked: timings belong to BENCHMARKS.md).

use bearing_sweep::bench::{bench_loads, BenchLoadsOptions};

#[test]
fn bench_loads_writes_json_markdown_and_svg() {
    let out =
        std::env::temp_dir().join(format!("bearing-sweep-bench-smoke-{}", std::process::id()));
    let report = bench_loads(&BenchLoadsOptions {
        threads: Some(2),
        states: 40,
        out: out.clone(),
        baseline_grids: vec![16, 32, 64],
        min_time_s: 0.001,
    })
    .expect("bench runs");
    assert_eq!(report.rows.len(), 4 + 3);
    for r in &report.rows {
        assert!(
            r.evals_per_s_1thread > 0.0 && r.evals_per_s_parallel > 0.0,
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
    let svg = std::fs::read_to_string(out.join("bench-loads.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("baseline"));
    let _ = std::fs::remove_dir_all(&out);
}
