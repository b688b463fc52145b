//! The three workloads of issue 28, timed and checked against a tight reference.
//!
//! - `grid9`: the paper rotor over 3 clearances x 3 viscosities (clearance 2e-4, 3e-4,
//!   4.5e-4 m; viscosity 0.0121, 0.0242, 0.0484 Pa·s), 0.5 s, samples every 5e-4 s.
//! - `sweep30`: `sweeps/clearance-viscosity.json` (clearance logspace 1e-4..6e-4 m, 6 values,
//!   x viscosity logspace 0.005..0.1 Pa·s, 5 values), 0.5 s, samples every 5e-4 s.
//! - `spin256`: 256 paper rotors with initial spins spread over 60-140 rad/s, 0.5 s,
//!   samples every 5e-4 s.
//!
//! Every workload runs as ONE lockstep batch (`simulate_batch`) on the CPU backend on one
//! thread at the 1e-6 load level, `rtol = atol = 1e-6` (the scenes' defaults), with the
//! method given by `--method` (default `dopri5`, the sweep file's choice), with the
//! `bearing-sweep` binary's allocator switched to mimalloc's huge pages as `run` switches
//! it (`bearing_sweep::allocator`).
//!
//! Error: the largest distance over all samples and variants between the run's `G`
//! (Figs. 8-9) and a reference's, and the same for the journal centres at both end faces
//! of both bearings (Fig. 10's orbit is bearing 1's first face). The reference is dopri5 at
//! `rtol = atol = 1e-11` with loads at the 1e-12 level (for `spin256`: every 16th variant,
//! 16 of the 256, to keep the reference affordable); it is written once to
//! `$CARGO_TARGET_DIR/workload-ref-NAME.json` and reused.
//!
//! Run (harness-less): `cargo bench --bench workloads -- NAME [--method auto] [--rtol X]
//! [--no-error]` (`--rtol`: `rtol = atol = X` instead of 1e-6).
//! `--no-error` skips the reference (for instruction counts under callgrind).
//! `--sample-interval X` samples every X s instead (0.5: start and end only, the
//! integration timed without the samples' loads and stores; no error then).
//! `--every K` runs every K-th variant only (spin256 under callgrind; the error is then
//! over the reference variants among them).
//! `--kernel` runs the workload once recording its packed states, then times the film
//! rule alone on them (states per second per thread, slices and root sweeps per state).

use std::time::Instant;

/// The `bearing-sweep` binary's allocator, switched as `run` switches it
/// ([`bearing_sweep::allocator`]), so that these timings are the command's.
#[global_allocator]
static ALLOCATOR: bearing_sweep::allocator::Allocator = bearing_sweep::allocator::Allocator;

use bearing_sweep::backend::{BackendError, BackendInfo, CpuBackend, FilmBackend, LoadEvaluator};
use bearing_sweep::bearing::{
    Accuracy, FilmIntegrals, FilmRule, PackedState, RuleSettings, Singularities,
};
use bearing_sweep::integrate::Method;
use bearing_sweep::rotor::{load_scene, simulate_batch, Scene, SimResult};

const BASE: &str = r#"{
    "name": "paper-rotor",
    "rotor": {"mass": 1.0, "inertia": [0.01, 0.01, 0.3], "static_unbalance": [0.001, 0.0]},
    "bearings": [
      {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242, "axial_position": 0.2},
      {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242, "axial_position": -0.1}
    ],
    "gravity": [0.0, 0.0, 0.0],
    "spin": "free",
    "initial": {"spin": 100.0},
    "integrator": {"method": "dopri5", "rtol": 1e-6, "atol": 1e-6, "t_end": 0.5, "sample_interval": 5e-4},
    "film": {"threshold": 1e-6}
}"#;

fn base() -> Scene {
    load_scene(BASE).expect("the base scene loads").remove(0)
}

/// `n` values from `a` to `b`, equally spaced in log (the sweep's `logspace`).
fn logspace(a: f64, b: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|k| a * (b / a).powf(k as f64 / (n - 1) as f64))
        .collect()
}

fn grid(clearances: &[f64], viscosities: &[f64]) -> Vec<Scene> {
    let mut out = Vec::new();
    for &c in clearances {
        for &mu in viscosities {
            let mut s = base();
            s.name = format!("c{c:.3e}-mu{mu:.3e}");
            for b in &mut s.bearings {
                b.clearance = c;
                b.viscosity = Some(mu);
            }
            out.push(s);
        }
    }
    out
}

fn workload(name: &str) -> Vec<Scene> {
    match name {
        "grid9" => grid(&[2e-4, 3e-4, 4.5e-4], &[0.0121, 0.0242, 0.0484]),
        "sweep30" => grid(&logspace(1e-4, 6e-4, 6), &logspace(0.005, 0.1, 5)),
        "spin256" => (0..256)
            .map(|k| {
                let mut s = base();
                s.name = format!("v{k}");
                s.initial.spin = 60.0 + 80.0 * k as f64 / 255.0;
                s
            })
            .collect(),
        other => panic!("unknown workload {other} (grid9, sweep30, spin256)"),
    }
}

/// A CPU backend that keeps a copy of every state it integrates (for `--kernel`).
struct Recording {
    inner: CpuBackend,
    states: std::sync::Arc<std::sync::Mutex<Vec<PackedState>>>,
}

impl FilmBackend for Recording {
    fn info(&self) -> BackendInfo {
        self.inner.info()
    }
    fn settings(&self) -> RuleSettings {
        self.inner.settings()
    }
    fn integrate(
        &mut self,
        states: &[PackedState],
        out: &mut Vec<FilmIntegrals>,
    ) -> Result<(), BackendError> {
        self.states.lock().unwrap().extend_from_slice(states);
        self.inner.integrate(states, out)
    }
}

/// `--kernel`: the workload's own packed states (every 7th, at most 200 000), then the
/// rule alone on them on this thread: states per second, slices and root-finder sweeps
/// per state, and a checksum of the integrals (to compare kernels).
fn kernel(scenes: &[Scene], level: f64) {
    let acc = Accuracy::new(level).expect("a calibrated level");
    let states = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let rec = Recording {
        inner: CpuBackend::new(acc, Some(1)),
        states: states.clone(),
    };
    let mut ev = LoadEvaluator::new(Box::new(rec));
    simulate_batch(scenes, &mut ev, &mut |_, _| {});
    let all = states.lock().unwrap();
    let picked: Vec<PackedState> = all.iter().step_by(7).take(200_000).copied().collect();
    let rule = FilmRule::new(acc.settings());
    let (mut slices, mut sweeps, mut tilted) = (0u64, 0u64, 0u64);
    for s in &picked {
        let (_, n) = rule.integrate(s);
        slices += n as u64;
        if n > 1 {
            tilted += 1;
            sweeps += Singularities::of(s, rule.settings()).root_work.1 as u64;
        }
    }
    if std::env::var("ROOT_HIST").is_ok() {
        let mut hist = [0u64; 8];
        for s in &picked {
            let sing = Singularities::of(s, rule.settings());
            let d = sing.complex[..sing.complex_count]
                .iter()
                .map(|&(re, im)| (re - 0.5).hypot(im))
                .fold(f64::INFINITY, f64::min);
            let b = [1.0, 2.5, 4.0, 6.0, 13.0, 100.0, 1e4, f64::INFINITY]
                .iter()
                .position(|&x| d < x)
                .unwrap_or(7);
            hist[b] += 1;
        }
        println!(
            "nearest complex singularity |s - 1/2| < 1, 2.5, 4, 6, 13, 100, 1e4, inf: {hist:?}"
        );
    }
    let mut out = Vec::new();
    let mut cpu = CpuBackend::new(acc, Some(1));
    let t0 = Instant::now();
    let mut reps = 0;
    while reps < 3 || t0.elapsed().as_secs_f64() < 1.0 {
        cpu.integrate(&picked, &mut out).unwrap();
        reps += 1;
    }
    let per = t0.elapsed().as_secs_f64() / reps as f64;
    let sum: f64 = out.iter().flat_map(|v| v.iter()).map(|v| v.abs()).sum();
    println!(
        "kernel: {} states ({} recorded, {tilted} tilted), {:.0} states/s on one thread, \
         {:.1} slices/state, {:.1} root sweeps per tilted state, checksum {sum:.15e}",
        picked.len(),
        all.len(),
        picked.len() as f64 / per,
        slices as f64 / picked.len() as f64,
        sweeps as f64 / tilted.max(1) as f64
    );
}

fn run(scenes: &[Scene], level: f64) -> Vec<SimResult> {
    let mut ev = LoadEvaluator::new(Box::new(CpuBackend::new(
        Accuracy::new(level).expect("a calibrated level"),
        Some(1),
    )));
    simulate_batch(scenes, &mut ev, &mut |_, _| {})
}

/// Sampled positions kept from a run: per variant, per sample, `[xg, yg]` and the four
/// journal centres `[xi, yi, xj, yj]` of both bearings.
#[derive(serde::Serialize, serde::Deserialize)]
struct Track {
    g: Vec<[f64; 2]>,
    centres: Vec<[f64; 8]>,
}

fn track(r: &SimResult) -> Track {
    let s = &r.samples;
    let (b0, b1) = (&s.bearings[0], &s.bearings[1]);
    Track {
        g: (0..s.t.len()).map(|k| [s.x_g[k], s.y_g[k]]).collect(),
        centres: (0..s.t.len())
            .map(|k| {
                [
                    b0.xi[k], b0.yi[k], b0.xj[k], b0.yj[k], b1.xi[k], b1.yi[k], b1.xj[k], b1.yj[k],
                ]
            })
            .collect(),
    }
}

fn main() {
    // As `bearing-sweep run` does before its sweep.
    bearing_sweep::allocator::use_huge_pages();
    let args: Vec<String> = std::env::args().skip(1).collect();
    let name = args
        .iter()
        .find(|a| !a.starts_with("--"))
        .cloned()
        .unwrap_or_else(|| "grid9".into());
    let method = args
        .windows(2)
        .find(|w| w[0] == "--method")
        .map(|w| w[1].clone())
        .unwrap_or_else(|| "dopri5".into());
    let no_error = args.iter().any(|a| a == "--no-error");
    // `--rtol X`: rtol = atol = X instead of the scenes' 1e-6 (for comparisons at equal
    // error).
    let tol: Option<f64> = args
        .windows(2)
        .find(|w| w[0] == "--rtol")
        .map(|w| w[1].parse().expect("--rtol takes a number"));
    // `--every K`: every K-th variant only (a subset for instruction counts of spin256,
    // which takes most of an hour under callgrind whole); the error is then against the
    // reference variants among them.
    let every: usize = args
        .windows(2)
        .find(|w| w[0] == "--every")
        .map(|w| w[1].parse().expect("--every takes a positive integer"))
        .unwrap_or(1);
    assert!(every >= 1, "--every takes a positive integer");
    // `--sample-interval X`: samples every X s instead of 5e-4 (X = 0.5: the start and the
    // end only, to time the integration without the samples' loads and stores); the error
    // is then not computed (the reference is sampled every 5e-4 s).
    let sample_interval: Option<f64> = args
        .windows(2)
        .find(|w| w[0] == "--sample-interval")
        .map(|w| w[1].parse().expect("--sample-interval takes a number"));
    let no_error = no_error || sample_interval.is_some();
    let all = workload(&name);
    let kept: Vec<usize> = (0..all.len()).step_by(every).collect();
    let mut scenes: Vec<Scene> = kept.iter().map(|&k| all[k].clone()).collect();
    let m: Method =
        serde_json::from_value(serde_json::Value::String(method.clone())).expect("a method name");
    for s in &mut scenes {
        s.integrator.method = m;
        if let Some(t) = tol {
            s.integrator.rtol = t;
            s.integrator.atol = t;
        }
        if let Some(dt) = sample_interval {
            s.integrator.sample_interval = dt;
        }
    }
    if args.iter().any(|a| a == "--kernel") {
        kernel(&scenes, 1e-6);
        return;
    }
    let t0 = Instant::now();
    let rs = run(&scenes, 1e-6);
    let wall = t0.elapsed().as_secs_f64();
    let loads: u64 = rs.iter().map(|r| r.stats.load_evaluations).sum();
    let steps: Vec<u64> = rs.iter().map(|r| r.stats.steps).collect();
    let finished = rs.iter().filter(|r| r.status.is_finished()).count();
    let jacobians: u64 = rs.iter().map(|r| r.stats.jacobians).sum();
    let lus: u64 = rs.iter().map(|r| r.stats.factorizations).sum();
    println!(
        "workload {name} ({} variants, method {method}): wall {wall:.4} s, {finished} finished, \
         {loads} load evaluations, steps max {} sum {}, {jacobians} jacobians, {lus} LUs",
        scenes.len(),
        steps.iter().max().unwrap_or(&0),
        steps.iter().sum::<u64>()
    );
    for r in &rs {
        println!(
            "  {}: {} steps, {} rejected, {} load evaluations, {} jacobians, {} LUs, method {}{}",
            r.name,
            r.stats.steps,
            r.stats.rejected,
            r.stats.load_evaluations,
            r.stats.jacobians,
            r.stats.factorizations,
            r.method.name(),
            r.stats.stiff_switch_s.map_or(String::new(), |t| format!(
                ", switched to radau5 at {t:.4e} s"
            ))
        );
    }
    if no_error {
        return;
    }
    // Reference variants (spin256: every 16th of the 256), as indices into `all`.
    let pick: Vec<usize> = if name == "spin256" {
        (0..all.len()).step_by(16).collect()
    } else {
        (0..all.len()).collect()
    };
    let dir = std::env::var("CARGO_TARGET_DIR").unwrap_or_else(|_| "target".into());
    let path = format!("{dir}/workload-ref-{name}.json");
    let reference: Vec<Track> = match std::fs::read_to_string(&path) {
        Ok(text) => serde_json::from_str(&text).expect("a reference file"),
        Err(_) => {
            // The scenes as the workload defines them, at a tight tolerance.
            let mut tight: Vec<Scene> = pick.iter().map(|&k| workload(&name)[k].clone()).collect();
            for s in &mut tight {
                s.integrator.method = Method::Dopri5;
                s.integrator.rtol = 1e-11;
                s.integrator.atol = 1e-11;
            }
            let t = Instant::now();
            let refs = run(&tight, 1e-12);
            eprintln!("reference computed in {:.1} s", t.elapsed().as_secs_f64());
            let tracks: Vec<Track> = refs.iter().map(track).collect();
            std::fs::write(&path, serde_json::to_string(&tracks).unwrap()).unwrap();
            tracks
        }
    };
    let (mut eg, mut ec) = (0.0f64, 0.0f64);
    let mut worst = (0, 0.0f64);
    for (r, &k) in reference.iter().zip(&pick) {
        // The run's index of reference variant k, if this run has it.
        let Some(run_k) = kept.iter().position(|&j| j == k) else {
            continue;
        };
        let got = track(&rs[run_k]);
        for (a, b) in got.g.iter().zip(&r.g) {
            eg = eg.max((a[0] - b[0]).hypot(a[1] - b[1]));
        }
        for (a, b) in got.centres.iter().zip(&r.centres) {
            for p in 0..4 {
                let e = (a[2 * p] - b[2 * p]).hypot(a[2 * p + 1] - b[2 * p + 1]);
                ec = ec.max(e);
                if e > worst.1 {
                    worst = (run_k, e);
                }
            }
        }
    }
    println!(
        "error against the reference: max |G - G_ref| = {eg:.2e} m, max journal-centre error \
         = {ec:.2e} m (variant {})",
        scenes[worst.0].name
    );
}
