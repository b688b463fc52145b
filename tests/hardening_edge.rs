//! Issue 13 item 10: CPU and GPU-f64 backends at the edge (ε = 0.9997, opposite tilt).
//! The issue saw W_y differ by 3.2e-5 *relative to W_y*. For a journal tilted about its
//! mid-plane the net force is a cancellation residual: the two halves of the film push
//! with ~±17 N and W is ~1e-12 N, so its relative difference measures rounding in the
//! cancellation, not the rule. Accuracy is defined on the load vector
//! `(W_x, W_y, M_x/B, M_y/B)` (README "How the loads are computed"); in that norm the
//! backends agree to ~1e-16 here (5e-14 on asymmetric edge states). The documented
//! bound, tested here: every component differs by at most 1e-9 × |load vector|.
//! Skips with a notice without a GPU adapter unless `BEARING_SWEEP_REQUIRE_GPU=1`.

use bearing_sweep::backend::{
    CpuBackend, GpuBackend, GpuOptions, LoadEvaluator, LoadRequest, LoadResult, Precision,
};
use bearing_sweep::bearing::{Accuracy, BearingParams, BearingState};

/// Per-component CPU/GPU-f64 agreement relative to the load-vector norm (the suite's
/// near-wall f64 tolerance, tests/backend_suite.rs).
const TOL: f64 = 1e-9;

fn states() -> Vec<BearingState> {
    let d = BearingParams::paper_table2().clearance;
    let mut out = Vec::new();
    for k in 0..24 {
        let a = k as f64 * 0.27;
        let e2 = [0.9997, 0.9, 0.5, 0.0][k % 4];
        let twist = [0.0, 0.2, -0.3][k % 3];
        let omega = [100.0, -100.0, 1000.0][k % 3];
        out.push(BearingState {
            xi: 0.9997 * d * a.cos(),
            yi: 0.9997 * d * a.sin(),
            xj: -e2 * d * (a + twist).cos(),
            yj: -e2 * d * (a + twist).sin(),
            vxi: if k % 5 == 0 { 0.01 } else { 0.0 },
            omega,
            ..Default::default()
        });
    }
    out
}

fn run(mut ev: LoadEvaluator, s: &[BearingState]) -> Vec<LoadResult> {
    let req: Vec<_> = s
        .iter()
        .map(|&state| LoadRequest { bearing: 0, state })
        .collect();
    let mut out = Vec::new();
    ev.evaluate(&[BearingParams::paper_table2()], &req, &mut out);
    out
}

#[test]
fn cpu_and_gpu_agree_in_the_load_vector_norm_at_the_edge() {
    for level in [1e-6, 1e-9, 1e-12] {
        let accuracy = Accuracy::new(level).unwrap();
        let options = GpuOptions {
            precision: Some(Precision::F64),
            ..GpuOptions::default()
        };
        let gpu = match GpuBackend::new(accuracy, options) {
            Ok(g) => g,
            Err(e) if std::env::var("BEARING_SWEEP_REQUIRE_GPU").is_ok_and(|v| v == "1") => {
                panic!("BEARING_SWEEP_REQUIRE_GPU=1 but: {e}")
            }
            Err(e) => {
                eprintln!("notice: skipping the GPU comparison: {e}");
                return;
            }
        };
        let s = states();
        let cpu = run(
            LoadEvaluator::new(Box::new(CpuBackend::with_settings(
                accuracy.settings(),
                Some(1),
            ))),
            &s,
        );
        let gpu = run(LoadEvaluator::new(Box::new(gpu)), &s);
        let b = BearingParams::paper_table2().length;
        let mut worst = 0.0_f64;
        for (k, (c, g)) in cpu.iter().zip(&gpu).enumerate() {
            let (c, g) = (c.as_ref().unwrap(), g.as_ref().unwrap());
            let (vc, vg) = (c.load_vector(b), g.load_vector(b));
            let norm = vc.iter().map(|x| x * x).sum::<f64>().sqrt();
            for i in 0..4 {
                let diff = (vc[i] - vg[i]).abs();
                worst = worst.max(diff / norm);
                assert!(
                    diff <= TOL * norm,
                    "accuracy {level}: state {k} component {i}: actual {:e}, expected {:e}, tolerance {:e}",
                    vg[i],
                    vc[i],
                    TOL * norm
                );
            }
        }
        eprintln!("accuracy {level}: worst component difference / |load vector| = {worst:e}");
    }
}
