//! The multigrid kernel's resumable dispatches (shaders/finite_mg.wgsl, issue 26 item 3):
//! a solve split into many more dispatches by a smaller loop budget per dispatch
//! (`BEARING_SWEEP_MG_BUDGET`, the driver's diagnostic switch, clamped to at least 1000
//! loop iterations) gives the same loads, work counts, error estimates and fields, bit for
//! bit, as the default budget: the kernel keeps its whole state (phase, level, cycle,
//! stop-rule and ladder history, fields) between dispatches. At 512 × 64 one smoothing
//! sweep is 128 loop iterations per invocation and a solve ~40 sweeps, so the small budget
//! splits every solve into several dispatches (measured with `BEARING_SWEEP_MG_TRACE=1` on
//! lavapipe: the explicit solve ends within one submission of 8 dispatches at the default
//! budget and takes 5 submissions at 1000; the ladder 1 and 2). Runs on whatever f64 adapter wgpu finds
//! (lavapipe on CI); skips with a notice without one, fails with
//! `BEARING_SWEEP_REQUIRE_GPU=1`. One test in its own binary: it sets the process
//! environment, which no other test here reads concurrently.

mod common;

use bearing_sweep::bearing::finite::FiniteSettings;
use bearing_sweep::bearing::{BearingParams, FilmModel};

#[test]
fn a_smaller_dispatch_budget_gives_the_same_bits() {
    let Some(mut backend) = common::gpu_f64_or_skip("finite-film multigrid GPU") else {
        return;
    };
    let states = common::two_finite_states();
    let cases = [
        (
            "explicit 512×64",
            FiniteSettings {
                n_theta: Some(512),
                n_z: Some(64),
                tolerance: 1e-9,
                ..FiniteSettings::default()
            },
        ),
        (
            "accuracy 5e-4 (the ladder)",
            FiniteSettings {
                accuracy: 5e-4,
                ..FiniteSettings::default()
            },
        ),
    ];
    for (label, finite) in cases {
        let p = BearingParams {
            model: FilmModel::Finite,
            finite,
            ..BearingParams::paper_table2()
        };
        std::env::remove_var("BEARING_SWEEP_MG_BUDGET");
        let (loads, reports, fields) = common::solve_finite_cold(&mut backend, &p, &states);
        std::env::set_var("BEARING_SWEEP_MG_BUDGET", "1000");
        let (loads_b, reports_b, fields_b) = common::solve_finite_cold(&mut backend, &p, &states);
        std::env::remove_var("BEARING_SWEEP_MG_BUDGET");
        for k in 0..states.len() {
            for q in 0..4 {
                assert_eq!(
                    loads_b[k][q].to_bits(),
                    loads[k][q].to_bits(),
                    "{label}: state {k}, load {q}: small budget {:e}, default {:e}",
                    loads_b[k][q],
                    loads[k][q]
                );
            }
            let (a, b) = (&reports[k], &reports_b[k]);
            assert_eq!(
                (b.sweeps, b.n_theta, b.n_z, b.converged),
                (a.sweeps, a.n_theta, a.n_z, a.converged),
                "{label}: state {k}: work, grid and verdict"
            );
            assert_eq!(
                (b.iteration_error.to_bits(), b.error_estimate.to_bits()),
                (a.iteration_error.to_bits(), a.error_estimate.to_bits()),
                "{label}: state {k}: iteration error and error estimate"
            );
            assert_eq!(fields_b[k].len(), fields[k].len(), "{label}: state {k}");
            if let Some(i) = (0..fields[k].len()).find(|&i| fields_b[k][i] != fields[k][i]) {
                panic!(
                    "{label}: state {k}: field node {i}: small budget {:e}, default {:e}",
                    fields_b[k][i], fields[k][i]
                );
            }
        }
    }
}
