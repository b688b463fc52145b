//! Cost probe of the finite-film solvers (BENCHMARKS.md "Issue 20: multigrid cost"):
//! one thread, cold starts, the 32 states of the finite benchmark, fixed grids with the
//! default settings (max-film inlet, tolerance 1e-8); PSOR and multigrid per state, the
//! minimum over `reps` repetitions (the machine is shared), counted work (sweeps of the
//! grid) and the largest relative difference of the load vectors (same discrete problem).
//!
//! Then the default accuracy mode (multigrid ladder) and accuracy 1e-4 against the 64 × 16
//! PSOR state (the default before issue 20): ms/state, node updates/state
//! (machine-independent work) and the median and largest error of the load vector against
//! the converged solution ([`FiniteSolver::reference`]: the accuracy ladder's 1024 × 128
//! Richardson-extrapolated from 512 × 64).
//!
//! `cargo run --release --example mg_cost -- [reps] [accuracy]` (`accuracy`: only the
//! second table, e.g. under `valgrind --tool=callgrind` for counted instructions).
//!
//! `cargo run --release --example mg_cost -- prof psor|mg N_THETA N_Z [reps [tolerance]]` and
//! `... -- prof acc ACCURACY [reps [tolerance]]`: one solver on one setting only (the 32 states, cold
//! starts), its node updates per state and wall per state and per node update: the run to
//! put under `valgrind --tool=callgrind` (instructions per state and where they go).
//!
//! `MG_CYCLE=lines,2,0` (or `points,PRE,POST`): the multigrid's V-cycle on explicit grids
//! (default `points,2,1`; issue 20, session 37).
//!
//! `cargo run --release --example mg_cost -- check`: checksums of the multigrid's outputs
//! to the last bit, to compare two builds (see `check`).
use std::time::Instant;

use bearing_sweep::bearing::finite::{FiniteGrid, FiniteJob, FiniteSettings, FiniteSolver};
use bearing_sweep::bearing::{finish_loads, pack_state};
use bearing_sweep::bench::finite::{bench_states, mg_cycle_from_env};

/// `prof`: one solver, one setting (see the module doc).
fn prof(args: &[String]) {
    let (p, states) = bench_states(32);
    let jobs: Vec<_> = states
        .iter()
        .map(|s| {
            let packed = pack_state(&p, s).expect("valid state");
            FiniteJob::new(&p, &packed)
        })
        .collect();
    let method = args.first().map(String::as_str).unwrap_or("mg");
    let num = |k: usize, d: f64| args.get(k).and_then(|s| s.parse().ok()).unwrap_or(d);
    let (g, reps) = if method == "acc" {
        let settings = FiniteSettings {
            accuracy: num(1, FiniteSettings::default().accuracy),
            tolerance: num(3, FiniteSettings::default().tolerance),
            ..FiniteSettings::default()
        };
        (FiniteGrid::from(&settings), num(2, 1.0) as usize)
    } else {
        let (t, z) = (num(1, 128.0) as u32, num(2, 32.0) as u32);
        let settings = FiniteSettings {
            tolerance: num(4, 1e-8),
            ..FiniteSettings::with_grid(t, z)
        };
        (FiniteGrid::from(&settings), num(3, 1.0) as usize)
    };
    let mut solver = FiniteSolver::new();
    solver.cycle = mg_cycle_from_env();
    let mut best = f64::INFINITY;
    let mut updates = 0u64;
    for _ in 0..reps.max(1) {
        updates = 0;
        let start = Instant::now();
        for job in &jobs {
            let (_, r) = if method == "psor" {
                solver.solve_psor(job, &g, &mut Vec::new())
            } else {
                solver.solve(job, &g, &mut Vec::new())
            };
            updates += r.sweeps as u64 * (r.n_theta as u64 * (r.n_z as u64 - 1));
        }
        best = best.min(start.elapsed().as_secs_f64());
    }
    let n = jobs.len() as f64;
    println!(
        "{method} {:?}: {:.0} node updates/state, {:.3} ms/state, {:.2} ns/update",
        args.get(1..).unwrap_or(&[]),
        updates as f64 / n,
        best / n * 1e3,
        best / updates as f64 * 1e9
    );
}

/// `check`: bit-level checksums of the multigrid paths over the 32 states (explicit
/// grids cold and warm, the accuracy ladder at three accuracies, the rectangle ladder,
/// two grooves on both, the converged reference): the sums of the load vectors and of
/// the error estimates, printed to the last bit, to compare two builds (issue 20,
/// session 36: the set-up changes keep every output).
fn check() {
    use bearing_sweep::bearing::{Groove, Grooves};
    let (p, states) = bench_states(32);
    let groove = |angle: f64| Groove {
        angle,
        width: 20.0,
        supply_pressure: 0.0,
        length: None,
    };
    let grooved = bearing_sweep::bearing::BearingParams {
        grooves: Grooves::new(&[groove(0.0), groove(180.0)]).expect("two grooves"),
        ..p
    };
    let explicit = |t, z| FiniteSettings::with_grid(t, z);
    let accuracy = |a| FiniteSettings {
        accuracy: a,
        ..FiniteSettings::default()
    };
    let cases: Vec<(
        &str,
        &bearing_sweep::bearing::BearingParams,
        FiniteSettings,
        bool,
    )> = vec![
        ("mg 64x16", &p, explicit(64, 16), false),
        ("mg 128x32", &p, explicit(128, 32), false),
        ("acc 2e-3", &p, accuracy(2e-3), false),
        ("acc 5e-4", &p, accuracy(5e-4), false),
        ("acc 1e-4", &p, accuracy(1e-4), false),
        ("acc 5e-4 rectangle ladder", &p, accuracy(5e-4), true),
        ("grooves mg 64x16", &grooved, explicit(64, 16), false),
        ("grooves acc 5e-4", &grooved, accuracy(5e-4), false),
    ];
    for (label, params, settings, rectangle) in cases {
        let mut g = FiniteGrid::from(&settings);
        g.layout = FiniteGrid::for_bearing(params).layout;
        let mut solver = FiniteSolver::new();
        solver.cycle = mg_cycle_from_env();
        solver.rectangle_ladder = rectangle;
        let (mut loads, mut est, mut warm) = ([0.0; 4], 0.0, [0.0; 4]);
        for s in &states {
            let job = FiniteJob::new(params, &pack_state(params, s).expect("valid state"));
            let mut field = Vec::new();
            let (v, r) = solver.solve(&job, &g, &mut field);
            // Warm start from its own field (explicit grids read it).
            let (w, _) = solver.solve(&job, &g, &mut field);
            for k in 0..4 {
                loads[k] += v[k];
                warm[k] += w[k];
            }
            est += r.error_estimate + r.iteration_error;
        }
        println!("{label}: loads {loads:?} warm {warm:?} estimates {est:?}");
    }
    let mut solver = FiniteSolver::new();
    solver.cycle = mg_cycle_from_env();
    let g = FiniteGrid::for_bearing(&p);
    let mut sum = [0.0; 4];
    for s in states.iter().step_by(8) {
        let job = FiniteJob::new(&p, &pack_state(&p, s).expect("valid state"));
        let v = solver.reference(&job, &g);
        for k in 0..4 {
            sum[k] += v[k];
        }
    }
    println!("reference (4 states): {sum:?}");
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("prof") {
        prof(&args[1..]);
        return;
    }
    if args.first().map(String::as_str) == Some("check") {
        check();
        return;
    }
    let reps: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(5);
    let only_accuracy = std::env::args().nth(2).as_deref() == Some("accuracy");
    let (p, states) = bench_states(32);
    let jobs: Vec<_> = states
        .iter()
        .map(|s| {
            let packed = pack_state(&p, s).expect("valid state");
            (FiniteJob::new(&p, &packed), packed.rate_scale, *s)
        })
        .collect();
    println!("| grid | PSOR sweeps | PSOR ms/state | multigrid work (sweeps) | multigrid ms/state | speed-up | max rel. difference |");
    println!("|---|---|---|---|---|---|---|");
    let fixed: &[(u32, u32)] = if only_accuracy {
        &[]
    } else {
        &[(32, 8), (64, 16), (128, 32), (256, 64)]
    };
    for &(t, z) in fixed {
        let g = FiniteGrid::from(&FiniteSettings::with_grid(t, z));
        let mut solver = FiniteSolver::new();
        solver.cycle = mg_cycle_from_env();
        let mut run = |psor: bool| {
            let mut best = f64::INFINITY;
            let mut sweeps = 0u64;
            let mut loads = Vec::new();
            for _ in 0..reps {
                sweeps = 0;
                loads.clear();
                let start = Instant::now();
                for (job, scale, s) in &jobs {
                    let (ints, r) = if psor {
                        solver.solve_psor(job, &g, &mut Vec::new())
                    } else {
                        solver.solve(job, &g, &mut Vec::new())
                    };
                    sweeps += r.sweeps as u64;
                    loads.push(finish_loads(&p, s, &ints, *scale).load_vector(p.length));
                }
                best = best.min(start.elapsed().as_secs_f64());
            }
            let n = jobs.len() as f64;
            (sweeps as f64 / n, best / n * 1e3, loads)
        };
        let a = run(true);
        let b = run(false);
        let diff =
            a.2.iter()
                .zip(&b.2)
                .map(|(x, y)| {
                    let d: f64 = (0..4).map(|k| (x[k] - y[k]).powi(2)).sum::<f64>().sqrt();
                    d / x.iter().map(|v| v * v).sum::<f64>().sqrt()
                })
                .fold(0.0, f64::max);
        println!(
            "| {t}×{z} | {:.0} | {:.3} | {:.0} | {:.3} | {:.2}× | {:.1e} |",
            a.0,
            a.1,
            b.0,
            b.1,
            a.1 / b.1,
            diff
        );
    }
    // Default accuracy against the old default (64 × 16 PSOR), errors against the
    // converged solution.
    let reference: Vec<[f64; 4]> = if only_accuracy {
        Vec::new()
    } else {
        let g = FiniteGrid::for_bearing(&p);
        jobs.iter()
            .map(|(job, scale, s)| {
                let ints = FiniteSolver::new().reference(job, &g);
                finish_loads(&p, s, &ints, *scale).load_vector(p.length)
            })
            .collect()
    };
    let mut solver = FiniteSolver::new();
    solver.cycle = mg_cycle_from_env();
    let mut time_it = |g: &FiniteGrid, psor: bool| {
        let mut best = f64::INFINITY;
        let mut updates = 0u64;
        let mut errs = Vec::new();
        for _ in 0..reps {
            updates = 0;
            errs.clear();
            let start = Instant::now();
            for (k, (job, scale, s)) in jobs.iter().enumerate() {
                let (ints, r) = if psor {
                    solver.solve_psor(job, g, &mut Vec::new())
                } else {
                    solver.solve(job, g, &mut Vec::new())
                };
                updates += r.sweeps as u64 * (r.n_theta as u64 * (r.n_z as u64 - 1));
                if let Some(want) = reference.get(k) {
                    let v = finish_loads(&p, s, &ints, *scale).load_vector(p.length);
                    let d: f64 = (0..4).map(|i| (v[i] - want[i]).powi(2)).sum::<f64>();
                    errs.push(d.sqrt() / want.iter().map(|x| x * x).sum::<f64>().sqrt());
                }
            }
            best = best.min(start.elapsed().as_secs_f64());
        }
        errs.sort_by(f64::total_cmp);
        let n = jobs.len() as f64;
        let (med, max) = if errs.is_empty() {
            (f64::NAN, f64::NAN)
        } else {
            (errs[errs.len() / 2], errs[errs.len() - 1])
        };
        (best / n * 1e3, updates as f64 / n, med, max)
    };
    let old = time_it(&FiniteGrid::from(&FiniteSettings::with_grid(64, 16)), true);
    println!();
    println!("| setting | ms/state | node updates/state | median error | max error |");
    println!("|---|---|---|---|---|");
    println!(
        "| 64×16 PSOR (old default) | {:.3} | {:.0} | {:.2e} | {:.2e} |",
        old.0, old.1, old.2, old.3
    );
    // The last two rows: each ladder grid stopped at accuracy/10 on the loads instead of
    // accuracy/50 (`tolerance` above accuracy/50 sets the per-grid stop; issue 20 item 3).
    let tol = FiniteSettings::default().tolerance;
    for (label, accuracy, tolerance) in [
        ("5e-4 (default)", FiniteSettings::default().accuracy, tol),
        ("1e-4", 1e-4, tol),
        ("5e-4, grids stopped at 5e-5", 5e-4, 5e-5),
        ("1e-4, grids stopped at 1e-5", 1e-4, 1e-5),
    ] {
        let acc = time_it(
            &FiniteGrid::from(&FiniteSettings {
                accuracy,
                tolerance,
                ..FiniteSettings::default()
            }),
            false,
        );
        println!(
            "| accuracy {label} multigrid | {:.3} | {:.0} | {:.2e} | {:.2e} |",
            acc.0, acc.1, acc.2, acc.3
        );
        println!(
            "| ratio to the old default | {:.1}× | {:.1}× | | |",
            acc.0 / old.0,
            acc.1 / old.1
        );
    }
}
