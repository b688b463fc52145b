//! Lubricants and the thermal balance (issue 24 items 3-4, docs/thermal.md) through
//! `eval`, friction maps, scenes and the service.

mod service_support;

use bearing_sweep::app::{eval_json, EvalOptions};
use bearing_sweep::bearing::{Accuracy, Lubricant};
use bearing_sweep::sweep::friction_map::{friction_map, FrictionMapSpec};
use serde_json::{json, Value};

fn lubricated(extra: Value) -> Value {
    let mut b = json!({"radius": 0.02, "length": 0.02, "clearance": 3e-4,
                       "lubricant": "ISO VG 46", "supply_temperature": 40.0});
    if let (Some(m), Value::Object(e)) = (b.as_object_mut(), extra) {
        m.extend(e);
    }
    b
}

fn state(eps: f64, omega: f64) -> Value {
    json!({"xi": eps * 3e-4, "yi": 0.0, "xj": eps * 3e-4, "yj": 0.0,
           "vxi": 0.0, "vyi": 0.0, "vxj": 0.0, "vyj": 0.0, "omega": omega})
}

fn eval(bearing: Value, states: Vec<Value>) -> Vec<Value> {
    let doc = json!({"bearing": bearing, "states": states});
    let (out, _) = eval_json(&doc.to_string(), EvalOptions::default()).unwrap();
    out["loads"].as_array().unwrap().clone()
}

fn f(v: &Value, key: &str) -> f64 {
    v[key]
        .as_f64()
        .unwrap_or_else(|| panic!("{key} missing in {v}"))
}

/// Through `eval`: the balance closes per state to its tolerance, the rise grows with
/// speed, and the loads are those of a plain-viscosity bearing at μ(T_eff).
#[test]
fn eval_balance_closes_rise_grows_with_speed_and_loads_are_at_t_eff() {
    let speeds = [30.0, 100.0, 300.0, 1000.0, 3000.0];
    let loads = eval(
        lubricated(json!({})),
        speeds.iter().map(|&w| state(0.6, w)).collect(),
    );
    let lub = Lubricant::iso_vg(46).unwrap();
    let mut last_rise = 0.0;
    for (k, l) in loads.iter().enumerate() {
        assert_eq!(l["status"], "ok", "{l}");
        let t = &l["thermal"];
        let (p, out) = (
            f(t, "power_loss_w"),
            f(t, "heat_to_flow_w") + f(t, "heat_to_housing_w"),
        );
        // |P − out| <= |dr/dT| tol, |dr/dT| <= removal slope + 0.1 P (|dμ/dT| < 0.1 μ/K).
        let teff = f(t, "effective_temperature_c");
        let slope = lub.heat_capacity_per_volume(teff) * f(t, "side_flow_m3_s") / 0.8 + 0.1 * p;
        let bound = slope * f(t, "tolerance_k");
        assert!(
            (p - out).abs() <= bound,
            "state {k}: heat in {p} W, out {out} W, tolerance {bound} W"
        );
        // The heat is the film's own friction power at μ(T_eff), not the paper's law
        // (`power_loss`, still reported beside it with `friction_model: "paper"`).
        let film_p = f(&l["film"], "power_loss_w");
        assert!(
            (film_p - p).abs() <= 1e-12 * p,
            "state {k}: film power {film_p} vs balance {p}"
        );
        assert_eq!(l["friction_model"], "paper", "{l}");
        assert!(
            (f(l, "power_loss") - p).abs() > 1e-3 * p,
            "state {k}: the paper's law {} should differ from the film's {p}",
            f(l, "power_loss")
        );
        assert!(t["heat_source"].as_str().unwrap().contains("film"), "{t}");
        let rise = f(t, "temperature_rise_k");
        assert!(
            rise > last_rise,
            "state {k}: rise {rise} K at {} rad/s not above {last_rise} K",
            speeds[k]
        );
        last_rise = rise;
        // The same state with the plain viscosity μ(T_eff): the same loads.
        let mu = f(t, "effective_viscosity_pa_s");
        assert!(
            (mu - lub.dynamic_viscosity(teff)).abs() <= 1e-15,
            "state {k}: μ {mu}"
        );
        let plain = eval(
            json!({"radius": 0.02, "length": 0.02, "clearance": 3e-4, "viscosity": mu}),
            vec![state(0.6, speeds[k])],
        );
        for key in ["wx", "wy", "mx", "my", "mz", "power_loss"] {
            let (a, e) = (f(l, key), f(&plain[0], key));
            assert!(
                (a - e).abs() <= 1e-12 * e.abs().max(1e-30),
                "state {k} {key}: actual {a}, expected {e}, tolerance 1e-12 relative"
            );
        }
    }
}

/// Grooves with a supply pressure make the film nonlinear in μ (the held pressure does not
/// scale, the flow it drives goes as 1/μ): `eval` then solves the film at every trial
/// viscosity. The loads, flow, power and the finite error estimate equal those of a
/// plain bearing at μ(T_eff) (1e-9 relative: the same cold solve), the balance closes,
/// and a higher supply pressure, more flow, gives a lower rise.
#[test]
fn pressurised_grooves_solve_the_film_at_each_viscosity() {
    let grooved = |extra: Value, ps: f64| {
        let mut b = json!({"radius": 0.02, "length": 0.02, "clearance": 1e-4, "model": "finite",
                           "finite": {"n_theta": 72, "n_z": 8},
                           "grooves": [{"angle": 0.0, "width": 20.0, "supply_pressure": ps},
                                       {"angle": 180.0, "width": 20.0, "supply_pressure": ps}]});
        b.as_object_mut()
            .unwrap()
            .extend(extra.as_object().unwrap().clone());
        b
    };
    let st = json!({"xi": 0.0, "yi": -6e-5, "xj": 0.0, "yj": -6e-5,
                    "vxi": 0.0, "vyi": 0.0, "vxj": 0.0, "vyj": 0.0, "omega": 1000.0});
    let lub = json!({"lubricant": "ISO VG 46", "supply_temperature": 40.0});
    let mut rises = Vec::new();
    for ps in [1e5, 4e5] {
        let l = &eval(grooved(lub.clone(), ps), vec![st.clone()])[0];
        assert_eq!(l["status"], "ok", "{l}");
        let t = &l["thermal"];
        let mu = f(t, "effective_viscosity_pa_s");
        let plain = &eval(grooved(json!({"viscosity": mu}), ps), vec![st.clone()])[0];
        for key in [
            "wx",
            "wy",
            "mx",
            "my",
            "power_loss",
            "finite_error_estimate",
        ] {
            let (a, e) = (f(l, key), f(plain, key));
            assert!(
                (a - e).abs() <= 1e-9 * e.abs(),
                "supply {ps} Pa {key}: thermal {a}, plain at μ(T_eff) {e}"
            );
        }
        for key in ["power_loss_w", "side_flow_m3_per_s"] {
            let (a, e) = (f(&l["film"], key), f(&plain["film"], key));
            assert!(
                (a - e).abs() <= 1e-9 * e.abs(),
                "supply {ps} Pa film.{key}: thermal {a}, plain at μ(T_eff) {e}"
            );
        }
        // The balance closes at the film's own power and flow at μ(T_eff).
        let (pin, q) = (f(t, "power_loss_w"), f(t, "side_flow_m3_s"));
        assert!(
            (pin - f(&plain["film"], "power_loss_w")).abs() <= 1e-9 * pin,
            "{t}"
        );
        let teff = f(t, "effective_temperature_c");
        let lubr = Lubricant::iso_vg(46).unwrap();
        let out = f(t, "heat_to_flow_w") + f(t, "heat_to_housing_w");
        let bound =
            (lubr.heat_capacity_per_volume(teff) * q / 0.8 + 0.2 * pin) * f(t, "tolerance_k");
        assert!(
            (pin - out).abs() <= bound,
            "in {pin} W, out {out} W, bound {bound} W"
        );
        rises.push(f(t, "temperature_rise_k"));
    }
    assert!(
        rises[1] < rises[0],
        "rises {rises:?} K at 1e5 and 4e5 Pa supply"
    );
}

/// A heat path through the housing takes part of the heat: a lower rise; a higher
/// effective-temperature factor a higher T_eff at the same flow.
#[test]
fn housing_conductance_lowers_the_rise() {
    let at = |extra: Value| {
        let l = eval(lubricated(extra), vec![state(0.6, 2000.0)]);
        l[0]["thermal"].clone()
    };
    let adiabatic = at(json!({}));
    let cooled = at(json!({"thermal": {"housing_conductance": 2.0}}));
    let (a, c) = (
        f(&adiabatic, "temperature_rise_k"),
        f(&cooled, "temperature_rise_k"),
    );
    assert!(c < a, "rise with housing {c} K, adiabatic {a} K");
    assert!(f(&cooled, "heat_to_housing_w") > 0.0, "{cooled}");
}

/// Bad lubricant input: a clear error naming the bearing's path and the fields.
#[test]
fn lubricant_input_errors_name_path_and_fields() {
    let cases = [
        (
            json!({"radius": 0.02, "length": 0.02, "clearance": 3e-4, "viscosity": 0.02,
                   "lubricant": "ISO VG 46", "supply_temperature": 40}),
            "not both",
        ),
        (
            json!({"radius": 0.02, "length": 0.02, "clearance": 3e-4, "lubricant": "ISO VG 46"}),
            "needs `supply_temperature`",
        ),
        (
            json!({"radius": 0.02, "length": 0.02, "clearance": 3e-4, "viscosity": 0.02,
                   "supply_temperature": 40}),
            "needs `lubricant`",
        ),
        (
            json!({"radius": 0.02, "length": 0.02, "clearance": 3e-4, "lubricant": "ISO VG 47",
                   "supply_temperature": 40}),
            "unknown lubricant",
        ),
        (
            json!({"radius": 0.02, "length": 0.02, "clearance": 3e-4}),
            "missing field `viscosity`",
        ),
        (
            lubricated(json!({"supply_temperature": 900})),
            "supply_temperature",
        ),
        (
            lubricated(json!({"thermal": {"effective_factor": 2}})),
            "effective_factor",
        ),
    ];
    for (k, (bearing, want)) in cases.into_iter().enumerate() {
        let doc = json!({"bearing": bearing, "states": [state(0.5, 100.0)]});
        let e = eval_json(&doc.to_string(), EvalOptions::default())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("bearing") && e.contains(want),
            "case {k}: {e:?} should name `bearing` and say {want:?}"
        );
    }
}

/// Friction map, film model with a lubricant: the balance closes at every point, the
/// rise grows with speed at a fixed load, and the equilibrium is the one at μ(T_eff).
#[test]
fn friction_map_solves_equilibrium_and_balance_together() {
    let doc = json!({"kind": "friction_map", "bearing": lubricated(json!({})),
                     "load": [200.0], "speed": [100.0, 300.0, 1000.0, 3000.0], "model": "film"});
    let spec = FrictionMapSpec::parse(&doc).unwrap();
    let (out, _) = friction_map(&spec, Accuracy::default());
    let mut last = 0.0;
    for (k, c) in out["curves"].as_array().unwrap().iter().enumerate() {
        let p = &c["points"][0];
        let t = &p["thermal"];
        let rise = f(t, "temperature_rise_k");
        assert!(rise > last, "speed {k}: rise {rise} K not above {last} K");
        last = rise;
        let (pin, pout) = (
            f(t, "power_loss_w"),
            f(t, "heat_to_flow_w") + f(t, "heat_to_housing_w"),
        );
        // Each balance step re-solves the equilibrium (bisection to 1e-12 in load), so
        // the residual bound is the solver's: slope x tolerance, slope < 0.2 P/K here.
        let teff = f(t, "effective_temperature_c");
        let lub = Lubricant::iso_vg(46).unwrap();
        let bound = (lub.heat_capacity_per_volume(teff) * f(t, "side_flow_m3_s") / 0.8 + 0.2 * pin)
            * f(t, "tolerance_k");
        assert!(
            (pin - pout).abs() <= bound,
            "speed {k}: in {pin} W, out {pout} W, bound {bound} W"
        );
        // The balance's heat is the film's friction power at the equilibrium at μ(T_eff).
        assert!(
            (f(p, "film_power_loss_w") - pin).abs() <= 1e-9 * pin,
            "speed {k}: film power {} vs balance {pin}",
            f(p, "film_power_loss_w")
        );
    }
    // The paper's law (model "sommerfeld") has no eccentricity: refused with a reason.
    let mut bad = doc.clone();
    bad["model"] = json!("sommerfeld");
    let e = FrictionMapSpec::parse(&bad).unwrap_err().to_string();
    assert!(e.contains("model") && e.contains("film"), "{e}");
}

/// A symmetric rotor (no unbalance) on two equal lubricated bearings, gravity `-y`,
/// spin held at `omega` from cold oil: each bearing carries half the weight, so its
/// lumped temperature has the steady balance at that load as rest point.
fn run_up_scene(omega: f64, capacity: f64, housing: f64, t_end: f64, dt: f64) -> Value {
    let bearing = |z: f64| {
        json!({"radius": 0.02, "length": 0.02, "clearance": 1e-4, "axial_position": z,
               "lubricant": "ISO VG 46", "supply_temperature": 40.0,
               "thermal": {"thermal_capacity": capacity, "housing_conductance": housing}})
    };
    json!({
        "name": "thermal-run-up",
        "rotor": {"mass": 500.0, "inertia": [5.0, 5.0, 1.25]},
        "bearings": [bearing(0.15), bearing(-0.15)],
        "gravity": [0.0, -9.81, 0.0],
        "spin": "held",
        "initial": {"spin": omega},
        "integrator": {"method": "dopri5", "rtol": 1e-8, "atol": 1e-8, "t_end": t_end,
                       "sample_interval": dt},
        "film": {"threshold": 1e-7}
    })
}

fn run(scene: &Value) -> bearing_sweep::rotor::SimResult {
    use bearing_sweep::backend::{CpuBackend, LoadEvaluator};
    use bearing_sweep::rotor::{load_scene, simulate_batch};
    let scenes = load_scene(&scene.to_string()).unwrap();
    let mut ev = LoadEvaluator::new(Box::new(CpuBackend::new(Accuracy::default(), None)));
    let r = simulate_batch(&scenes, &mut ev, &mut |_, _| {}).remove(0);
    assert!(r.status.is_finished(), "{:?}", r.status);
    r
}

/// An adiabatic run-up: the lumped oil temperature of each bearing rises from the supply
/// temperature to the steady balance at the final speed and load (the friction map's
/// equilibrium solved with the balance, `map_balance`), within 1e-4 K after 30 time
/// constants (3e-6 K is reached); its film viscosity is μ(T) at every sample.
#[test]
fn run_up_lumped_temperature_approaches_the_steady_balance() {
    use bearing_sweep::bearing::{BearingParams, FilmRule};
    use bearing_sweep::sweep::friction_map::map_balance;
    let (omega, capacity) = (1000.0, 2.0);
    let scene = run_up_scene(omega, capacity, 0.0, 1.0, 1e-3);
    let r = run(&scene);
    let mut pj = scene["bearings"][0].clone();
    pj.as_object_mut().unwrap().remove("axial_position");
    let p: BearingParams = serde_json::from_value(pj).unwrap();
    let rule = FilmRule::new(Accuracy::default().settings());
    let steady = map_balance(&p, &rule, 0.5 * 500.0 * 9.81, omega).unwrap();
    let lub = Lubricant::iso_vg(46).unwrap();
    for (b, series) in r.samples.bearings.iter().enumerate() {
        let th = series
            .thermal
            .as_ref()
            .expect("a thermal bearing has a thermal series");
        let t = &th.temperature_c;
        assert_eq!(t[0], 40.0, "bearing {b} starts at the supply temperature");
        // The time constant C / (ρ c Q / k + H) at the steady point bounds the approach.
        let tau = capacity
            / (lub.heat_capacity_per_volume(steady.effective_temperature_c)
                * steady.side_flow_m3_s
                / 0.8);
        let t_end = *r.samples.t.last().unwrap();
        assert!(t_end > 30.0 * tau, "run {t_end} s, time constant {tau} s");
        let last = *t.last().unwrap();
        let want = steady.effective_temperature_c;
        assert!(
            (last - want).abs() <= 1e-4,
            "bearing {b}: lumped {last} °C, steady balance {want} °C (rise {} K), tolerance 1e-4 K",
            want - 40.0
        );
        // A run-up heats the film well above the supply; the journal's settling orbit
        // (ε 0.78-0.81 in the first 0.1 s) moves the power and flow, so the temperature
        // overshoots a little on the way (0.02 K here), never by 0.1 K.
        assert!(
            want - 40.0 > 1.0,
            "rise {} K too small to test",
            want - 40.0
        );
        for (k, &tk) in t.iter().enumerate() {
            assert!(
                tk >= 40.0 && tk <= want + 0.1,
                "bearing {b} sample {k}: {tk} °C outside [40, {want} + 0.1]"
            );
        }
        for (k, (&tc, &mu)) in t.iter().zip(&th.viscosity_pa_s).enumerate() {
            assert!(
                (mu - lub.dynamic_viscosity(tc)).abs() <= 1e-15,
                "sample {k}: μ {mu} at {tc} °C"
            );
        }
        // At the end the heat in equals the heat out (the rest point).
        let (pin, pout) = (
            *th.power_w.last().unwrap(),
            th.heat_to_flow_w.last().unwrap() + th.heat_to_housing_w.last().unwrap(),
        );
        assert!(
            (pin - pout).abs() <= 1e-3 * pin,
            "bearing {b}: in {pin} W, out {pout} W at the end"
        );
    }
}

/// The run's summary `oil_temperature` is the samples' last and highest temperature;
/// a sweep over the supply temperature carries it per variant (`sim.oil_temperature`),
/// equal to the scene run alone, and a variant without a lubricant has none.
#[test]
fn oil_temperature_summary_in_runs_and_sweeps() {
    use bearing_sweep::backend::{create_backend, BackendKind, LoadEvaluator};
    use bearing_sweep::sweep::parse_spec;
    use bearing_sweep::sweep::rotor_sim::{validate_scene, RotorSimulator};
    use bearing_sweep::sweep::runner::{run_sweep, RunOptions, RunnerOptions};
    let mut base = run_up_scene(1000.0, 2.0, 0.0, 0.05, 1e-3);
    let r = run(&base);
    assert_eq!(r.oil_temperature.len(), 2);
    for o in &r.oil_temperature {
        let th = r.samples.bearings[o.bearing].thermal.as_ref().unwrap();
        assert_eq!(o.final_temperature_c, *th.temperature_c.last().unwrap());
        assert_eq!(o.final_power_w, *th.power_w.last().unwrap());
        let max = th.temperature_c.iter().cloned().fold(f64::MIN, f64::max);
        assert_eq!(o.max_temperature_c, max);
        let k = th.temperature_c.iter().position(|&t| t == max).unwrap();
        assert_eq!(o.max_at_s, r.samples.t[k]);
        assert_eq!(o.supply_temperature_c, 40.0);
    }
    // The sweep: supply at 40 and 60 °C, and a plain-viscosity variant.
    base.as_object_mut().unwrap().remove("name");
    let spec = json!({"kind": "rotor", "base": base,
                      "axes": [{"path": "bearings[*].supply_temperature", "values": [40.0, 60.0]}],
                      "reductions": {"window": {"fraction": 0.5}}});
    let spec = parse_spec(&spec, None).unwrap();
    let dir = std::env::temp_dir().join(format!("thermal-sweep-{}", std::process::id()));
    let out = dir.join("result.json");
    std::fs::create_dir_all(&dir).unwrap();
    let accuracy = Accuracy::default();
    let backend = create_backend(BackendKind::Cpu, accuracy).unwrap().0;
    let mut sim = RotorSimulator::new(LoadEvaluator::new(backend), accuracy);
    let opts = RunOptions {
        result: out.clone(),
        progress: false,
        runner: RunnerOptions::default(),
        settings: sim.settings(accuracy.rtol()),
    };
    run_sweep(&spec, &validate_scene, &mut sim, &opts, &mut |_| {}).unwrap();
    let result: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let variants = result["variants"].as_array().unwrap();
    assert_eq!(variants.len(), 2);
    let mut finals = Vec::new();
    for v in variants {
        assert_eq!(v["status"], "ok", "{v}");
        let oil = v["sim"]["oil_temperature"]
            .as_array()
            .expect("sim.oil_temperature");
        assert_eq!(oil.len(), 2, "{v}");
        finals.push(f(&oil[0], "final_temperature_c") - f(&oil[0], "supply_temperature_c"));
    }
    // Variant 0 is the scene run alone (supply 40 °C).
    let direct = r.oil_temperature[0].final_temperature_c;
    let swept = f(
        &variants[0]["sim"]["oil_temperature"][0],
        "final_temperature_c",
    );
    assert!(
        (swept - direct).abs() <= 1e-9,
        "sweep {swept} °C, direct {direct} °C"
    );
    // Hotter supply, thinner oil, less friction power: a smaller rise.
    assert!(finals[1] < finals[0], "rises {finals:?}");
    let _ = std::fs::remove_dir_all(&dir);
    // Without a lubricant: no summary.
    let mut plain = run_up_scene(1000.0, 2.0, 0.0, 0.01, 1e-3);
    for b in plain["bearings"].as_array_mut().unwrap() {
        let m = b.as_object_mut().unwrap();
        for k in ["lubricant", "supply_temperature", "thermal"] {
            m.remove(k);
        }
        m.insert("viscosity".into(), json!(0.03));
    }
    let r = run(&plain);
    assert!(r.oil_temperature.is_empty());
    assert!(r.samples.bearings[0].thermal.is_none());
    let text = serde_json::to_string(&r).unwrap();
    assert!(!text.contains("oil_temperature") && !text.contains("\"thermal\""));
}

/// The lumped temperature on the GPU backend (lavapipe or a real GPU; skipped without
/// one unless `BEARING_SWEEP_REQUIRE_GPU=1`): the run-up's final temperature agrees with
/// the CPU's within 1e-6 K.
#[test]
fn lumped_temperature_gpu_matches_cpu() {
    use bearing_sweep::backend::{create_backend, BackendKind, LoadEvaluator};
    use bearing_sweep::rotor::{load_scene, simulate_batch};
    let require = std::env::var("BEARING_SWEEP_REQUIRE_GPU").is_ok_and(|v| v == "1");
    let accuracy = Accuracy::default();
    let gpu = match create_backend(BackendKind::Gpu, accuracy) {
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
    let scene = run_up_scene(1000.0, 2.0, 0.0, 0.05, 1e-3);
    let scenes = load_scene(&scene.to_string()).unwrap();
    let mut ev = LoadEvaluator::new(gpu);
    let g = simulate_batch(&scenes, &mut ev, &mut |_, _| {}).remove(0);
    assert!(g.status.is_finished(), "{:?}", g.status);
    let c = run(&scene);
    for (a, b) in g.oil_temperature.iter().zip(&c.oil_temperature) {
        assert!(
            (a.final_temperature_c - b.final_temperature_c).abs() <= 1e-6,
            "gpu {} °C, cpu {} °C",
            a.final_temperature_c,
            b.final_temperature_c
        );
    }
}

/// A centred, unloaded journal has no side flow (`Q = ε δ ω r B = 0`) and, adiabatic, no
/// heat path: its lumped temperature grows without bound, and the run stops with a load
/// failure naming the bearing and the runaway once it is 1000 K above the supply (never
/// a NaN or a hang).
#[test]
fn thermal_runaway_stops_the_run_with_a_reason() {
    use bearing_sweep::backend::{CpuBackend, LoadEvaluator};
    use bearing_sweep::rotor::{load_scene, simulate_batch, SimStatus};
    let mut scene = run_up_scene(1000.0, 1e-3, 0.0, 2.0, 1e-3);
    scene["gravity"] = json!([0.0, 0.0, 0.0]);
    let scenes = load_scene(&scene.to_string()).unwrap();
    let mut ev = LoadEvaluator::new(Box::new(CpuBackend::new(Accuracy::default(), None)));
    let r = simulate_batch(&scenes, &mut ev, &mut |_, _| {}).remove(0);
    match &r.status {
        SimStatus::LoadFailure {
            bearing, reason, ..
        } => {
            assert!(*bearing < 2 && reason.contains("runaway"), "{reason}");
        }
        other => panic!(
            "expected a runaway load failure, got {other:?}: T {:?}",
            r.samples.bearings[0]
                .thermal
                .as_ref()
                .map(|t| t.temperature_c.last().copied())
        ),
    }
    let th = r.samples.bearings[0].thermal.as_ref().unwrap();
    assert!(th
        .temperature_c
        .iter()
        .all(|t| t.is_finite() && *t <= 40.0 + 1000.0 + 1e-6));
}

/// The finite film (two pressurised axial grooves) carries the lumped temperature too:
/// each stage's film runs at μ(T) (the per-stage bearing parameters reach the finite
/// solver), the oil warms from the supply temperature, and the heat flows at the last
/// sample are the film's (power positive, flow carrying heat out).
#[test]
fn finite_film_scene_carries_the_temperature() {
    let mut scene = run_up_scene(500.0, 0.05, 0.0, 0.004, 5e-4);
    scene["rotor"] = json!({"mass": 3.0, "inertia": [0.03, 0.03, 0.02]});
    for b in scene["bearings"].as_array_mut().unwrap() {
        let m = b.as_object_mut().unwrap();
        m.insert("model".into(), json!("finite"));
        m.insert("finite".into(), json!({"n_theta": 72, "n_z": 8}));
        m.insert(
            "grooves".into(),
            json!([{"angle": 0.0, "width": 20.0, "supply_pressure": 1e5},
                   {"angle": 180.0, "width": 20.0, "supply_pressure": 1e5}]),
        );
    }
    scene["integrator"]["rtol"] = json!(1e-6);
    scene["integrator"]["atol"] = json!(1e-6);
    let r = run(&scene);
    let lub = Lubricant::iso_vg(46).unwrap();
    for (b, series) in r.samples.bearings.iter().enumerate() {
        let th = series.thermal.as_ref().unwrap();
        let (first, last) = (th.temperature_c[0], *th.temperature_c.last().unwrap());
        assert_eq!(first, 40.0);
        assert!(
            last > 40.01,
            "bearing {b}: {last} °C after {} s",
            r.samples.t.last().unwrap()
        );
        for (&t, &mu) in th.temperature_c.iter().zip(&th.viscosity_pa_s) {
            assert!((mu - lub.dynamic_viscosity(t)).abs() <= 1e-15);
        }
        assert!(*th.power_w.last().unwrap() > 0.0 && *th.heat_to_flow_w.last().unwrap() > 0.0);
    }
}

/// Energy bookkeeping of the lumped temperature: the heat generated minus the heat
/// removed, integrated over the run, equals `C ΔT`, with a housing path too. The
/// integral is Simpson's rule over the samples, whose own error is estimated from the
/// samples at twice the interval; the bound is that estimate plus the integrator's
/// tolerance on `T` (rtol × T + atol × 1 K, times 10 for the accumulated local errors).
#[test]
fn lumped_temperature_energy_bookkeeping_closes() {
    let capacity = 0.2;
    let r = run(&run_up_scene(800.0, capacity, 0.5, 0.1, 1e-4));
    let t = &r.samples.t;
    assert_eq!(r.samples.sample_stride, 1, "every sample kept");
    // Composite Simpson over an even number of intervals of samples taken every `step`.
    let simpson = |g: &dyn Fn(usize) -> f64, step: usize| {
        let n = (t.len() - 1) / (2 * step) * 2 * step;
        let mut sum = 0.0;
        let mut k = 0;
        while k + 2 * step <= n {
            let h = t[k + step] - t[k];
            sum += h / 3.0 * (g(k) + 4.0 * g(k + step) + g(k + 2 * step));
            k += 2 * step;
        }
        (sum, n)
    };
    for (b, series) in r.samples.bearings.iter().enumerate() {
        let th = series.thermal.as_ref().unwrap();
        let net = |k: usize| th.power_w[k] - th.heat_to_flow_w[k] - th.heat_to_housing_w[k];
        let (fine, n) = simpson(&net, 1);
        let (coarse, n2) = simpson(&net, 2);
        assert_eq!(n, n2, "both rules over the same span");
        let stored = capacity * (th.temperature_c[n] - th.temperature_c[0]);
        let quad_err = (fine - coarse).abs() / 15.0;
        let tol = quad_err + 10.0 * capacity * (1e-8 * th.temperature_c[n] + 1e-8);
        assert!(
            (fine - stored).abs() <= tol,
            "bearing {b}: ∫(in − out) dt = {fine} J, C ΔT = {stored} J, tolerance {tol} J \
             (quadrature {quad_err} J)"
        );
        assert!(
            stored > 1.0,
            "bearing {b}: {stored} J stored is too little to test"
        );
        assert!(
            th.heat_to_housing_w.last().unwrap() > &0.0,
            "the housing path takes heat"
        );
    }
}

/// With an enormous thermal capacity the oil cannot warm: the run equals the isothermal
/// run at μ(T_supply) (plain viscosity) within the integrator's tolerance on the orbit
/// (the thermal run's step sizes see two more components, so it is not bit for bit).
/// Ideal joints carry no temperature state. Both ways at once are refused.
#[test]
fn huge_thermal_capacity_equals_the_isothermal_run() {
    let base: Value = serde_json::from_str(include_str!("../sweeps/paper-example.json")).unwrap();
    let mu = Lubricant::iso_vg(68).unwrap().dynamic_viscosity(50.0);
    let mut runs = Vec::new();
    for lubricant in [true, false] {
        let mut s = base.clone();
        s["compare_ideal"] = json!(false);
        s["integrator"]["t_end"] = json!(0.05);
        s["integrator"]["rtol"] = json!(1e-9);
        s["integrator"]["atol"] = json!(1e-9);
        for b in s["bearings"].as_array_mut().unwrap() {
            let m = b.as_object_mut().unwrap();
            m.remove("viscosity");
            if lubricant {
                m.insert("lubricant".into(), json!("ISO VG 68"));
                m.insert("supply_temperature".into(), json!(50.0));
                m.insert("thermal".into(), json!({"thermal_capacity": 1e15}));
            } else {
                m.insert("viscosity".into(), json!(mu));
            }
        }
        runs.push(run(&s));
    }
    let (hot, plain) = (&runs[0], &runs[1]);
    assert_eq!(hot.samples.t, plain.samples.t);
    assert!(plain.samples.bearings[0].thermal.is_none());
    let th = hot.samples.bearings[0].thermal.as_ref().unwrap();
    let rise = th.temperature_c.last().unwrap() - 50.0;
    assert!(rise.abs() < 1e-9, "rise {rise} K with C = 1e15 J/K");
    // Orbit of G: within rtol × clearance (3e-13 m; 4e-15 m is seen).
    let tol = 1e-9 * 3e-4;
    for k in 0..plain.samples.len() {
        for (a, e) in [
            (hot.samples.x_g[k], plain.samples.x_g[k]),
            (hot.samples.y_g[k], plain.samples.y_g[k]),
        ] {
            assert!(
                (a - e).abs() <= tol,
                "sample {k}: thermal {a}, isothermal {e}, tolerance {tol} m"
            );
        }
    }
    // Ideal joints: no film, no flow, no temperature state (the joint runs at μ(T_supply)).
    let mut s = base.clone();
    s["model"] = json!("ideal");
    s["compare_ideal"] = json!(false);
    s["integrator"]["t_end"] = json!(0.01);
    for b in s["bearings"].as_array_mut().unwrap() {
        let m = b.as_object_mut().unwrap();
        m.remove("viscosity");
        m.insert("lubricant".into(), json!("ISO VG 68"));
        m.insert("supply_temperature".into(), json!(50.0));
    }
    let r = run(&s);
    assert!(r.samples.bearings[0].thermal.is_none());
    // Both ways at once in a scene: refused, naming the bearing.
    let mut s = base.clone();
    s["bearings"][1]["lubricant"] = json!("ISO VG 68");
    s["bearings"][1]["supply_temperature"] = json!(50.0);
    let e = bearing_sweep::rotor::load_scene(&s.to_string())
        .unwrap_err()
        .to_string();
    assert!(e.contains("bearings[1]") && e.contains("not both"), "{e}");
}

/// The service answers `eval` with a lubricant (127.0.0.1, ephemeral port).
#[test]
fn service_eval_with_a_lubricant() {
    use service_support::*;
    let dir = scratch("thermal-eval");
    let server = Server::start(&dir.join("data"), &["--eval-backend", "cpu"]);
    let base = server.url.clone();
    let body = json!({"bearing": lubricated(json!({})), "states": [state(0.6, 1000.0)]});
    let a = post(
        &format!("{base}/api/eval"),
        body.to_string().as_bytes(),
        None,
    );
    assert_eq!(a.status, 200, "{}", a.text);
    let l = &a.json()["loads"][0];
    let t = &l["thermal"];
    assert_eq!(t["lubricant"], "ISO VG 46", "{l}");
    assert!(f(t, "temperature_rise_k") > 0.0, "{l}");
    // And a bearing giving both ways is refused with its path.
    let bad =
        json!({"bearing": lubricated(json!({"viscosity": 0.02})), "states": [state(0.6, 1000.0)]});
    let a = post(
        &format!("{base}/api/eval"),
        bad.to_string().as_bytes(),
        None,
    );
    assert_eq!(a.status, 422, "{}", a.text);
    assert!(a.text.contains("not both"), "{}", a.text);
}

/// The design chart of the paper bearing (h_min, power loss, side flow and temperature
/// rise against clearance for ISO VG 32/46/68 supplied at 40 °C; docs/thermal.md), with
/// its physics checked: a thicker grade gives a thicker film and more power at every
/// clearance. `BEARING_SWEEP_WRITE_FIGURES=1` writes
/// `reports/figures/thermal-design-chart.svg` and prints the isothermal-vs-thermal table.
/// One chart point: (h_min µm, power W, flow L/min, rise K, isothermal h_min µm,
/// isothermal power W).
type Point = (f64, f64, f64, f64, f64, f64);

#[test]
fn design_chart_thicker_oil_thicker_film_more_power() {
    use bearing_sweep::bearing::{BearingParams, FilmRule};
    use bearing_sweep::plot::{line_plot_svg, Scale, Series};
    use bearing_sweep::sweep::friction_map::{equilibrium_eccentricity, map_balance};
    let (load, omega, supply) = (1000.0, 1000.0, 40.0);
    let clearances: Vec<f64> = (0..12)
        .map(|k| 40e-6 * (600.0f64 / 40.0).powf(k as f64 / 11.0))
        .collect();
    let rule = FilmRule::new(Accuracy::default().settings());
    let grades = [32u16, 46, 68];
    // [grade][clearance] -> (h_min µm, power W, flow L/min, rise K, isothermal h_min µm,
    // isothermal power W)
    let mut rows: Vec<Vec<Point>> = Vec::new();
    for &g in &grades {
        let mut row = Vec::new();
        for &c in &clearances {
            let p: BearingParams = serde_json::from_value(json!({
                "radius": 0.02, "length": 0.02, "clearance": c,
                "lubricant": format!("ISO VG {g}"), "supply_temperature": supply}))
            .unwrap();
            let b = map_balance(&p, &rule, load, omega).unwrap();
            let hot = BearingParams {
                viscosity: b.viscosity_pa_s,
                ..p
            };
            let (_, l) = equilibrium_eccentricity(&hot, &rule, load, omega).unwrap();
            let (_, li) = equilibrium_eccentricity(&p, &rule, load, omega).unwrap();
            row.push((
                l.h_min * 1e6,
                b.power_loss_w,
                b.side_flow_m3_s * 6e4,
                b.temperature_rise_k,
                li.h_min * 1e6,
                li.film.power_loss_w,
            ));
        }
        rows.push(row);
    }
    for k in 0..clearances.len() {
        for gi in 1..grades.len() {
            let (thin, thick) = (rows[gi - 1][k], rows[gi][k]);
            assert!(
                thick.0 > thin.0 && thick.1 > thin.1,
                "clearance index {k}: VG {} h_min {} µm / {} W not above VG {} {} µm / {} W",
                grades[gi],
                thick.0,
                thick.1,
                grades[gi - 1],
                thin.0,
                thin.1
            );
        }
        for (gi, r) in rows.iter().enumerate() {
            // Heating thins the oil: the thermal film is thinner than the isothermal one.
            assert!(
                r[k].0 < r[k].4,
                "VG {} clearance index {k}: thermal h_min {} not below isothermal {}",
                grades[gi],
                r[k].0,
                r[k].4
            );
        }
    }
    if std::env::var("BEARING_SWEEP_WRITE_FIGURES").is_err() {
        return;
    }
    let names: Vec<String> = grades.iter().map(|g| format!("ISO VG {g}")).collect();
    let panel = |title: &str, y: &str, pick: &dyn Fn(&Point) -> f64| {
        let series: Vec<Series<'_>> = rows
            .iter()
            .zip(&names)
            .map(|(row, n)| Series {
                label: n,
                points: clearances
                    .iter()
                    .zip(row)
                    .map(|(&c, r)| (c * 1e6, pick(r)))
                    .collect(),
            })
            .collect();
        line_plot_svg(
            title,
            "radial clearance (µm)",
            y,
            &series,
            Scale::Log,
            Scale::Log,
        )
        .unwrap()
    };
    let panels = [
        panel("Minimum film thickness", "h_min (µm)", &|r| r.0),
        panel("Film friction power (the heat)", "power loss (W)", &|r| r.1),
        panel("Side flow", "side flow (L/min)", &|r| r.2),
        panel("Oil temperature rise", "ΔT (K)", &|r| r.3),
    ];
    // Four panels in a 2 x 2 grid of nested SVGs, each at its own size.
    let size = |s: &str, key: &str| -> f64 {
        let at = s.find(&format!("{key}=\"")).unwrap() + key.len() + 2;
        s[at..]
            .split('"')
            .next()
            .unwrap()
            .trim_end_matches("px")
            .parse()
            .unwrap()
    };
    let (w, h) = (size(&panels[0], "width"), size(&panels[0], "height"));
    let head = 40.0;
    let mut svg = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{}\" height=\"{}\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n<text x=\"{}\" y=\"26\" font-family=\"sans-serif\" font-size=\"18\" text-anchor=\"middle\">Paper bearing (r0 = B = 20 mm), {load} N at {omega} rad/s, oil supplied at {supply} °C, thermal balance (k = 0.8, adiabatic)</text>\n",
        2.0 * w,
        2.0 * h + head,
        w
    );
    for (i, p) in panels.iter().enumerate() {
        let body = p.trim_start_matches(|c| c != '<');
        let body = body
            .strip_prefix("<?xml")
            .map_or(body, |r| &r[r.find("?>").unwrap() + 2..]);
        let inner = body.replacen(
            "<svg ",
            &format!(
                "<svg x=\"{}\" y=\"{}\" ",
                (i % 2) as f64 * w,
                head + (i / 2) as f64 * h
            ),
            1,
        );
        svg.push_str(&inner);
        svg.push('\n');
    }
    svg.push_str("</svg>\n");
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("reports/figures/thermal-design-chart.svg");
    std::fs::write(&path, svg).unwrap();
    println!("| grade | clearance µm | h_min isothermal µm | h_min thermal µm | change | power isothermal W | power thermal W | change | ΔT K |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for (gi, row) in rows.iter().enumerate() {
        for k in [0, 4, 8, 11] {
            let r = row[k];
            println!(
                "| VG {} | {:.0} | {:.2} | {:.2} | {:+.1} % | {:.1} | {:.1} | {:+.1} % | {:.1} |",
                grades[gi],
                clearances[k] * 1e6,
                r.4,
                r.0,
                100.0 * (r.0 / r.4 - 1.0),
                r.5,
                r.1,
                100.0 * (r.1 / r.5 - 1.0),
                r.3
            );
        }
    }
}

/// `coefficients` with a lubricant: per speed the equilibrium and the balance solved
/// together; the stiffness and damping are those of a plain bearing at μ(T_eff) (within
/// their own error estimates), and the rise grows with speed.
#[test]
fn coefficients_solve_equilibrium_and_balance_together() {
    use bearing_sweep::app::coefficients_json;
    let doc =
        json!({"bearing": lubricated(json!({})), "speeds": [300.0, 3000.0], "load": [0.0, -200.0]});
    let out = coefficients_json(&doc.to_string()).unwrap();
    let pts = out["points"].as_array().unwrap();
    let rises: Vec<f64> = pts
        .iter()
        .map(|p| f(&p["thermal"], "temperature_rise_k"))
        .collect();
    assert!(rises[1] > rises[0], "rises {rises:?}");
    for (k, p) in pts.iter().enumerate() {
        let mu = f(&p["thermal"], "effective_viscosity_pa_s");
        let plain = json!({"bearing": {"radius": 0.02, "length": 0.02, "clearance": 3e-4, "viscosity": mu},
                           "speed": p["speed"], "load": [0.0, -200.0]});
        let q = coefficients_json(&plain.to_string()).unwrap();
        for kind in ["stiffness", "damping"] {
            for i in 0..2 {
                for j in 0..2 {
                    let (a, e) = (
                        p[kind][i][j].as_f64().unwrap(),
                        q[kind][i][j].as_f64().unwrap(),
                    );
                    let tol = 1e-6 * e.abs().max(1.0)
                        + p[format!("{kind}_error")][i][j].as_f64().unwrap_or(0.0)
                        + q[format!("{kind}_error")][i][j].as_f64().unwrap_or(0.0);
                    assert!(
                        (a - e).abs() <= tol,
                        "speed {k} {kind}[{i}][{j}]: actual {a}, expected {e}, tolerance {tol}"
                    );
                }
            }
        }
    }
}
