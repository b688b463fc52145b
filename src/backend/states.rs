//! Deterministic bearing states for benchmarks and tests: reproducible from a seed, spread
//! over aligned, tilted, squeezed and reversed-spin journals.

use super::LoadRequest;
use crate::bearing::{BearingParams, BearingState};

/// Deterministic benchmark states in the paper's Table 2 bearing: a fifth aligned, the
/// rest tilted; a quarter without spin (squeeze only), a quarter with negative spin; end
/// eccentricity ratios up to `max_ratio`. The first state is a tilted one with positive
/// spin (the batch of one is a typical state).
pub fn bench_states(n: usize, max_ratio: f64, seed: u64) -> (BearingParams, Vec<LoadRequest>) {
    let b = BearingParams::paper_table2();
    let d = b.clearance;
    let mut x = seed;
    let mut uniform = move || {
        // 64-bit LCG, top 53 bits.
        x = x
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (x >> 11) as f64 / (1u64 << 53) as f64
    };
    let tau = std::f64::consts::TAU;
    let requests = (0..n)
        .map(|k| {
            let aligned = k % 5 == 4;
            let ei = max_ratio * uniform().sqrt();
            let ej = if aligned {
                ei
            } else {
                max_ratio * uniform().sqrt()
            };
            let ai = tau * uniform();
            let aj = if aligned { ai } else { tau * uniform() };
            let spin = 10.0 + 990.0 * uniform();
            let omega = match k % 4 {
                3 => 0.0,
                1 => -spin,
                _ => spin,
            };
            // Velocities up to clearance × 300 1/s, comparable with the spin term.
            let mut v = || (2.0 * uniform() - 1.0) * d * 300.0;
            let (vxi, vyi) = (v(), v());
            let (vxj, vyj) = if aligned { (vxi, vyi) } else { (v(), v()) };
            LoadRequest {
                bearing: 0,
                state: BearingState {
                    xi: ei * d * ai.cos(),
                    yi: ei * d * ai.sin(),
                    xj: ej * d * aj.cos(),
                    yj: ej * d * aj.sin(),
                    vxi,
                    vyi,
                    vxj,
                    vyj,
                    omega,
                },
            }
        })
        .collect();
    (b, requests)
}
