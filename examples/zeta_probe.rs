//! Probe of the load sums and error estimates of the accuracy ladder (issue 20, cost at
//! the default accuracy, pass 4): on the 12 states of tests/finite_accuracy.rs, per ladder
//! grid, the true error of the load vector summed by several quadratures of the same
//! field, and the ratio of several error estimates to it.
//!
//! `cargo run --release --example zeta_probe` (modes: `where ACC…`, `cost ACC…`, `aniso`, `extrap`,
//! `split [rules]`, `work`, `cycles ACC…`, `fmg1`, `rules ACC LOOSE,cubic|linear,FLOOR…`,
//! `prof ACC LOOSE,cubic|linear,FLOOR [REPS]`: see each function)
use bearing_sweep::bearing::finite::{ladder_estimate, FiniteGrid, FiniteJob, FiniteSolver};
use bearing_sweep::bearing::{
    finish_loads, pack_state, BearingParams, BearingState, FilmModel, Packed,
};

#[path = "../tests/support/finite_states.rs"]
mod finite_states;

fn states(p: &BearingParams) -> Vec<(String, BearingState)> {
    finite_states::accuracy_states(p)
}

/// The probe's two state sets, each with its bearing: the 12 test states of
/// tests/finite_accuracy.rs on the paper bearing, and the finite benchmark's 32 states on
/// theirs, both with the finite film at accuracy `acc` (`None`: the default).
fn test_and_bench(acc: Option<f64>) -> [(BearingParams, Vec<BearingState>); 2] {
    use bearing_sweep::bearing::finite::FiniteSettings;
    let mut finite = FiniteSettings::default();
    if let Some(a) = acc {
        finite.accuracy = a;
    }
    let p = BearingParams {
        model: FilmModel::Finite,
        finite,
        ..BearingParams::paper_table2()
    };
    let (pb, bench) = bearing_sweep::bench::finite::bench_states(32);
    [
        (p, states(&p).into_iter().map(|x| x.1).collect()),
        (BearingParams { finite, ..pb }, bench),
    ]
}

fn norm(a: &[f64; 4]) -> f64 {
    a.iter().map(|x| x * x).sum::<f64>().sqrt()
}
fn dist(a: &[f64; 4], b: &[f64; 4]) -> f64 {
    (0..4).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
}

/// Row sums `(Σ p cos θ, Σ p sin θ)` per ζ row times Δθ.
fn rows(p: &[f64], nt: usize, nz: usize, theta0: f64) -> Vec<[f64; 2]> {
    let dt = 2.0 * std::f64::consts::PI / nt as f64;
    (0..=nz)
        .map(|j| {
            let (mut c, mut s) = (0.0, 0.0);
            for i in 0..nt {
                let th = theta0 + i as f64 * dt;
                c += p[j * nt + i] * th.cos();
                s += p[j * nt + i] * th.sin();
            }
            [c * dt, s * dt]
        })
        .collect()
}

/// [`rows`] plus the Euler–Maclaurin correction of the periodic trapezoid sum for the
/// derivative jump at node 0 (the inlet line): `−Δθ²/12 (f'(0⁻) − f'(0⁺))`, one-sided
/// third-order derivatives.
fn rows_em(p: &[f64], nt: usize, nz: usize, theta0: f64) -> Vec<[f64; 2]> {
    let dt = 2.0 * std::f64::consts::PI / nt as f64;
    let mut out = rows(p, nt, nz, theta0);
    for j in 0..=nz {
        for (c, trig) in [(0usize, f64::cos as fn(f64) -> f64), (1, f64::sin)] {
            let f = |i: isize| {
                let ii = i.rem_euclid(nt as isize) as usize;
                p[j * nt + ii] * trig(theta0 + i as f64 * dt)
            };
            let dp = (-11.0 * f(0) + 18.0 * f(1) - 9.0 * f(2) + 2.0 * f(3)) / (6.0 * dt);
            let dm = (11.0 * f(0) - 18.0 * f(-1) + 9.0 * f(-2) - 2.0 * f(-3)) / (6.0 * dt);
            out[j][c] -= dt * dt / 12.0 * (dm - dp);
        }
    }
    out
}

/// Quadrature in ζ of the four integrands (cos, sin, ζ cos, ζ sin) by rule `rule`:
/// 0 rectangle (= trapezoid), 1 Simpson, 2 trapezoid + Euler–Maclaurin end correction
/// with second-order one-sided derivatives, 3 same with third-order derivatives.
fn quad(r: &[[f64; 2]], nz: usize, rule: u32) -> [f64; 4] {
    let h = 1.0 / nz as f64;
    let f = |j: usize| -> [f64; 4] {
        let z = j as f64 * h;
        [r[j][0], r[j][1], z * r[j][0], z * r[j][1]]
    };
    let mut acc = [0.0; 4];
    for j in 1..nz {
        let w = match rule {
            1 => {
                if j % 2 == 1 {
                    4.0 / 3.0
                } else {
                    2.0 / 3.0
                }
            }
            _ => 1.0,
        };
        let v = f(j);
        for k in 0..4 {
            acc[k] += w * v[k] * h;
        }
    }
    if rule >= 2 && nz >= 4 {
        let (a0, a1, a2, a3) = (f(0), f(1), f(2), f(3));
        let (b0, b1, b2, b3) = (f(nz), f(nz - 1), f(nz - 2), f(nz - 3));
        for k in 0..4 {
            let (d0, d1) = if rule == 2 {
                (
                    (-3.0 * a0[k] + 4.0 * a1[k] - a2[k]) / (2.0 * h),
                    (3.0 * b0[k] - 4.0 * b1[k] + b2[k]) / (2.0 * h),
                )
            } else {
                (
                    (-11.0 * a0[k] + 18.0 * a1[k] - 9.0 * a2[k] + 2.0 * a3[k]) / (6.0 * h),
                    (11.0 * b0[k] - 18.0 * b1[k] + 9.0 * b2[k] - 2.0 * b3[k]) / (6.0 * h),
                )
            };
            acc[k] -= h * h / 12.0 * (d1 - d0);
        }
    }
    acc.map(|v| -v / 3.0)
}

const RULES: [&str; 6] = ["rect", "simpson", "EM2", "EM3", "EM3+th", "simp+th"];

/// The states turned so that the maximum film is at θ = 0 (a node of explicit grids):
/// Simpson-summed error on grids refined in one direction at a time.
fn aniso() {
    use bearing_sweep::bearing::finite::FiniteSettings;
    let p = BearingParams {
        model: FilmModel::Finite,
        ..BearingParams::paper_table2()
    };
    let g = FiniteGrid::for_bearing(&p);
    let shapes: [(&str, Vec<(usize, usize)>); 2] = [
        (
            "8",
            vec![(16, 2), (32, 4), (64, 8), (128, 16), (256, 32), (512, 64)],
        ),
        (
            "4",
            vec![(16, 4), (32, 8), (64, 16), (128, 32), (256, 64), (512, 128)],
        ),
    ];
    let accs = [1e-2, 2e-3, 1e-3, 5e-4];
    for (name, grids) in &shapes {
        println!("shape {name}:");
        let mut worst = vec![(0.0_f64, f64::INFINITY, 0.0_f64); accs.len()];
        for (label, s0) in states(&p) {
            // Eccentricity along −x: the maximum film arg(−ε) is at θ = 0.
            let r = |x: f64, y: f64| -(x.hypot(y));
            let s = BearingState {
                xi: r(s0.xi, s0.yi),
                yi: 0.0,
                xj: r(s0.xj, s0.yj),
                yj: 0.0,
                vxi: r(s0.vxi, s0.vyi) * (s0.vxi.signum() * s0.xi.signum()),
                vyi: 0.0,
                vxj: r(s0.vxj, s0.vyj) * (s0.vxj.signum() * s0.xj.signum()),
                vyj: 0.0,
                ..s0
            };
            let packed: Packed = pack_state(&p, &s).unwrap();
            let job = FiniteJob::new(&p, &packed);
            let lv = |ints: &[f64; 4]| {
                finish_loads(&p, &s, ints, packed.rate_scale).load_vector(p.length)
            };
            let mut solver = FiniteSolver::new();
            let truth = lv(&solver.reference(&job, &g));
            let tn = norm(&truth);
            let mut vals = Vec::new();
            print!("{label:14}");
            for &(nt, nz) in grids {
                let gg = FiniteGrid::from(&FiniteSettings {
                    tolerance: 1e-11,
                    ..FiniteSettings::with_grid(nt as u32, nz as u32)
                });
                let mut f = Vec::new();
                let _ = solver.solve(&job, &gg, &mut f);
                let sim = lv(&quad(&rows(&f, nt, nz, 0.0), nz, 1));
                let err = dist(&sim, &truth) / tn;
                let est = vals
                    .last()
                    .map(|v: &[f64; 4]| dist(&sim, v) / 3.0 / norm(&sim))
                    .unwrap_or(f64::INFINITY);
                print!(" {err:.1e}/{:.2}", est / err);
                vals.push(sim);
                let _ = est;
            }
            // stop simulation (estimate from the third grid on)
            for (a, &acc) in accs.iter().enumerate() {
                for l in 2..vals.len() {
                    let est = dist(&vals[l], &vals[l - 1]) / 3.0 / norm(&vals[l]);
                    if est <= acc {
                        let err = dist(&vals[l], &truth) / tn;
                        print!(
                            " | {acc:.0e}: {}x{} err {err:.1e} r {:.2}",
                            grids[l].0,
                            grids[l].1,
                            est / err
                        );
                        worst[a].0 = worst[a].0.max(err);
                        worst[a].1 = worst[a].1.min(est / err);
                        worst[a].2 = worst[a].2.max(est / err);
                        break;
                    }
                }
            }
            println!();
        }
        for (a, &acc) in accs.iter().enumerate() {
            println!(
                "  acc {acc:.0e}: largest true {:.2e}, estimate/true {:.2}-{:.2}",
                worst[a].0, worst[a].1, worst[a].2
            );
        }
    }
}

/// The solver as it runs (accuracy mode) on the 12 test states and the 32 states of the
/// finite benchmark, at accuracy `acc`: per state the grid, node updates, estimate and
/// true error against [`FiniteSolver::reference`]; median and largest updates, largest
/// error, range of estimate / true error.
fn cost(acc: f64) {
    let [(pt, test), (pb, bench)] = test_and_bench(Some(acc));
    let sets = [("test set (12)", pt, test), ("bench set (32)", pb, bench)];
    for (name, p, states) in sets {
        let g = FiniteGrid::for_bearing(&p);
        let (mut ups, mut errs, mut ratios) = (Vec::new(), Vec::new(), Vec::new());
        let mut moved: Vec<(f64, f64)> = Vec::new();
        let mut grids = std::collections::BTreeMap::new();
        for s in &states {
            let packed: Packed = pack_state(&p, s).unwrap();
            let job = FiniteJob::new(&p, &packed);
            let lv = |ints: &[f64; 4]| {
                finish_loads(&p, s, ints, packed.rate_scale).load_vector(p.length)
            };
            let mut solver = FiniteSolver::new();
            let truth = lv(&solver.reference(&job, &g));
            let (ints, r) = solver.solve(&job, &g, &mut Vec::new());
            let err = dist(&lv(&ints), &truth) / norm(&truth);
            // The loads before pass 4: the same ladder, rectangle sums, stopped where the
            // measured-contraction estimate is at most `acc` (its per-grid stop measured
            // on the Simpson loads instead: within 2 % of the accuracy).
            let steps = solver.ladder(&job, &g, 0.02 * acc, true, usize::MAX);
            let rect: Vec<[f64; 4]> = steps.iter().map(|t| t.rectangle).collect();
            let mut old = None;
            for l in 2..rect.len() {
                let e = ladder_estimate(&rect[..=l]).unwrap();
                if e <= acc || l + 1 == rect.len() {
                    old = Some((lv(&rect[l]), e));
                    break;
                }
            }
            let (old, old_est) = old.expect("three grids");
            moved.push((dist(&lv(&ints), &old) / norm(&truth), old_est));
            ups.push(r.sweeps as u64 * (r.n_theta as u64 * (r.n_z as u64 - 1)));
            errs.push(err);
            ratios.push(r.error_estimate / err);
            *grids.entry((r.n_theta, r.n_z)).or_insert(0) += 1;
        }
        ups.sort();
        errs.sort_by(f64::total_cmp);
        ratios.sort_by(f64::total_cmp);
        println!(
            "{name} accuracy {acc:e}: node updates median {} mean {:.0} max {}; true error median {:.2e} max {:.2e}; estimate/true {:.2}-{:.2}; grids {grids:?}",
            ups[ups.len() / 2],
            ups.iter().sum::<u64>() as f64 / ups.len() as f64,
            ups[ups.len() - 1],
            errs[errs.len() / 2],
            errs[errs.len() - 1],
            ratios[0],
            ratios[ratios.len() - 1]
        );
        let worst = moved.iter().map(|m| m.0 / m.1).fold(0.0, f64::max);
        let largest = moved.iter().map(|m| m.0).fold(0.0, f64::max);
        println!("   loads moved from the pre-pass-4 solver's: largest {largest:.2e}, largest over the old estimate {worst:.2}");
    }
}

/// Richardson-extrapolated ladder loads (issue 20, session 35): on the 12 test states and
/// the 32 benchmark states, per ladder grid (fields at the default's per-grid stop,
/// accuracy 5e-4 × 0.02 on the loads), the true error of the Simpson-summed loads `v` and
/// of their extrapolate `R = (4 v₀ − v₋₁)/3`, and candidate estimates of R's error over
/// the true one; the reference's own uncertainty (rectangle- against Simpson-summed
/// extrapolates of 1024 × 128 / 512 × 64).
fn extrap() {
    let p = BearingParams {
        model: FilmModel::Finite,
        ..BearingParams::paper_table2()
    };
    let (pb, bench) = bearing_sweep::bench::finite::bench_states(32);
    let mut all: Vec<(String, BearingParams, BearingState)> =
        states(&p).into_iter().map(|(l, s)| (l, p, s)).collect();
    for (k, s) in bench.into_iter().enumerate() {
        all.push((
            format!("bench {k}"),
            BearingParams {
                finite: p.finite,
                ..pb
            },
            s,
        ));
    }
    for (label, p, s) in all {
        let g = FiniteGrid::for_bearing(&p);
        let packed: Packed = pack_state(&p, &s).unwrap();
        let job = FiniteJob::new(&p, &packed);
        let lv =
            |ints: &[f64; 4]| finish_loads(&p, &s, ints, packed.rate_scale).load_vector(p.length);
        let mut solver = FiniteSolver::new();
        let tight = solver.ladder(&job, &g, 1e-10, false, usize::MAX);
        let n = tight.len();
        let ext = |f: [f64; 4], c: [f64; 4]| -> [f64; 4] {
            std::array::from_fn(|k| (4.0 * f[k] - c[k]) / 3.0)
        };
        let truth = ext(lv(&tight[n - 1].rectangle), lv(&tight[n - 2].rectangle));
        let truth_s = ext(lv(&tight[n - 1].integrals), lv(&tight[n - 2].integrals));
        let tn = norm(&truth);
        let steps = solver.ladder(&job, &g, 0.02 * 5e-4, true, 6);
        let v: Vec<[f64; 4]> = steps.iter().map(|t| lv(&t.integrals)).collect();
        print!("{label:28} ref {:.1e}", dist(&truth, &truth_s) / tn);
        let r: Vec<[f64; 4]> = (1..v.len()).map(|l| ext(v[l], v[l - 1])).collect();
        for l in 2..v.len() {
            let ev = dist(&v[l], &truth) / tn;
            let est_v = dist(&v[l], &v[l - 1]) / 3.0 / norm(&v[l]);
            let rl = r[l - 1];
            let er = dist(&rl, &truth) / tn;
            let dr = dist(&rl, &r[l - 2]) / norm(&rl);
            print!(
                " | {}x{} u{} v {:.1e} ({:.2}) R {:.1e} dR {:.1e} ({:.2})",
                steps[l].n_theta,
                steps[l].n_z,
                steps[l].updates,
                ev,
                est_v / ev,
                er,
                dr,
                dr / er
            );
        }
        println!();
    }
}

/// Where the error sits, per direction (issue 20, session 35): the 12 test states and
/// the 32 benchmark states turned so that the mid-plane's maximum film is at θ = 0 (node 0
/// of explicit grids: the inlet line on the grid, as on the ladder), solved on explicit
/// grids to 1e-11 and summed by Simpson in ζ. Per ladder grid `nt × nz` of the state's
/// default stop region: the true error of `v(nt, nz)`, of the ζ-refined `v(nt, 2nz)`, the
/// θ-refined `v(2nt, nz)`, the ζ-extrapolate `Rζ = (4 v(nt, nz) − v(nt, nz/2))/3`, the
/// two-direction extrapolate `(5 v − v(nt, nz/2) − v(nt/2, nz))/3`, and the one-direction
/// Richardson terms `dθ = |v − v(nt/2, nz)|/3`, `dζ = |v − v(nt, nz/2)|/3` (relative).
fn split() {
    use bearing_sweep::bearing::finite::FiniteSettings;
    let p = BearingParams {
        model: FilmModel::Finite,
        ..BearingParams::paper_table2()
    };
    let (pb, bench) = bearing_sweep::bench::finite::bench_states(32);
    let mut all: Vec<(String, BearingParams, BearingState)> =
        states(&p).into_iter().map(|(l, s)| (l, p, s)).collect();
    for (k, s) in bench.into_iter().enumerate() {
        let b = BearingParams {
            finite: p.finite,
            ..pb
        };
        all.push((format!("bench {k}"), b, s));
    }
    for (label, p, s0) in all {
        // Turn every vector by π − φ, φ the mid-plane eccentricity's angle.
        let phi = (0.5 * (s0.yi + s0.yj)).atan2(0.5 * (s0.xi + s0.xj));
        let (c, sn) = (
            (std::f64::consts::PI - phi).cos(),
            (std::f64::consts::PI - phi).sin(),
        );
        let rot = |x: f64, y: f64| (x * c - y * sn, x * sn + y * c);
        let (xi, yi) = rot(s0.xi, s0.yi);
        let (xj, yj) = rot(s0.xj, s0.yj);
        let (vxi, vyi) = rot(s0.vxi, s0.vyi);
        let (vxj, vyj) = rot(s0.vxj, s0.vyj);
        let s = BearingState {
            xi,
            yi,
            xj,
            yj,
            vxi,
            vyi,
            vxj,
            vyj,
            ..s0
        };
        let g = FiniteGrid::for_bearing(&p);
        let packed: Packed = pack_state(&p, &s).unwrap();
        let job = FiniteJob::new(&p, &packed);
        let lv =
            |ints: &[f64; 4]| finish_loads(&p, &s, ints, packed.rate_scale).load_vector(p.length);
        let mut solver = FiniteSolver::new();
        let truth = lv(&solver.reference(&job, &g));
        let tn = norm(&truth);
        let mut solve = |nt: usize, nz: usize| {
            let gg = FiniteGrid::from(&FiniteSettings {
                tolerance: 1e-11,
                ..FiniteSettings::with_grid(nt as u32, nz as u32)
            });
            let mut f = Vec::new();
            let _ = solver.solve(&job, &gg, &mut f);
            lv(&quad(&rows(&f, nt, nz, 0.0), nz, 1))
        };
        print!("{label:28}");
        if std::env::args().nth(2).as_deref() == Some("rules") {
            // Candidate ladders from 32 × 4 on: the estimate |v₀ − v₋₁|/3 against the
            // true error of v₀ at each accuracy's stopping grid.
            let grids = [
                (32, 4),
                (64, 8),
                (128, 16),
                (128, 32),
                (256, 32),
                (256, 64),
                (512, 64),
                (512, 128),
            ];
            let vals: Vec<[f64; 4]> = grids.iter().map(|&(a, b)| solve(a, b)).collect();
            let at = |d: (usize, usize)| grids.iter().position(|&x| x == d).unwrap();
            let rules: [(&str, &[(usize, usize)]); 2] = [
                ("now", &[(32, 4), (64, 8), (128, 16), (256, 32), (512, 64)]),
                (
                    "z-step",
                    &[
                        (32, 4),
                        (64, 8),
                        (128, 16),
                        (128, 32),
                        (256, 64),
                        (512, 128),
                    ],
                ),
            ];
            for (name, seq) in rules {
                print!(" | {name}:");
                for acc in [2e-3, 1e-3, 5e-4, 1e-4] {
                    let mut out = None;
                    for l in 1..seq.len() {
                        let (v, w) = (&vals[at(seq[l])], &vals[at(seq[l - 1])]);
                        let est = dist(v, w) / 3.0 / norm(v);
                        if est <= acc || l + 1 == seq.len() {
                            out = Some((seq[l], est, dist(v, &truth) / tn));
                            break;
                        }
                    }
                    let (g, est, e) = out.unwrap();
                    print!(" {acc:.0e}:{}x{} e {e:.1e} r {:.2}", g.0, g.1, est / e);
                }
            }
            // the ζ step with a measured ζ contraction ρ = |v(128×32) − v(128×16)| /
            // |v(128×16) − v(128×8)| (clamped to [0.05, 0.8]): tail d₂ ρ/(1 − ρ)
            {
                let v8 = solve(128, 8);
                let (v16, v32) = (&vals[at((128, 16))], &vals[at((128, 32))]);
                let (d1, d2) = (dist(v16, &v8), dist(v32, v16));
                let rho = (d2 / d1).clamp(0.05, 0.8);
                let e = dist(v32, &truth) / tn;
                print!(
                    " | 128x32 rho {rho:.2} tail/true {:.2}",
                    d2 * rho / (1.0 - rho) / norm(v32) / e
                );
            }
            // Session 37: the two-direction model `E = A/n_θ² + B/n_z²` fitted on
            // v(n/2 × m/2), v(n × m), v(n × 2m): the error of v(n × 2m) is
            // `(v(n/2×m/2) − v(n×m))/3 − (v(n×m) − v(n×2m))` (vectors).
            for (c, m, f) in [
                ((64, 8), (128, 16), (128, 32)),
                ((128, 16), (256, 32), (256, 64)),
            ] {
                let (vc, vm, vf) = (&vals[at(c)], &vals[at(m)], &vals[at(f)]);
                let est: [f64; 4] =
                    std::array::from_fn(|k| (vc[k] - vm[k]) / 3.0 - (vm[k] - vf[k]));
                let e = dist(vf, &truth) / tn;
                print!(
                    " | 2d {}x{} e {e:.1e} r {:.2}",
                    f.0,
                    f.1,
                    norm(&est) / norm(vf) / e
                );
            }
            // Session 37: steps of 1.5 (192 × 24 after 128 × 16, 384 × 48 after 256 × 32,
            // off the nested ladder): their error and the Richardson estimate
            // |v − v(coarse)| / (1.5² − 1) over it.
            for (f, c) in [((192, 24), (128, 16)), ((384, 48), (256, 32))] {
                let v = solve(f.0, f.1);
                let w = &vals[at(c)];
                let e = dist(&v, &truth) / tn;
                print!(
                    " | 1.5 {}x{} e {e:.1e} r {:.2}",
                    f.0,
                    f.1,
                    dist(&v, w) / 1.25 / norm(&v) / e
                );
            }
            // the ζ step's own ratio at 128 × 32, 256 × 64
            for (f, c) in [((128, 32), (128, 16)), ((256, 64), (128, 32))] {
                let (v, w) = (&vals[at(f)], &vals[at(c)]);
                let e = dist(v, &truth) / tn;
                print!(
                    " | {}x{} e {e:.1e} r {:.2}",
                    f.0,
                    f.1,
                    dist(v, w) / 3.0 / norm(v) / e
                );
            }
            println!();
            continue;
        }
        for (nt, nz) in [(64, 8), (128, 16), (256, 32)] {
            let v = solve(nt, nz);
            let vz = solve(nt, nz / 2);
            let vt = solve(nt / 2, nz);
            let fz = solve(nt, 2 * nz);
            let ft = solve(2 * nt, nz);
            let rz: [f64; 4] = std::array::from_fn(|k| (4.0 * v[k] - vz[k]) / 3.0);
            let rc: [f64; 4] = std::array::from_fn(|k| (5.0 * v[k] - vz[k] - vt[k]) / 3.0);
            let e = |x: &[f64; 4]| dist(x, &truth) / tn;
            print!(
                " | {nt}x{nz} v {:.1e} 2z {:.1e} 2t {:.1e} Rz {:.1e} Rc {:.1e} dt {:.1e} dz {:.1e}",
                e(&v),
                e(&fz),
                e(&ft),
                e(&rz),
                e(&rc),
                dist(&v, &vt) / 3.0 / norm(&v),
                dist(&v, &vz) / 3.0 / norm(&v)
            );
        }
        println!();
    }
}

/// Work of the ladder against its per-grid stop (issue 20, session 35): on the 12 test
/// states and the 32 benchmark states, the ladder's node updates up to 128 × 16 and
/// 256 × 32 with each grid iterated until the load vector's estimated iteration error is
/// below `fraction × 5e-4` (the solver: 0.02), and the iteration error that leaves in the
/// loads of 128 × 16 (against the same grid at 1e-10) and in its estimate
/// `|v₀ − v₋₁|/3`, relative to the accuracy 5e-4.
fn work() {
    let all: Vec<(BearingParams, BearingState)> = test_and_bench(None)
        .into_iter()
        .flat_map(|(p, states)| states.into_iter().map(move |s| (p, s)))
        .collect();
    let acc = 5e-4;
    for frac in [0.02, 0.05, 0.1, 0.2, 0.5] {
        let (mut u16, mut u32_, mut dv, mut de) = (Vec::new(), Vec::new(), 0.0_f64, 0.0_f64);
        for (p, s) in &all {
            let g = FiniteGrid::for_bearing(p);
            let packed: Packed = pack_state(p, s).unwrap();
            let job = FiniteJob::new(p, &packed);
            let lv =
                |ints: &[f64; 4]| finish_loads(p, s, ints, packed.rate_scale).load_vector(p.length);
            let mut solver = FiniteSolver::new();
            let tight = solver.ladder(&job, &g, 1e-10, false, 5);
            let loose = solver.ladder(&job, &g, frac * acc, true, 5);
            u16.push(loose[3].updates);
            u32_.push(loose[4].updates);
            let (t3, t2, l3, l2) = (
                lv(&tight[3].integrals),
                lv(&tight[2].integrals),
                lv(&loose[3].integrals),
                lv(&loose[2].integrals),
            );
            let n = norm(&t3);
            dv = dv.max(dist(&l3, &t3) / n / acc);
            de = de.max((dist(&l3, &l2) - dist(&t3, &t2)).abs() / 3.0 / n / acc);
        }
        u16.sort();
        u32_.sort();
        println!(
            "fraction {frac}: updates to 128x16 median {} max {}; to 256x32 median {} max {}; 128x16 loads' iteration error up to {dv:.3} of the accuracy, its estimate moved up to {de:.3} of it",
            u16[u16.len() / 2], u16[u16.len() - 1], u32_[u32_.len() / 2], u32_[u32_.len() - 1]
        );
    }
}

/// Cycles per ladder grid (issue 20, session 36): on the 32 benchmark states at accuracy
/// `acc`, the ladder as the solver runs it (`FiniteSolver::ladder`, each grid to
/// accuracy/10 on the loads) up to 512 × 64: per grid the V-cycles, the node updates it
/// added, the relative load change from the grid below `d` and the estimate `d/3`; a `*`
/// marks the grid where the solver stops. Then the mean node updates per grid.
fn cycles(acc: f64) {
    use bearing_sweep::bearing::finite::FiniteSettings;
    let (pb, bench) = bearing_sweep::bench::finite::bench_states(32);
    let p = BearingParams {
        model: FilmModel::Finite,
        finite: FiniteSettings {
            accuracy: acc,
            ..FiniteSettings::default()
        },
        ..pb
    };
    let g = FiniteGrid::for_bearing(&p);
    let mut sum = [0u64; 6];
    for (k, s) in bench.iter().enumerate() {
        let packed: Packed = pack_state(&p, s).unwrap();
        let job = FiniteJob::new(&p, &packed);
        let mut solver = FiniteSolver::new();
        let (_, r) = solver.solve(&job, &g, &mut Vec::new());
        let steps = solver.ladder(&job, &g, 0.1 * acc, true, 6);
        print!("{k:2}:");
        let mut last = 0;
        for (l, st) in steps.iter().enumerate() {
            let d = if l > 0 {
                dist(&st.integrals, &steps[l - 1].integrals) / norm(&st.integrals)
            } else {
                f64::NAN
            };
            let mark = if st.n_theta == r.n_theta as usize {
                "*"
            } else {
                ""
            };
            print!(
                " | {}x{}{mark} c{} u{} d{:.1e} e{:.1e}",
                st.n_theta,
                st.n_z,
                st.result.0,
                st.updates - last,
                d,
                d / 3.0
            );
            if st.n_theta <= r.n_theta as usize {
                sum[l] += st.updates - last;
            }
            last = st.updates;
        }
        println!();
    }
    let n = bench.len() as f64;
    let means: Vec<String> = sum
        .iter()
        .map(|s| format!("{:.0}", *s as f64 / n))
        .collect();
    println!(
        "mean updates per state on each ladder grid (as the solver stops): {}; total {:.0}",
        means.join(" "),
        sum.iter().sum::<u64>() as f64 / n
    );
}

/// Pure full multigrid on the ladder (issue 20, session 36): on the 12 test and 32
/// benchmark states, each ladder grid iterated by one V-cycle from the interpolated grid
/// below (a per-grid stop of 1 on the loads ends every grid after its first cycle)
/// against the same ladder iterated to 1e-10: per grid, the largest iteration error of the
/// loads `δ` relative to the next grid's load difference `d₊` (what an intermediate grid's
/// error enters the estimate through) and to the accuracy 5e-4, and the largest relative
/// move of the estimate `|v₀ − v₋₁|/3`.
fn fmg1() {
    let all: Vec<(BearingParams, BearingState)> = test_and_bench(None)
        .into_iter()
        .flat_map(|(p, states)| states.into_iter().map(move |s| (p, s)))
        .collect();
    let nl = 6;
    let mut worst = vec![(0.0_f64, 0.0_f64, 0.0_f64, 0.0_f64); nl];
    for (p, s) in &all {
        let g = FiniteGrid::for_bearing(p);
        let packed: Packed = pack_state(p, s).unwrap();
        let job = FiniteJob::new(p, &packed);
        let mut solver = FiniteSolver::new();
        let tight = solver.ladder(&job, &g, 1e-10, false, nl);
        let one = solver.ladder(&job, &g, 1.0, true, nl);
        for l in 0..nl {
            let n = norm(&tight[l].integrals);
            let delta = dist(&one[l].integrals, &tight[l].integrals) / n;
            let dnext = if l + 1 < nl {
                dist(&tight[l + 1].integrals, &tight[l].integrals) / n
            } else {
                f64::NAN
            };
            let de = if l > 0 {
                let a = dist(&one[l].integrals, &one[l - 1].integrals);
                let b = dist(&tight[l].integrals, &tight[l - 1].integrals);
                ((a - b) / b).abs()
            } else {
                0.0
            };
            let w = &mut worst[l];
            w.0 = w.0.max(delta / dnext);
            w.1 = w.1.max(delta / 5e-4);
            w.2 = w.2.max(de);
            w.3 = w.3.max(delta);
        }
    }
    for (l, w) in worst.iter().enumerate() {
        println!(
            "grid {l}: one-cycle load error δ up to {:.3e} ({:.3} of 5e-4, {:.3} of the next grid's difference); estimate moved up to {:.3} of itself",
            w.3, w.1, w.0, w.2
        );
    }
}

/// The ladder's per-grid stop rule against the one before (issue 20, session 36): on the
/// 32 benchmark and the 12 test states at accuracy `acc`, for each [`LadderRule`] variant
/// (`loose` 0 = every grid to accuracy/10; the bilinear or cubic start), node updates per
/// state (median, mean, largest), the mean V-cycles and node updates per ladder grid, the
/// largest true error against [`FiniteSolver::reference`], the range of estimate / true
/// error, and the largest distance of the returned loads from the same grid iterated to
/// 1e-10 over the accuracy (tests/finite_accuracy.rs allows 0.25).
fn rules(acc: f64) {
    use bearing_sweep::bearing::finite::LadderRule;
    let [(pt, test), (pb, bench)] = test_and_bench(Some(acc));
    let sets = [("bench (32)", pb, bench), ("test (12)", pt, test)];
    let variants: Vec<LadderRule> = std::env::args().skip(3).map(|a| rule_of(&a)).collect();
    for (name, p, states) in sets {
        let g = FiniteGrid::for_bearing(&p);
        let mut refs = Vec::new();
        for s in &states {
            let packed: Packed = pack_state(&p, s).unwrap();
            let job = FiniteJob::new(&p, &packed);
            let mut solver = FiniteSolver::new();
            let r = solver.reference(&job, &g);
            let tight = solver.ladder(&job, &g, 1e-10, false, 7);
            refs.push((r, tight));
        }
        for &rule in &variants {
            let LadderRule {
                loose,
                cubic_start,
                floor,
                ..
            } = rule;
            let (mut ups, mut errs, mut ratios, mut tightd) =
                (Vec::new(), Vec::new(), Vec::new(), 0.0_f64);
            let mut per = [(0u64, 0u64); 7];
            // Per grid: largest iteration error of the loads over the next grid's (tight)
            // difference, and the range of the stop's estimate over the iteration error.
            let mut iter_err = [(0.0_f64, f64::INFINITY, 0.0_f64); 7];
            for (s, (r, tight)) in states.iter().zip(&refs) {
                let packed: Packed = pack_state(&p, s).unwrap();
                let job = FiniteJob::new(&p, &packed);
                let lv =
                    |i: &[f64; 4]| finish_loads(&p, s, i, packed.rate_scale).load_vector(p.length);
                let mut solver = FiniteSolver::new();
                solver.ladder_rule = rule;
                solver.coarsest =
                    bearing_sweep::bench::finite::coarsest_from_env("ZETA_PROBE_COARSEST");
                solver.below_top = bearing_sweep::bench::finite::below_from_env("ZETA_PROBE_BELOW");
                let (ints, rep) = solver.solve(&job, &g, &mut Vec::new());
                for (l, st) in solver.trace.iter().enumerate() {
                    let t = &tight[l].integrals;
                    let e = dist(&st.integrals, t) / norm(t);
                    if l + 1 < tight.len() {
                        let dn = dist(&tight[l + 1].integrals, t) / norm(t);
                        iter_err[l].0 = iter_err[l].0.max(e / dn);
                    }
                    if l > 0 && e > 0.0 {
                        let r = st.result.1 / e;
                        iter_err[l].1 = iter_err[l].1.min(r);
                        iter_err[l].2 = iter_err[l].2.max(r);
                    }
                }
                let truth = lv(r);
                let err = dist(&lv(&ints), &truth) / norm(&truth);
                errs.push(err);
                ratios.push(rep.error_estimate / err);
                let same = tight
                    .iter()
                    .find(|t| t.n_theta == rep.n_theta as usize)
                    .expect("on the ladder");
                tightd = tightd.max(dist(&ints, &same.integrals) / norm(&same.integrals) / acc);
                if std::env::var_os("ZETA_PROBE_VERBOSE").is_some() {
                    let t: Vec<String> = solver
                        .trace
                        .iter()
                        .map(|st| {
                            format!(
                                "{}x{} c{} e{:.1e}",
                                st.n_theta, st.n_z, st.result.0, st.result.1
                            )
                        })
                        .collect();
                    println!(
                        "  err {err:.2e} est {:.2e}: {}",
                        rep.error_estimate,
                        t.join(" | ")
                    );
                }
                let mut last = 0;
                for (l, st) in solver.trace.iter().enumerate() {
                    per[l].0 += st.result.0 as u64;
                    per[l].1 += st.updates - last;
                    last = st.updates;
                }
                ups.push(last);
            }
            ups.sort();
            errs.sort_by(f64::total_cmp);
            ratios.sort_by(f64::total_cmp);
            let n = states.len() as f64;
            let grids: Vec<String> = per
                .iter()
                .map(|(c, u)| format!("{:.2}c/{:.0}", *c as f64 / n, *u as f64 / n))
                .collect();
            println!(
                "{name} acc {acc:e} loose {loose} cubic {cubic_start} floor {floor}: updates median {} mean {:.0} max {}; error max {:.2e}; est/true {:.2}-{:.2}; from tight {:.3} acc; per grid {}",
                ups[ups.len() / 2],
                ups.iter().sum::<u64>() as f64 / n,
                ups[ups.len() - 1],
                errs[errs.len() - 1],
                ratios[0],
                ratios[ratios.len() - 1],
                tightd,
                grids.join(" ")
            );
            let it: Vec<String> = iter_err
                .iter()
                .take_while(|x| x.1.is_finite() || x.0 > 0.0)
                .map(|(a, b, c)| format!("{a:.3}/{b:.2}-{c:.2}"))
                .collect();
            println!(
                "   per grid: iteration error over the next grid's difference (largest) / stop estimate over iteration error: {}",
                it.join(" ")
            );
        }
    }
}

/// A ladder rule from `LOOSE,cubic|linear[,FLOOR]` (see [`LadderRule`]; FLOOR default 0.1).
fn rule_of(a: &str) -> bearing_sweep::bearing::finite::LadderRule {
    let v: Vec<&str> = a.split(',').collect();
    bearing_sweep::bearing::finite::LadderRule {
        loose: v[0].parse().expect("LOOSE"),
        cubic_start: v[1] == "cubic",
        floor: v.get(2).map_or(0.1, |f| f.parse().expect("FLOOR")),
        // Post-smoothing sweeps of the ladder's cycles (session 42): `ZETA_PROBE_POST`,
        // else the default.
        post: std::env::var("ZETA_PROBE_POST")
            .map_or(bearing_sweep::bearing::finite::LADDER_POST_SWEEPS, |v| {
                v.parse().expect("ZETA_PROBE_POST: a count")
            }),
        // `ZETA_PROBE_LAST=0`: the grid that ends the ladder may stop after one cycle.
        measured_last: std::env::var("ZETA_PROBE_LAST")
            .map_or(bearing_sweep::bearing::finite::LADDER_MEASURED_LAST, |v| {
                v != "0"
            }),
    }
}

/// One rule, the solves only (for `valgrind --tool=callgrind`; issue 20, session 36): the 32
/// benchmark states at accuracy `acc`, cold starts, one solver, with the ladder rule
/// `LOOSE,cubic|linear,FLOOR[,REPS]` or `... RULE REPS` (`0,linear,0.1`: the rule before
/// session 36 on the same binary; wall per state the best of REPS, default 1); prints the exact node updates per state (the solver's trace) and those the
/// report's whole sweeps give (`mg_cost`'s count).
fn prof(acc: f64, rule: &str) {
    use bearing_sweep::bearing::finite::FiniteSettings;
    let (pb, bench) = bearing_sweep::bench::finite::bench_states(32);
    let p = BearingParams {
        finite: FiniteSettings {
            accuracy: acc,
            ..FiniteSettings::default()
        },
        ..pb
    };
    let v: Vec<&str> = rule.split(',').collect();
    let mut solver = FiniteSolver::new();
    solver.ladder_rule = rule_of(rule);
    solver.coarsest = bearing_sweep::bench::finite::coarsest_from_env("ZETA_PROBE_COARSEST");
    solver.below_top = bearing_sweep::bench::finite::below_from_env("ZETA_PROBE_BELOW");
    let g = FiniteGrid::for_bearing(&p);
    let jobs: Vec<FiniteJob> = bench
        .iter()
        .map(|s| FiniteJob::new(&p, &pack_state(&p, s).unwrap()))
        .collect();
    // REPS as the rule's fourth field (the session-36 commands) or the next argument.
    let reps: usize = v
        .get(3)
        .map(|r| r.to_string())
        .or_else(|| std::env::args().nth(4))
        .map_or(1, |r| r.parse().expect("REPS"));
    let (mut exact, mut whole, mut best) = (0u64, 0u64, f64::INFINITY);
    let mut sum = [0.0; 4];
    // The reports' error estimates and grids, summed: with the loads, the bits a set-up
    // change must keep.
    let (mut est_sum, mut grid_sum) = (0.0, 0u64);
    for _ in 0..reps {
        (exact, whole) = (0, 0);
        let start = std::time::Instant::now();
        for job in &jobs {
            let (ints, r) = solver.solve(job, &g, &mut Vec::new());
            exact += solver.trace.last().map_or(0, |t| t.updates);
            whole += r.sweeps as u64 * (r.n_theta as u64 * (r.n_z as u64 - 1));
            for k in 0..4 {
                sum[k] += ints[k];
            }
            est_sum += r.error_estimate;
            grid_sum += r.n_theta as u64 * r.n_z as u64;
        }
        best = best.min(start.elapsed().as_secs_f64());
    }
    let n = bench.len() as f64;
    println!(
        "rule {rule} accuracy {acc:e}: node updates per state {:.0} (exact), {:.0} (whole sweeps); {:.3} ms/state (best of {reps}); load checksum {:?}; estimate checksum {:?}; grid nodes {}",
        exact as f64 / n,
        whole as f64 / n,
        best / n * 1e3,
        sum.map(|x| x / reps as f64),
        est_sum / reps as f64,
        grid_sum / reps as u64
    );
}

/// Where the node updates go (issue 20, session 38): the 32 benchmark and the 12 test
/// states at accuracy `acc` with the default rule, each solve's work broken down by the
/// ladder grid being solved, the grid relaxed and the role (pre-/post-smoothing, the
/// coarsest grid's solve inside a V-cycle, the first grid's own solve); the total checked
/// against the solver's exact count (its trace).
fn work_where(acc: f64) {
    let [(pt, test), (pb, bench)] = test_and_bench(Some(acc));
    for (name, p, states) in [("bench (32)", pb, bench), ("test (12)", pt, test)] {
        let g = FiniteGrid::for_bearing(&p);
        let mut solver = FiniteSolver::new();
        solver.coarsest = bearing_sweep::bench::finite::coarsest_from_env("ZETA_PROBE_COARSEST");
        solver.below_top = bearing_sweep::bench::finite::below_from_env("ZETA_PROBE_BELOW");
        solver.keep_work_tally(true);
        let mut exact = 0u64;
        for s in &states {
            let job = FiniteJob::new(&p, &pack_state(&p, s).unwrap());
            solver.solve(&job, &g, &mut Vec::new());
            exact += solver.trace.last().map_or(0, |t| t.updates);
        }
        let n = states.len() as f64;
        println!(
            "{name}, accuracy {acc:e}: exact node updates per state {:.0}",
            exact as f64 / n
        );
        let tally = solver.take_work_tally();
        print!(
            "{}",
            bearing_sweep::bench::finite::work_tally_table(&tally, n)
        );
        let total = tally.iter().map(|w| w.updates).sum::<u64>() as f64 / n;
        assert_eq!(
            (total * n).round() as u64,
            exact,
            "the breakdown sums to the solver's count"
        );
    }
}

fn main() {
    if std::env::args().nth(1).as_deref() == Some("where") {
        for a in std::env::args().skip(2) {
            work_where(a.parse().expect("an accuracy"));
        }
        return;
    }
    if std::env::args().nth(1).as_deref() == Some("prof") {
        let a: Vec<String> = std::env::args().skip(2).collect();
        prof(a[0].parse().expect("an accuracy"), &a[1]);
        return;
    }
    if std::env::args().nth(1).as_deref() == Some("rules") {
        rules(
            std::env::args()
                .nth(2)
                .and_then(|a| a.parse().ok())
                .expect("an accuracy"),
        );
        return;
    }
    if std::env::args().nth(1).as_deref() == Some("fmg1") {
        fmg1();
        return;
    }
    if std::env::args().nth(1).as_deref() == Some("cycles") {
        for a in std::env::args().skip(2) {
            cycles(a.parse().expect("an accuracy"));
        }
        return;
    }
    if std::env::args().nth(1).as_deref() == Some("work") {
        work();
        return;
    }
    if std::env::args().nth(1).as_deref() == Some("split") {
        split();
        return;
    }
    if std::env::args().nth(1).as_deref() == Some("extrap") {
        extrap();
        return;
    }
    if std::env::args().nth(1).as_deref() == Some("cost") {
        for a in std::env::args().skip(2) {
            cost(a.parse().expect("an accuracy"));
        }
        return;
    }
    if std::env::args().nth(1).as_deref() == Some("aniso") {
        aniso();
        return;
    }
    let p = BearingParams {
        model: FilmModel::Finite,
        ..BearingParams::paper_table2()
    };
    let g = FiniteGrid::for_bearing(&p);
    let acc: f64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(5e-4);
    // per rule, per level: (true errors, estimate ratios [rich, d/3])
    let nl = 7;
    let mut errs = vec![vec![Vec::new(); nl]; RULES.len()];
    let mut ratios = vec![vec![vec![Vec::new(); 4]; nl]; RULES.len()];
    let mut cost = vec![Vec::new(); nl];
    for (label, s) in states(&p) {
        let packed: Packed = pack_state(&p, &s).unwrap();
        let job = FiniteJob::new(&p, &packed);
        let lv =
            |ints: &[f64; 4]| finish_loads(&p, &s, ints, packed.rate_scale).load_vector(p.length);
        let mut solver = FiniteSolver::new();
        let (_, tight) = solver.ladder_fields(&job, &g, 1e-10, false, nl);
        let n = tight.len();
        let v: Vec<[f64; 4]> = tight.iter().map(|t| lv(&t.0.integrals)).collect();
        let truth: [f64; 4] = std::array::from_fn(|k| (4.0 * v[n - 1][k] - v[n - 2][k]) / 3.0);
        let tn = norm(&truth);
        // The fields at the accuracy's per-grid stop (what the solver returns).
        let (th0, steps) = solver.ladder_fields(&job, &g, 0.02 * acc, true, nl - 1);
        for (l, (st, _)) in steps.iter().enumerate() {
            cost[l].push(st.updates);
        }
        print!("{label:14}");
        for (ri, _) in RULES.iter().enumerate() {
            let ys: Vec<[f64; 4]> = steps
                .iter()
                .map(|(st, f)| {
                    let r = if ri >= 4 {
                        rows_em(f, st.n_theta, st.n_z, th0)
                    } else {
                        rows(f, st.n_theta, st.n_z, th0)
                    };
                    let rule = [0, 1, 2, 3, 3, 1][ri];
                    lv(&quad(&r, st.n_z, rule))
                })
                .collect();
            let rect: Vec<[f64; 4]> = steps
                .iter()
                .map(|(st, f)| lv(&quad(&rows(f, st.n_theta, st.n_z, th0), st.n_z, 0)))
                .collect();
            for l in 0..ys.len() {
                let e = dist(&ys[l], &truth) / tn;
                errs[ri][l].push(e);
                if l >= 2 {
                    let d1 = dist(&ys[l - 1], &ys[l - 2]);
                    let d2 = dist(&ys[l], &ys[l - 1]);
                    let rho = if d1 > 0.0 {
                        (d2 / d1).clamp(0.25, 0.8)
                    } else {
                        0.25
                    };
                    let rich = d2 * rho / (1.0 - rho) / norm(&ys[l]);
                    let third = d2 / 3.0 / norm(&ys[l]);
                    // Embedded pair: |rect - rule| (quadrature part) and the rect Richardson.
                    let pair = dist(&ys[l], &rect[l]) / norm(&ys[l]);
                    let r1 = dist(&rect[l - 1], &rect[l - 2]);
                    let r2 = dist(&rect[l], &rect[l - 1]);
                    let rrho = if r1 > 0.0 {
                        (r2 / r1).clamp(0.25, 0.8)
                    } else {
                        0.25
                    };
                    let rrich = r2 * rrho / (1.0 - rrho) / norm(&ys[l]);
                    for (k, est) in [rich, third, pair, rrich].iter().enumerate() {
                        ratios[ri][l][k].push(est / e);
                    }
                }
            }
            print!(" {}:", RULES[ri]);
            for e in errs[ri].iter().take(ys.len()).skip(2) {
                print!(" {:.1e}", e.last().unwrap());
            }
        }
        println!();
    }
    let mm = |v: &[f64]| {
        (
            v.iter().cloned().fold(f64::INFINITY, f64::min),
            v.iter().cloned().fold(0.0, f64::max),
        )
    };
    for l in 0..nl - 1 {
        let c = &mut cost[l];
        c.sort();
        println!(
            "level {l}: updates at acc {acc:e}: median {} max {}",
            c[c.len() / 2],
            c[c.len() - 1]
        );
        for (ri, name) in RULES.iter().enumerate() {
            let (a, b) = mm(&errs[ri][l]);
            print!("   {name:8} err {a:.1e}-{b:.1e}");
            if l >= 2 {
                for (k, en) in ["rich", "d/3", "pair", "rectrich"].iter().enumerate() {
                    let (a, b) = mm(&ratios[ri][l][k]);
                    print!(" | {en} {a:.2}-{b:.2}");
                }
            }
            println!();
        }
    }
}
