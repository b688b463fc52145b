//! PSOR against multigrid at equal error (issue 20, BENCHMARKS.md "Issue 20: PSOR against
//! multigrid at equal error (session 36)").
//!
//! For each of the 32 states of the finite benchmark (`bench_states(32)`, default
//! settings: max-film inlet) and each explicit grid: the converged reference `v_ref`
//! ([`FiniteSolver::reference`]: the accuracy ladder's 1024 × 128 Richardson-extrapolated
//! from 512 × 64, ~1e-5), the grid's discrete solution `v_h` (multigrid to 1e-12) and its
//! discretisation error `e_h = |v_h − v_ref| / |v_ref|` on the load vector
//! `(W_x, W_y, M_x/B, M_y/B)`. Then, cold starts for both:
//!
//! - **oracle**: the work (relaxation node updates on all grids, counted) after which the
//!   iterate's load vector stays within `(1 + 0.1) e_h` of `v_ref` (judged against the
//!   truth; PSOR observed after every sweep, multigrid once the finest grid is
//!   interpolated and after each of its V-cycles). Also the stricter `|v − v_h| ≤ 0.1 e_h`.
//! - **own stop rule**: `finite.tolerance` from 1e-2 down; the largest tolerance at which
//!   every state is within `(1 + 0.1) e_h` of `v_ref` (and every smaller one too), and the
//!   work there.
//!
//! `cargo run --release --example mg_equal_error -- [table [GRID …]]` (GRID as 128x32;
//! default 64x16 128x32 256x64): the tables; writes the oracle's per-state work to
//! `/tmp/mg_equal_error_NTxNZ.txt` (directory `$MGE_DIR` if set) for the run below. With `MGE_DEBUG=1`: each state's
//! multigrid error over `e_h`, at the FMG start and after its first five V-cycles (stderr).
//!
//! `MG_CYCLE=lines,2,1` (or `points,PRE,POST`): the multigrid's V-cycle (default
//! `points,2,1`); `MG_COARSEST=corr:0.01` (or `field:TOL`, `sweeps:N`): its coarsest-grid
//! solve (default the solver's); `MG_BELOW=1,1`: smoothing sweeps on the levels below the
//! grid being solved (default the cycle's); `MGE_BD=1`: the bearing's B/D (default the benchmark's 0.5).
//!
//! `cargo run --release --example mg_equal_error -- where NT NZ`: where the multigrid's
//! node updates go at the oracle's work (from that file), by grid and role.
//!
//! `cargo run --release --example mg_equal_error -- prof mg|psor NT NZ [PASSES]`: each state
//! solved with exactly the oracle's work from that file (multigrid: its V-cycles on the
//! finest grid after full multigrid; PSOR: its sweeps), nothing else: the run to put under
//! `valgrind --tool=callgrind` for instructions at equal error. One pass over the states
//! by default (the first state's arrays allocated inside it; the CPU's features detected
//! before it, see `prof`); with `PASSES`, the best of
//! that many passes in the process too (the solver's arrays reused, as in a sweep). The
//! last line's load checksum (the states' loads summed, as bits) is what a cost change
//! must keep. Probes of the cold pass (issue 20, session 42), all before or beside the
//! clock: `MGE_STATE_TIMES=1` prints each state's µs in the first two passes (stderr);
//! `MGE_WARM_CODE=1` runs one 32 × 8 solve on another solver before the clock (the same
//! code paths, little memory: what warm code and caches alone are worth);
//! `MGE_PREFAULT=1` writes and frees 800 kB of heap before the clock (with
//! `GLIBC_TUNABLES=glibc.malloc.trim_threshold=100000000` the allocator keeps those pages,
//! and the hierarchy's arrays take them: the pass without fresh pages).
use std::time::Instant;

use bearing_sweep::bearing::finite::{FiniteGrid, FiniteJob, FiniteSettings, FiniteSolver};
use bearing_sweep::bearing::{finish_loads, pack_state, BearingParams, BearingState};
use bearing_sweep::bench::finite::{bench_states, mg_cycle_from_env};
use rayon::prelude::*;

/// Iteration error allowed on top of the discretisation error (the issue's "equal
/// error": within (1 + 0.1) × the grid's own error of the truth).
const MARGIN: f64 = 0.1;

/// Multigrid V-cycles observed on the finest grid after full multigrid (converged far
/// below the bound: ~0.25 per cycle).
const MG_CYCLES: u32 = 14;

/// Tolerances of the own-stop scan, loosest first.
const TOLERANCES: [f64; 15] = [
    1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4, 5e-5, 2e-5, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10,
];

struct Case {
    job: FiniteJob,
    scale: f64,
    state: BearingState,
}

fn rel(a: &[f64; 4], b: &[f64; 4]) -> f64 {
    let d: f64 = (0..4).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt();
    d / b.iter().map(|x| x * x).sum::<f64>().sqrt()
}

fn cases() -> (BearingParams, Vec<Case>) {
    let (mut p, states) = bench_states(32);
    // `MGE_BD`: the bearing's B/D instead of the benchmark's 0.5 (the grids' anisotropy
    // `λ/Δθ² : 1/Δζ²` with it; issue 20, session 37).
    if let Some(bd) = std::env::var("MGE_BD")
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
    {
        p.length = bd * 2.0 * p.radius;
    }
    let cases = states
        .iter()
        .map(|s| {
            let packed = pack_state(&p, s).expect("valid state");
            Case {
                job: FiniteJob::new(&p, &packed),
                scale: packed.rate_scale,
                state: *s,
            }
        })
        .collect();
    (p, cases)
}

/// The multigrid's solver with the V-cycle of `MG_CYCLE` and the coarsest-grid solve of
/// `MG_COARSEST` (`field:TOL`, `corr:FRACTION`, `sweeps:N`; default the solver's).
fn mg_solver() -> FiniteSolver {
    use bearing_sweep::bench::finite::{below_from_env, coarsest_from_env};
    let mut solver = FiniteSolver::new();
    solver.cycle = mg_cycle_from_env();
    solver.below_top = below_from_env("MG_BELOW");
    solver.coarsest = coarsest_from_env("MG_COARSEST");
    solver
}

fn grid(nt: u32, nz: u32, tolerance: f64) -> FiniteGrid {
    FiniteGrid::from(&FiniteSettings {
        tolerance,
        ..FiniteSettings::with_grid(nt, nz)
    })
}

/// First index from which every entry of `errs` is within `bound` (None: never).
fn settles(errs: &[f64], bound: f64) -> Option<usize> {
    let mut k = errs.len();
    while k > 0 && errs[k - 1] <= bound {
        k -= 1;
    }
    (k < errs.len()).then_some(k)
}

fn pct(v: &mut [f64], q: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q).round() as usize]
}

/// The oracle file of a grid: in `$MGE_DIR` (default `/tmp`; set it where several runs
/// share the machine, session 38).
fn file(nt: u32, nz: u32) -> String {
    let dir = std::env::var("MGE_DIR").unwrap_or_else(|_| "/tmp".into());
    format!("{dir}/mg_equal_error_{nt}x{nz}.txt")
}

fn table(grids: &[(u32, u32)]) {
    let (p, cases) = cases();
    let lv =
        |c: &Case, ints: &[f64; 4]| finish_loads(&p, &c.state, ints, c.scale).load_vector(p.length);
    let g0 = FiniteGrid::for_bearing(&p);
    let t0 = Instant::now();
    let reference: Vec<[f64; 4]> = cases
        .par_iter()
        .map(|c| {
            let ints = FiniteSolver::new().reference(&c.job, &g0);
            finish_loads(&p, &c.state, &ints, c.scale).load_vector(p.length)
        })
        .collect();
    eprintln!("references: {:.1} s", t0.elapsed().as_secs_f64());
    println!("| grid | e_h median / max | MG oracle updates/state mean (max) | MG top cycles (median, max) | PSOR oracle updates/state mean (max) | PSOR sweeps (median, max) | PSOR/MG oracle | strict (0.1 e_h of v_h) MG / PSOR / ratio |");
    println!("|---|---|---|---|---|---|---|---|");
    let mut own = Vec::new();
    for &(nt, nz) in grids {
        let interior = (nt * (nz - 1)) as f64;
        let mut solver = mg_solver();
        let tight = grid(nt, nz, 1e-12);
        let mut e_h = Vec::new();
        let mut v_h = Vec::new();
        for (c, r) in cases.iter().zip(&reference) {
            let (ints, _) = solver.solve(&c.job, &tight, &mut Vec::new());
            let v = lv(c, &ints);
            e_h.push(rel(&v, r));
            v_h.push(v);
        }
        // Oracle traces.
        let g = grid(nt, nz, FiniteSettings::default().tolerance);
        let psor_len = 4 * nt;
        let (mut mg_w, mut mg_c, mut ps_w, mut ps_s) = (vec![], vec![], vec![], vec![]);
        let (mut mg_ws, mut ps_ws) = (vec![], vec![]);
        let mut lines = String::new();
        for (k, c) in cases.iter().enumerate() {
            let bound = (1.0 + MARGIN) * e_h[k];
            let strict = MARGIN * e_h[k];
            let mut trace: Vec<(u64, f64, f64)> = Vec::new();
            solver.fmg_cycles(
                &c.job,
                &g,
                MG_CYCLES,
                Some(&mut |w, f: &[f64]| {
                    let v = lv(c, &g.integrals(f));
                    // Against the truth, and the iteration error (from v_h), both over |v_ref|.
                    let n_ref = reference_norm(&reference[k]);
                    trace.push((
                        w,
                        rel(&v, &reference[k]),
                        rel(&v, &v_h[k]) * reference_norm(&v_h[k]) / n_ref,
                    ));
                }),
            );
            let truth: Vec<f64> = trace.iter().map(|t| t.1).collect();
            let iter: Vec<f64> = trace.iter().map(|t| t.2).collect();
            if std::env::var("MGE_DEBUG").is_ok() {
                let r: Vec<String> = truth
                    .iter()
                    .take(6)
                    .map(|e| format!("{:.2}", e / e_h[k]))
                    .collect();
                eprintln!(
                    "{nt}x{nz} state {k}: e_h {:.2e} MG err/e_h {}",
                    e_h[k],
                    r.join(" ")
                );
            }
            let i = settles(&truth, bound).expect("multigrid reaches the bound");
            let is = settles(&iter, strict).expect("multigrid reaches the strict bound");
            mg_w.push(trace[i].0 as f64);
            mg_c.push(i as f64);
            mg_ws.push(trace[is].0 as f64);
            let mut trace: Vec<(u64, f64, f64)> = Vec::new();
            solver.psor_sweeps(&c.job, &g, &mut Vec::new(), psor_len, |w, f| {
                let v = lv(c, &g.integrals(f));
                let n_ref = reference_norm(&reference[k]);
                trace.push((
                    w,
                    rel(&v, &reference[k]),
                    rel(&v, &v_h[k]) * reference_norm(&v_h[k]) / n_ref,
                ));
            });
            let truth: Vec<f64> = trace.iter().map(|t| t.1).collect();
            let iter: Vec<f64> = trace.iter().map(|t| t.2).collect();
            let j = settles(&truth, bound).expect("PSOR reaches the bound");
            let js = settles(&iter, strict).expect("PSOR reaches the strict bound");
            ps_w.push(trace[j].0 as f64);
            ps_s.push((j + 1) as f64);
            ps_ws.push(trace[js].0 as f64);
            lines += &format!("{} {}\n", i, j + 1);
        }
        std::fs::write(file(nt, nz), lines).expect("write the oracle file");
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        let max = |v: &[f64]| v.iter().cloned().fold(0.0, f64::max);
        println!(
            "| {nt}×{nz} | {:.2e} / {:.2e} | {:.0} ({:.0}) = {:.1} sweeps | {:.0}, {:.0} | {:.0} ({:.0}) = {:.1} sweeps | {:.0}, {:.0} | **{:.2}×** | {:.0} / {:.0} / {:.2}× |",
            pct(&mut e_h.clone(), 0.5),
            max(&e_h),
            mean(&mg_w),
            max(&mg_w),
            mean(&mg_w) / interior,
            pct(&mut mg_c.clone(), 0.5),
            max(&mg_c),
            mean(&ps_w),
            max(&ps_w),
            mean(&ps_w) / interior,
            pct(&mut ps_s.clone(), 0.5),
            max(&ps_s),
            mean(&ps_w) / mean(&mg_w),
            mean(&mg_ws),
            mean(&ps_ws),
            mean(&ps_ws) / mean(&mg_ws),
        );
        // Own stop rule: per tolerance, worst error over the bound and the mean work.
        for psor in [false, true] {
            let mut rows = Vec::new();
            for &tol in &TOLERANCES {
                let gt = grid(nt, nz, tol);
                let mut worst = 0.0_f64;
                let mut work = 0.0;
                for (k, c) in cases.iter().enumerate() {
                    let (ints, r) = if psor {
                        solver.solve_psor(&c.job, &gt, &mut Vec::new())
                    } else {
                        solver.solve(&c.job, &gt, &mut Vec::new())
                    };
                    let e = rel(&lv(c, &ints), &reference[k]);
                    worst = worst.max(e / ((1.0 + MARGIN) * e_h[k]));
                    work += r.sweeps as f64 * interior;
                }
                rows.push((tol, worst, work / cases.len() as f64));
            }
            // The loosest tolerance from which every tighter one keeps every state within.
            let mut k = rows.len();
            while k > 0 && rows[k - 1].1 <= 1.0 {
                k -= 1;
            }
            own.push((nt, nz, psor, rows, k));
        }
    }
    println!();
    println!("Own stop rule (`finite.tolerance`): worst state's error over (1 + 0.1) e_h, mean node updates per state.");
    println!();
    println!("| grid | solver | tolerance: worst / updates … | loosest passing tolerance | updates/state there |");
    println!("|---|---|---|---|---|");
    for (nt, nz, psor, rows, k) in &own {
        let cells: Vec<String> = rows
            .iter()
            .map(|(t, w, u)| format!("{t:.0e}: {w:.2} / {u:.0}"))
            .collect();
        let (t, u) = rows.get(*k).map_or(("none".to_string(), f64::NAN), |r| {
            (format!("{:.0e}", r.0), r.2)
        });
        println!(
            "| {nt}×{nz} | {} | {} | {t} | {u:.0} |",
            if *psor { "PSOR" } else { "MG" },
            cells.join("; ")
        );
    }
}

fn reference_norm(v: &[f64; 4]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// Each state with exactly the oracle's work (see the module doc).
fn prof(args: &[String]) {
    let method = args.first().map(String::as_str).unwrap_or("mg");
    let nt: u32 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(128);
    let nz: u32 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(32);
    let work: Vec<(u32, u32)> = std::fs::read_to_string(file(nt, nz))
        .expect("run the table first: it writes the oracle file")
        .lines()
        .map(|l| {
            let mut it = l.split_whitespace().map(|x| x.parse().expect("a count"));
            (it.next().expect("mg"), it.next().expect("psor"))
        })
        .collect();
    let passes: usize = args.get(3).map_or(1, |s| s.parse().expect("PASSES"));
    let (_, cases) = cases();
    let g = grid(nt, nz, FiniteSettings::default().tolerance);
    let mut solver = mg_solver();
    // The process's one-time CPU feature detection (`cpuid`, which traps in a virtual
    // machine: ~35 µs here) and the lanes' choice by timed solves (session 41) before the
    // clock, as the program's start is: a cost per process, not per state, that only the
    // multigrid's lanes paid inside the first pass (issue 20, session 39;
    // `MGE_DETECT_IN_PASS=1`: inside it, as before).
    if std::env::var("MGE_DETECT_IN_PASS").is_err() {
        let isa = bearing_sweep::bearing::finite::multigrid_lanes();
        if std::env::var("MGE_SHOW_LANES").is_ok() {
            eprintln!("lanes: {isa:?}");
        }
    }
    // The cold-pass probes (see the module doc).
    if std::env::var("MGE_WARM_CODE").is_ok() {
        // 32 × 8: the smallest grid with the same passes (four levels, lanes everywhere).
        let g8 = grid(32, 8, FiniteSettings::default().tolerance);
        let mut s8 = mg_solver();
        std::hint::black_box(s8.fmg_cycles(&cases[0].job, &g8, 3, None));
    }
    if std::env::var("MGE_PREFAULT").is_ok() {
        // 200 blocks of 4 kB (each below the allocator's mmap threshold): 800 kB, about
        // twice a 128 × 32 hierarchy.
        let v: Vec<Vec<f64>> = (0..200).map(|_| vec![1.0; 512]).collect();
        std::hint::black_box(&v);
        drop(v);
    }
    let (mut first, mut best) = (0.0, f64::INFINITY);
    let (mut sweeps_done, mut sum) = (0u64, [0.0; 4]);
    let faults_before = minor_faults();
    let mut first_faults = 0;
    for pass in 0..passes.max(1) {
        if pass == 1 {
            first_faults = minor_faults() - faults_before;
        }
        (sweeps_done, sum) = (0, [0.0; 4]);
        let start = Instant::now();
        let mut times = Vec::new();
        for (c, &(cycles, sweeps)) in cases.iter().zip(&work) {
            let t_state = Instant::now();
            let (ints, r) = if method == "psor" {
                solver.psor_sweeps(&c.job, &g, &mut Vec::new(), sweeps, |_, _| {})
            } else {
                solver.fmg_cycles(&c.job, &g, cycles, None)
            };
            sweeps_done += u64::from(r.sweeps);
            for (s, v) in sum.iter_mut().zip(ints) {
                *s += v;
            }
            times.push(t_state.elapsed().as_secs_f64() * 1e6);
        }
        if std::env::var("MGE_STATE_TIMES").is_ok() && pass < 2 {
            let t: Vec<String> = times.iter().map(|t| format!("{t:.0}")).collect();
            eprintln!("pass {pass} µs per state: {}", t.join(" "));
        }
        let s = start.elapsed().as_secs_f64();
        if pass == 0 {
            first = s;
        }
        best = best.min(s);
    }
    let n = cases.len() as f64;
    println!(
        "{method} {nt}x{nz} oracle work: {:.2} sweeps/state (each state's rounded up; exact \
         node updates: the table), {:.4} ms/state",
        sweeps_done as f64 / n,
        first / n * 1e3
    );
    if passes > 1 {
        println!(
            "  best of {passes} passes in the process: {:.4} ms/state",
            best / n * 1e3
        );
    }
    if passes <= 1 {
        first_faults = minor_faults() - faults_before;
    }
    println!("  load checksum {:?}", sum.map(f64::to_bits));
    // The first pass's page faults (its arrays' pages as first touched: ~2 µs each on
    // the 2-core VM; issue 20, session 40).
    if std::env::var("MGE_FAULTS").is_ok() {
        println!("  minor page faults in the first pass: {first_faults}");
    }
}

/// The process's minor page faults so far (`/proc/self/stat`, field 10; 0 where there is
/// no such file).
fn minor_faults() -> u64 {
    std::fs::read_to_string("/proc/self/stat")
        .ok()
        .and_then(|s| {
            // After the command's name in parentheses: state is field 3, minflt field 10.
            let rest = &s[s.rfind(')')? + 2..];
            rest.split_whitespace().nth(7)?.parse().ok()
        })
        .unwrap_or(0)
}

/// Where the multigrid's node updates go at the oracle's work (issue 20, session 38): each
/// state solved as `prof mg NT NZ` does (the oracle file's V-cycles after full multigrid),
/// the work broken down by the grid being solved (the FMG start's intermediate grids, then
/// the top grid), the grid relaxed and the role; per-state means, as a markdown table.
fn work_where(args: &[String]) {
    let nt: u32 = args.first().and_then(|s| s.parse().ok()).unwrap_or(128);
    let nz: u32 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(32);
    let work: Vec<u32> = std::fs::read_to_string(file(nt, nz))
        .expect("run the table first: it writes the oracle file")
        .lines()
        .map(|l| {
            l.split_whitespace()
                .next()
                .expect("mg")
                .parse()
                .expect("a count")
        })
        .collect();
    let (_, cases) = cases();
    let g = grid(nt, nz, FiniteSettings::default().tolerance);
    let mut solver = mg_solver();
    solver.keep_work_tally(true);
    let mut sweeps = 0u64;
    for (c, &cycles) in cases.iter().zip(&work) {
        sweeps += u64::from(solver.fmg_cycles(&c.job, &g, cycles, None).1.sweeps);
    }
    let n = cases.len() as f64;
    let t = solver.take_work_tally();
    let total: u64 = t.iter().map(|w| w.updates).sum();
    println!(
        "{nt}x{nz} at the oracle's work: {:.0} node updates per state ({:.2} sweeps of the grid; whole sweeps per state {:.2})",
        total as f64 / n,
        total as f64 / n / (nt * (nz - 1)) as f64,
        sweeps as f64 / n
    );
    print!("{}", bearing_sweep::bench::finite::work_tally_table(&t, n));
    let top = (nt as usize, nz as usize);
    let start: u64 = t.iter().filter(|w| w.top != top).map(|w| w.updates).sum();
    println!(
        "  FMG start (grids below {nt}x{nz} as the grid solved): {:.0} per state ({:.1} %)",
        start as f64 / n,
        100.0 * start as f64 / total as f64
    );
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("prof") => prof(&args[1..]),
        Some("where") => work_where(&args[1..]),
        _ => {
            let grids: Vec<(u32, u32)> = args
                .iter()
                .skip(1)
                .filter_map(|a| {
                    let (t, z) = a.split_once('x')?;
                    Some((t.parse().ok()?, z.parse().ok()?))
                })
                .collect();
            let grids = if grids.is_empty() {
                vec![(64, 16), (128, 32), (256, 64)]
            } else {
                grids
            };
            table(&grids);
        }
    }
}
