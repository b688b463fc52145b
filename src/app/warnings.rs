//! Warnings, not errors, for inputs that are valid but far outside what journal bearings
//! usually have (a viscosity typed in mPa·s as Pa·s, a clearance in mm on a radius in
//! mm): the run goes on, and stderr names the JSON path, the value and the usual range.
//! The ranges are deliberately wide (a warning on a sensible design would teach users to
//! ignore them); docs/cli.md lists them.

use serde_json::Value;

/// One checked bearing field: name, unit, usual lower and upper bound, and a hint.
struct Usual {
    field: &'static str,
    unit: &'static str,
    low: f64,
    high: f64,
    hint: &'static str,
}

/// The bearing fields with a usual range (SI units).
const USUAL: [Usual; 4] = [
    Usual {
        field: "viscosity",
        unit: "Pa·s",
        // Light spindle oils at temperature ~2e-3, heavy gear oils cold ~1; water 1e-3.
        low: 1e-4,
        high: 1.0,
        hint: "lubricants are about 0.002 to 0.5 Pa·s; mPa·s typed as Pa·s?",
    },
    Usual {
        field: "radius",
        unit: "m",
        low: 1e-3,
        high: 1.0,
        hint: "the journal radius in metres; mm typed as m?",
    },
    Usual {
        field: "length",
        unit: "m",
        low: 1e-4,
        high: 2.0,
        hint: "the bearing length in metres; mm typed as m?",
    },
    Usual {
        field: "clearance",
        unit: "m",
        low: 1e-6,
        high: 5e-3,
        hint: "the radial clearance in metres, usually 0.05 to 1.5 % of the radius",
    },
];

/// Usual range of the clearance ratio `clearance / radius`: precision bearings ~5e-4,
/// industrial ones 1e-3 to 3e-3, the paper's loose example 0.015; 3 mm on a 20 mm
/// radius (0.15) is a slip.
const CLEARANCE_RATIO: (f64, f64) = (1e-4, 0.05);

/// Largest `length / (2 radius)` the short-bearing film describes well (MODEL.md section
/// 2: valid for `B / 2r0 < 1`; docs/finite-film.md for its error).
const SHORT_MAX_ASPECT: f64 = 1.0;

/// `x` to 3 significant digits, as JSON writes numbers.
fn fmt(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return crate::json::num(x);
    }
    let scale = 10f64.powi(2 - x.abs().log10().floor() as i32);
    crate::json::num((x * scale).round() / scale)
}

fn out_of(u: &Usual, x: f64) -> bool {
    x.is_finite() && x > 0.0 && (x < u.low || x > u.high)
}

fn field_warning(path: &str, u: &Usual, x: f64) -> String {
    format!(
        "warning: {path} = {} {} is outside the usual range {} to {} {} ({}); running anyway",
        fmt(x),
        u.unit,
        fmt(u.low),
        fmt(u.high),
        u.unit,
        u.hint
    )
}

/// Warnings for one bearing object at JSON path `at` (e.g. `bearings[0]`).
pub fn bearing_warnings(at: &str, bearing: &Value) -> Vec<String> {
    let mut out = Vec::new();
    let num = |k: &str| bearing.get(k).and_then(Value::as_f64);
    for u in &USUAL {
        if let Some(x) = num(u.field).filter(|&x| out_of(u, x)) {
            out.push(field_warning(&format!("{at}.{}", u.field), u, x));
        }
    }
    if let (Some(c), Some(r)) = (num("clearance"), num("radius")) {
        if c > 0.0 && r > 0.0 {
            out.extend(ratio_warning(&format!("{at}.clearance"), c, r));
        }
    }
    let short = bearing
        .get("model")
        .and_then(Value::as_str)
        .is_none_or(|m| m == "short");
    if let (Some(b), Some(r), true) = (num("length"), num("radius"), short) {
        if r > 0.0 && b / (2.0 * r) > SHORT_MAX_ASPECT {
            out.push(format!(
                "warning: {at}.length: B/D = {} is above {SHORT_MAX_ASPECT}, where the short-bearing film (the default model) overestimates the load; consider \"model\": \"finite\" (docs/finite-film.md); running anyway",
                fmt(b / (2.0 * r))
            ));
        }
    }
    out
}

fn ratio_warning(path: &str, clearance: f64, radius: f64) -> Option<String> {
    let ratio = clearance / radius;
    let (low, high) = CLEARANCE_RATIO;
    (ratio < low || ratio > high).then(|| {
        format!(
            "warning: {path}: clearance / radius = {} (clearance {} m, radius {} m) is outside the usual {} to {}; running anyway",
            fmt(ratio),
            fmt(clearance),
            fmt(radius),
            fmt(low),
            fmt(high)
        )
    })
}

/// Warnings for every bearing of a scene object at `at` (`""` at the top level).
fn scene_warnings_at(at: &str, scene: &Value) -> Vec<String> {
    let Some(list) = scene.get("bearings").and_then(Value::as_array) else {
        return Vec::new();
    };
    list.iter()
        .enumerate()
        .flat_map(|(k, b)| {
            bearing_warnings(&crate::json::join_path(at, &format!("bearings[{k}]")), b)
        })
        .collect()
}

/// Warnings for a scene file (one scene, or `{"scenes": [...]}`).
pub fn scene_file_warnings(doc: &Value) -> Vec<String> {
    match doc.get("scenes").and_then(Value::as_array) {
        Some(list) => list
            .iter()
            .enumerate()
            .flat_map(|(k, s)| scene_warnings_at(&format!("scenes[{k}]"), s))
            .collect(),
        None => scene_warnings_at("", doc),
    }
}

/// The numbers an axis takes: its `values` that are numbers, or the ends of its
/// `linspace` / `logspace` (the extremes of a range).
fn axis_numbers(axis: &Value) -> Vec<f64> {
    if let Some(v) = axis.get("values").and_then(Value::as_array) {
        return v.iter().filter_map(Value::as_f64).collect();
    }
    for key in ["linspace", "logspace"] {
        if let Some(r) = axis.get(key).and_then(Value::as_array) {
            return r.iter().take(2).filter_map(Value::as_f64).collect();
        }
    }
    Vec::new()
}

/// Warnings for a sweep spec: its base scene (`base`, inlined) and every axis that sweeps
/// a checked bearing field (`axes[k]`, each value outside the usual range; a clearance
/// axis also against the base's first radius).
pub fn sweep_warnings(doc: &Value, base: &Value) -> Vec<String> {
    let mut out = scene_warnings_at("base", base);
    let radius = base
        .get("bearings")
        .and_then(|b| b.get(0))
        .and_then(|b| b.get("radius"))
        .and_then(Value::as_f64);
    let Some(axes) = doc.get("axes").and_then(Value::as_array) else {
        return out;
    };
    for (k, axis) in axes.iter().enumerate() {
        let Some(path) = axis.get("path").and_then(Value::as_str) else {
            continue;
        };
        let leaf = path.rsplit('.').next().unwrap_or(path);
        let at = format!("axes[{k}] ({path})");
        let xs = axis_numbers(axis);
        if let Some(u) = USUAL.iter().find(|u| u.field == leaf) {
            if let Some(&x) = xs.iter().find(|&&x| out_of(u, x)) {
                out.push(field_warning(&at, u, x));
            }
        }
        if leaf == "clearance" {
            if let Some(r) = radius.filter(|&r| r > 0.0) {
                if let Some(w) = xs
                    .iter()
                    .filter(|&&c| c > 0.0)
                    .find_map(|&c| ratio_warning(&at, c, r))
                {
                    out.push(w);
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn implausible_bearings_warn_with_path_value_and_range_and_sensible_ones_do_not() {
        let paper =
            json!({"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242});
        assert!(bearing_warnings("bearing", &paper).is_empty());
        let mpas = json!({"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 24.2});
        let w = bearing_warnings("bearings[1]", &mpas);
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(
            w[0].contains("bearings[1].viscosity = 24.2 Pa·s") && w[0].contains("0.0001 to 1 Pa·s"),
            "{}",
            w[0]
        );
        let loose =
            json!({"radius": 0.02, "length": 0.02, "clearance": 0.003, "viscosity": 0.0242});
        let w = bearing_warnings("bearing", &loose);
        assert!(
            w.iter()
                .any(|l| l.contains("bearing.clearance: clearance / radius = 0.15")),
            "{w:?}"
        );
        let long =
            json!({"radius": 0.02, "length": 0.08, "clearance": 0.0003, "viscosity": 0.0242});
        assert_eq!(bearing_warnings("b", &long).len(), 1);
        let long_finite = json!({"radius": 0.02, "length": 0.08, "clearance": 0.0003, "viscosity": 0.0242, "model": "finite"});
        assert!(bearing_warnings("b", &long_finite).is_empty());
    }

    #[test]
    fn sweep_axes_and_scene_lists_are_checked() {
        let base = json!({"bearings": [{"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242}]});
        let doc = json!({"axes": [
            {"path": "bearings[*].viscosity", "logspace": [0.005, 30, 4]},
            {"path": "bearings[*].clearance", "values": [1e-4, 3e-4]},
        ]});
        let w = sweep_warnings(&doc, &base);
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(
            w[0].contains("axes[0] (bearings[*].viscosity) = 30 Pa·s"),
            "{}",
            w[0]
        );
        let scenes = json!({"scenes": [base.clone(), {"bearings": [{"radius": 20, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242}]}]});
        let w = scene_file_warnings(&scenes);
        assert!(
            !w.is_empty() && w.iter().all(|l| l.contains("scenes[1].bearings[0]")),
            "{w:?}"
        );
    }
}
