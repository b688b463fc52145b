//! Criterion benchmark of lockstep rotor steps: 16 variants of the paper example
//! (`sweeps/paper-example.json`, spins spread over 60-140 rad/s, film loads at the 1e-6
//! level on the CPU backend, one thread) advance together; every integration stage is one
//! batched evaluator call carrying all variants' bearing states.
//!
//! - `rk4_10_steps`: classical RK4 at the fixed step 1e-4 s for 1 ms (10 steps, 40 stage
//!   calls). Error: the same step over 0.5 s keeps `G` within 1.4e-12 m of the reference
//!   (dopri5 at rtol = atol = 1e-13; BENCHMARKS.md "Rotor integration"), so over these 10
//!   steps the error is at most that.
//! - `dopri5_5ms`: Dormand-Prince 5(4) at the scene default rtol = atol = 1e-6 for 5 ms
//!   from centred journals (the start of the transient). Error: over 0.5 s it keeps `G`
//!   within 1.4e-10 m of the same reference, the largest deviation sitting in the
//!   transient (BENCHMARKS.md).
//!
//! The load evaluations per iteration are printed when the bench starts (they are
//! deterministic; time per load evaluation = time / evaluations). Run:
//! `cargo bench --bench rotor_step` (compile only: `cargo bench --no-run`).

use bearing_sweep::backend::{CpuBackend, LoadEvaluator};
use bearing_sweep::bearing::Accuracy;
use bearing_sweep::integrate::Method;
use bearing_sweep::rotor::{load_scene, simulate_batch, Scene};
use criterion::Criterion;

/// Variants per lockstep batch.
const VARIANTS: usize = 16;

fn scenes(method: Method, t_end: f64) -> Vec<Scene> {
    let base = load_scene(include_str!("../sweeps/paper-example.json"))
        .expect("the example scene loads")
        .remove(0);
    (0..VARIANTS)
        .map(|k| {
            let mut s = base.clone();
            s.name = format!("v{k}");
            // Spins 60..140 rad/s around the paper's 100.
            s.initial.spin = 60.0 + 80.0 * k as f64 / (VARIANTS - 1) as f64;
            s.integrator.method = method;
            s.integrator.t_end = t_end;
            if method == Method::Rk4 {
                // 1e-4 s: the coarsest stable RK4 step of the rotor study.
                s.integrator.fixed_step = Some(1e-4);
            }
            s
        })
        .collect()
}

fn run(scenes: &[Scene]) -> u64 {
    let mut ev = LoadEvaluator::new(Box::new(CpuBackend::new(Accuracy::default(), Some(1))));
    let r = simulate_batch(scenes, &mut ev, &mut |_, _| {});
    r.iter().map(|x| x.stats.load_evaluations).sum()
}

fn main() {
    let cases = [
        ("rk4_10_steps", scenes(Method::Rk4, 1e-3)),
        ("dopri5_5ms", scenes(Method::Dopri5, 5e-3)),
    ];
    for (name, s) in &cases {
        eprintln!(
            "{name}: {VARIANTS} variants, {} load evaluations per iteration",
            run(s)
        );
    }
    let mut c = Criterion::default().configure_from_args();
    let mut group = c.benchmark_group("rotor_lockstep_16");
    for (name, s) in &cases {
        group.bench_function(*name, |b| b.iter(|| run(s)));
    }
    group.finish();
    c.final_summary();
}
