//! `stability` with the effective-temperature balance (issue 24, docs/thermal.md
//! "Stability"): each speed's rotor equilibrium solved together with every lubricated
//! bearing's balance, the linearisation and the threshold search at `μ(T_eff)`.

use bearing_sweep::backend::{create_backend, BackendKind, LoadEvaluator};
use bearing_sweep::bearing::film_flow::bearing_loads;
use bearing_sweep::bearing::{Accuracy, FilmRule, Lubricant};
use bearing_sweep::rotor::load_scene;
use bearing_sweep::stability::{analyse_points, geometric_grid, thresholds, RotorDescription};
use serde_json::{json, Value};

fn evaluator() -> LoadEvaluator {
    let (b, _) = create_backend(BackendKind::Cpu, Accuracy::new(1e-12).unwrap()).unwrap();
    LoadEvaluator::new(b)
}

/// A rigid rotor (2 kg) under gravity on two bearings at different distances from `G`
/// (so they carry different loads and run at different temperatures). `oil(k)` is
/// bearing `k`'s lubricant fields (a grade and supply temperature, or a viscosity).
fn scene(speed: f64, oil: impl Fn(usize) -> Value) -> Value {
    scene_of_mass(2.0, speed, oil)
}

fn scene_of_mass(mass: f64, speed: f64, oil: impl Fn(usize) -> Value) -> Value {
    let bearing = |k: usize, z: f64| {
        let mut b = json!({"radius": 0.02, "length": 0.02, "clearance": 1e-4, "axial_position": z});
        if let (Some(m), Value::Object(o)) = (b.as_object_mut(), oil(k)) {
            m.extend(o);
        }
        b
    };
    json!({
        "name": "thermal-stability",
        "rotor": {"mass": mass, "inertia": [0.002, 0.002, 0.001]},
        "bearings": [bearing(0, 0.08), bearing(1, -0.12)],
        "gravity": [0.0, -9.81, 0.0],
        "spin": "held",
        "initial": {"spin": speed},
        "integrator": {"t_end": 0.1}
    })
}

fn lubricated(k: usize) -> Value {
    // Some heat leaves through the housing of bearing 1 (both heat paths exercised).
    json!({"lubricant": "ISO VG 32", "supply_temperature": 40.0,
           "thermal": {"housing_conductance": if k == 1 { 0.5 } else { 0.0 }}})
}

fn rotor(doc: &Value) -> RotorDescription {
    let s = load_scene(&doc.to_string()).unwrap().remove(0);
    RotorDescription::from_scene(&s).unwrap()
}

/// The coefficients at each speed are those of a plain-viscosity rotor whose bearings
/// have the reported `μ(T_eff)` (to the difference-step error estimates), and each
/// bearing's balance closes at the equilibrium the coefficients are taken at: the film
/// power there equals the heat to the flow and the housing.
#[test]
fn coefficients_at_mu_t_eff_and_the_balance_closes_per_bearing() {
    let mut ev = evaluator();
    let lub = Lubricant::by_name("ISO VG 32").unwrap();
    let rule = FilmRule::new(Accuracy::new(1e-12).unwrap().settings());
    for speed in [150.0, 600.0] {
        let hot = rotor(&scene(speed, lubricated));
        let a = analyse_points(&mut ev, &[(&hot, speed)]).remove(0).unwrap();
        let mut mus = Vec::new();
        let mut temps = Vec::new();
        for (b, bp) in a.linear.bearings.iter().enumerate() {
            let t = bp.thermal.expect("a balance per lubricated bearing");
            eprintln!(
                "speed {speed}: bearing {b} T_eff {:.4} °C, rise {:.4} K, mu {:.5e} Pa s, Q {:.4e} m3/s, eps {:.4}, {} evaluations",
                t.effective_temperature_c, t.temperature_rise_k, t.viscosity_pa_s,
                t.side_flow_m3_s, bp.eccentricity_ratio, t.evaluations
            );
            assert!(t.temperature_rise_k > 0.0);
            assert!(
                (t.viscosity_pa_s - lub.dynamic_viscosity(t.effective_temperature_c)).abs()
                    <= 1e-12 * t.viscosity_pa_s
            );
            // The balance at the linearised state, from the film there (K).
            let (p, _) = &hot.bearings[b];
            let mut pm = *p;
            pm.viscosity = t.viscosity_pa_s;
            let l = bearing_loads(&pm, &bp.state, &rule).unwrap();
            let theta = t.effective_temperature_c - 40.0;
            let k = pm.thermal.effective_factor;
            let removal = lub.heat_capacity_per_volume(t.effective_temperature_c)
                * l.film.side_flow_m3_per_s
                / k
                + pm.thermal.housing_conductance;
            let closing = l.film.power_loss_w / removal;
            eprintln!(
                "  balance at the linearised state: theta {theta:.9} K, P/removal {closing:.9} K"
            );
            // Brent's tolerance 1e-6 K, the Gauss-Seidel sweeps' 1e-5 K.
            assert!(
                (closing - theta).abs() <= 2e-5,
                "bearing {b} at {speed}: T_eff - T_supply {theta} vs the balance at the state {closing}"
            );
            mus.push(t.viscosity_pa_s);
            temps.push(t.effective_temperature_c);
        }
        // Different loads, different temperatures (the coupling is exercised).
        assert!((temps[0] - temps[1]).abs() > 1e-3, "{temps:?}");
        let plain = rotor(&scene(speed, |k| json!({"viscosity": mus[k]})));
        let c = analyse_points(&mut ev, &[(&plain, speed)])
            .remove(0)
            .unwrap();
        for (b, (x, y)) in a.linear.bearings.iter().zip(&c.linear.bearings).enumerate() {
            assert!(y.thermal.is_none());
            for (kind, m, n, em, en) in [
                (
                    "stiffness",
                    &x.coefficients.stiffness,
                    &y.coefficients.stiffness,
                    &x.coefficients.stiffness_error,
                    &y.coefficients.stiffness_error,
                ),
                (
                    "damping",
                    &x.coefficients.damping,
                    &y.coefficients.damping,
                    &x.coefficients.damping_error,
                    &y.coefficients.damping_error,
                ),
            ] {
                let scale = m.iter().flatten().fold(0.0_f64, |s, v| s.max(v.abs()));
                for i in 0..4 {
                    for j in 0..4 {
                        let tol = 1e-7 * scale + em[i][j] + en[i][j];
                        assert!(
                            (m[i][j] - n[i][j]).abs() <= tol,
                            "{speed} rad/s bearing {b} {kind}[{i}][{j}]: {} vs plain {}, tolerance {tol}",
                            m[i][j], n[i][j]
                        );
                    }
                }
            }
        }
        for (m, n) in a.modes.iter().zip(&c.modes) {
            assert!((m.sigma_1_s - n.sigma_1_s).abs() <= 1e-6 * n.frequency_rad_s.abs().max(1.0));
        }
    }
}

/// Thinner hot oil runs the journal at a higher eccentricity. Which way the threshold
/// speed moves then follows the isothermal stability curve `ω_th √(δ/g)` against ε
/// (tests/stability.rs, Lund's closed form), which falls with ε for a lightly loaded
/// journal (the film stiffness `~ W/(δ ε)` drops) and rises steeply towards ε* ≈ 0.75
/// (stable at every speed above). Seen here (ISO VG 32 at 40 °C, two bearings): 2 kg
/// (ε 0.03-0.08) -0.3 %, 20 kg (ε 0.25-0.38) -1.5 %, 60 kg (ε 0.48-0.59) +1.7 %. In every
/// case the threshold is self-consistent: a plain rotor with the bearings' `μ(T_eff)` at
/// the thermal threshold has its own threshold there (1e-5 relative).
#[test]
fn threshold_moves_with_the_thermal_balance_along_the_stability_curve() {
    let mut ev = evaluator();
    let lub = Lubricant::by_name("ISO VG 32").unwrap();
    let mu_supply = lub.dynamic_viscosity(40.0);
    let grid = geometric_grid(100.0, 5000.0, 12);
    for (mass, rises) in [(60.0, true), (20.0, false), (2.0, false)] {
        let hot = rotor(&scene_of_mass(mass, 300.0, lubricated));
        let cold = rotor(&scene_of_mass(
            mass,
            300.0,
            |_| json!({"viscosity": mu_supply}),
        ));
        let t = thresholds(&mut ev, &[&hot, &cold], &[grid.clone(), grid.clone()]);
        let (th, tc) = (
            t[0].speed_rad_s
                .unwrap_or_else(|| panic!("thermal: {}", t[0].note)),
            t[1].speed_rad_s
                .unwrap_or_else(|| panic!("isothermal: {}", t[1].note)),
        );
        let at = analyse_points(&mut ev, &[(&hot, th), (&cold, tc)]);
        let (ah, ac) = (at[0].as_ref().unwrap(), at[1].as_ref().unwrap());
        eprintln!(
            "{mass} kg: threshold thermal {th:.3} rad/s (eps {:.4}, {:.4}; T_eff {:.3}, {:.3} °C), isothermal at mu(40 °C) {tc:.3} rad/s (eps {:.4}, {:.4}): {:+.2} %",
            ah.linear.bearings[0].eccentricity_ratio, ah.linear.bearings[1].eccentricity_ratio,
            ah.linear.bearings[0].thermal.unwrap().effective_temperature_c,
            ah.linear.bearings[1].thermal.unwrap().effective_temperature_c,
            ac.linear.bearings[0].eccentricity_ratio, ac.linear.bearings[1].eccentricity_ratio,
            100.0 * (th / tc - 1.0),
        );
        for b in 0..2 {
            assert!(
                ah.linear.bearings[b].eccentricity_ratio > ac.linear.bearings[b].eccentricity_ratio
            );
        }
        if rises {
            assert!(
                th > 1.01 * tc,
                "{mass} kg: thermal threshold {th} not above the isothermal {tc}"
            );
        } else {
            assert!(
                th < tc,
                "{mass} kg: thermal threshold {th} not below the isothermal {tc}"
            );
        }
        // Self-consistency: the plain rotor at the thermal threshold's μ(T_eff).
        let mus: Vec<f64> = ah
            .linear
            .bearings
            .iter()
            .map(|b| b.thermal.unwrap().viscosity_pa_s)
            .collect();
        let plain = rotor(&scene_of_mass(
            mass,
            300.0,
            |k| json!({"viscosity": mus[k]}),
        ));
        let near = geometric_grid(0.9 * th, 1.1 * th, 3);
        let tp = thresholds(&mut ev, &[&plain], &[near]).remove(0);
        let tp = tp
            .speed_rad_s
            .unwrap_or_else(|| panic!("plain: {}", tp.note));
        eprintln!("  plain rotor at the thermal threshold's mu(T_eff): threshold {tp:.4} rad/s");
        assert!((tp - th).abs() <= 1e-5 * th, "{tp} vs {th}");
    }
}

/// `stability SCENE` with lubricants: the scene's speed and every Campbell speed carry
/// each bearing's balance; a bad lubricant name names its JSON path.
#[test]
fn stability_cli_reports_the_balance_and_names_bad_lubricants() {
    use bearing_sweep::app::{stability_scene_file, StabilityOptions};
    let opts = StabilityOptions {
        backend: BackendKind::Cpu,
        accuracy: 1e-12,
        speeds: vec![200.0, 400.0],
        out: None,
    };
    let doc = scene(300.0, lubricated);
    let (out, _, _) = stability_scene_file("t.json", &doc.to_string(), &opts).unwrap();
    let th = out["equilibrium"]["thermal"]
        .as_array()
        .expect("equilibrium.thermal");
    assert_eq!(th.len(), 2);
    for t in th {
        for key in [
            "effective_temperature_c",
            "temperature_rise_k",
            "effective_viscosity_pa_s",
            "side_flow_m3_s",
        ] {
            assert!(
                t[key].as_f64().is_some_and(|v| v.is_finite() && v > 0.0),
                "{key} in {t}"
            );
        }
    }
    let rises: Vec<f64> = out["campbell"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["thermal"][0]["temperature_rise_k"].as_f64().unwrap())
        .collect();
    assert!(rises[1] > rises[0], "the rise grows with speed: {rises:?}");
    // Without a lubricant: no thermal keys.
    let plain = scene(300.0, |_| json!({"viscosity": 0.03}));
    let (out, _, _) = stability_scene_file("t.json", &plain.to_string(), &opts).unwrap();
    assert!(out.get("thermal_note").is_none() && out["equilibrium"].get("thermal").is_none());
    assert!(out["campbell"][0].get("thermal").is_none());
    let bad = scene(
        300.0,
        |_| json!({"lubricant": "ISO VG 47", "supply_temperature": 40.0}),
    );
    let e = stability_scene_file("t.json", &bad.to_string(), &opts)
        .unwrap_err()
        .to_string();
    assert!(e.contains("bearings[0].lubricant"), "{e}");
}
