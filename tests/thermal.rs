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
        assert!(
            (f(l, "power_loss") - p).abs() <= 1e-12 * p,
            "state {k}: loads' power {} vs balance {p}",
            f(l, "power_loss")
        );
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
        assert!(
            (f(p, "power_loss_w") - pin).abs() <= 1e-9 * pin,
            "speed {k}: point power {} vs balance {pin}",
            f(p, "power_loss_w")
        );
    }
    // The paper's law (model "sommerfeld") has no eccentricity: refused with a reason.
    let mut bad = doc.clone();
    bad["model"] = json!("sommerfeld");
    let e = FrictionMapSpec::parse(&bad).unwrap_err().to_string();
    assert!(e.contains("model") && e.contains("film"), "{e}");
}

/// A scene bearing with a lubricant runs the film at μ(T_supply): the same run as the
/// plain viscosity of that value.
#[test]
fn scene_with_a_lubricant_runs_at_the_supply_viscosity() {
    use bearing_sweep::backend::{CpuBackend, LoadEvaluator};
    use bearing_sweep::rotor::{load_scene, simulate_batch};
    let base: Value = serde_json::from_str(include_str!("../sweeps/paper-example.json")).unwrap();
    let mut last = Vec::new();
    let mu = Lubricant::iso_vg(68).unwrap().dynamic_viscosity(50.0);
    for lubricant in [true, false] {
        let mut s = base.clone();
        s["compare_ideal"] = json!(false);
        s["integrator"]["t_end"] = json!(0.02);
        for b in s["bearings"].as_array_mut().unwrap() {
            let m = b.as_object_mut().unwrap();
            m.remove("viscosity");
            if lubricant {
                m.insert("lubricant".into(), json!("ISO VG 68"));
                m.insert("supply_temperature".into(), json!(50.0));
            } else {
                m.insert("viscosity".into(), json!(mu));
            }
        }
        let scenes = load_scene(&s.to_string()).unwrap();
        let mut ev = LoadEvaluator::new(Box::new(CpuBackend::new(Accuracy::default(), None)));
        let r = simulate_batch(&scenes, &mut ev, &mut |_, _| {}).remove(0);
        last.push((
            *r.samples.x_g.last().unwrap(),
            *r.samples.y_g.last().unwrap(),
        ));
    }
    assert_eq!(last[0], last[1], "lubricant vs plain viscosity {mu}");
    // Both ways at once in a scene: refused, naming the bearing.
    let mut s = base.clone();
    s["bearings"][1]["lubricant"] = json!("ISO VG 68");
    s["bearings"][1]["supply_temperature"] = json!(50.0);
    let e = load_scene(&s.to_string()).unwrap_err().to_string();
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
                li.power_loss,
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
        panel("Friction power loss", "power loss (W)", &|r| r.1),
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
