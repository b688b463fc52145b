//! The multigrid kernel's per-adapter settings (shaders/finite_mg.wgsl, issue 20,
//! session 40), forced on lavapipe by the driver's diagnostic switches:
//! - the hardware loop limit per dispatch (`BEARING_SWEEP_MG_LOOP_LIMIT`, here 2 000 000
//!   against llvmpipe's 30 000): fewer dispatches, the same loads, work counts, error
//!   estimates and fields, bit for bit (the kernel is resumable: the same arithmetic in
//!   the same order however the solve is split);
//! - workgroups of 64, 128 and 1024 invocations (`BEARING_SWEEP_MG_WG`; the default is
//!   256 on llvmpipe, and on hardware chosen per chunk among 64, 128 and 256 by the
//!   chunk's states, session 42) against 256: the same loads, sweeps, grids, verdicts,
//!   estimates and fields, bit for bit (the loads' sums run in 64 fixed lanes whatever
//!   the size; before session 42 they ran in WG lanes and differed at 3.2e-16 relative).
//!
//! Lavapipe allows 1024 invocations and 32 KiB of workgroup memory, so the 1024 path runs
//! here (the kernel needs ~22 KiB at 1024); on an adapter that does not allow it the
//! driver keeps 256 and the second comparison is between equal settings. Runs on whatever
//! f64 adapter wgpu finds (lavapipe on CI); skips with a notice without one, fails with
//! `BEARING_SWEEP_REQUIRE_GPU=1`. One test in its own binary: it sets the process
//! environment, which no other test here reads concurrently (the settings are read when
//! a backend builds its multigrid pipeline, so each setting gets a fresh backend).

mod common;

use bearing_sweep::backend::GpuBackend;
use bearing_sweep::bearing::finite::FiniteSettings;
use bearing_sweep::bearing::{BearingParams, BearingState, FilmModel};

/// Loads, reports and fields of `states` solved on a fresh backend's kernel at the
/// bearing's grid (`None`: no f64 adapter).
fn solve(p: &BearingParams, states: &[BearingState]) -> Option<common::FiniteSolved> {
    let mut backend: GpuBackend = common::gpu_f64_or_skip("finite-film multigrid GPU")?;
    Some(common::solve_finite_cold(&mut backend, p, states))
}

fn paper(finite: FiniteSettings) -> BearingParams {
    BearingParams {
        model: FilmModel::Finite,
        finite,
        ..BearingParams::paper_table2()
    }
}

#[test]
fn hardware_loop_limit_and_workgroup_size_give_the_same_solution() {
    let states = common::two_finite_states();
    std::env::remove_var("BEARING_SWEEP_MG_LOOP_LIMIT");
    std::env::remove_var("BEARING_SWEEP_MG_WG");

    // The loop limit: 512 × 64 takes several dispatches at llvmpipe's limit, one at 2e6.
    let p = paper(FiniteSettings {
        n_theta: Some(512),
        n_z: Some(64),
        tolerance: 1e-9,
        ..FiniteSettings::default()
    });
    let Some(base) = solve(&p, &states) else {
        return;
    };
    std::env::set_var("BEARING_SWEEP_MG_LOOP_LIMIT", "2000000");
    let large = solve(&p, &states).expect("adapter found above");
    std::env::remove_var("BEARING_SWEEP_MG_LOOP_LIMIT");
    for k in 0..states.len() {
        for q in 0..4 {
            assert_eq!(
                large.0[k][q].to_bits(),
                base.0[k][q].to_bits(),
                "loop limit 2e6: state {k}, load {q}: {:e}, expected {:e} (bit for bit)",
                large.0[k][q],
                base.0[k][q]
            );
        }
        let (a, b) = (&base.1[k], &large.1[k]);
        assert_eq!(
            (b.sweeps, b.n_theta, b.n_z, b.converged),
            (a.sweeps, a.n_theta, a.n_z, a.converged),
            "loop limit 2e6: state {k}: work, grid and verdict"
        );
        assert_eq!(
            b.iteration_error.to_bits(),
            a.iteration_error.to_bits(),
            "loop limit 2e6: state {k}: iteration error {:e}, expected {:e}",
            b.iteration_error,
            a.iteration_error
        );
        assert_eq!(
            large.2[k].len(),
            base.2[k].len(),
            "loop limit 2e6: state {k}"
        );
        if let Some(i) = (0..base.2[k].len()).find(|&i| large.2[k][i] != base.2[k][i]) {
            panic!(
                "loop limit 2e6: state {k}: field node {i}: {:e}, expected {:e} (bit for bit)",
                large.2[k][i], base.2[k][i]
            );
        }
    }

    // The workgroup size, on an explicit grid and on the accuracy ladder.
    let cases = [
        ("explicit 128×32", paper(FiniteSettings::with_grid(128, 32))),
        (
            "accuracy 5e-4 (the ladder)",
            paper(FiniteSettings {
                accuracy: 5e-4,
                ..FiniteSettings::default()
            }),
        ),
    ];
    for (label, p) in cases {
        let base = solve(&p, &states).expect("adapter found above");
        // 64 invocations on the explicit grid only: on the ladder (its hierarchy up to
        // 1024 × 128) one step of the largest level at 64 would not fit llvmpipe's loop
        // limit per dispatch; 128 does. Hardware's limit is ten times llvmpipe's.
        let sizes: &[&str] = if label.starts_with("explicit") {
            &["64", "128", "1024"]
        } else {
            &["128", "1024"]
        };
        for &wg in sizes {
            std::env::set_var("BEARING_SWEEP_MG_WG", wg);
            let other = solve(&p, &states).expect("adapter found above");
            std::env::remove_var("BEARING_SWEEP_MG_WG");
            for k in 0..states.len() {
                for q in 0..4 {
                    let (got, want) = (other.0[k][q], base.0[k][q]);
                    assert_eq!(
                        got.to_bits(),
                        want.to_bits(),
                        "{label}, workgroup {wg}: state {k}, load {q}: {got:e}, expected \
                         {want:e} (bit for bit)"
                    );
                }
                let (a, b) = (&base.1[k], &other.1[k]);
                assert_eq!(
                    (b.sweeps, b.n_theta, b.n_z, b.converged, b.accuracy_met),
                    (a.sweeps, a.n_theta, a.n_z, a.converged, a.accuracy_met),
                    "{label}, workgroup {wg}: state {k}: work, grid and verdicts"
                );
                assert_eq!(
                    (b.iteration_error.to_bits(), b.error_estimate.to_bits()),
                    (a.iteration_error.to_bits(), a.error_estimate.to_bits()),
                    "{label}, workgroup {wg}: state {k}: iteration error {:e} and estimate \
                     {:e}, expected {:e} and {:e} (bit for bit)",
                    b.iteration_error,
                    b.error_estimate,
                    a.iteration_error,
                    a.error_estimate
                );
                assert_eq!(other.2[k].len(), base.2[k].len(), "{label}: state {k}");
                if let Some(i) = (0..base.2[k].len()).find(|&i| other.2[k][i] != base.2[k][i]) {
                    panic!(
                        "{label}, workgroup {wg}: state {k}, field node {i}: {:e}, expected \
                         {:e} (bit for bit)",
                        other.2[k][i], base.2[k][i]
                    );
                }
            }
        }
    }
}
