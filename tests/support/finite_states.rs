//! The finite film's accuracy test set (issue 20): twelve states of the paper's bearing
//! (B/D = 0.5) at 100 rad/s — aligned ε 0.1-0.95, tilted in the plane of the eccentricity,
//! squeezed. `tests/finite_accuracy.rs` asserts on it, and the probes behind its BENCHMARKS
//! sections (`examples/ladder_probe.rs`, `zeta_probe.rs`, `mg_probe.rs`) measure on it;
//! each includes this file by path, so the set is written once.
#![allow(dead_code)] // each includer uses part of it

use bearing_sweep::bearing::{BearingParams, BearingState};

/// Relative distance of load vector `a` from `b`: `|a − b| / |b|` (Euclidean), the
/// measure of every error of `(W_x, W_y, M_x/B, M_y/B)` in these tests and probes.
pub fn rel(a: &[f64; 4], b: &[f64; 4]) -> f64 {
    let d: f64 = (0..4).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt();
    d / b.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// The set: (eccentricity ratio of the mid-plane, tilt as end offset over the radial
/// clearance δ (+ at one end, − at the other), squeeze velocity over δω).
pub const CASES: [(f64, f64, f64); 12] = [
    (0.1, 0.0, 0.0),
    (0.3, 0.0, 0.0),
    (0.6, 0.0, 0.0),
    (0.8, 0.0, 0.0),
    (0.9, 0.0, 0.0),
    (0.95, 0.0, 0.0),
    (0.3, 0.2, 0.0),
    (0.6, 0.2, 0.0),
    (0.8, 0.1, 0.0),
    (0.5, 0.0, 0.1),
    (0.7, 0.0, -0.1),
    (0.6, 0.15, 0.05),
];

/// Spin speed of the set, rad/s.
pub const OMEGA: f64 = 100.0;

/// Angle of the eccentricity from x in the test set, rad (off every grid's nodes).
pub const ANGLE: f64 = 0.7;

/// The set's states, labelled `ε=… tilt=… squeeze=…`, eccentricity at [`ANGLE`].
pub fn accuracy_states(p: &BearingParams) -> Vec<(String, BearingState)> {
    let d = p.clearance;
    let w = OMEGA;
    let (c, s) = (ANGLE.cos(), ANGLE.sin());
    CASES
        .iter()
        .map(|&(e, tilt, sq)| {
            (
                format!("ε={e} tilt={tilt} squeeze={sq}"),
                BearingState {
                    xi: (e + tilt) * d * c,
                    yi: (e + tilt) * d * s,
                    xj: (e - tilt) * d * c,
                    yj: (e - tilt) * d * s,
                    vxi: sq * d * w * c,
                    vyi: sq * d * w * s,
                    vxj: sq * d * w * c,
                    vyj: sq * d * w * s,
                    omega: w,
                },
            )
        })
        .collect()
}
