//! Issue 13 item 4: subnormal inputs are valid tiny inputs with tiny loads. A spin of
//! 1e-310 rad/s or positions of 1e-320 m used to report `backend_non_finite` (the rate
//! scale's reciprocal overflowed) or `overflow` (an infinite friction coefficient or
//! Sommerfeld number that MODEL.md section 5 writes as null). Checked on the CPU backend
//! and, where an adapter exists, the GPU backend (skipped with a notice otherwise unless
//! `BEARING_SWEEP_REQUIRE_GPU=1`).

use bearing_sweep::backend::{
    CpuBackend, FilmBackend, GpuBackend, GpuOptions, LoadEvaluator, LoadRequest, Precision,
};
use bearing_sweep::bearing::{Accuracy, BearingParams, BearingState, Loads};

/// Smallest positive subnormal f64 (2^-1074): the absolute rounding unit of tiny loads.
const TINY_ULP: f64 = 5e-324;

fn bearing() -> BearingParams {
    BearingParams::paper_table2()
}

/// Every backend to check: CPU, plus the GPU at f64 where an adapter offers it.
fn backends() -> Vec<(String, Box<dyn FilmBackend>)> {
    let accuracy = Accuracy::default();
    let mut out: Vec<(String, Box<dyn FilmBackend>)> = vec![(
        "cpu".into(),
        Box::new(CpuBackend::with_settings(accuracy.settings(), Some(1))),
    )];
    let options = GpuOptions {
        precision: Some(Precision::F64),
        ..GpuOptions::default()
    };
    match GpuBackend::new(accuracy, options) {
        Ok(b) => out.push(("gpu-f64".into(), Box::new(b))),
        Err(e) if std::env::var("BEARING_SWEEP_REQUIRE_GPU").is_ok_and(|v| v == "1") => {
            panic!("BEARING_SWEEP_REQUIRE_GPU=1 but: {e}")
        }
        Err(e) => eprintln!("notice: skipping the GPU cases: {e}"),
    }
    out
}

fn evaluate(backend: Box<dyn FilmBackend>, states: &[BearingState]) -> Vec<Loads> {
    let mut ev = LoadEvaluator::new(backend);
    let requests: Vec<_> = states
        .iter()
        .map(|&state| LoadRequest { bearing: 0, state })
        .collect();
    let mut out = Vec::new();
    ev.evaluate(&[bearing()], &requests, &mut out);
    out.into_iter()
        .enumerate()
        .map(|(k, r)| r.unwrap_or_else(|f| panic!("state {k} {:?}: {} ({f})", states[k], f.code())))
        .collect()
}

fn vector(l: &Loads) -> [f64; 4] {
    [l.wx, l.wy, l.mx, l.my]
}

fn check(label: &str, k: usize, actual: f64, expected: f64, rtol: f64, atol: f64) {
    let tol = rtol * expected.abs() + atol;
    assert!(
        (actual - expected).abs() <= tol,
        "{label}: index {k}: actual {actual:e}, expected {expected:e}, tolerance {tol:e}"
    );
}

/// Moderate states (tilted, squeezed, both spin signs) at ε up to 0.8.
fn moderate_states() -> Vec<BearingState> {
    let d = bearing().clearance;
    vec![
        BearingState {
            xi: 0.3 * d,
            xj: 0.3 * d,
            omega: 100.0,
            ..Default::default()
        },
        BearingState {
            xi: 0.5 * d,
            yi: -0.2 * d,
            xj: -0.1 * d,
            yj: 0.6 * d,
            vxi: 0.01,
            vyj: -0.02,
            omega: 250.0,
            ..Default::default()
        },
        BearingState {
            xi: -0.7 * d,
            yi: 0.1 * d,
            xj: 0.2 * d,
            yj: 0.4 * d,
            vyi: 0.03,
            omega: -80.0,
            ..Default::default()
        },
    ]
}

/// Scaling the spin and every velocity by c > 0 scales the loads by c (MODEL.md section 7),
/// down to c = 1e-312, where the rate scale is subnormal.
#[test]
fn tiny_spin_and_velocities_scale_the_loads() {
    let c = 1e-312;
    let base = moderate_states();
    let tiny: Vec<_> = base
        .iter()
        .map(|s| BearingState {
            vxi: s.vxi * c,
            vyi: s.vyi * c,
            vxj: s.vxj * c,
            vyj: s.vyj * c,
            omega: s.omega * c,
            ..*s
        })
        .collect();
    for ((name, backend), (_, backend2)) in backends().into_iter().zip(backends()) {
        let reference = evaluate(backend, &base);
        let scaled = evaluate(backend2, &tiny);
        for (k, (r, s)) in reference.iter().zip(&scaled).enumerate() {
            for (a, e) in vector(s).iter().zip(vector(r)) {
                // Loads ~1e-312 carry ~12 significant digits as subnormals.
                check(&name, k, *a, e * c, 1e-9, 8.0 * TINY_ULP);
            }
            // The Sommerfeld number is invariant under this scaling.
            check(
                &name,
                k,
                s.sommerfeld.unwrap(),
                r.sommerfeld.unwrap(),
                1e-9,
                0.0,
            );
        }
    }
}

/// An aligned journal displaced by 1e-320 m: the small-ε Ocvirk force
/// W_y = π μ ω0 r0 B³ ε / (4 δ²), W_x ∝ ε² (underflows to zero).
#[test]
fn subnormal_positions_give_the_small_eccentricity_law() {
    let p = bearing();
    let x = 1e-320;
    let omega = 100.0;
    let state = BearingState {
        xi: x,
        xj: x,
        omega,
        ..Default::default()
    };
    let coef = std::f64::consts::PI * p.viscosity * omega * p.radius * p.length.powi(3)
        / (4.0 * p.clearance.powi(3));
    let wy = coef * x;
    for (name, backend) in backends() {
        let l = evaluate(backend, &[state])[0];
        // ε = x/δ is a subnormal with ~17 significant bits: relative 1e-5.
        check(&name, 0, l.wy, wy, 1e-5, 4.0 * TINY_ULP);
        check(&name, 0, l.wx, 0.0, 0.0, 4.0 * TINY_ULP);
        check(&name, 0, l.mx, -0.5 * p.length * wy, 1e-5, 4.0 * TINY_ULP);
        assert!(
            l.friction_coefficient.is_none(),
            "{name}: f = 3 φ / S overflows: null"
        );
        assert!(
            l.mz.is_finite() && l.mz < 0.0,
            "{name}: M_z {} opposes the spin",
            l.mz
        );
    }
}

/// The smallest subnormal in every field, alone and all together: status ok, finite.
#[test]
fn smallest_subnormal_in_every_field_is_ok_and_finite() {
    let mut states = Vec::new();
    for field in 0..9 {
        let mut v = [0.0; 9];
        v[field] = TINY_ULP;
        states.push(v);
        v[field] = -TINY_ULP;
        states.push(v);
    }
    states.push([TINY_ULP; 9]);
    states.push([
        1e-310, -1e-320, 3e-315, 2e-308, 1e-312, -1e-309, 7e-320, 5e-311, 1e-310,
    ]);
    let states: Vec<BearingState> = states
        .iter()
        .map(|v| BearingState {
            xi: v[0],
            yi: v[1],
            xj: v[2],
            yj: v[3],
            vxi: v[4],
            vyi: v[5],
            vxj: v[6],
            vyj: v[7],
            omega: v[8],
        })
        .collect();
    for (name, backend) in backends() {
        for (k, l) in evaluate(backend, &states).iter().enumerate() {
            let all = [l.wx, l.wy, l.mx, l.my, l.mz, l.h_min, l.power_loss];
            assert!(
                all.iter().all(|v| v.is_finite()),
                "{name}: index {k}: {l:?}"
            );
            // Loads below 1e-300 N: the inputs are all below 1e-307.
            assert!(
                vector(l).iter().all(|v| v.abs() < 1e-300),
                "{name}: index {k}: {l:?}"
            );
        }
    }
}

/// The same through the `eval` command: no state of a subnormal input is refused.
#[test]
fn eval_command_accepts_subnormal_inputs() {
    let doc = serde_json::json!({
        "bearing": {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242},
        "states": [
            {"xi": 1e-4, "yi": 0, "xj": 1e-4, "yj": 0, "vxi": 0, "vyi": 0, "vxj": 0, "vyj": 0, "omega": 1e-310},
            {"xi": 1e-320, "yi": 0, "xj": 1e-320, "yj": 0, "vxi": 0, "vyi": 0, "vxj": 0, "vyj": 0, "omega": 100},
            {"xi": 1e-4, "yi": 0, "xj": 1e-4, "yj": 0, "vxi": 0.1, "vyi": 0, "vxj": 0, "vyj": 0, "omega": 1e-310}
        ]
    });
    let (out, _) = bearing_sweep::app::eval_json(&doc.to_string(), Default::default()).unwrap();
    for (k, l) in out["loads"].as_array().unwrap().iter().enumerate() {
        assert_eq!(l["status"], "ok", "index {k}: {l}");
    }
}
