//! The multigrid kernel's host side (src/backend/finite_mg.rs, issue 20, session 41):
//! what it reads back and how it splits a call changes its cost, never its results.
//! - **No field read-back.** `integrate_finite_with(.., fields_wanted: false, ..)` skips
//!   the fields' read-back: the same loads and reports, bit for bit, as the call that
//!   reads them (explicit grids on the PSOR kernel and on the multigrid kernel, and the
//!   accuracy ladder), with every field left empty.
//! - **Chunks and passes.** A small scratch budget (`BEARING_SWEEP_MG_SCRATCH_MIB`) splits
//!   an accuracy-mode call into several chunks (`BEARING_SWEEP_MG_TIERED=0`), or into a
//!   first pass on the lower ladder and more on larger ladders for the states that need
//!   more grids (`BEARING_SWEEP_MG_TIERED=1`, the hardware default): loads,
//!   reports and fields equal, bit for bit, to the call in one chunk.
//!
//! Runs on whatever f64 adapter wgpu finds (lavapipe on CI); skips with a notice without
//! one, fails with `BEARING_SWEEP_REQUIRE_GPU=1`. One test in its own binary: it sets the
//! process environment, which no other test here reads concurrently (the driver reads
//! these settings per call).

mod common;

use bearing_sweep::backend::{take_mg_tally, FilmBackend, GpuBackend};
use bearing_sweep::bearing::finite::{FiniteGrid, FiniteJob, FiniteSettings};
use bearing_sweep::bearing::{pack_state, BearingParams, BearingState, FilmModel};

/// States of the benchmark's set (ε 0.1-0.9, half tilted, a third whirling or
/// squeezing): enough that the ladder stops on different grids.
const N_STATES: usize = 8;

fn paper(finite: FiniteSettings) -> BearingParams {
    BearingParams {
        model: FilmModel::Finite,
        finite,
        ..BearingParams::paper_table2()
    }
}

/// Loads, reports and fields of `states` on `backend` at the bearing's grid, the fields
/// read back or not.
fn solve(
    backend: &mut GpuBackend,
    p: &BearingParams,
    states: &[BearingState],
    fields_wanted: bool,
) -> common::FiniteSolved {
    let jobs: Vec<FiniteJob> = states
        .iter()
        .map(|s| FiniteJob::of_state(p, &pack_state(p, s).unwrap(), s.omega))
        .collect();
    let grid = FiniteGrid::for_bearing(p);
    let mut fields = vec![Vec::new(); jobs.len()];
    let (mut out, mut reports) = (Vec::new(), Vec::new());
    backend
        .integrate_finite_with(
            &jobs,
            &grid,
            &mut fields,
            fields_wanted,
            &mut out,
            &mut reports,
        )
        .expect("the finite-film solve runs");
    (out, reports, fields)
}

/// Loads and reports of `got` equal `want`'s bit for bit; fields too if `fields`.
fn assert_same(label: &str, got: &common::FiniteSolved, want: &common::FiniteSolved, fields: bool) {
    assert_eq!(got.0.len(), want.0.len(), "{label}: states");
    for k in 0..want.0.len() {
        for q in 0..4 {
            assert_eq!(
                got.0[k][q].to_bits(),
                want.0[k][q].to_bits(),
                "{label}: state {k}, load {q}: {:e}, expected {:e} (bit for bit)",
                got.0[k][q],
                want.0[k][q]
            );
        }
        // The report's Debug form: every float in its shortest round-trip form, so equal
        // strings are equal bits.
        assert_eq!(
            format!("{:?}", got.1[k]),
            format!("{:?}", want.1[k]),
            "{label}: state {k}: report"
        );
        if fields {
            assert_eq!(got.2[k].len(), want.2[k].len(), "{label}: state {k}: field");
            if let Some(i) = (0..want.2[k].len()).find(|&i| got.2[k][i] != want.2[k][i]) {
                panic!(
                    "{label}: state {k}: field node {i}: {:e}, expected {:e} (bit for bit)",
                    got.2[k][i], want.2[k][i]
                );
            }
        }
    }
}

#[test]
fn skipping_the_read_back_and_splitting_a_call_change_no_result() {
    for v in [
        "BEARING_SWEEP_MG_SCRATCH_MIB",
        "BEARING_SWEEP_MG_TIERED",
        "BEARING_SWEEP_MG_COUNT",
    ] {
        std::env::remove_var(v);
    }
    let Some(mut backend) = common::gpu_f64_or_skip("finite-film host-side GPU") else {
        return;
    };
    let (_, states) = bearing_sweep::bench::finite::bench_states(N_STATES);
    let accuracy = paper(FiniteSettings {
        accuracy: 5e-4,
        ..FiniteSettings::default()
    });

    // No read-back: PSOR kernel (64 × 16), multigrid kernel (128 × 32), the ladder.
    let cases = [
        ("explicit 64×16", paper(FiniteSettings::with_grid(64, 16))),
        ("explicit 128×32", paper(FiniteSettings::with_grid(128, 32))),
        ("accuracy 5e-4", accuracy),
    ];
    for (label, p) in &cases {
        let with = solve(&mut backend, p, &states, true);
        let without = solve(&mut backend, p, &states, false);
        assert_same(&format!("{label}, no read-back"), &without, &with, false);
        for k in 0..states.len() {
            assert!(
                !with.2[k].is_empty() && without.2[k].is_empty(),
                "{label}: state {k}: field of {} values read back, {} without",
                with.2[k].len(),
                without.2[k].len()
            );
        }
    }

    // One chunk: the whole ladder of 8 states (~12.4 MB each) within lavapipe's 128 MiB
    // binding and the default budget.
    let one = solve(&mut backend, &accuracy, &states, true);
    // Chunks of 2 states (30 MiB).
    std::env::set_var("BEARING_SWEEP_MG_TIERED", "0");
    std::env::set_var("BEARING_SWEEP_MG_SCRATCH_MIB", "30");
    let chunks = solve(&mut backend, &accuracy, &states, true);
    assert_same("chunks of 2 states", &chunks, &one, true);
    // Passes: 2 MiB holds the 8 states' ladder up to 128 × 16 (~206 KB each), the states
    // that need more run again (on the whole ladder, in chunks of one: 256 × 32 needs
    // ~0.8 MB a state). The kernel's tally (one row per
    // state solved) counts the reruns: some, or the second pass went untested.
    std::env::set_var("BEARING_SWEEP_MG_TIERED", "1");
    std::env::set_var("BEARING_SWEEP_MG_SCRATCH_MIB", "2");
    std::env::set_var("BEARING_SWEEP_MG_COUNT", "1");
    let _ = take_mg_tally();
    let passes = solve(&mut backend, &accuracy, &states, true);
    let solved = take_mg_tally().1.len();
    std::env::remove_var("BEARING_SWEEP_MG_COUNT");
    std::env::remove_var("BEARING_SWEEP_MG_TIERED");
    std::env::remove_var("BEARING_SWEEP_MG_SCRATCH_MIB");
    assert_same("passes", &passes, &one, true);
    let above: Vec<u32> = one.1.iter().map(|r| r.n_theta).collect();
    assert!(
        solved > N_STATES && solved < 2 * N_STATES,
        "passes: {solved} states solved for {N_STATES} (expected some, not all, run \
         again; last grids {above:?})"
    );
}
