//! The evaluator's deduplication of large calls (issue 26 item 2: a lean host path): calls
//! of at least `PARALLEL_HOST_STATES` requests find identical film states in parallel (hash,
//! sort, compare runs) instead of inserting every key into one map. Loads must be those of
//! the call without deduplication bit for bit, every repeat must be counted, a state that
//! differs by 1e-12 must stay apart, and +0 / -0 must count as one state, as in the
//! serial map of smaller calls.

use bearing_sweep::backend::{
    bench_states, CpuBackend, EvaluatorOptions, LoadEvaluator, LoadRequest, PARALLEL_HOST_STATES,
};
use bearing_sweep::bearing::{Accuracy, BearingParams};

/// `distinct` benchmark states, each repeated `1 + k % 3` times, interleaved (a
/// repeat's first occurrence is not where the run of its copies starts), with one state
/// that differs from another by 1e-12 and one with a -0 velocity where its twin has +0.
fn requests(distinct: usize) -> (BearingParams, Vec<LoadRequest>, u64) {
    let (bearing, base) = bench_states(distinct, 0.95, 29);
    let mut reqs: Vec<LoadRequest> = Vec::new();
    let mut repeats = 0u64;
    for round in 0..3 {
        for (k, r) in base.iter().enumerate() {
            if round <= k % 3 {
                if round > 0 {
                    repeats += 1;
                }
                reqs.push(*r);
            }
        }
    }
    // 1e-12 apart: a distinct film state (not a repeat). (One ulp of the request can
    // vanish in the division by the clearance that packs it.)
    let mut near = base[1];
    near.state.xi *= 1.0 + 1e-12;
    reqs.push(near);
    // +0 and -0 velocities: the same kernel input, so a repeat.
    let mut plus = base[2];
    plus.state.vxi = 0.0;
    let mut minus = plus;
    minus.state.vxi = -0.0;
    reqs.push(plus);
    reqs.push(minus);
    repeats += 1;
    // A centre on the x axis at +0 and at -0 (and so its y velocity): packed components
    // of +0 and -0 (`ecc[1]`, `rate[1]`), the same integrals, so a repeat (the key maps
    // both zeros to one).
    let mut on_axis = base[3];
    on_axis.state.yi = 0.0;
    on_axis.state.vxi = 0.0;
    let mut on_axis_minus = on_axis;
    on_axis_minus.state.yi = -0.0;
    on_axis_minus.state.vxi = -0.0;
    reqs.push(on_axis);
    reqs.push(on_axis_minus);
    repeats += 1;
    (bearing, reqs, repeats)
}

fn run(bearing: &BearingParams, reqs: &[LoadRequest], dedupe: bool) -> (Vec<String>, u64, u64) {
    let options = EvaluatorOptions {
        dedupe,
        ..EvaluatorOptions::default()
    };
    let mut ev = LoadEvaluator::with_options(
        Box::new(CpuBackend::new(Accuracy::default(), Some(2))),
        options,
    );
    let mut out = Vec::new();
    ev.evaluate(std::slice::from_ref(bearing), reqs, &mut out);
    // Bit patterns, so that equality is exact.
    let bits = out.iter().map(|r| format!("{r:?}")).collect();
    (bits, ev.stats().deduplicated, ev.stats().integrated)
}

fn check(distinct: usize) {
    let (bearing, reqs, repeats) = requests(distinct);
    let (with, dup, integrated) = run(&bearing, &reqs, true);
    let (without, dup0, integrated0) = run(&bearing, &reqs, false);
    assert_eq!(dup0, 0);
    assert_eq!(integrated0, reqs.len() as u64);
    assert_eq!(
        dup,
        repeats,
        "{} requests: repeats counted {dup}, expected {repeats}",
        reqs.len()
    );
    assert_eq!(integrated + dup, reqs.len() as u64);
    for (k, (a, b)) in with.iter().zip(&without).enumerate() {
        assert_eq!(
            a, b,
            "request {k}: deduplicated {a} vs integrated alone {b}"
        );
    }
}

#[test]
fn large_calls_deduplicate_in_parallel_exactly() {
    // ~2 requests per distinct state: well above the parallel threshold.
    let distinct = PARALLEL_HOST_STATES * 3 / 2;
    let (_, reqs, _) = requests(distinct);
    assert!(reqs.len() >= PARALLEL_HOST_STATES);
    check(distinct);
}

#[test]
fn small_calls_deduplicate_the_same_way() {
    let distinct = 600;
    let (_, reqs, _) = requests(distinct);
    assert!(reqs.len() < PARALLEL_HOST_STATES);
    check(distinct);
}
