//! Issue 20: stability with the finite film at its default settings on the issue's
//! rotor: 2.963 kg, transverse inertia 0.01174 kg m², polar 0.008393 kg m², two paper
//! bearings at ±0.1 m, gravity −y (14.53 N per bearing), spin held. A scan over 440-520 rad/s has no failed point and
//! brackets a threshold within 2 % of ROSS's own finite-element film (~469 rad/s; here
//! 461.5; the short film: 459.3).

use bearing_sweep::backend::{create_backend, BackendKind, LoadEvaluator};
use bearing_sweep::bearing::Accuracy;
use bearing_sweep::rotor::load_scene;
use bearing_sweep::stability::{thresholds, RotorDescription};

fn rotor(model: &str, finite: serde_json::Value) -> RotorDescription {
    let bearing = |z: f64| {
        serde_json::json!({"radius": 0.02, "length": 0.02, "clearance": 3e-4,
            "viscosity": 0.0242, "axial_position": z, "model": model, "finite": finite})
    };
    let json = serde_json::json!({
        "name": "issue-20 rotor",
        "rotor": {"mass": 2.963, "inertia": [0.01174, 0.01174, 0.008393]},
        "bearings": [bearing(0.1), bearing(-0.1)],
        "gravity": [0.0, -9.81, 0.0],
        "spin": "held",
        "initial": {"spin": 450.0},
        "integrator": {"t_end": 0.1}
    });
    RotorDescription::from_scene(&load_scene(&json.to_string()).unwrap().remove(0)).unwrap()
}

#[test]
fn finite_film_threshold_without_failed_points() {
    let (b, _) = create_backend(BackendKind::Cpu, Accuracy::default()).unwrap();
    let mut ev = LoadEvaluator::new(b);
    let grid: Vec<f64> = (0..9).map(|k| 440.0 + 10.0 * k as f64).collect();
    // At the default settings (accuracy 5e-4: 512 × 64 here). Before the held ladder
    // grid (issue 20) this scan ran at 2e-3; at the defaults Newton failed near 500
    // rad/s on the explicit grid's snapped inlet column.
    let r = rotor("finite", serde_json::json!({}));
    let t = thresholds(&mut ev, &[&r], std::slice::from_ref(&grid)).remove(0);
    println!(
        "finite film: threshold {:?} rad/s, bracket {:?}, growth {:?}, failed {:?}, note {}",
        t.speed_rad_s, t.bracket_rad_s, t.grid_growth_1_s, t.failed, t.note
    );
    assert!(t.failed.is_empty(), "failed points: {:?}", t.failed);
    let w = t.speed_rad_s.expect("a threshold on 440-520 rad/s");
    assert!(
        (440.0..=520.0).contains(&w),
        "threshold {w} rad/s outside the scan"
    );
    // ROSS's finite-element film puts it at ~469 rad/s; measured here at the defaults
    // 461.54 (462.04 at accuracy 2e-3, 461.52 at 1.25e-4: converged in the accuracy;
    // BENCHMARKS.md "Issue 20: coefficients and equilibria at the default accuracy").
    // 2 % covers both solvers' meshes. (469.5 was measured before the held ladder grid,
    // on an explicit grid whose inlet column snapped between nearby states.)
    assert!(
        (w - 469.0).abs() <= 0.02 * 469.0,
        "threshold: actual {w} rad/s, expected 469 (ROSS finite-element film), tolerance 2 %"
    );
}

/// Issue 20 item 3: a failed point of a scan is reported by its speed with its reason, not
/// dropped, and the threshold is still found from the analysed speeds. The scan starts at
/// 0 rad/s, where the film carries no load (no spin, no squeeze: the rotor has no static
/// equilibrium on its bearings: a singular Jacobian); the rest brackets the threshold as
/// above. Accuracy 2e-3 (256 × 32) to keep the test short: measured 461.65 rad/s there,
/// 461.59 at the defaults (the test above).
#[test]
fn a_failed_speed_is_reported_with_its_reason_and_the_threshold_still_found() {
    let (b, _) = create_backend(BackendKind::Cpu, Accuracy::default()).unwrap();
    let mut ev = LoadEvaluator::new(b);
    let grid = vec![0.0, 450.0, 460.0, 470.0, 480.0];
    let r = rotor("finite", serde_json::json!({"accuracy": 2e-3}));
    let t = thresholds(&mut ev, &[&r], std::slice::from_ref(&grid)).remove(0);
    println!(
        "threshold {:?} rad/s, growth {:?}, failed {:?}, note {}",
        t.speed_rad_s, t.grid_growth_1_s, t.failed, t.note
    );
    assert_eq!(t.failed.len(), 1, "failed points: {:?}", t.failed);
    assert_eq!(t.failed[0].speed_rad_s, 0.0);
    assert!(
        t.failed[0]
            .reason
            .contains("no static equilibrium at 0 rad/s"),
        "the failed point carries its reason: {}",
        t.failed[0].reason
    );
    assert_eq!(
        t.grid_growth_1_s[0], None,
        "no growth rate at the failed speed"
    );
    assert!(t.grid_growth_1_s[1..].iter().all(Option::is_some));
    let w = t.speed_rad_s.expect("a threshold from the analysed speeds");
    assert!(
        (w - 461.6).abs() <= 0.01 * 461.6,
        "threshold: actual {w} rad/s, expected 461.6 (the defaults' 461.59), tolerance 1 %"
    );
}
