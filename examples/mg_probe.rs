//! Probe of the projected multigrid's cycle count on explicit grids (issue 20, pass 3):
//! the states of the finite benchmark, cold starts, one thread; per grid the work in
//! sweeps of the grid (mean, min, max) and the largest relative difference of the load
//! vector and of the field from red-black projected SOR iterated to 1e-13 (the same
//! discrete problem, converged).
//!
//! `cargo run --release --example mg_probe -- [n_theta n_z] [none|max] [states]`
//! (defaults: the grids 64 × 16, 128 × 32, 256 × 64, max-film inlet, 32 states).
//!
//! `cargo run --release --example mg_probe -- gpu N_THETA N_Z [states]`: the same states
//! (32 by default) on the multigrid kernel (shaders/finite_mg.wgsl, any f64 adapter,
//! lavapipe here): work per state on the GPU and the CPU, and the largest relative
//! difference of their load vectors. `mg_probe acc ACCURACY [states]`: accuracy mode.
//! With `BEARING_SWEEP_MG_COUNT=1` both also print the kernel's tally per state (its chain
//! of barriers by part of the solve, serial loops, sweeps: src/backend/finite_mg.rs
//! `TALLY_NAMES`), mean and largest over the states, and the GPU call's wall time.
//!
//! `cargo run --release --example mg_probe -- aniso`: which direction's discretisation
//! error dominates at 256 × 32 (B/D = 0.5): relative load-vector errors of 256 × 32,
//! 512 × 32 (θ refined), 256 × 64 (ζ refined) and 512 × 64 against the converged solution
//! ([`FiniteSolver::reference`]), free inlet (no snapped inlet column on explicit grids),
//! the states of the finite benchmark.
use bearing_sweep::bearing::finite::{
    ladder_estimate, FiniteGrid, FiniteJob, FiniteSettings, FiniteSolver, Inlet,
};
use bearing_sweep::bearing::{pack_state, BearingParams, BearingState};
use bearing_sweep::bench::finite::bench_states;

fn aniso(n: usize) {
    let (mut p, states) = bench_states(n);
    p.finite.inlet = Inlet::None;
    p.model = bearing_sweep::bearing::FilmModel::Finite;
    let grids = [
        (256u32, 32u32),
        (512, 32),
        (256, 64),
        (512, 64),
        (64, 16),
        (128, 16),
        (128, 32),
        (128, 64),
    ];
    println!("| state | 256×32 | 512×32 (θ refined) | 256×64 (ζ refined) | 512×64 | Simpson-ζ 64x16 | S 128x16 | S 128x32 | S 128x64 | S 256x32 |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let mut worst = [0.0_f64; 9];
    for (k, s) in states.iter().enumerate() {
        let packed = pack_state(&p, s).expect("valid state");
        let job = FiniteJob::new(&p, &packed);
        let mut solver = FiniteSolver::new();
        let want = solver.reference(&job, &FiniteGrid::for_bearing(&p));
        let norm = want.iter().map(|v| v * v).sum::<f64>().sqrt();
        print!("| {k} |");
        let mut simpson_256 = 0.0;
        for (c, &(t, z)) in grids.iter().enumerate() {
            let g = FiniteGrid::from(&FiniteSettings {
                inlet: Inlet::None,
                tolerance: 1e-11,
                ..FiniteSettings::with_grid(t, z)
            });
            let mut field = Vec::new();
            let (got, _) = solver.solve(&job, &g, &mut field);
            // Columns 4-7: the same fields summed by Simpson's rule in ζ.
            let got = if c >= 4 {
                simpson(&field, t as usize, z as usize)
            } else {
                got
            };
            let e = (0..4)
                .map(|i| (got[i] - want[i]).powi(2))
                .sum::<f64>()
                .sqrt()
                / norm;
            worst[c] = worst[c].max(e);
            print!(" {e:.2e} |");
            if c == 0 {
                let got = simpson(&field, t as usize, z as usize);
                let e = (0..4)
                    .map(|i| (got[i] - want[i]).powi(2))
                    .sum::<f64>()
                    .sqrt()
                    / norm;
                worst[8] = worst[8].max(e);
                simpson_256 = e;
            }
        }
        print!(" {simpson_256:.2e} |");
        println!();
    }
    println!(
        "| largest | {:.2e} | {:.2e} | {:.2e} | {:.2e} | {:.2e} | {:.2e} | {:.2e} | {:.2e} | {:.2e} |",
        worst[0], worst[1], worst[2], worst[3], worst[4], worst[5], worst[6], worst[7], worst[8]
    );
}

/// Load integrals with Simpson's rule in ζ (rectangle rule in θ).
fn simpson(p: &[f64], nt: usize, nz: usize) -> [f64; 4] {
    let dt = 2.0 * std::f64::consts::PI / nt as f64;
    let dz = 1.0 / nz as f64;
    let mut acc = [0.0; 4];
    for j in 1..nz {
        let zeta = j as f64 * dz;
        let w = if j % 2 == 1 { 4.0 / 3.0 } else { 2.0 / 3.0 };
        let (mut c, mut s) = (0.0, 0.0);
        for i in 0..nt {
            let th = i as f64 * dt;
            c += p[j * nt + i] * th.cos();
            s += p[j * nt + i] * th.sin();
        }
        acc[0] += w * c;
        acc[1] += w * s;
        acc[2] += w * c * zeta;
        acc[3] += w * s * zeta;
    }
    acc.map(|v| -v * dt * dz / 3.0)
}

#[path = "../tests/support/finite_states.rs"]
mod finite_states;

/// The 12 states of tests/finite_accuracy.rs turned so that the maximum film is at θ = 0
/// (a node of every grid, as the accuracy ladder places it): aligned ε 0.1-0.95, tilted in
/// the plane of the eccentricity, squeezed.
fn turned_states(p: &BearingParams) -> Vec<BearingState> {
    let d = p.clearance;
    let w = finite_states::OMEGA;
    let mut out = Vec::new();
    for &(e, tilt, sq) in &finite_states::CASES {
        // Eccentricity along −x: the maximum film arg(−ε) is at θ = 0.
        out.push(BearingState {
            xi: -(e + tilt) * d,
            yi: 0.0,
            xj: -(e - tilt) * d,
            yj: 0.0,
            vxi: -sq * d * w,
            vyi: 0.0,
            vxj: -sq * d * w,
            vyj: 0.0,
            omega: w,
        });
    }
    out
}

/// Ladder shapes `n_theta/n_z` = 8 (today's at B/D = 0.5), 4 and 2: per grid the largest
/// true error of the load vector against the converged solution and the range of the
/// Richardson estimate ([`ladder_estimate`]) over it, max-film inlet on a node.
fn shapes() {
    let p = BearingParams {
        model: bearing_sweep::bearing::FilmModel::Finite,
        ..BearingParams::paper_table2()
    };
    let states = turned_states(&p);
    let mut refs = Vec::new();
    for s in &states {
        let packed = pack_state(&p, s).expect("valid state");
        let job = FiniteJob::new(&p, &packed);
        refs.push((
            job,
            FiniteSolver::new().reference(&job, &FiniteGrid::for_bearing(&p)),
        ));
    }
    for r in [8u32, 4, 2] {
        println!("shape {r}: | grid | nodes | largest true error | estimate / true (min-max) | states with estimate ≤ 5e-4 |");
        let mut values: Vec<Vec<[f64; 4]>> = vec![Vec::new(); states.len()];
        let mut nz = (16 / r).max(2);
        while nz * r <= 1024 && nz <= 256 {
            let nt = nz * r;
            let g = FiniteGrid::from(&FiniteSettings {
                tolerance: 1e-11,
                ..FiniteSettings::with_grid(nt, nz)
            });
            let mut solver = FiniteSolver::new();
            let (mut worst, mut lo, mut hi, mut met) = (0.0_f64, f64::INFINITY, 0.0_f64, 0);
            for (k, (job, want)) in refs.iter().enumerate() {
                let (got, _) = solver.solve(job, &g, &mut Vec::new());
                let norm = want.iter().map(|v| v * v).sum::<f64>().sqrt();
                let e = (0..4)
                    .map(|i| (got[i] - want[i]).powi(2))
                    .sum::<f64>()
                    .sqrt()
                    / norm;
                worst = worst.max(e);
                values[k].push(got);
                if let Some(est) = ladder_estimate(&values[k]) {
                    lo = lo.min(est / e);
                    hi = hi.max(est / e);
                    met += usize::from(est <= 5e-4);
                }
            }
            println!(
                "| {nt}×{nz} | {} | {worst:.2e} | {lo:.2} - {hi:.2} | {met} |",
                nt * (nz - 1)
            );
            nz *= 2;
        }
    }
}

/// Diagnostics: the multigrid kernel's tally of the last `n` states it solved (collected
/// under `BEARING_SWEEP_MG_COUNT`), mean and largest per state, as a markdown table.
fn print_tally(n: usize, label: &str) {
    #[cfg(feature = "gpu")]
    {
        if std::env::var_os("BEARING_SWEEP_MG_COUNT").is_none() {
            return;
        }
        let (names, rows) = bearing_sweep::backend::take_mg_tally();
        let rows = &rows[rows.len().saturating_sub(n)..];
        let m = rows.len().max(1) as f64;
        let stat = |f: &dyn Fn(&[f64]) -> f64| {
            let v: Vec<f64> = rows.iter().map(|r| f(r)).collect();
            (
                v.iter().sum::<f64>() / m,
                v.iter().fold(0.0_f64, |a, b| a.max(*b)),
            )
        };
        println!(
            "| {label}, {} states | mean per state | largest |",
            rows.len()
        );
        println!("|---|---|---|");
        let (a, b) = stat(&|r| r[..10].iter().sum());
        println!("| **chain: barriers, all parts** | **{a:.0}** | **{b:.0}** |");
        for (q, name) in names.iter().enumerate() {
            let (a, b) = stat(&|r| r[q]);
            println!("| {name} | {a:.1} | {b:.0} |");
        }
        // Loops over device memory: all counted iterations but the reductions' (workgroup
        // memory).
        let (a, b) = stat(&|r| r[21] - r[22]);
        println!("| **loop iters over device memory** | **{a:.0}** | **{b:.0}** |");
    }
    #[cfg(not(feature = "gpu"))]
    let _ = (n, label);
}

fn gpu(nt: u32, nz: u32, n_states: usize) {
    use bearing_sweep::backend::{FilmBackend, GpuBackend, GpuOptions, Precision};
    let options = GpuOptions {
        precision: Some(Precision::F64),
        ..GpuOptions::default()
    };
    let mut backend = match GpuBackend::new(bearing_sweep::bearing::Accuracy::default(), options) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("no f64 GPU adapter: {e}");
            return;
        }
    };
    let (p, states) = bench_states(n_states);
    let jobs: Vec<FiniteJob> = states
        .iter()
        .map(|s| FiniteJob::of_state(&p, &pack_state(&p, s).expect("valid state"), s.omega))
        .collect();
    let g = FiniteGrid::from(&FiniteSettings::with_grid(nt, nz));
    let (mut out, mut reports) = (Vec::new(), Vec::new());
    // A warm-up call (pipeline creation), then a timed one.
    let mut wall = 0.0;
    for _ in 0..2 {
        let mut fields = vec![Vec::new(); jobs.len()];
        let t = std::time::Instant::now();
        backend
            .integrate_finite(&jobs, &g, &mut fields, &mut out, &mut reports)
            .expect("the multigrid kernel runs");
        wall = t.elapsed().as_secs_f64();
    }
    print_tally(jobs.len(), &format!("{nt}×{nz}"));
    let mut solver = FiniteSolver::new();
    let (mut gsum, mut csum, mut diff, mut gmax) = (0u64, 0u64, 0.0_f64, 0u32);
    for (k, job) in jobs.iter().enumerate() {
        let (want, r) = solver.solve(job, &g, &mut Vec::new());
        csum += r.sweeps as u64;
        gsum += reports[k].sweeps as u64;
        gmax = gmax.max(reports[k].sweeps);
        let norm = want.iter().map(|v| v * v).sum::<f64>().sqrt();
        let d = (0..4)
            .map(|i| (out[k][i] - want[i]).powi(2))
            .sum::<f64>()
            .sqrt();
        diff = diff.max(d / norm);
    }
    let n = jobs.len() as f64;
    println!(
        "| {nt}×{nz} | GPU sweeps mean {:.1} (max {gmax}) | CPU {:.1} | max load diff {diff:.1e} | GPU call {:.1} ms, {} states |",
        gsum as f64 / n,
        csum as f64 / n,
        wall * 1e3,
        jobs.len()
    );
}

/// `mg_probe dump FILE [states]`: the multigrid kernel's loads and reports, as bits, for a
/// fixed set of settings (explicit 128 × 32 and 256 × 64 with both inlets, accuracy mode at
/// the default and 1e-3, a warm start; two supplied grooves at 128 × 32 with a warm start and
/// at accuracy 2e-3: the held bands), one line per state, to compare two kernel versions bit
/// for bit (`diff` the files; `BEARING_SWEEP_MG_WGSL` runs another kernel source).
fn dump(path: &str, n: usize) {
    use bearing_sweep::backend::{FilmBackend, GpuBackend, GpuOptions, Precision};
    use std::fmt::Write as _;
    let options = GpuOptions {
        precision: Some(Precision::F64),
        ..GpuOptions::default()
    };
    let mut backend = match GpuBackend::new(bearing_sweep::bearing::Accuracy::default(), options) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("no f64 GPU adapter: {e}");
            return;
        }
    };
    let (p0, states) = bench_states(n);
    let mut text = String::new();
    let explicit = |nt, nz, inlet| FiniteSettings {
        inlet,
        ..FiniteSettings::with_grid(nt, nz)
    };
    let cases: Vec<(String, FiniteSettings, bool)> = vec![
        ("128x32 max".into(), explicit(128, 32, Inlet::MaxFilm), true),
        ("128x32 none".into(), explicit(128, 32, Inlet::None), false),
        (
            "256x64 max".into(),
            explicit(256, 64, Inlet::MaxFilm),
            false,
        ),
        ("accuracy default".into(), FiniteSettings::default(), false),
        (
            "accuracy 1e-3 none".into(),
            FiniteSettings {
                accuracy: 1e-3,
                inlet: Inlet::None,
                ..FiniteSettings::default()
            },
            false,
        ),
    ];
    // Two supplied grooves (tests/finite_gpu_multigrid.rs `grooved`): the held bands.
    let grooves = bearing_sweep::bearing::Grooves::new(&[
        bearing_sweep::bearing::Groove {
            angle: 90.0,
            width: 20.0,
            supply_pressure: 2e4,
            length: None,
        },
        bearing_sweep::bearing::Groove {
            angle: 270.0,
            width: 20.0,
            supply_pressure: 2e4,
            length: None,
        },
    ])
    .expect("valid grooves");
    let mut cases: Vec<_> = cases
        .into_iter()
        .map(|(l, f, w)| (l, f, w, false))
        .collect();
    cases.push((
        "grooves 128x32 max".into(),
        explicit(128, 32, Inlet::MaxFilm),
        true,
        true,
    ));
    cases.push((
        "grooves accuracy 2e-3".into(),
        FiniteSettings {
            accuracy: 2e-3,
            ..FiniteSettings::default()
        },
        false,
        true,
    ));
    for (label, finite, warm_too, grooved) in cases {
        let p = BearingParams {
            model: bearing_sweep::bearing::FilmModel::Finite,
            finite,
            grooves: if grooved { grooves } else { p0.grooves },
            ..p0
        };
        let jobs: Vec<FiniteJob> = states
            .iter()
            .map(|s| FiniteJob::of_state(&p, &pack_state(&p, s).expect("valid state"), s.omega))
            .collect();
        let g = FiniteGrid::for_bearing(&p);
        let mut fields = vec![Vec::new(); jobs.len()];
        let rounds = if warm_too { 2 } else { 1 };
        for round in 0..rounds {
            let (mut out, mut reports) = (Vec::new(), Vec::new());
            backend
                .integrate_finite(&jobs, &g, &mut fields, &mut out, &mut reports)
                .expect("the multigrid kernel runs");
            for (k, (o, r)) in out.iter().zip(&reports).enumerate() {
                let _ = write!(text, "{label} round {round} state {k}:");
                for v in o {
                    let _ = write!(text, " {:016x}", v.to_bits());
                }
                let _ = writeln!(
                    text,
                    " sweeps {} err {:016x} conv {} grid {}x{} est {:016x} met {}",
                    r.sweeps,
                    r.iteration_error.to_bits(),
                    r.converged,
                    r.n_theta,
                    r.n_z,
                    r.error_estimate.to_bits(),
                    r.accuracy_met
                );
            }
            for (k, f) in fields.iter().enumerate() {
                let h = f.iter().fold(0u64, |h, v| {
                    h.rotate_left(5) ^ v.to_bits().wrapping_mul(0x9e37_79b9_7f4a_7c15)
                });
                let _ = writeln!(
                    text,
                    "{label} round {round} field {k}: len {} hash {h:016x}",
                    f.len()
                );
            }
        }
    }
    std::fs::write(path, text).expect("writable dump file");
}

/// `mg_probe acc ACCURACY [states]`: accuracy mode on the multigrid kernel against the CPU
/// solver: per state the grids reached and the relative difference of the load vectors.
fn gpu_acc(accuracy: f64, n: usize) {
    use bearing_sweep::backend::{FilmBackend, GpuBackend, GpuOptions, Precision};
    let options = GpuOptions {
        precision: Some(Precision::F64),
        ..GpuOptions::default()
    };
    let mut backend = match GpuBackend::new(bearing_sweep::bearing::Accuracy::default(), options) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("no f64 GPU adapter: {e}");
            return;
        }
    };
    let (p0, states) = bench_states(n);
    let p = BearingParams {
        model: bearing_sweep::bearing::FilmModel::Finite,
        finite: FiniteSettings {
            accuracy,
            ..FiniteSettings::default()
        },
        ..p0
    };
    let jobs: Vec<FiniteJob> = states
        .iter()
        .map(|s| FiniteJob::of_state(&p, &pack_state(&p, s).expect("valid state"), s.omega))
        .collect();
    let g = FiniteGrid::for_bearing(&p);
    // One warm-up call each (pipeline creation), then a timed one; the CPU backend on
    // all threads (rayon), as `finite --bench` runs it.
    let mut cpu_backend =
        bearing_sweep::backend::CpuBackend::new(bearing_sweep::bearing::Accuracy::default(), None);
    let run = |b: &mut dyn FilmBackend| {
        let mut fields = vec![Vec::new(); jobs.len()];
        let (mut out, mut reports) = (Vec::new(), Vec::new());
        b.integrate_finite(&jobs, &g, &mut fields, &mut out, &mut reports)
            .expect("the finite film runs");
        let t = std::time::Instant::now();
        let mut fields = vec![Vec::new(); jobs.len()];
        b.integrate_finite(&jobs, &g, &mut fields, &mut out, &mut reports)
            .expect("the finite film runs");
        (t.elapsed().as_secs_f64(), out, reports)
    };
    let (tg, out, reports) = run(&mut backend);
    print_tally(jobs.len(), &format!("accuracy {accuracy:e}"));
    let (tc, want, wr) = run(&mut cpu_backend);
    let nj = jobs.len() as f64;
    let mut diff = 0.0_f64;
    let mut top = 0;
    for k in 0..jobs.len() {
        let norm = want[k].iter().map(|v| v * v).sum::<f64>().sqrt();
        let d = (0..4)
            .map(|i| (out[k][i] - want[k][i]).powi(2))
            .sum::<f64>()
            .sqrt();
        diff = diff.max(d / norm);
        assert_eq!(
            (reports[k].n_theta, reports[k].n_z),
            (wr[k].n_theta, wr[k].n_z),
            "state {k}: GPU and CPU grids"
        );
        if reports[k].n_theta == 1024 {
            top += 1;
        }
    }
    let sweeps = |r: &[bearing_sweep::bearing::finite::SolveReport]| {
        r.iter().map(|r| r.sweeps as f64).sum::<f64>() / nj
    };
    println!(
        "| accuracy {accuracy:e} | {} states ({top} on 1024×128) | GPU {:.1} states/s, {:.1} sweeps | CPU {:.1} states/s, {:.1} sweeps | max load diff {diff:.1e} |",
        jobs.len(),
        nj / tg,
        sweeps(&reports),
        nj / tc,
        sweeps(&wr)
    );
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("gpu") {
        let nt = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(128);
        let nz = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(32);
        gpu(
            nt,
            nz,
            args.get(3).and_then(|s| s.parse().ok()).unwrap_or(32),
        );
        return;
    }
    if args.first().map(String::as_str) == Some("acc") {
        gpu_acc(
            args.get(1).and_then(|s| s.parse().ok()).unwrap_or(1e-4),
            args.get(2).and_then(|s| s.parse().ok()).unwrap_or(8),
        );
        return;
    }
    if args.first().map(String::as_str) == Some("dump") {
        let path = args.get(1).map_or("mg_dump.txt", String::as_str);
        dump(path, args.get(2).and_then(|s| s.parse().ok()).unwrap_or(8));
        return;
    }
    if args.first().map(String::as_str) == Some("shapes") {
        shapes();
        return;
    }
    if args.first().map(String::as_str) == Some("aniso") {
        aniso(args.get(1).and_then(|s| s.parse().ok()).unwrap_or(16));
        return;
    }
    let grids: Vec<(u32, u32)> = match (args.first(), args.get(1)) {
        (Some(a), Some(b)) => vec![(a.parse().expect("n_theta"), b.parse().expect("n_z"))],
        _ => vec![(64, 16), (128, 32), (256, 64)],
    };
    let inlet = match args.get(2).map(String::as_str) {
        Some("none") => Inlet::None,
        _ => Inlet::MaxFilm,
    };
    let n: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(32);
    let (p, states) = bench_states(n);
    let jobs: Vec<FiniteJob> = states
        .iter()
        .map(|s| FiniteJob::new(&p, &pack_state(&p, s).expect("valid state")))
        .collect();
    println!("| grid | inlet | MG sweeps mean (min-max) | max load diff | max field diff |");
    println!("|---|---|---|---|---|");
    for (t, z) in grids {
        let settings = FiniteSettings {
            inlet,
            ..FiniteSettings::with_grid(t, z)
        };
        let g = FiniteGrid::from(&settings);
        let tight = FiniteGrid {
            tolerance: 1e-13,
            ..g
        };
        let mut solver = FiniteSolver::new();
        let (mut sum, mut lo, mut hi) = (0u64, u32::MAX, 0u32);
        let (mut dl, mut df) = (0.0_f64, 0.0_f64);
        for job in &jobs {
            let mut want = Vec::new();
            let (wi, _) = solver.solve_psor(job, &tight, &mut want);
            let mut got = Vec::new();
            let (gi, r) = solver.solve(job, &g, &mut got);
            sum += r.sweeps as u64;
            if std::env::var("PROBE_EACH").is_ok() {
                eprint!(" {}", r.sweeps);
            }
            lo = lo.min(r.sweeps);
            hi = hi.max(r.sweeps);
            let norm = wi.iter().map(|v| v * v).sum::<f64>().sqrt();
            let d = (0..4).map(|k| (gi[k] - wi[k]).powi(2)).sum::<f64>().sqrt();
            dl = dl.max(d / norm);
            let fmax = want.iter().fold(0.0_f64, |m, v| m.max(*v));
            let fd = want
                .iter()
                .zip(&got)
                .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
            df = df.max(fd / fmax);
        }
        if std::env::var("PROBE_EACH").is_ok() {
            eprintln!();
        }
        println!(
            "| {t}×{z} | {inlet:?} | {:.1} ({lo}-{hi}) | {dl:.1e} | {df:.1e} |",
            sum as f64 / jobs.len() as f64
        );
    }
}
