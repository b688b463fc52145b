//! Model reductions (README "Model reductions"): the squeeze-drop estimate bounds the
//! load error it costs, the near-aligned approximation's error orders (why it is
//! declined), the evaluator's exact reductions (dedupe, small batches on the CPU) give
//! identical results with fewer kernel integrations, and runs report what they applied;
//! `--full-model` turns everything off.

mod common;

use std::sync::{Arc, Mutex};

use bearing_sweep::app::{run_scene_file, SceneRunOptions};
use bearing_sweep::backend::BackendKind;
use bearing_sweep::backend::{
    BackendError, BackendInfo, CpuBackend, EvaluatorOptions, FilmBackend, LoadEvaluator,
    LoadRequest, LoadResult, Precision,
};
use bearing_sweep::bearing::{
    film_loads, Accuracy, BearingParams, BearingState, FilmIntegrals, FilmRule, Loads, PackedState,
    RuleSettings,
};
use bearing_sweep::rotor::simplifications::{
    squeeze_error_estimate, squeeze_ratio, tilt_measure, without_squeeze, SimplificationSpec,
    SQUEEZE_GAIN,
};
use bearing_sweep::rotor::{load_scene, simulate_batch, Scene};
use bearing_sweep::sweep::SweepOptions;
use common::*;

fn lv(l: &Loads, b: f64) -> [f64; 4] {
    [l.wx, l.wy, l.mx / b, l.my / b]
}

fn rule() -> FilmRule {
    FilmRule::new(Accuracy::new(1e-12).unwrap().settings())
}

/// A random state with end ratios up to `emax`, end velocities scaled so that the squeeze
/// ratio `ρ` is `rho`.
fn state_with_rho(
    rng: &mut Rng,
    p: &BearingParams,
    emax: f64,
    tilt: f64,
    rho: f64,
) -> BearingState {
    let d = p.clearance;
    let (x, y) = rng.in_disc(emax * d * (1.0 - tilt));
    let (dx, dy) = rng.in_disc(tilt * emax * d);
    let omega = rng.range(50.0, 500.0) * rng.sign();
    let mut s = BearingState {
        xi: x - dx,
        yi: y - dy,
        xj: x + dx,
        yj: y + dy,
        vxi: rng.range(-1.0, 1.0),
        vyi: rng.range(-1.0, 1.0),
        vxj: rng.range(-1.0, 1.0),
        vyj: rng.range(-1.0, 1.0),
        omega,
    };
    let (r0, _) = squeeze_ratio(p, &s);
    let k = if r0.is_finite() { rho / r0 } else { 0.0 };
    s.vxi *= k;
    s.vyi *= k;
    s.vxj *= k;
    s.vyj *= k;
    s
}

/// The squeeze-drop estimate `SQUEEZE_GAIN ρ / (1 − ε²)` bounds the relative error of the
/// load vector `(W, M/B)` on random aligned and tilted states, ε up to 0.95, ρ from 1e-4
/// to 0.3; the measured gain (printed) is at most half the constant.
#[test]
fn squeeze_estimate_bounds_the_load_error() {
    let rule = rule();
    let mut rng = Rng::new(0x5EE2E);
    let mut worst_gain: f64 = 0.0;
    let mut index = 0;
    for (gname, p) in geometries() {
        for _ in 0..1300 {
            let emax = rng.range(0.05, 0.95);
            let tilt = if rng.uniform() < 0.3 {
                0.0
            } else {
                rng.range(0.0, 0.5)
            };
            let rho = 10f64.powf(rng.range(-4.0, -0.5));
            let s = state_with_rho(&mut rng, &p, emax, tilt, rho);
            let (rho, eps) = squeeze_ratio(&p, &s);
            if rho == 0.0 {
                continue;
            }
            let full = lv(&film_loads(&p, &s, &rule).unwrap(), p.length);
            let drop = lv(
                &film_loads(&p, &without_squeeze(&s), &rule).unwrap(),
                p.length,
            );
            let err = rel_error(&drop, &full);
            let est = squeeze_error_estimate(&p, &s);
            worst_gain = worst_gain.max(err * (1.0 - eps * eps) / rho);
            assert!(
                err <= est,
                "{gname} state {index}: relative error {err:e} > estimate {est:e} (ρ {rho:e}, ε {eps}) {s:?}"
            );
            index += 1;
        }
    }
    eprintln!("squeeze drop: worst measured gain err (1 − ε²) / ρ = {worst_gain:.3} (constant {SQUEEZE_GAIN})");
    assert!(
        worst_gain <= 0.5 * SQUEEZE_GAIN,
        "measured gain {worst_gain} leaves less than a factor 2 of margin on {SQUEEZE_GAIN}"
    );
}

/// Why near-aligned tilt is declined: evaluating a tilted journal at its mid-plane values
/// has a force error second order in the tilt and a moment error first order. Halving the
/// tilt divides the force error by ~4 and the moment error by ~2.
#[test]
fn near_aligned_error_orders() {
    let rule = rule();
    let p = table2();
    let d = p.clearance;
    let mut rng = Rng::new(0x7117);
    for case in 0..20 {
        let (x, y) = rng.in_disc(0.8 * d);
        let (tx, ty) = rng.in_disc(1.0);
        let omega = 100.0;
        let (vx, vy) = (rng.range(-1e-3, 1e-3), rng.range(-1e-3, 1e-3));
        let errs = |t: f64| {
            let s = BearingState {
                xi: x - t * tx * d,
                yi: y - t * ty * d,
                xj: x + t * tx * d,
                yj: y + t * ty * d,
                vxi: vx,
                vyi: vy,
                vxj: vx,
                vyj: vy,
                omega,
            };
            assert!(tilt_measure(&p, &s) > 0.0);
            let mid = BearingState {
                xi: x,
                yi: y,
                xj: x,
                yj: y,
                ..s
            };
            let full = lv(&film_loads(&p, &s, &rule).unwrap(), p.length);
            let aligned = lv(&film_loads(&p, &mid, &rule).unwrap(), p.length);
            let scale = norm(&full);
            let ew = (full[0] - aligned[0]).hypot(full[1] - aligned[1]) / scale;
            let em = (full[2] - aligned[2]).hypot(full[3] - aligned[3]) / scale;
            (ew, em)
        };
        let (w1, m1) = errs(2e-3);
        let (w2, m2) = errs(1e-3);
        let (rw, rm) = (w1 / w2, m1 / m2);
        assert!(
            (rw - 4.0).abs() < 0.4,
            "case {case}: force error ratio {rw} (expected ~4: second order), errors {w1:e} {w2:e}"
        );
        assert!(
            (rm - 2.0).abs() < 0.2,
            "case {case}: moment error ratio {rm} (expected ~2: first order), errors {m1:e} {m2:e}"
        );
        // First order with a non-trivial constant: the moment error is not negligible.
        assert!(m2 > 1e-5, "case {case}: moment error {m2:e} at tilt 1e-3");
    }
}

/// A CPU kernel that calls itself `gpu` and records the size of every call it gets.
struct CountingBackend {
    inner: CpuBackend,
    calls: Arc<Mutex<Vec<usize>>>,
}

impl FilmBackend for CountingBackend {
    fn info(&self) -> BackendInfo {
        BackendInfo {
            name: "gpu".into(),
            device: "counting stand-in".into(),
            precision: Precision::F64,
        }
    }
    fn settings(&self) -> RuleSettings {
        self.inner.settings()
    }
    fn integrate(
        &mut self,
        states: &[PackedState],
        out: &mut Vec<FilmIntegrals>,
    ) -> Result<(), BackendError> {
        self.calls.lock().unwrap().push(states.len());
        self.inner.integrate(states, out)
    }
}

fn counting(options: EvaluatorOptions) -> (LoadEvaluator, Arc<Mutex<Vec<usize>>>) {
    let calls = Arc::new(Mutex::new(Vec::new()));
    let b = CountingBackend {
        inner: CpuBackend::new(Accuracy::default(), Some(1)),
        calls: calls.clone(),
    };
    (LoadEvaluator::with_options(Box::new(b), options), calls)
}

fn bits(r: &[LoadResult]) -> Vec<Option<[u64; 5]>> {
    r.iter()
        .map(|l| {
            l.as_ref()
                .ok()
                .map(|l| [l.wx, l.wy, l.mx, l.my, l.mz].map(f64::to_bits))
        })
        .collect()
}

/// N identical variants (identical bearings, identical states, under different bearing
/// indices) make one backend call with one state, and their results are bit-identical to
/// the evaluation without dedupe.
#[test]
fn identical_variants_are_integrated_once() {
    let mut rng = Rng::new(0xDED0);
    let p = table2();
    let s = state_with_rho(&mut rng, &p, 0.7, 0.3, 0.1);
    let n = 50;
    let bearings = vec![p; n];
    let requests: Vec<LoadRequest> = (0..n)
        .map(|k| LoadRequest {
            bearing: k as u32,
            state: s,
        })
        .collect();
    let opts = EvaluatorOptions {
        dedupe: true,
        cpu_below: 0,
    };
    let (mut ev, calls) = counting(opts);
    let mut got = Vec::new();
    ev.evaluate(&bearings, &requests, &mut got);
    assert_eq!(
        *calls.lock().unwrap(),
        vec![1],
        "one backend call with one state"
    );
    assert_eq!(ev.stats().deduplicated, (n - 1) as u64);
    assert_eq!(ev.stats().integrated, 1);
    let (mut full, calls_full) = counting(EvaluatorOptions::full());
    let mut want = Vec::new();
    full.evaluate(&bearings, &requests, &mut want);
    assert_eq!(
        *calls_full.lock().unwrap(),
        vec![n],
        "no dedupe: all states"
    );
    assert_eq!(full.stats().deduplicated, 0);
    assert_eq!(bits(&got), bits(&want), "dedupe changed a result");
    // Distinct states are not merged; different bearings with the same packed state share
    // integrals but get their own loads (scaled by their own parameters).
    let mut p2 = p;
    p2.viscosity *= 2.0;
    let s2 = BearingState {
        omega: s.omega * 1.5,
        ..s
    };
    let reqs = [
        LoadRequest {
            bearing: 0,
            state: s,
        },
        LoadRequest {
            bearing: 1,
            state: s,
        },
        LoadRequest {
            bearing: 0,
            state: s2,
        },
    ];
    let (mut ev, calls) = counting(opts);
    ev.evaluate(&[p, p2], &reqs, &mut got);
    assert_eq!(*calls.lock().unwrap(), vec![2]);
    let rule = FilmRule::new(Accuracy::default().settings());
    for (k, (r, bp)) in reqs.iter().zip([p, p2, p]).enumerate() {
        let want = film_loads(&bp, &r.state, &rule).unwrap();
        let g = got[k].as_ref().unwrap();
        assert_close(
            "dedupe across bearings",
            k,
            &lv(g, bp.length),
            &lv(&want, bp.length),
            1e-15,
            0.0,
        );
    }
}

/// A GPU-named backend gets no call below the crossover; the CPU fallback's results are
/// the same rule's (identical to a CPU evaluator's); at and above it, the backend runs.
#[test]
fn tiny_batches_stay_on_the_cpu() {
    let mut rng = Rng::new(0x7172);
    let p = table2();
    let states: Vec<BearingState> = (0..80)
        .map(|_| state_with_rho(&mut rng, &p, 0.9, 0.5, 0.2))
        .collect();
    let req = |n: usize| -> Vec<LoadRequest> {
        states[..n]
            .iter()
            .map(|&state| LoadRequest { bearing: 0, state })
            .collect()
    };
    let opts = EvaluatorOptions {
        dedupe: true,
        cpu_below: 64,
    };
    let (mut ev, calls) = counting(opts);
    let mut cpu = LoadEvaluator::new(Box::new(CpuBackend::new(Accuracy::default(), Some(1))));
    let (mut got, mut want) = (Vec::new(), Vec::new());
    for n in [1, 10, 63] {
        ev.evaluate(&[p], &req(n), &mut got);
        cpu.evaluate(&[p], &req(n), &mut want);
        assert_eq!(bits(&got), bits(&want), "{n} states on the CPU fallback");
    }
    assert!(
        calls.lock().unwrap().is_empty(),
        "the GPU got a tiny call: {:?}",
        calls.lock().unwrap()
    );
    assert_eq!(ev.stats().small_batch_cpu_calls, 3);
    assert_eq!(ev.stats().small_batch_cpu_states, 74);
    ev.evaluate(&[p], &req(64), &mut got);
    cpu.evaluate(&[p], &req(64), &mut want);
    assert_eq!(bits(&got), bits(&want));
    assert_eq!(
        *calls.lock().unwrap(),
        vec![64],
        "at the crossover the GPU runs"
    );
    // Off: every call goes to the backend.
    let (mut ev, calls) = counting(EvaluatorOptions::full());
    ev.evaluate(&[p], &req(3), &mut got);
    assert_eq!(*calls.lock().unwrap(), vec![3]);
}

fn short_paper(t_end: f64) -> Scene {
    let mut s = load_scene(include_str!("../sweeps/paper-example.json")).unwrap()[0].clone();
    s.integrator.t_end = t_end;
    s
}

fn entry<'a>(v: &'a serde_json::Value, list: &str, name: &str) -> Option<&'a serde_json::Value> {
    v[list]
        .as_array()
        .and_then(|a| a.iter().find(|e| e["name"] == name))
}

/// Squeeze drop is applied exactly where the estimate is under the bound: a loose bound
/// takes every state, a tight one none, and the run reports counts, bound and error;
/// its default is off.
#[test]
fn squeeze_drop_follows_its_bound() {
    let base = short_paper(0.01);
    assert!(!base.reductions.squeeze_drop.enabled, "default off");
    let mut loose = base.clone();
    loose.name = "loose".into();
    loose.reductions.squeeze_drop.enabled = true;
    loose.reductions.squeeze_drop.bound = 1e9;
    let mut tight = loose.clone();
    tight.name = "tight".into();
    tight.reductions.squeeze_drop.bound = 1e-300;
    // The paper rotor starts centred (ε = 0: ρ infinite); give it an offset so that the
    // rotational rate exists.
    for s in [&mut loose, &mut tight] {
        s.initial.offset = [1e-4, 0.0];
    }
    let mut full = tight.clone();
    full.name = "full".into();
    full.reductions = SimplificationSpec::full();
    let mut ev = LoadEvaluator::new(Box::new(CpuBackend::new(Accuracy::default(), Some(1))));
    let r = simulate_batch(&[loose, tight, full], &mut ev, &mut |_, _| {});
    let v: Vec<serde_json::Value> = r
        .iter()
        .map(|r| serde_json::to_value(&r.model_reductions).unwrap())
        .collect();
    let states = r[0].stats.load_evaluations + r[0].stats.sample_load_evaluations;
    let e = entry(&v[0], "applied", "squeeze_drop").expect("loose bound: applied");
    let applied = e["applied_to"].as_u64().unwrap();
    // All but the states without squeeze (the start at rest).
    assert!(applied <= states && applied + 10 >= states, "{e}");
    assert_eq!(e["of"], states);
    assert_eq!(e["bound"], 1e9);
    assert!(e["error"].as_f64().unwrap() > 0.0);
    let e = entry(&v[1], "declined", "squeeze_drop").expect("tight bound: declined");
    assert!(
        e["why"]
            .as_str()
            .unwrap()
            .contains("no state met the bound"),
        "{e}"
    );
    assert_eq!(v[2]["full_model"], true);
    assert!(entry(&v[2], "declined", "squeeze_drop").is_some());
    // The tight-bound run is the full model (nothing was dropped): bit-identical samples.
    assert_eq!(r[1].samples.x_g, r[2].samples.x_g);
    // The loose one differs (no squeeze damping).
    assert_ne!(r[0].samples.x_g, r[2].samples.x_g);
}

/// A moderate bound on a moving rotor: dropped where allowed, kept elsewhere, and every
/// dropped evaluation's actual load error (recomputed here) is within the bound.
#[test]
fn dropped_evaluations_stay_within_the_bound() {
    let rule = rule();
    let p = table2();
    let bound = 1e-2;
    let mut rng = Rng::new(0xB0D);
    let (mut applied, mut declined) = (0, 0);
    for k in 0..400 {
        let rho = 10f64.powf(rng.range(-5.0, -1.0));
        let s = state_with_rho(&mut rng, &p, 0.9, 0.2, rho);
        let mut spec = SimplificationSpec::default();
        spec.squeeze_drop.enabled = true;
        spec.squeeze_drop.bound = bound;
        let mut tally = bearing_sweep::rotor::simplifications::SimplificationTally::default();
        let mut reduced = s;
        tally.observe(&spec, &p, &mut reduced);
        let est = squeeze_error_estimate(&p, &s);
        if est <= bound {
            applied += 1;
            assert_eq!(
                tally.squeeze_dropped, 1,
                "state {k}: estimate {est:e} under the bound"
            );
            assert_eq!(reduced, without_squeeze(&s));
            let full = lv(&film_loads(&p, &s, &rule).unwrap(), p.length);
            let got = lv(&film_loads(&p, &reduced, &rule).unwrap(), p.length);
            let err = rel_error(&got, &full);
            assert!(err <= bound, "state {k}: error {err:e} > bound {bound:e}");
        } else {
            declined += 1;
            assert_eq!(tally.squeeze_declined, 1);
            assert_eq!(reduced, s, "state {k}: declined but changed");
        }
    }
    assert!(
        applied > 50 && declined > 50,
        "both branches: {applied} applied, {declined} declined"
    );
}

/// `run` writes the report; `--full-model` turns every reduction off; held spin with the
/// friction check reports the deviation a frozen coefficient would have cost.
#[test]
fn run_reports_reductions_and_full_model_turns_them_off() {
    let dir = std::env::temp_dir().join(format!("bs-reductions-{}", std::process::id()));
    let mut scene: serde_json::Value =
        serde_json::from_str(include_str!("../sweeps/paper-example.json")).unwrap();
    scene["compare_ideal"] = false.into();
    scene["integrator"]["t_end"] = 0.02.into();
    scene["spin"] = "held".into();
    scene["initial"]["offset"] = serde_json::json!([1e-4, 0.0]);
    scene["reductions"] = serde_json::json!({
        "squeeze_drop": {"enabled": true, "bound": 1e-3},
        "near_aligned": {"enabled": true},
        "constant_friction": {"enabled": true, "settle_time": 0.01, "bound": 0.5}
    });
    let text = scene.to_string();
    let read = |full: bool| -> serde_json::Value {
        let out = dir.join(if full { "full" } else { "reduced" });
        let rep = run_scene_file(
            "s.json",
            &text,
            &SceneRunOptions {
                out: out.clone(),
                options: SweepOptions {
                    backend: BackendKind::Cpu,
                    full_model: full,
                    ..Default::default()
                },
            },
        )
        .unwrap();
        let doc = std::fs::read_to_string(rep.dir.join("result.json")).unwrap();
        serde_json::from_str(&doc).unwrap()
    };
    let red = read(false);
    let top = &red["model_reductions"];
    assert!(entry(top, "applied", "dedupe").is_some(), "{top}");
    assert!(entry(top, "applied", "aligned_one_slice").is_some());
    assert!(
        entry(top, "declined", "small_batch_cpu").is_some(),
        "CPU backend"
    );
    let v = &red["results"][0]["model_reductions"];
    assert_eq!(v["full_model"], false);
    let sq = entry(v, "applied", "squeeze_drop")
        .or_else(|| entry(v, "declined", "squeeze_drop"))
        .unwrap();
    assert_eq!(sq["bound"], 1e-3);
    let tilt = entry(v, "declined", "near_aligned_tilt").unwrap();
    assert_eq!(tilt["applied_to"], 0);
    let fr = entry(v, "declined", "constant_friction").unwrap();
    assert!(
        fr["error"].as_f64().is_some(),
        "held spin: deviation measured: {fr}"
    );
    let full = read(true);
    let top = &full["model_reductions"];
    assert!(entry(top, "declined", "dedupe").is_some(), "{top}");
    let v = &full["results"][0]["model_reductions"];
    assert_eq!(v["full_model"], true);
    assert!(v["applied"].as_array().unwrap().is_empty(), "{v}");
    assert!(entry(v, "declined", "squeeze_drop").unwrap()["why"]
        .as_str()
        .unwrap()
        .contains("--full-model"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A rotor sweep of four identical variants in one lockstep batch integrates each film
/// state once (3 of 4 served by dedupe), gives four identical variants equal to the
/// full-model run, and both the variant lines and the run section carry the report.
#[test]
fn identical_sweep_variants_share_integrals_and_report_it() {
    use bearing_sweep::sweep::parse_spec;
    use bearing_sweep::sweep::rotor_sim::{validate_scene, RotorSimulator};
    use bearing_sweep::sweep::runner::{run_sweep, BatchSize, RunOptions, RunnerOptions};
    let dir = std::env::temp_dir().join(format!("bs-reductions-sweep-{}", std::process::id()));
    let spec = serde_json::json!({
        "kind": "rotor",
        "base": {
            "rotor": {"mass": 1.0, "inertia": [0.01, 0.01, 0.3], "static_unbalance": [0.001, 0.0]},
            "bearings": [
                {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242, "axial_position": 0.2},
                {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242, "axial_position": -0.1}
            ],
            "gravity": [0.0, 0.0, 0.0],
            "initial": {"spin": 100.0},
            "integrator": {"method": "dopri5", "t_end": 0.01, "sample_interval": 1e-3}
        },
        "axes": [{"path": "gravity", "values": [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]}],
        "reductions": {"points": 5}
    });
    let spec = parse_spec(&spec, None).unwrap();
    let mut docs = Vec::new();
    let mut all_stats = Vec::new();
    for (name, options, full) in [
        (
            "reduced",
            EvaluatorOptions {
                dedupe: true,
                cpu_below: 0,
            },
            false,
        ),
        ("full", EvaluatorOptions::full(), true),
    ] {
        let (ev, calls) = counting(options);
        let mut sim = RotorSimulator::new(ev, Accuracy::default());
        sim.set_full_model(full);
        let out = dir.join(name).join("result.json");
        std::fs::create_dir_all(out.parent().unwrap()).unwrap();
        let opts = RunOptions {
            result: out.clone(),
            progress: false,
            runner: RunnerOptions {
                shard: None,
                batch: BatchSize::Fixed(4),
            },
            settings: sim.settings(1e-6),
        };
        run_sweep(&spec, &validate_scene, &mut sim, &opts, &mut |_| {}).unwrap();
        let stats = sim.eval_stats();
        let sizes = calls.lock().unwrap().clone();
        let total: usize = sizes.iter().sum();
        assert_eq!(
            total as u64, stats.integrated,
            "backend saw every integration"
        );
        all_stats.push(stats);
        let doc: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
        docs.push(doc);
    }
    let (sr, sf) = (all_stats[0], all_stats[1]);
    assert_eq!(sf.deduplicated, 0);
    assert_eq!(sr.states, sf.states);
    assert_eq!(
        sr.integrated + sr.deduplicated,
        sf.integrated,
        "{sr:?} {sf:?}"
    );
    // Four identical variants: at most a quarter of the states integrated (fewer where
    // a variant's two bearings meet the same state).
    assert!(4 * sr.integrated <= sf.integrated, "{sr:?} {sf:?}");
    let (red, full) = (&docs[0], &docs[1]);
    let top = &red["run"]["simulator"]["model_reductions"];
    assert!(entry(top, "applied", "dedupe").is_some(), "{top}");
    assert!(entry(
        &full["run"]["simulator"]["model_reductions"],
        "declined",
        "dedupe"
    )
    .is_some());
    assert_eq!(full["settings"]["full_model"], true);
    let vr = red["variants"].as_array().unwrap();
    let vf = full["variants"].as_array().unwrap();
    assert_eq!(vr.len(), 4);
    for (a, b) in vr.iter().zip(vf) {
        assert!(
            a["sim"]["model_reductions"]["declined"].is_array(),
            "{}",
            a["sim"]
        );
        assert_eq!(b["sim"]["model_reductions"]["full_model"], true);
        assert_eq!(
            a["reductions"], vr[0]["reductions"],
            "identical variants differ"
        );
        assert_eq!(a["reductions"], b["reductions"], "dedupe changed a result");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// On the real GPU backend (lavapipe here; skipped without one unless
/// BEARING_SWEEP_REQUIRE_GPU=1): calls below the crossover are counted as CPU calls and
/// are bit-identical to the CPU evaluator; a call above it runs on the GPU and agrees
/// within the backend tolerance.
#[test]
fn gpu_small_batches_run_on_the_cpu() {
    let accuracy = Accuracy::default();
    let require = std::env::var("BEARING_SWEEP_REQUIRE_GPU").is_ok_and(|v| v == "1");
    let gpu = match bearing_sweep::backend::create_backend(BackendKind::Gpu, accuracy) {
        Ok((b, _)) => b,
        Err(e) => {
            assert!(
                !require,
                "BEARING_SWEEP_REQUIRE_GPU=1 but no GPU backend: {e}"
            );
            eprintln!("skipped: no GPU backend ({e})");
            return;
        }
    };
    let f32_kernel = gpu.info().precision == Precision::F32;
    let mut ev = LoadEvaluator::with_options(
        gpu,
        EvaluatorOptions {
            dedupe: true,
            cpu_below: 64,
        },
    );
    let mut cpu = LoadEvaluator::new(Box::new(CpuBackend::new(accuracy, Some(1))));
    let mut rng = Rng::new(0x6C0);
    let p = table2();
    let states: Vec<LoadRequest> = (0..200)
        .map(|_| LoadRequest {
            bearing: 0,
            state: state_with_rho(&mut rng, &p, 0.9, 0.5, 0.2),
        })
        .collect();
    let (mut got, mut want) = (Vec::new(), Vec::new());
    ev.evaluate(&[p], &states[..10], &mut got);
    cpu.evaluate(&[p], &states[..10], &mut want);
    assert_eq!(
        bits(&got),
        bits(&want),
        "10 states: the CPU fallback's results"
    );
    assert_eq!(ev.stats().small_batch_cpu_calls, 1);
    ev.evaluate(&[p], &states, &mut got);
    cpu.evaluate(&[p], &states, &mut want);
    assert_eq!(
        ev.stats().small_batch_cpu_calls,
        1,
        "200 states went to the GPU"
    );
    let tol = if f32_kernel { 3e-5 } else { 1e-9 };
    for (k, (g, w)) in got.iter().zip(&want).enumerate() {
        let (g, w) = (g.as_ref().unwrap(), w.as_ref().unwrap());
        assert_close(
            "gpu above the crossover",
            k,
            &lv(g, p.length),
            &lv(w, p.length),
            tol,
            0.0,
        );
    }
}

/// Issue 21 renamed the Rust type of the scene's `reductions` block
/// (`rotor::simplifications::SimplificationSpec`); the message a wrong type gets still
/// names it as before, word for word.
#[test]
fn a_wrong_reductions_block_is_refused_in_the_old_words() {
    let mut scene: serde_json::Value =
        serde_json::from_str(include_str!("../sweeps/paper-example.json")).unwrap();
    scene["reductions"] = serde_json::json!(5);
    let e = load_scene(&scene.to_string()).unwrap_err();
    assert_eq!(
        (e.path.as_str(), e.reason.as_str()),
        (
            "reductions",
            "invalid type: integer `5`, expected struct ReductionSpec"
        )
    );
}
