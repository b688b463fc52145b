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
//! - `radau5_5ms`: Radau IIA 5 at rtol = atol = 1e-6 for the same 5 ms (finite-difference
//!   Jacobians, `36 x 36` Newton LU per variant). Error: over 0.5 s radau5 at 1e-6 keeps
//!   `G` within 3.3e-10 m of the reference (BENCHMARKS.md "Rotor integration").
//!
//! A second group, `radau_newton_16`, isolates the implicit method's linear algebra: 16
//! variants of six weakly coupled stiff Van der Pol oscillators (dimension 12, like the
//! rotor state; `eps` 1e-3..1e-2) whose right-hand side costs nanoseconds, so the time is
//! the Newton matrices' LU factorisations and solves plus the step logic. Its error
//! against radau5 at rtol = atol = 1e-12 is printed when the bench starts.
//!
//! The load evaluations per iteration are printed when the bench starts (they are
//! deterministic; time per load evaluation = time / evaluations). Run:
//! `cargo bench --bench rotor_step` (compile only: `cargo bench --no-run`).

use bearing_sweep::backend::{CpuBackend, LoadEvaluator};
use bearing_sweep::bearing::Accuracy;
use bearing_sweep::integrate::{run_batch, BatchSystem, Method, Settings, Stats, Status};
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

/// Oscillators per Van der Pol variant (state dimension `2 * OSC`).
const OSC: usize = 6;
/// Coupling of neighbouring oscillators' positions (weak: the stiffness stays `1/eps`).
const COUPLING: f64 = 0.1;
/// End time of the Van der Pol runs (the initial fast transient and the slow drift after it).
const VDP_T_END: f64 = 0.1;

/// Coupled stiff Van der Pol oscillators `x' = y`, `eps y' = (1 - x²) y - x + c (x⁺ - x)`
/// per variant, `eps` per variant; the last state of every variant is kept.
struct VanDerPol {
    eps: Vec<f64>,
    last: Vec<[f64; 2 * OSC]>,
}

impl BatchSystem for VanDerPol {
    type Fault = ();
    fn dim(&self) -> usize {
        2 * OSC
    }
    fn eval(
        &mut self,
        ids: &[usize],
        _ts: &[f64],
        ys: &[f64],
        dys: &mut [f64],
        _faults: &mut [Option<()>],
    ) {
        let d = 2 * OSC;
        for (k, &id) in ids.iter().enumerate() {
            let (y, dy) = (&ys[k * d..(k + 1) * d], &mut dys[k * d..(k + 1) * d]);
            for o in 0..OSC {
                let (x, v) = (y[2 * o], y[2 * o + 1]);
                let next = y[2 * ((o + 1) % OSC)];
                dy[2 * o] = v;
                dy[2 * o + 1] = ((1.0 - x * x) * v - x + COUPLING * (next - x)) / self.eps[id];
            }
        }
    }
    fn record(&mut self, ids: &[usize], _ts: &[f64], ys: &[f64]) {
        let d = 2 * OSC;
        for (k, &id) in ids.iter().enumerate() {
            self.last[id].copy_from_slice(&ys[k * d..(k + 1) * d]);
        }
    }
    fn finished(&mut self, id: usize, status: &Status<()>, _stats: &Stats) {
        assert_eq!(*status, Status::Finished, "Van der Pol variant {id}");
    }
}

/// Runs the Van der Pol batch with radau5 at `tol`; returns the end states and the LU
/// factorisations done.
fn van_der_pol(tol: f64) -> (Vec<[f64; 2 * OSC]>, u64) {
    let eps: Vec<f64> = (0..VARIANTS)
        .map(|k| 1e-3 * 10f64.powf(k as f64 / (VARIANTS - 1) as f64))
        .collect();
    let mut y0 = Vec::with_capacity(VARIANTS * 2 * OSC);
    for _ in 0..VARIANTS {
        for o in 0..OSC {
            // Spread initial phases: x from 2 down, v = 0.
            y0.extend([2.0 - 0.5 * o as f64, 0.0]);
        }
    }
    let settings = Settings {
        t_end: VDP_T_END,
        sample_interval: VDP_T_END,
        rtol: tol,
        atol: tol,
        ..Settings::default()
    };
    let mut sys = VanDerPol {
        last: vec![[0.0; 2 * OSC]; VARIANTS],
        eps,
    };
    let out = run_batch(Method::Radau5, &mut sys, &y0, &vec![settings; VARIANTS]);
    (sys.last, out.iter().map(|(_, s)| s.factorizations).sum())
}

fn main() {
    let cases = [
        ("rk4_10_steps", scenes(Method::Rk4, 1e-3)),
        ("dopri5_5ms", scenes(Method::Dopri5, 5e-3)),
        ("radau5_5ms", scenes(Method::Radau5, 5e-3)),
    ];
    let (reference, _) = van_der_pol(1e-12);
    let (end, lus) = van_der_pol(1e-6);
    let err = end
        .iter()
        .zip(&reference)
        .flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| (x - y).abs()))
        .fold(0.0, f64::max);
    eprintln!(
        "van_der_pol_radau5: {VARIANTS} variants, {lus} LU factorisations per iteration, \
         max end-state error {err:.2e} against radau5 at 1e-12"
    );
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
    let mut group = c.benchmark_group("radau_newton_16");
    group.bench_function("van_der_pol_radau5", |b| b.iter(|| van_der_pol(1e-6).1));
    group.finish();
    c.final_summary();
}
