//! Issue 13 item 1: no figure can hang. A friction map whose load axis spans 1e-160..1e160
//! used to loop forever in plotters' tick generation (a log range wider than f64::MAX)
//! before result.json was written; now the result is written and the figure skipped with
//! a note. Every extreme range either draws or is refused, in bounded time.

use std::sync::mpsc;
use std::time::{Duration, Instant};

use bearing_sweep::plot::{line_plot_svg, line_plot_svg_equal_aspect, Scale, Series};
use serde_json::json;

mod cli_support;
use cli_support::*;

/// Runs `f` on a thread; fails the test if it takes longer than `limit`.
fn bounded<T: Send + 'static>(
    what: &str,
    limit: Duration,
    f: impl FnOnce() -> T + Send + 'static,
) -> T {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    rx.recv_timeout(limit)
        .unwrap_or_else(|_| panic!("{what}: no answer within {limit:?} (a hang)"))
}

#[test]
fn friction_map_over_320_decades_writes_its_result_and_skips_the_figure() {
    let dir = scratch("hardening-plots", "map");
    let spec = write(
        &dir,
        "map.json",
        &json!({"kind": "friction_map",
        "bearing": {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242},
        "load": {"logspace": [1e-160, 1e160, 33]}, "speed": [10, 100]}),
    );
    let out = dir.join("out");
    let mut child = bin()
        .args([
            "run",
            spec.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            panic!("friction map still running after 60 s (the plotting hang)");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    let result = read(&out.join("map/result.json"));
    assert_eq!(
        result["curves"].as_array().map(Vec::len),
        Some(2),
        "{result}"
    );
    assert!(
        err.contains("no plot") && err.contains("decades"),
        "no note of the skipped figure: {err}"
    );
}

#[test]
fn extreme_ranges_draw_or_are_refused_in_bounded_time() {
    let max = f64::MAX;
    let tiny = 5e-324;
    let cases: Vec<(&str, Vec<(f64, f64)>, Scale, Scale)> = vec![
        (
            "linear full f64",
            vec![(-max, -max), (max, max)],
            Scale::Linear,
            Scale::Linear,
        ),
        (
            "linear one ulp",
            vec![(1.0, 1.0), (1.0 + f64::EPSILON, 1.0 + f64::EPSILON)],
            Scale::Linear,
            Scale::Linear,
        ),
        (
            "subnormal point",
            vec![(tiny, tiny)],
            Scale::Linear,
            Scale::Linear,
        ),
        (
            "log 600 decades",
            vec![(1e-300, 1e-300), (1e300, 1e300)],
            Scale::Log,
            Scale::Log,
        ),
        (
            "log subnormal",
            vec![(tiny, tiny), (1.0, 1.0)],
            Scale::Log,
            Scale::Log,
        ),
        (
            "log near max",
            vec![(1.0, 1e308), (10.0, max)],
            Scale::Log,
            Scale::Log,
        ),
        (
            "log 100 decades",
            vec![(1e-50, 1.0), (1e50, 2.0)],
            Scale::Log,
            Scale::Linear,
        ),
        (
            "non-finite only",
            vec![(f64::NAN, 1.0), (f64::INFINITY, 2.0)],
            Scale::Linear,
            Scale::Linear,
        ),
        (
            "huge flat",
            vec![(1e300, 1e300), (1e300, 1e300)],
            Scale::Linear,
            Scale::Linear,
        ),
    ];
    for (name, points, xs, ys) in cases {
        let pts = points.clone();
        let r = bounded(name, Duration::from_secs(20), move || {
            let s = [Series {
                label: "s",
                points: pts,
            }];
            line_plot_svg("t", "x", "y", &s, xs, ys)
        });
        if let Err(e) = &r {
            assert!(!e.is_empty(), "{name}: empty reason");
        }
        let pts = points.clone();
        if xs == Scale::Linear && ys == Scale::Linear {
            let _ = bounded(name, Duration::from_secs(20), move || {
                let s = [Series {
                    label: "s",
                    points: pts,
                }];
                line_plot_svg_equal_aspect("t", "x", "y", &s).map(|svg| svg.len())
            });
        }
    }
    // A normal log range still draws.
    let s = [Series {
        label: "s",
        points: vec![(1.0, 1e-3), (1e4, 1e2)],
    }];
    let svg = line_plot_svg("t", "x", "y", &s, Scale::Log, Scale::Log).unwrap();
    assert!(svg.contains("<polyline"));
}
