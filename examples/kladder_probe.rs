//! Probe of the multigrid kernel's accuracy ladder against the CPU's (issue 20, session 37:
//! the kernel's ladder follows `LadderRule`): the finite benchmark's states at one accuracy
//! on the WGSL kernel (shaders/finite_mg.wgsl, any f64 adapter: lavapipe here), the CPU
//! solver with its rule ([`LadderRule::default`]) and with the rule before session 36
//! (every grid to accuracy/10 from the bilinear start), and the converged reference
//! ([`FiniteSolver::reference`]).
//!
//! `cargo run --release --example kladder_probe -- ACCURACY [states] [--each]`
//! (defaults 5e-4, 32 states). Per setting: node updates per state counted as the report's
//! whole sweeps of the final grid times its interior nodes (what the kernel reports; the
//! CPU's exact count from its ladder trace beside it), median / mean / largest; the final
//! grids; the largest true error and the estimate over the true error; the largest
//! difference of the GPU's load vector from the CPU's over the CPU's estimate. `--each`:
//! one line per state.

use bearing_sweep::backend::{FilmBackend, GpuBackend, GpuOptions, Precision};
use bearing_sweep::bearing::finite::{
    FiniteGrid, FiniteJob, FiniteSettings, FiniteSolver, LadderRule, SolveReport,
};
use bearing_sweep::bearing::{finish_loads, pack_state, Accuracy, BearingParams, FilmModel};
use bearing_sweep::bench::finite::bench_states;

fn rel(a: &[f64; 4], b: &[f64; 4]) -> f64 {
    let d: f64 = (0..4).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt();
    d / b.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// Node updates of a report counted as whole sweeps of its final grid.
fn whole(r: &SolveReport) -> u64 {
    r.sweeps as u64 * r.n_theta as u64 * (r.n_z as u64 - 1)
}

/// Median, mean and largest of `v`.
fn stats(v: &[u64]) -> String {
    let mut s = v.to_vec();
    s.sort_unstable();
    let mean = s.iter().sum::<u64>() as f64 / s.len() as f64;
    format!(
        "{} / {:.0} / {}",
        s[s.len() / 2],
        mean,
        s.last().copied().unwrap_or(0)
    )
}

/// Final grids and how many states end on each, as `128×16: 19, …`.
fn grids(r: &[SolveReport]) -> String {
    let mut g: Vec<(u32, u32, usize)> = Vec::new();
    for x in r {
        match g.iter_mut().find(|e| (e.0, e.1) == (x.n_theta, x.n_z)) {
            Some(e) => e.2 += 1,
            None => g.push((x.n_theta, x.n_z, 1)),
        }
    }
    g.sort_unstable();
    g.iter()
        .map(|(t, z, n)| format!("{t}×{z}: {n}"))
        .collect::<Vec<_>>()
        .join(", ")
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let accuracy: f64 = args.first().and_then(|s| s.parse().ok()).unwrap_or(5e-4);
    let n: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(32);
    let each = args.iter().any(|a| a == "--each");
    let options = GpuOptions {
        precision: Some(Precision::F64),
        ..GpuOptions::default()
    };
    let mut backend = match GpuBackend::new(Accuracy::default(), options) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("no f64 GPU adapter: {e}");
            return;
        }
    };
    let (p0, states) = bench_states(n);
    let p = BearingParams {
        model: FilmModel::Finite,
        finite: FiniteSettings {
            accuracy,
            ..FiniteSettings::default()
        },
        ..p0
    };
    let packed: Vec<_> = states
        .iter()
        .map(|s| pack_state(&p, s).expect("valid state"))
        .collect();
    let jobs: Vec<FiniteJob> = packed
        .iter()
        .zip(&states)
        .map(|(pk, s)| FiniteJob::of_state(&p, pk, s.omega))
        .collect();
    let g = FiniteGrid::for_bearing(&p);
    let load = |k: usize, ints: &[f64; 4]| {
        finish_loads(&p, &states[k], ints, packed[k].rate_scale).load_vector(p.length)
    };
    let t = std::time::Instant::now();
    let mut fields = vec![Vec::new(); jobs.len()];
    let (mut out, mut reports) = (Vec::new(), Vec::new());
    backend
        .integrate_finite(&jobs, &g, &mut fields, &mut out, &mut reports)
        .expect("the multigrid kernel runs");
    let gpu_s = t.elapsed().as_secs_f64();
    let mut solver = FiniteSolver::new();
    let old = LadderRule {
        loose: 0.0,
        cubic_start: false,
        // The crate's ALGEBRAIC_FRACTION (crate-private): the rule before session 36.
        floor: 0.1,
        // The V(2,1) cycle of before session 42.
        post: 1,
        measured_last: false,
    };
    let (mut cpu, mut cpu_exact, mut cpu_old) = (Vec::new(), Vec::new(), Vec::new());
    let (mut cpu_out, mut old_out) = (Vec::new(), Vec::new());
    for job in &jobs {
        solver.ladder_rule = LadderRule::default();
        let (v, r) = solver.solve(job, &g, &mut Vec::new());
        cpu_exact.push(solver.trace.last().map_or(0, |s| s.updates));
        cpu.push(r);
        cpu_out.push(v);
        solver.ladder_rule = old;
        let (v, r) = solver.solve(job, &g, &mut Vec::new());
        cpu_old.push(r);
        old_out.push(v);
    }
    use rayon::prelude::*;
    let reference: Vec<[f64; 4]> = (0..jobs.len())
        .into_par_iter()
        .map(|k| {
            let job = FiniteJob::new(&p, &packed[k]);
            load(k, &FiniteSolver::new().reference(&job, &g))
        })
        .collect();
    let mut same_grid = 0;
    let (mut diff_over_est, mut diff_max) = (0.0_f64, 0.0_f64);
    let rows = [
        ("GPU kernel", &reports[..], &out[..]),
        ("CPU, LadderRule::default()", &cpu[..], &cpu_out[..]),
        ("CPU, rule before session 36", &cpu_old[..], &old_out[..]),
    ];
    for k in 0..jobs.len() {
        let (gv, cv) = (load(k, &out[k]), load(k, &cpu_out[k]));
        if (reports[k].n_theta, reports[k].n_z) == (cpu[k].n_theta, cpu[k].n_z) {
            same_grid += 1;
        }
        let d = rel(&gv, &cv);
        diff_max = diff_max.max(d);
        diff_over_est = diff_over_est.max(d / cpu[k].error_estimate);
        if each {
            println!(
                "state {k}: GPU {}×{} {} sweeps est {:.3e} err {:.3e} | CPU {}×{} {} sweeps \
                 ({} updates) est {:.3e} err {:.3e} | old rule {} sweeps | GPU−CPU {d:.2e}",
                reports[k].n_theta,
                reports[k].n_z,
                reports[k].sweeps,
                reports[k].error_estimate,
                rel(&gv, &reference[k]),
                cpu[k].n_theta,
                cpu[k].n_z,
                cpu[k].sweeps,
                cpu_exact[k],
                cpu[k].error_estimate,
                rel(&cv, &reference[k]),
                cpu_old[k].sweeps,
            );
        }
    }
    println!(
        "accuracy {accuracy:e}, {n} benchmark states; GPU call {gpu_s:.1} s (loose: lavapipe \
         on a shared machine)"
    );
    println!(
        "| setting | updates per state (whole sweeps × interior nodes): median / mean / largest | \
         final grids | largest true error | estimate / true |"
    );
    println!("|---|---|---|---|---|");
    for (label, r, v) in rows {
        let updates: Vec<u64> = r.iter().map(whole).collect();
        let (mut emax, mut lo, mut hi) = (0.0_f64, f64::INFINITY, 0.0_f64);
        for k in 0..jobs.len() {
            let e = rel(&load(k, &v[k]), &reference[k]);
            emax = emax.max(e);
            let q = r[k].error_estimate / e;
            lo = lo.min(q);
            hi = hi.max(q);
        }
        println!(
            "| {label} | {} | {} | {emax:.2e} | {lo:.2}-{hi:.2} |",
            stats(&updates),
            grids(r)
        );
    }
    println!(
        "CPU exact node updates (its ladder trace): {}",
        stats(&cpu_exact)
    );
    println!(
        "GPU and CPU (default rule): same final grid {same_grid} of {}; largest load \
         difference {diff_max:.2e}, {diff_over_est:.3} of the CPU's estimate",
        jobs.len()
    );
}
