//! The multigrid's lanes on the instruction set that is faster on this CPU, chosen once per
//! process by timing a few cold solves on each (issue 20, session 41).
//!
//! AVX-512F is not always faster than AVX2 for these passes: the rows' chunks are short and
//! held nodes take selects, and some CPUs run 512-bit vectors on 256-bit units. Measured on
//! two hosts of the same 2-core AMD EPYC VM type (BENCHMARKS.md, issue 20, sessions 39 and
//! 40): AVX-512 13 % faster on one (session 39's passes), AVX2 3 % faster on the other
//! (session 40's). Both give the same bits ([`super::lanes`]), so the choice changes only
//! the time.

use std::time::{Duration, Instant};

use super::lanes::on_isa;
use super::{FiniteGrid, FiniteJob, FiniteSettings, FiniteSolver};
use crate::bearing::{pack_state, BearingParams, BearingState, LaneIsa};

/// Rounds of the timing: each round times every candidate once, in turn, and the fastest
/// round per candidate counts (the minimum is what an interruption cannot raise).
const ROUNDS: usize = 3;

/// Grid of the timed solves, intervals `θ × z`: the grid of issue 20's "10× PSOR" goal,
/// whose passes have the default accuracy's row lengths and longer.
const GRID: (u32, u32) = (128, 32);

/// Relative iteration tolerance of the timed solves: looser than the default so that the
/// calibration costs a few milliseconds (about 15 V-cycles of work per solve), with every
/// pass the same as in any solve.
const TOLERANCE: f64 = 1e-5;

/// Of AVX-512F and AVX2 (the CPU has both), the one whose timed solves took less: the
/// smallest over [`ROUNDS`] of cold solves of three states of the paper's bearing on
/// [`GRID`] (aligned and tilted, ε 0.5-0.9). AVX-512F on a tie or where a solve fails.
pub(super) fn faster() -> LaneIsa {
    let Some(jobs) = jobs() else {
        return LaneIsa::Avx512;
    };
    let grid = grid();
    let candidates = [LaneIsa::Avx512, LaneIsa::Avx2];
    let mut best = [Duration::MAX; 2];
    let mut solver = FiniteSolver::new();
    let mut field = Vec::new();
    for _ in 0..ROUNDS {
        for (k, &isa) in candidates.iter().enumerate() {
            let start = Instant::now();
            on_isa(isa, || {
                for job in &jobs {
                    solver.solve(job, &grid, &mut field);
                }
            });
            best[k] = best[k].min(start.elapsed());
        }
    }
    if best[1] < best[0] {
        LaneIsa::Avx2
    } else {
        LaneIsa::Avx512
    }
}

/// The timed solves' grid: [`GRID`] at [`TOLERANCE`].
fn grid() -> FiniteGrid {
    FiniteGrid::from(&FiniteSettings {
        tolerance: TOLERANCE,
        ..FiniteSettings::with_grid(GRID.0, GRID.1)
    })
}

/// The timed states (the paper's bearing at 100 rad/s, eccentricities as fractions of the
/// clearance): aligned at ε 0.5, tilted 0.8 → 0.6 squeezing, aligned at 0.9 whirling.
fn jobs() -> Option<Vec<FiniteJob>> {
    let p = BearingParams::paper_table2();
    let d = p.clearance;
    let spin = 100.0; // rad/s
    let states = [
        (0.5, 0.0, 0.5, 0.0, 0.0, 0.0),
        (0.0, 0.8, 0.0, 0.6, 0.0, -0.03),
        (0.6, -0.67, 0.6, -0.67, 0.02, 0.0),
    ];
    states
        .iter()
        .map(|&(xi, yi, xj, yj, vx, vy)| {
            let s = BearingState {
                xi: xi * d,
                yi: yi * d,
                xj: xj * d,
                yj: yj * d,
                vxi: vx * d * spin,
                vyi: vy * d * spin,
                vxj: vx * d * spin,
                vyj: vy * d * spin,
                omega: spin,
            };
            pack_state(&p, &s)
                .ok()
                .map(|packed| FiniteJob::new(&p, &packed))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The calibration's states are valid (a failed pack would leave AVX-512F chosen
    /// without a measurement), and on a CPU with both instruction sets it picks one of
    /// them and its solves under either give the same loads bit for bit (the premise of
    /// choosing by time alone).
    #[test]
    fn calibration_states_are_valid_and_either_choice_gives_the_same_bits() {
        let jobs = jobs().expect("the calibration's states pack");
        assert_eq!(jobs.len(), 3);
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx512f") {
            let chosen = faster();
            assert!(
                matches!(chosen, LaneIsa::Avx512 | LaneIsa::Avx2),
                "{chosen:?}"
            );
            let grid = grid();
            for (k, job) in jobs.iter().enumerate() {
                let loads = |isa| {
                    on_isa(isa, || {
                        FiniteSolver::new()
                            .solve(job, &grid, &mut Vec::new())
                            .0
                            .map(f64::to_bits)
                    })
                };
                assert_eq!(loads(LaneIsa::Avx512), loads(LaneIsa::Avx2), "state {k}");
            }
        } else {
            eprintln!("calibration: no AVX-512F on this CPU, nothing to choose");
        }
    }
}
