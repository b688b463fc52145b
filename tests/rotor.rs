//! The rotor model on the paper's example (MODEL.md section 8): ideal joints keep G on
//! its circle, the energy balance holds along the trajectory, batches equal single runs,
//! failing variants end alone with a physical status, scene errors name the JSON path,
//! methods agree, held spin stays held, and CPU and GPU backends agree.

use bearing_sweep::backend::{create_backend, BackendKind, LoadEvaluator};
use bearing_sweep::bearing::Accuracy;
use bearing_sweep::integrate::Method;
use bearing_sweep::rotor::{
    load_scene, simulate_batch, ModelKind, RotorModel, Scene, SimResult, SimStatus, SpinMode,
};

const PAPER: &str = include_str!("../sweeps/paper-example.json");

fn paper() -> (Scene, Scene) {
    let scenes = load_scene(PAPER).expect("the paper example loads");
    assert_eq!(scenes.len(), 2, "bearing model and ideal-joint comparison");
    assert_eq!(scenes[0].model, ModelKind::Bearing);
    assert_eq!(scenes[1].model, ModelKind::Ideal);
    (scenes[0].clone(), scenes[1].clone())
}

fn cpu(accuracy: f64) -> LoadEvaluator {
    let (b, _) = create_backend(BackendKind::Cpu, Accuracy::new(accuracy).unwrap()).unwrap();
    LoadEvaluator::new(b)
}

fn run(scenes: &[Scene], accuracy: f64) -> Vec<SimResult> {
    let mut ev = cpu(accuracy);
    let mut seen = Vec::new();
    let out = simulate_batch(scenes, &mut ev, &mut |i, _| seen.push(i));
    let mut sorted = seen.clone();
    sorted.sort();
    assert_eq!(
        sorted,
        (0..scenes.len()).collect::<Vec<_>>(),
        "progress once per scene"
    );
    out
}

fn assert_finite(r: &SimResult) {
    let s = &r.samples;
    for (name, v) in [
        ("t", &s.t),
        ("x_g", &s.x_g),
        ("y_g", &s.y_g),
        ("spin", &s.spin),
        ("work", &s.work),
    ] {
        assert!(
            v.iter().all(|x| x.is_finite()),
            "{}: non-finite {name}",
            r.name
        );
    }
    for b in &s.bearings {
        for v in [&b.xi, &b.yi, &b.h_min, &b.wx, &b.wy, &b.mz] {
            assert!(
                v.iter().all(|x| x.is_finite()),
                "{}: non-finite bearing output",
                r.name
            );
        }
    }
}

#[test]
fn the_paper_example_matches_model_md_section_8() {
    let (b, _) = paper();
    let m = RotorModel::new(&b);
    let y = m.initial_state(&b);
    let want = [1e-3, 0.0, 0.0, 0.1];
    for k in 0..4 {
        assert!(
            (y[k] - want[k]).abs() < 1e-15,
            "y0[{k}] = {}, want {}",
            y[k],
            want[k]
        );
    }
    // Journals centred: full film at both bearings.
    for (k, h) in m.initial_film(&y).iter().enumerate() {
        assert!((h - 3e-4).abs() < 1e-15, "bearing {k} initial film {h}");
    }
    assert_eq!(b.integrator.t_end, 0.5);
    assert_eq!(b.spin, SpinMode::Free);
}

#[test]
fn ideal_joints_keep_g_on_the_circle_of_radius_e() {
    let (_, ideal) = paper();
    let r = &run(&[ideal], 1e-6)[0];
    assert_eq!(r.status, SimStatus::Finished);
    assert_eq!(r.samples.t.len(), 5001);
    let e = 1e-3;
    for (k, (x, y)) in r.samples.x_g.iter().zip(&r.samples.y_g).enumerate() {
        let rad = x.hypot(*y);
        assert!(
            (rad - e).abs() < 1e-15,
            "sample {k}: |G| = {rad}, want {e}, tol 1e-15"
        );
    }
    // It turns: after 0.5 s at ~100 rad/s, G has gone round ~8 times.
    let turns: f64 = r.samples.spin.iter().sum::<f64>() * 1e-4 / (2.0 * std::f64::consts::PI);
    assert!((turns - 7.96).abs() < 0.05, "turns {turns}");
    // Friction slows it: the spin drops by |M_z| t / J_axis (S < 1: load-independent).
    let spin_end = *r.samples.spin.last().unwrap();
    let j = 0.3 + 1.0 * e * e;
    let mz = 2.0 * 1.5488e-2;
    let want = 100.0 - mz * 0.5 / j;
    assert!(
        (spin_end - want).abs() < 1e-4,
        "spin at 0.5 s {spin_end}, want {want}"
    );
}

#[test]
fn energy_balance_on_the_paper_rotor_holds_to_integration_error() {
    // Kinetic energy change equals the work of the film forces (end-point forces times
    // the end-centre velocities) and the friction torques, integrated along the
    // trajectory as a quadrature state. The dynamics use the torque about G instead, so a
    // wrong torque arm breaks the balance (the paper's axial-only arms: 1e-7 J after
    // 0.2 ms).
    let (mut b, _) = paper();
    b.integrator.rtol = 1e-11;
    b.integrator.atol = 1e-11;
    let mut held = b.clone();
    held.spin = SpinMode::Held;
    held.name = "held".into();
    let rs = run(&[b, held], 1e-9);
    for r in &rs {
        assert_eq!(r.status, SimStatus::Finished, "{}", r.name);
        assert_finite(r);
        let s = &r.samples;
        let tol = 1e-9; // J, against a kinetic energy of 1500 J and a loss of ~1.6 J (measured 4e-11)
        let mut worst = 0.0f64;
        for k in 0..s.t.len() {
            let dke = s.kinetic_energy[k] - s.kinetic_energy[0];
            let err = (dke - s.work[k]).abs();
            worst = worst.max(err);
            assert!(
                err < tol,
                "{}: sample {k} t={}: dKE {dke}, work {}, tol {tol}",
                r.name,
                s.t[k],
                s.work[k]
            );
        }
        eprintln!("{}: worst |dKE - W| = {worst:e} J", r.name);
    }
    // Free spin loses energy to friction (about 2 x 1.55e-2 N·m x 100 rad/s x 0.5 s).
    let w = *rs[0].samples.work.last().unwrap();
    assert!(w < -1.5 && w > -1.7, "work of friction over 0.5 s: {w}");
    // Held spin: the spin stays at 100 rad/s.
    for (k, sp) in rs[1].samples.spin.iter().enumerate() {
        assert!((sp - 100.0).abs() < 1e-8, "held spin at sample {k}: {sp}");
    }
}

#[test]
fn a_batch_of_identical_variants_equals_one_and_failures_end_alone() {
    let (b, ideal) = paper();
    let mut short = b.clone();
    short.integrator.t_end = 0.1;
    let mut bad = short.clone();
    bad.name = "huge-unbalance".into();
    bad.rotor.static_unbalance = [0.05, 0.0];
    bad.film.threshold = 3e-5;
    let mut invalid = short.clone();
    invalid.name = "invalid".into();
    invalid.bearings[1].clearance = -3e-4;
    let mut ideal_short = ideal.clone();
    ideal_short.integrator.t_end = 0.1;
    let single = run(std::slice::from_ref(&short), 1e-6);
    let batch = run(
        &[
            short.clone(),
            bad,
            short.clone(),
            invalid,
            ideal_short,
            short.clone(),
        ],
        1e-6,
    );
    assert_eq!(single[0].status, SimStatus::Finished);
    for k in [0, 2, 5] {
        assert_eq!(batch[k].status, SimStatus::Finished, "variant {k}");
        assert_eq!(
            batch[k].samples, single[0].samples,
            "variant {k} differs from the single run"
        );
        assert_eq!(batch[k].stats.steps, single[0].stats.steps);
    }
    match &batch[1].status {
        SimStatus::FilmBreakdown {
            time,
            bearing,
            h_min,
        } => {
            assert!(*time > 0.0 && *time < 0.1, "breakdown time {time}");
            assert!(*h_min < 3e-5 && *h_min > 0.0, "h_min {h_min}");
            assert!(*bearing < 2);
            let last = *batch[1].samples.t.last().unwrap();
            assert!(
                last <= *time + 1e-4,
                "samples end at the breakdown: {last} vs {time}"
            );
        }
        other => panic!("huge unbalance should end in film breakdown, got {other:?}"),
    }
    assert_finite(&batch[1]);
    match &batch[3].status {
        SimStatus::InvalidScene { path, reason } => {
            assert_eq!(path, "bearings[1].clearance");
            assert!(reason.contains("must be positive"), "{reason}");
        }
        other => panic!("invalid scene: {other:?}"),
    }
    assert_eq!(batch[4].status, SimStatus::Finished);
}

#[test]
fn scene_errors_name_the_json_path_and_the_reason() {
    let mut doc: serde_json::Value = serde_json::from_str(PAPER).unwrap();
    doc["bearings"][1]["clearance"] = serde_json::json!(-0.0003);
    let e = load_scene(&doc.to_string()).unwrap_err();
    assert_eq!(
        e.to_string(),
        "bearings[1].clearance: must be positive (-0.0003)"
    );

    let mut doc: serde_json::Value = serde_json::from_str(PAPER).unwrap();
    doc["rotor"]["mas"] = serde_json::json!(1.0);
    let e = load_scene(&doc.to_string()).unwrap_err();
    assert!(
        e.to_string().starts_with("rotor.mas: unknown field `mas`"),
        "{e}"
    );

    // Nested unknown fields and wrong types are located, also inside a `scenes` list.
    let mut doc: serde_json::Value = serde_json::from_str(PAPER).unwrap();
    doc["bearings"][1]["clearance"] = serde_json::json!("big");
    let e = load_scene(&doc.to_string()).unwrap_err();
    assert!(
        e.to_string()
            .starts_with("bearings[1].clearance: invalid type"),
        "{e}"
    );
    let mut doc: serde_json::Value = serde_json::from_str(PAPER).unwrap();
    doc["integrator"]["rtoll"] = serde_json::json!(1e-6);
    let wrapped = serde_json::json!({"scenes": [doc]});
    let e = load_scene(&wrapped.to_string()).unwrap_err();
    assert!(
        e.to_string()
            .starts_with("scenes[0].integrator.rtoll: unknown field"),
        "{e}"
    );

    let mut doc: serde_json::Value = serde_json::from_str(PAPER).unwrap();
    doc["integrator"]["t_end"] = serde_json::json!(0.0);
    let wrapped = serde_json::json!({"scenes": [serde_json::from_str::<serde_json::Value>(PAPER).unwrap(), doc]});
    let e = load_scene(&wrapped.to_string()).unwrap_err();
    assert_eq!(
        e.to_string(),
        "scenes[1].integrator.t_end: must be positive (0)"
    );

    let mut doc: serde_json::Value = serde_json::from_str(PAPER).unwrap();
    doc["initial"]["offset"] = serde_json::json!([0.0003, 0.0]);
    let e = load_scene(&doc.to_string()).unwrap_err();
    assert!(
        e.to_string()
            .starts_with("initial: the journal in bearings[0] starts with film"),
        "{e}"
    );
}

/// Largest distance between two runs' G positions over common samples, m.
fn g_distance(a: &SimResult, b: &SimResult) -> f64 {
    a.samples
        .x_g
        .iter()
        .zip(&a.samples.y_g)
        .zip(b.samples.x_g.iter().zip(&b.samples.y_g))
        .map(|((xa, ya), (xb, yb))| (xa - xb).hypot(ya - yb))
        .fold(0.0, f64::max)
}

#[test]
fn every_method_agrees_on_the_paper_rotor() {
    let (b, _) = paper();
    let mut reference = b.clone();
    reference.integrator.t_end = 0.1;
    reference.integrator.rtol = 1e-11;
    reference.integrator.atol = 1e-11;
    let mut radau = reference.clone();
    radau.integrator.method = Method::Radau5;
    radau.integrator.rtol = 1e-8;
    radau.integrator.atol = 1e-8;
    let mut rk4 = reference.clone();
    rk4.integrator.method = Method::Rk4;
    rk4.integrator.fixed_step = Some(2.5e-5);
    let mut dopri = reference.clone();
    dopri.integrator.rtol = 1e-8;
    dopri.integrator.atol = 1e-8;
    let rs = run(&[reference, radau, rk4, dopri], 1e-9);
    for r in &rs {
        assert_eq!(r.status, SimStatus::Finished, "{:?}", r.method);
        assert_eq!(r.samples.t.len(), 1001);
    }
    // Measured 4e-12, 6e-15, 8e-13 m: tolerances ~25x above, far below the 1e-4 m orbit.
    for (k, tol) in [(1, 1e-10), (2, 1e-12), (3, 2e-11)] {
        let d = g_distance(&rs[0], &rs[k]);
        eprintln!("{:?}: max |G - G_ref| = {d:e} m", rs[k].method);
        assert!(
            d < tol,
            "{:?}: max |G - G_ref| = {d:e} m, tol {tol:e}",
            rs[k].method
        );
    }
}

#[test]
fn cpu_and_gpu_backends_agree_on_the_paper_rotor() {
    let require = std::env::var("BEARING_SWEEP_REQUIRE_GPU").is_ok_and(|v| v == "1");
    let gpu = match create_backend(BackendKind::Gpu, Accuracy::new(1e-6).unwrap()) {
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
    let (mut b, _) = paper();
    b.integrator.t_end = 0.1;
    let mut ev = LoadEvaluator::new(gpu);
    let on_gpu = simulate_batch(std::slice::from_ref(&b), &mut ev, &mut |_, _| {});
    let on_cpu = run(std::slice::from_ref(&b), 1e-6);
    assert_eq!(on_gpu[0].status, SimStatus::Finished);
    // The GPU kernel may compute in f32 on nondimensional variables: loads to ~1e-6
    // relative, trajectories to a small fraction of the 1e-4 m orbit.
    let d = g_distance(&on_cpu[0], &on_gpu[0]);
    assert!(d < 1e-8, "max |G_cpu - G_gpu| = {d:e} m, tol 1e-8");
}

#[test]
fn a_contact_model_carries_the_rotor_through_film_breakdown() {
    // The huge-unbalance variant that ends in film breakdown without a contact model
    // finishes with one: breakdowns are reported as events, outputs stay finite, and
    // the energy balance still holds (the penalty force's work is in `work`).
    let (b, _) = paper();
    let mut s = b.clone();
    s.name = "contact".into();
    s.integrator.t_end = 0.1;
    s.integrator.rtol = 1e-9;
    s.integrator.atol = 1e-9;
    s.rotor.static_unbalance = [0.05, 0.0];
    s.film.threshold = 3e-5;
    s.film.contact = Some(bearing_sweep::rotor::ContactSpec {
        stiffness: 1e8,
        damping: 100.0,
    });
    let r = &run(&[s], 1e-6)[0];
    assert_eq!(r.status, SimStatus::Finished);
    assert_finite(r);
    assert!(!r.film_events.is_empty(), "a breakdown event is reported");
    for ev in &r.film_events {
        assert!(ev.h_min < 3e-5 && ev.h_min > 0.0, "{ev:?}");
    }
    let s = &r.samples;
    for k in 0..s.t.len() {
        let dke = s.kinetic_energy[k] - s.kinetic_energy[0];
        assert!(
            (dke - s.work[k]).abs() < 1e-6,
            "sample {k}: dKE {dke}, work {}, tol 1e-6",
            s.work[k]
        );
    }
    let worst = s
        .bearings
        .iter()
        .flat_map(|b| b.h_min.iter())
        .fold(f64::INFINITY, |a, &b| a.min(b));
    assert!(worst > 0.0, "the journal stays off the wall: h_min {worst}");
    eprintln!(
        "contact: {} events, thinnest film {worst:e} m, {} steps",
        r.film_events.len(),
        r.stats.steps
    );
}

#[test]
fn streaming_hands_samples_to_progress_and_keeps_only_statuses() {
    let (b, ideal) = paper();
    let mut s = b.clone();
    s.integrator.t_end = 0.02;
    let mut i = ideal.clone();
    i.integrator.t_end = 0.02;
    let kept = run(&[s.clone(), i.clone()], 1e-6);
    let mut ev = cpu(1e-6);
    let mut streamed: Vec<Option<SimResult>> = vec![None, None];
    let out = bearing_sweep::rotor::simulate_batch_streaming(&[s, i], &mut ev, &mut |k, r| {
        streamed[k] = Some(r.clone())
    });
    for k in 0..2 {
        assert_eq!(out[k].status, SimStatus::Finished);
        assert!(
            out[k].samples.t.is_empty(),
            "returned result {k} keeps no samples"
        );
        let st = streamed[k].as_ref().unwrap();
        assert!(
            st.samples == kept[k].samples,
            "streamed samples of result {k} differ"
        );
        assert_eq!(st.status, kept[k].status);
        assert_eq!(st.stats.steps, kept[k].stats.steps);
    }
}

/// Largest distance over samples between two runs' `G` and between their journal centres
/// at both end faces of every bearing, m.
fn position_errors(a: &SimResult, b: &SimResult) -> (f64, f64) {
    let (sa, sb) = (&a.samples, &b.samples);
    assert_eq!(sa.t.len(), sb.t.len(), "{}: sample counts", a.name);
    let mut eg = 0.0f64;
    let mut ec = 0.0f64;
    for k in 0..sa.t.len() {
        eg = eg.max((sa.x_g[k] - sb.x_g[k]).hypot(sa.y_g[k] - sb.y_g[k]));
        for (ba, bb) in sa.bearings.iter().zip(&sb.bearings) {
            ec = ec.max((ba.xi[k] - bb.xi[k]).hypot(ba.yi[k] - bb.yi[k]));
            ec = ec.max((ba.xj[k] - bb.xj[k]).hypot(ba.yj[k] - bb.yj[k]));
        }
    }
    (eg, ec)
}

/// Issue 28, error control on what users read: at `rtol = atol = 1e-6` the journal
/// centres at both faces (Fig. 10's orbit) are as accurate as `G`, relative to the
/// clearance, against a tight-tolerance reference, on the paper rotor and on the corners
/// of the clearance x viscosity sweep, over the first 50 ms where the error peaks. Before
/// the quaternion's tilt components were scaled by the lever arm, the journal centres were
/// 10-50 times less accurate than `G` (BENCHMARKS.md "Issue 28").
#[test]
fn journal_centres_meet_the_tolerance_like_g_against_a_tight_reference() {
    let (base, _) = paper();
    let mut scenes = Vec::new();
    for (c, mu, method) in [
        (3e-4, 0.0242, Method::Dopri5),
        (1e-4, 0.005, Method::Dopri5),
        (1e-4, 0.1, Method::Auto),
        (6e-4, 0.005, Method::Dopri5),
        (6e-4, 0.1, Method::Dopri5),
    ] {
        let mut s = base.clone();
        s.name = format!("c{c}-mu{mu}-{}", method.name());
        s.integrator.t_end = 0.05;
        s.integrator.sample_interval = 5e-4;
        s.integrator.method = method;
        for b in &mut s.bearings {
            b.clearance = c;
            b.viscosity = Some(mu);
        }
        scenes.push(s);
    }
    let tight: Vec<Scene> = scenes
        .iter()
        .map(|s| {
            let mut t = s.clone();
            t.integrator.method = Method::Dopri5;
            t.integrator.rtol = 1e-11;
            t.integrator.atol = 1e-11;
            t
        })
        .collect();
    // Loads at the 1e-12 level in both, so the integrator's error is what is measured.
    let runs = run(&scenes, 1e-12);
    let refs = run(&tight, 1e-12);
    for (r, x) in runs.iter().zip(&refs) {
        assert_eq!(r.status, SimStatus::Finished, "{}", r.name);
        let d = r_clearance(&scenes, &r.name);
        let (eg, ec) = position_errors(r, x);
        eprintln!(
            "{}: G error {eg:.2e} m, journal-centre error {ec:.2e} m ({:.1} x G), \
             clearance {d:e} m",
            r.name,
            ec / eg.max(1e-300)
        );
        // rtol = 1e-6 of the clearance, with the usual global-error factor of tens.
        let tol = 50.0 * 1e-6 * d;
        assert!(eg < tol, "{}: G error {eg:e} m > {tol:e} m", r.name);
        assert!(
            ec < tol,
            "{}: journal-centre error {ec:e} m > {tol:e} m (G: {eg:e} m)",
            r.name
        );
        // And within a small factor of G's own error (floored at 1e-9 of the clearance,
        // where both are at rounding level): before the fix the factor was 10-50.
        let rel = 10.0 * eg.max(1e-9 * d);
        assert!(
            ec <= rel,
            "{}: journal-centre error {ec:e} m > 10 x G's {eg:e} m",
            r.name
        );
    }
}

fn r_clearance(scenes: &[Scene], name: &str) -> f64 {
    scenes
        .iter()
        .find(|s| s.name == name)
        .map(|s| s.bearings[0].clearance)
        .expect("a scene of that name")
}
