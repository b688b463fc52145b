//! Finite-film benchmark (BENCHMARKS.md "Finite-length film"): states/s at several grids
//! on the CPU backend and the WGSL kernel, the error against a converged grid, counted
//! flops, and the rotor-scene cost with the finite film against the short one.

use std::time::Instant;

use crate::backend::{CpuBackend, FilmBackend, GpuBackend, GpuOptions, LoadEvaluator, LoadRequest};
use crate::bearing::finite::{
    CoarsestSolve, FiniteGrid, FiniteJob, FiniteSettings, FiniteSolver, MgCycle, WorkRole,
    WorkShare,
};
use crate::bearing::{finish_loads, pack_state, Accuracy, BearingParams, BearingState, FilmModel};

/// Flops per node and sweep of the CPU kernel (coefficients precomputed per solve):
/// 4 mul + 3 add (neighbour sum), sub + mul (Gauss–Seidel value), sub + mul + add
/// (relaxation), max (projection), sub + abs + 2 max (convergence bookkeeping) = 17.
pub const CPU_FLOPS_PER_NODE_SWEEP: f64 = 17.0;
/// The WGSL kernel recomputes the coefficients every sweep: 17 as above, plus 3 film
/// interpolations (8 each), 4 `H³` (4 each), 4 coefficient scalings, the right-hand side
/// (8), the diagonal sum and division (4) = 17 + 24 + 16 + 4 + 8 + 4 = 73.
pub const GPU_FLOPS_PER_NODE_SWEEP: f64 = 73.0;

/// The explicit grids' V-cycle from the environment variable `MG_CYCLE`
/// (`points|lines,PRE,POST`, e.g. `lines,2,1`; unset or a part missing: the default's,
/// `points,2,1`), for the probes `examples/mg_cost.rs` and `examples/mg_equal_error.rs`
/// (issue 20, session 37).
pub fn mg_cycle_from_env() -> MgCycle {
    let Ok(v) = std::env::var("MG_CYCLE") else {
        return MgCycle::default();
    };
    let parts: Vec<&str> = v.split(',').collect();
    let num = |k: usize, d: u32| parts.get(k).and_then(|s| s.parse().ok()).unwrap_or(d);
    let d = MgCycle::default();
    MgCycle {
        z_lines: parts.first() == Some(&"lines"),
        pre: num(1, d.pre),
        post: num(2, d.post),
    }
}

/// A multigrid work tally (`FiniteSolver::keep_work_tally`) summed over `n` states as a
/// markdown table, node updates by grid solved, grid relaxed and role with per-state means,
/// then the shares by role over all grids: the probes `examples/zeta_probe.rs` (`where`) and
/// `examples/mg_equal_error.rs` (`where`), issue 20, session 38.
pub fn work_tally_table(tally: &[WorkShare], n: f64) -> String {
    use std::fmt::Write;
    let mut t = tally.to_vec();
    t.sort_by_key(|w| (w.top, w.level, w.role));
    let total: u64 = t.iter().map(|w| w.updates).sum();
    let mut out = String::new();
    out.push_str("| grid solved | grid relaxed | role | node updates / state | share | calls / state | sweeps / call |\n");
    out.push_str("|---|---|---|---|---|---|---|\n");
    for w in &t {
        let _ = writeln!(
            out,
            "| {}×{} | {}×{} | {:?} | {:.0} | {:.1} % | {:.2} | {:.2} |",
            w.top.0,
            w.top.1,
            w.level.0,
            w.level.1,
            w.role,
            w.updates as f64 / n,
            100.0 * w.updates as f64 / total as f64,
            w.calls as f64 / n,
            w.sweeps as f64 / w.calls as f64
        );
    }
    for role in [
        WorkRole::Solve,
        WorkRole::Pre,
        WorkRole::Coarsest,
        WorkRole::Post,
    ] {
        let u: u64 = t.iter().filter(|w| w.role == role).map(|w| w.updates).sum();
        let _ = writeln!(
            out,
            "  {role:?}: {:.0} per state ({:.1} %)",
            u as f64 / n,
            100.0 * u as f64 / total as f64
        );
    }
    out
}

/// The coarsest-grid solve from the environment variable `var` (`field:TOL`,
/// `corr:FRACTION`, `sweeps:N`; unset: the solver's default), for the probes
/// `examples/zeta_probe.rs` (`ZETA_PROBE_COARSEST`) and `examples/mg_equal_error.rs`
/// (`MG_COARSEST`), issue 20, session 38.
pub fn coarsest_from_env(var: &str) -> CoarsestSolve {
    let Ok(v) = std::env::var(var) else {
        return CoarsestSolve::default();
    };
    let (kind, x) = v.split_once(':').expect("KIND:VALUE");
    match kind {
        "field" => CoarsestSolve::Field(x.parse().expect("a tolerance")),
        "corr" => CoarsestSolve::Correction(x.parse().expect("a fraction")),
        "sweeps" => CoarsestSolve::Sweeps(x.parse().expect("a count")),
        _ => panic!("{var}: field|corr|sweeps"),
    }
}

/// Smoothing sweeps `PRE,POST` on the levels below the grid being solved from the
/// environment variable `var` (unset: the cycle's), for the same probes (`ZETA_PROBE_BELOW`,
/// `MG_BELOW`).
pub fn below_from_env(var: &str) -> Option<(u32, u32)> {
    let v = std::env::var(var).ok()?;
    let (a, b) = v.split_once(',').expect("PRE,POST");
    Some((a.parse().expect("PRE"), b.parse().expect("POST")))
}

/// The benchmark's bearing states: the paper's bearing (B/D = 0.5), eccentricities
/// 0.1..0.9, half of them tilted, a third whirling or squeezing.
pub fn bench_states(n: usize) -> (BearingParams, Vec<BearingState>) {
    let p = BearingParams::paper_table2();
    let d = p.clearance;
    let states = (0..n)
        .map(|k| {
            let t = k as f64 * 2.399; // golden angle: directions spread evenly
            let e = 0.1 + 0.8 * ((k * 61 % 97) as f64 / 96.0);
            let tilt = if k % 2 == 0 { 0.0 } else { 0.25 };
            BearingState {
                xi: e * d * t.cos(),
                yi: e * d * t.sin(),
                xj: e * d * (1.0 - tilt) * t.cos(),
                yj: e * d * (1.0 - tilt) * t.sin(),
                vxi: if k % 3 == 1 { 0.02 * d * 100.0 } else { 0.0 },
                vyi: if k % 3 == 2 { -0.03 * d * 100.0 } else { 0.0 },
                vxj: 0.0,
                vyj: 0.0,
                omega: 100.0,
            }
        })
        .collect();
    (p, states)
}

fn norm_err(a: [f64; 4], b: [f64; 4]) -> f64 {
    let d: f64 = (0..4).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt();
    d / b.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// One setting's row: states/s (cold start), mean sweeps, median error vs the reference.
struct Row {
    label: String,
    states_per_s: f64,
    sweeps: f64,
    error_median: f64,
    error_max: f64,
}

fn run_grid(
    ev: &mut LoadEvaluator,
    p: &BearingParams,
    states: &[BearingState],
    reference: &[[f64; 4]],
    finite: FiniteSettings,
    reps: usize,
) -> Row {
    let bp = BearingParams {
        model: FilmModel::Finite,
        finite,
        ..*p
    };
    ev.set_warm_start(false);
    let req: Vec<LoadRequest> = states
        .iter()
        .map(|&state| LoadRequest { bearing: 0, state })
        .collect();
    let mut out = Vec::new();
    // Loads only, as a rotor stage asks (no film friction or flow: in accuracy mode those
    // polish the last grid, which the GPU's multigrid kernel leaves to the CPU).
    let plan = crate::backend::BearingPlan::new(&[bp], false);
    ev.evaluate_planned(&[bp], &plan, &req, &mut out); // warm-up (pipeline build, allocation)
    let before = ev.stats();
    let t = Instant::now();
    for _ in 0..reps {
        ev.evaluate_planned(&[bp], &plan, &req, &mut out);
    }
    let secs = t.elapsed().as_secs_f64();
    let after = ev.stats();
    let mut errs: Vec<f64> = out
        .iter()
        .zip(reference)
        .map(|(r, want)| match r {
            Ok(l) => norm_err(l.load_vector(p.length), *want),
            Err(_) => f64::NAN,
        })
        .collect();
    errs.sort_by(|a, b| a.total_cmp(b));
    Row {
        label: match finite.fixed_grid() {
            Some((t, z)) => format!("{t}×{z}"),
            None => format!("accuracy {:.0e}", finite.accuracy),
        },
        states_per_s: (reps * states.len()) as f64 / secs,
        sweeps: (after.finite_sweeps - before.finite_sweeps) as f64
            / (after.finite_states - before.finite_states).max(1) as f64,
        error_median: errs[errs.len() / 2],
        error_max: errs[errs.len() - 1],
    }
}

/// States of the PSOR/multigrid table at most (the first of the call's states): ~32 ms
/// of one core per state at 256 × 64 and below.
const SOLVER_TABLE_STATES: usize = 256;

/// Runs the benchmark; `n` states per call, each grid timed over `reps` calls. Returns
/// the markdown report.
pub fn bench_finite(n: usize, reps: usize, gpu: bool) -> String {
    let (p, states) = bench_states(n);
    // Converged reference: the accuracy ladder's 1024×128 Richardson-extrapolated from
    // 512×64, inlet line on the grid (FiniteSolver::reference; ~1e-5 on these states,
    // tests/finite_accuracy.rs).
    let grid = FiniteGrid::for_bearing(&BearingParams {
        model: FilmModel::Finite,
        ..p
    });
    // One state per task: a reference is ~0.1-0.3 s of a core, the rest of the benchmark
    // is timed after.
    use rayon::prelude::*;
    let reference: Vec<[f64; 4]> = states
        .par_iter()
        .map(|s| match pack_state(&p, s) {
            Ok(packed) => {
                let job = FiniteJob::new(&p, &packed);
                let ints = FiniteSolver::new().reference(&job, &grid);
                finish_loads(&p, s, &ints, packed.rate_scale).load_vector(p.length)
            }
            Err(_) => [f64::NAN; 4],
        })
        .collect();
    let grids = [(32, 8), (64, 16), (128, 32)];
    // The one-thread solver table on the first states only: its per-state figures change
    // little beyond a few hundred states, and 4096 states cost minutes of one core.
    let table = states.len().min(SOLVER_TABLE_STATES);
    let mut md = solver_table(&p, &states[..table], &reference[..table]);
    md += &format!(
        "\nFinite film, {n} states of the paper's bearing (B/D = 0.5, ε 0.1-0.9, half tilted, a \
         third whirling/squeezing), cold start, projected multigrid (explicit grids: \
         tolerance 1e-8; accuracy mode: each grid to 1/10 of the accuracy on the loads); \
         error: load vector (W_x, W_y, M_x/B, M_y/B) against the accuracy ladder's \
         1024×128 Richardson-extrapolated (inlet line on the grid). \
         Sweeps: work in sweeps of the final grid.\n\n\
         | backend | setting | states/s | sweeps/state | median error | max error |\n\
         |---|---|---|---|---|---|\n"
    );
    let mut cpu = LoadEvaluator::new(Box::new(CpuBackend::new(Accuracy::default(), None)));
    let threads = cpu.info().device;
    let mut settings: Vec<(FiniteSettings, usize)> = grids
        .iter()
        .map(|&(t, z)| (FiniteSettings::with_grid(t, z), reps))
        .collect();
    for accuracy in [FiniteSettings::default().accuracy, 1e-4] {
        settings.push((
            FiniteSettings {
                accuracy,
                ..FiniteSettings::default()
            },
            1,
        ));
    }
    for (g, reps) in settings {
        let r = run_grid(&mut cpu, &p, &states, &reference, g, reps);
        md += &format!(
            "| cpu ({threads}) | {} | {:.0} | {:.0} | {:.2e} | {:.2e} |\n",
            r.label, r.states_per_s, r.sweeps, r.error_median, r.error_max
        );
    }
    if gpu {
        let opts = GpuOptions {
            precision: Some(crate::backend::Precision::F64),
            ..GpuOptions::default()
        };
        match GpuBackend::new(Accuracy::default(), opts) {
            Ok(g) => {
                let name = g.info().device;
                let mut ev = LoadEvaluator::new(Box::new(g));
                // Explicit grids within the workgroup memory run the PSOR kernel
                // (shaders/finite.wgsl), larger ones and accuracy mode the projected
                // multigrid kernel (shaders/finite_mg.wgsl).
                let mut gpu_settings: Vec<(FiniteSettings, usize, &str)> = grids
                    .iter()
                    .map(|&(t, z)| {
                        let kernel = if (t * (z - 1)) as usize > crate::backend::FINITE_MAX_NODES {
                            "multigrid kernel"
                        } else {
                            "PSOR kernel"
                        };
                        (FiniteSettings::with_grid(t, z), reps, kernel)
                    })
                    .collect();
                for accuracy in [FiniteSettings::default().accuracy, 1e-4] {
                    gpu_settings.push((
                        FiniteSettings {
                            accuracy,
                            ..FiniteSettings::default()
                        },
                        1,
                        "multigrid kernel",
                    ));
                }
                for (g, reps, kernel) in gpu_settings {
                    let r = run_grid(&mut ev, &p, &states, &reference, g, reps);
                    md += &format!(
                        "| gpu ({name}, {kernel}) | {} | {:.0} | {:.0} | {:.2e} | {:.2e} |\n",
                        r.label, r.states_per_s, r.sweeps, r.error_median, r.error_max
                    );
                }
                let notices = ev.take_notices();
                if !notices.is_empty() {
                    md += &format!("\nGPU notices: {notices:?}\n");
                }
            }
            Err(e) => md += &format!("\nGPU skipped: {e}\n"),
        }
    }
    md
}

/// Projected SOR against projected multigrid on fixed grids: one thread, cold starts,
/// tolerance 1e-8, the same states; work (sweeps of the grid: node updates over nodes),
/// time per state and the error against the reference (the same discrete problem, so
/// the same error: equal error by construction). Markdown table.
fn solver_table(p: &BearingParams, states: &[BearingState], reference: &[[f64; 4]]) -> String {
    let mut md = format!(
        "PSOR vs projected multigrid, one thread, cold start, tolerance 1e-8, {} states (same \
         discrete problem: the errors agree to the tolerance):\n\n\
         | grid | PSOR sweeps | PSOR ms/state | multigrid work (sweeps) | multigrid ms/state | \
         speed-up | median error | max error |\n|---|---|---|---|---|---|---|---|\n",
        states.len()
    );
    let jobs: Vec<(FiniteJob, f64)> = states
        .iter()
        .filter_map(|s| {
            let packed = pack_state(p, s).ok()?;
            Some((FiniteJob::new(p, &packed), packed.rate_scale))
        })
        .collect();
    for (t, z) in [(32, 8), (64, 16), (128, 32), (256, 64)] {
        let g = FiniteGrid::from(&FiniteSettings::with_grid(t, z));
        let mut solver = FiniteSolver::new();
        let mut run = |psor: bool| {
            let start = Instant::now();
            let mut sweeps = 0u64;
            let mut errs = Vec::new();
            for ((job, scale), (s, want)) in jobs.iter().zip(states.iter().zip(reference)) {
                let (ints, r) = if psor {
                    solver.solve_psor(job, &g, &mut Vec::new())
                } else {
                    solver.solve(job, &g, &mut Vec::new())
                };
                sweeps += r.sweeps as u64;
                let l = finish_loads(p, s, &ints, *scale);
                errs.push(norm_err(l.load_vector(p.length), *want));
            }
            errs.sort_by(|a, b| a.total_cmp(b));
            let n = jobs.len().max(1) as f64;
            (
                sweeps as f64 / n,
                start.elapsed().as_secs_f64() / n * 1e3,
                errs[errs.len() / 2],
                errs[errs.len() - 1],
            )
        };
        let a = run(true);
        let b = run(false);
        md += &format!(
            "| {t}×{z} | {:.0} | {:.3} | {:.0} | {:.3} | {:.1}× | {:.2e} | {:.2e} |\n",
            a.0,
            a.1,
            b.0,
            b.1,
            a.1 / b.1,
            b.2,
            b.3
        );
    }
    md
}

/// Rotor-scene cost: the paper's example (MODEL.md section 8, free spin, dopri5 at
/// rtol 1e-6) over `t_end` seconds with the short film, the finite film with warm start,
/// and the finite film from cold starts; CPU backend. Markdown rows.
pub fn bench_finite_rotor(t_end: f64) -> String {
    use crate::rotor::{load_scene, simulate_batch};
    let mut base: serde_json::Value =
        serde_json::from_str(include_str!("../../sweeps/paper-example.json"))
            .expect("the paper example parses");
    base["compare_ideal"] = serde_json::json!(false);
    base["integrator"]["t_end"] = serde_json::json!(t_end);
    let mut md = format!(
        "Paper rotor, {t_end} s, dopri5 rtol 1e-6, CPU backend (2 threads):\n\n\
         | film | wall s | load evaluations | sweeps/evaluation | warm starts | ε_max | min h_min µm |\n\
         |---|---|---|---|---|---|---|\n"
    );
    for (label, model, warm) in [
        ("short", "short", true),
        ("finite (default accuracy), warm start", "finite", true),
        ("finite (default accuracy), cold start", "finite", false),
    ] {
        let mut s = base.clone();
        for b in s["bearings"].as_array_mut().expect("bearings") {
            b["model"] = serde_json::json!(model);
        }
        let scenes = match load_scene(&s.to_string()) {
            Ok(x) => x,
            Err(e) => return format!("scene error: {e}"),
        };
        let mut ev = LoadEvaluator::new(Box::new(CpuBackend::new(Accuracy::default(), None)));
        ev.set_warm_start(warm);
        let t = Instant::now();
        let r = simulate_batch(&scenes, &mut ev, &mut |_, _| {}).remove(0);
        let wall = t.elapsed().as_secs_f64();
        let st = ev.stats();
        let ecc = r
            .samples
            .bearings
            .iter()
            .flat_map(|b| b.eccentricity_max.iter().copied())
            .fold(0.0, f64::max);
        let hmin = r
            .samples
            .bearings
            .iter()
            .flat_map(|b| b.h_min.iter().copied())
            .fold(f64::INFINITY, f64::min);
        let sweeps = if st.finite_states > 0 {
            format!("{:.1}", st.finite_sweeps as f64 / st.finite_states as f64)
        } else {
            "—".into()
        };
        md += &format!(
            "| {label} | {wall:.2} | {} | {sweeps} | {} | {ecc:.4} | {:.2} |\n",
            st.states,
            st.finite_warm_starts,
            hmin * 1e6
        );
    }
    md
}

/// JFO against Swift–Stieber at equal grid (BENCHMARKS.md "Issue 27", `finite --bench
/// --cavitation jfo`): `n` states of [`bench_states`], fed on the maximum-film line and
/// with an ambient axial groove at 180° (where the JFO film reforms in the land), explicit
/// grids 64 × 16 and 128 × 32, tolerance 1e-8, cold starts through the evaluator (warm
/// starts off), each setting timed over `reps` calls after a warm-up call; the CPU backend
/// and, with `gpu`, the WGSL kernels (JFO: shaders/finite_jfo.wgsl, started from the
/// Swift–Stieber kernel's solution). Per row: states/s, counted work (sweeps of the grid
/// per state, the JFO count including its Swift–Stieber start) and, for the GPU, the
/// largest relative difference of its load vectors from the CPU backend's. Markdown.
pub fn bench_finite_jfo(n: usize, reps: usize, gpu: bool) -> String {
    use crate::bearing::finite::Cavitation;
    use crate::bearing::{Groove, Grooves};
    let (p0, states) = bench_states(n);
    let req: Vec<LoadRequest> = states
        .iter()
        .map(|&state| LoadRequest { bearing: 0, state })
        .collect();
    let mut cpu = LoadEvaluator::new(Box::new(CpuBackend::new(Accuracy::default(), None)));
    let threads = cpu.info().device;
    let mut gpu_ev = None;
    let mut md = format!(
        "JFO vs Swift–Stieber at equal grid: {n} states of the paper's bearing (B/D = 0.5, \
         ε 0.1-0.9, half tilted, a third whirling/squeezing), tolerance 1e-8, cold starts, \
         {reps} timed calls per row. Sweeps: work in sweeps of the grid per state. GPU vs \
         CPU: largest relative difference of the load vectors.\n\n\
         | feed | grid | cavitation | backend | states/s | sweeps/state | GPU vs CPU |\n\
         |---|---|---|---|---|---|---|\n"
    );
    if gpu {
        let opts = GpuOptions {
            precision: Some(crate::backend::Precision::F64),
            ..GpuOptions::default()
        };
        match GpuBackend::new(Accuracy::default(), opts) {
            Ok(g) => gpu_ev = Some(LoadEvaluator::new(Box::new(g))),
            Err(e) => md = format!("GPU skipped: {e}\n\n{md}"),
        }
    }
    let gpu_name = gpu_ev.as_ref().map(|e| e.info().device);
    for groove in [false, true] {
        let mut p = BearingParams {
            model: FilmModel::Finite,
            ..p0
        };
        if groove {
            p.grooves = Grooves::new(&[Groove {
                angle: 180.0,
                width: 20.0,
                supply_pressure: 0.0,
                length: None,
            }])
            .expect("one groove");
        }
        let feed = if groove {
            "groove at 180°"
        } else {
            "max-film line"
        };
        for (t, z) in [(64, 16), (128, 32)] {
            for cav in [Cavitation::Reynolds, Cavitation::Jfo] {
                let bp = BearingParams {
                    finite: FiniteSettings {
                        cavitation: cav,
                        ..FiniteSettings::with_grid(t, z)
                    },
                    ..p
                };
                let timed = |ev: &mut LoadEvaluator| {
                    ev.set_warm_start(false);
                    let mut out = Vec::new();
                    ev.evaluate(&[bp], &req, &mut out); // warm-up (pipeline build)
                    let before = ev.stats();
                    let start = Instant::now();
                    for _ in 0..reps {
                        ev.evaluate(&[bp], &req, &mut out);
                    }
                    let secs = start.elapsed().as_secs_f64();
                    let after = ev.stats();
                    let sweeps = (after.finite_sweeps - before.finite_sweeps) as f64
                        / (after.finite_states - before.finite_states).max(1) as f64;
                    let loads: Vec<[f64; 4]> = out
                        .iter()
                        .map(|r| match r {
                            Ok(l) => l.load_vector(bp.length),
                            Err(_) => [f64::NAN; 4],
                        })
                        .collect();
                    ((reps * req.len()) as f64 / secs, sweeps, loads)
                };
                let (rate, sweeps, want) = timed(&mut cpu);
                md += &format!(
                    "| {feed} | {t}×{z} | {} | cpu ({threads}) | {rate:.0} | {sweeps:.0} | — |\n",
                    cav.name()
                );
                if let (Some(ev), Some(name)) = (gpu_ev.as_mut(), gpu_name.as_ref()) {
                    let (rate, sweeps, got) = timed(ev);
                    let diff = got
                        .iter()
                        .zip(&want)
                        .map(|(a, b)| norm_err(*a, *b))
                        .fold(0.0, f64::max);
                    md += &format!(
                        "| {feed} | {t}×{z} | {} | gpu ({name}) | {rate:.0} | {sweeps:.0} | \
                         {diff:.1e} |\n",
                        cav.name()
                    );
                }
            }
        }
    }
    if let Some(ev) = gpu_ev.as_mut() {
        let notices = ev.take_notices();
        if !notices.is_empty() {
            md += &format!("\nGPU notices: {notices:?}\n");
        }
    }
    md
}
