//! Variant records as CSV for pandas: one flat row per variant (id, axis values, status,
//! every scalar of the reductions and the simulator counters), short snake_case column
//! names that end with their unit (`b0_friction_torque_mean_nm`, `h_min_m`,
//! `b0_eccentricity_max_1`; the suffixes are in [`UNIT_SUFFIXES`] and docs/outputs.md),
//! and text that is the same on every row (the integration method, the model-reduction
//! report's names) moved out of the rows into `# name = value` comment lines above the
//! header: `pandas.read_csv(f, comment="#")`. Series (arrays) are left out.

use std::collections::HashMap;

use serde_json::Value;

use super::store::{for_each_variant_line, Store, StoreError};
use crate::sweep::job::light_line;

/// Unit suffixes of column names, with what they mean (docs/outputs.md lists them).
pub const UNIT_SUFFIXES: &[(&str, &str)] = &[
    ("_m", "metres"),
    ("_s", "seconds"),
    ("_ms", "milliseconds"),
    ("_n", "newtons"),
    ("_nm", "newton metres"),
    ("_w", "watts"),
    ("_kg", "kilograms"),
    ("_kg_m2", "kg·m²"),
    ("_pa_s", "pascal seconds"),
    ("_rad", "radians"),
    ("_rad_s", "radians per second"),
    ("_1_s", "per second (growth rate)"),
    ("_m_s", "metres per second"),
    ("_m3_per_s", "cubic metres per second"),
    ("_m_s2", "metres per second squared"),
    ("_n_per_m", "newtons per metre"),
    ("_n_s_per_m", "newton seconds per metre"),
    ("_1", "dimensionless (a ratio or coefficient)"),
    ("_count", "a count"),
    ("_index", "an index (0-based)"),
];

/// Unit suffixes that result keys carry in their names (`value_m`, `friction_torque_nm`,
/// `sigma_1_s`), longest first so `_rad_s` is not read as `_s`.
const KEY_SUFFIXES: &[&str] = &[
    "_m3_per_s",
    "_rad_s",
    "_1_s",
    "_nm",
    "_ms",
    "_m",
    "_s",
    "_n",
    "_w",
];

/// Unit suffix of a scene parameter (the last key of an axis path).
fn scene_unit(key: &str) -> Option<&'static str> {
    Some(match key {
        "clearance" | "radius" | "length" | "axial_position" | "static_unbalance" | "offset"
        | "threshold" | "g_radius" | "orbit" | "whirl" => "m",
        "viscosity" => "pa_s",
        "mass" => "kg",
        "inertia" => "kg_m2",
        "spin" | "omega" => "rad_s",
        "t_end" | "sample_interval" | "duration" | "fixed_step" | "max_step" | "settle_time" => "s",
        "gravity" => "m_s2",
        "velocity" => "m_s",
        "tilt" | "couple_unbalance" | "angle" => "rad",
        "stiffness" => "n_per_m",
        "damping" => "n_s_per_m",
        "load" => "n",
        "rtol"
        | "atol"
        | "bound"
        | "tilt_bound"
        | "eccentricity"
        | "whirl_ratio"
        | "friction_coefficient"
        | "auto_tolerance"
        | "tolerance" => "1",
        "max_steps" | "samples" | "n_theta" | "n_z" => "count",
        _ => return None,
    })
}

/// Unit suffix of a result leaf without one in its name: dimensionless quantities,
/// counts and indices.
fn plain_unit(key: &str) -> Option<&'static str> {
    Some(match key {
        "friction_coefficient"
        | "eccentricity_max"
        | "eccentricity_ratio"
        | "ratio"
        | "whirl_ratio"
        | "subsync_ratio"
        | "revolutions"
        | "threshold_over_speed"
        | "threshold_whirl_ratio"
        | "log_dec_min_whirl_ratio"
        | "log_dec"
        | "log_dec_min"
        | "damping_ratio"
        | "sommerfeld"
        | "bound"
        | "error"
        | "searched_up_to_ratio" => "1",
        "samples"
        | "steps"
        | "rejected"
        | "rhs_evaluations"
        | "load_evaluations"
        | "sample_load_evaluations"
        | "jacobians"
        | "factorizations"
        | "applied_to"
        | "of"
        | "sample_stride"
        | "record_samples"
        | "newton_iterations"
        | "threshold_iterations" => "count",
        "bearing" => "index",
        _ => return None,
    })
}

/// One piece of a flattened path: an object key or an array index.
#[derive(Clone, Debug, PartialEq)]
enum Piece {
    Key(String),
    Index(usize),
}

/// Flattens `v` into `(path, scalar)` pairs; arrays of objects and short arrays of
/// numbers (per-bearing values) get an index, longer number arrays (series) are skipped.
fn flatten(path: &mut Vec<Piece>, v: &Value, out: &mut Vec<(Vec<Piece>, Value)>) {
    /// Longest number array kept as columns (a per-bearing list; series are longer).
    const MAX_SHORT_ARRAY: usize = 16;
    match v {
        Value::Object(m) => {
            for (k, x) in m {
                path.push(Piece::Key(k.clone()));
                flatten(path, x, out);
                path.pop();
            }
        }
        Value::Array(a) => {
            let objects = a.iter().all(Value::is_object);
            let short_numbers = a.len() <= MAX_SHORT_ARRAY && a.iter().all(Value::is_number);
            if objects || short_numbers {
                for (k, x) in a.iter().enumerate() {
                    path.push(Piece::Index(k));
                    flatten(path, x, out);
                    path.pop();
                }
            }
        }
        scalar => out.push((path.clone(), scalar.clone())),
    }
}

/// Snake_case of one key (`tilt-x` and `Tilt X` read `tilt_x`).
fn snake(key: &str) -> String {
    let mut s = String::new();
    for c in key.chars() {
        if c.is_ascii_alphanumeric() {
            s.push(c.to_ascii_lowercase());
        } else if !s.ends_with('_') && !s.is_empty() {
            s.push('_');
        }
    }
    s.trim_end_matches('_').to_string()
}

/// The column name of a reduction or simulator path (`prefix` `""` or `"sim"`): keys in
/// snake_case joined by `_`, `bearings[k]` as `bk`, other indices as `_k`, a leaf
/// `value` dropped, and the unit, taken from the deepest key that carries one (or from
/// [`plain_unit`]), moved to the end once.
fn result_column(prefix: &str, path: &[Piece], numeric: bool) -> String {
    let mut words: Vec<String> = Vec::new();
    if !prefix.is_empty() {
        words.push(prefix.to_string());
    }
    let mut unit: Option<&str> = None;
    let mut last_key = "";
    for (i, p) in path.iter().enumerate() {
        match p {
            Piece::Key(k)
                if k == "bearings" && matches!(path.get(i + 1), Some(Piece::Index(_))) => {}
            Piece::Key(k) => {
                let mut w = k.as_str();
                if let Some(s) = KEY_SUFFIXES
                    .iter()
                    .find(|s| w.ends_with(**s) && w.len() > s.len())
                {
                    w = &w[..w.len() - s.len()];
                    unit = Some(&s[1..]);
                }
                last_key = w;
                let is_leaf = i + 1 == path.len();
                if !(is_leaf && w == "value") {
                    words.push(snake(w));
                }
            }
            Piece::Index(k) => match path.get(i.wrapping_sub(1)) {
                Some(Piece::Key(b)) if b == "bearings" => words.push(format!("b{k}")),
                _ => words.push(k.to_string()),
            },
        }
    }
    if unit.is_none() && numeric {
        // The leaf's own name, or its parent's for `mean`/`min`/`max` of a statistic.
        let named = path.iter().rev().find_map(|p| match p {
            Piece::Key(k) => plain_unit(k),
            Piece::Index(_) => None,
        });
        unit = named.or_else(|| plain_unit(last_key));
    }
    let mut name = words.join("_");
    if let Some(u) = unit {
        name.push('_');
        name.push_str(u);
    }
    name
}

/// The column name of an axis path (`bearings[*].clearance` → `bearings_clearance_m`,
/// `bearings[1].viscosity` → `b1_viscosity_pa_s`, `rotor.static_unbalance[0]` →
/// `rotor_static_unbalance_0_m`).
pub fn param_column(axis_path: &str, numeric: bool) -> String {
    let mut words: Vec<String> = Vec::new();
    let mut last = "";
    for part in axis_path.split('.') {
        let (key, rest) = part.split_once('[').unwrap_or((part, ""));
        let idx: Vec<&str> = rest
            .split('[')
            .map(|r| r.trim_end_matches(']'))
            .filter(|r| !r.is_empty())
            .collect();
        match (key, idx.first()) {
            ("bearings", Some(&"*")) => words.push("bearings".into()),
            ("bearings", Some(k)) => words.push(format!("b{k}")),
            _ => {
                words.push(snake(key));
                words.extend(idx.iter().filter(|i| **i != "*").map(|i| i.to_string()));
            }
        }
        last = key;
    }
    let mut name = words.join("_");
    // Groove and arc fields (docs/grooves.md): angles in degrees, pressure in Pa.
    let grooved = axis_path
        .split('.')
        .any(|p| p.starts_with("grooves") || p.starts_with("arcs"));
    let unit = match last {
        "angle" | "width" | "start" | "extent" if grooved => Some("deg"),
        "supply_pressure" => Some("pa"),
        _ => scene_unit(last),
    };
    if numeric {
        if let Some(u) = unit {
            name.push('_');
            name.push_str(u);
        }
    }
    name
}

fn field(v: &Value) -> String {
    let text = match v {
        Value::Null => return String::new(),
        Value::String(s) => s.clone(),
        other => other.to_string(),
    };
    if text.contains([',', '"', '\n', '\r', '#']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text
    }
}

/// The CSV of every variant of stored sweep `id` (the `?format=csv` export; offset and
/// limit do not apply): its lines read a page at a time, each kept without its series.
pub fn sweep_csv(store: &dyn Store, id: &str) -> Result<String, StoreError> {
    let mut lines = Vec::new();
    for_each_variant_line(
        store,
        id,
        &mut |_, line| {
            lines.push(light_line(line));
            Ok(())
        },
        |e| e,
    )?;
    Ok(variants_csv(&lines))
}

/// The CSV of variant lines (compact JSON, id order): comment lines with the constant
/// text columns, the header, one row per variant.
pub fn variants_csv(lines: &[String]) -> String {
    let mut columns: Vec<String> = Vec::new();
    let mut rows: Vec<HashMap<String, Value>> = Vec::with_capacity(lines.len());
    // Which columns may move to the comments: text of the reductions and counters only
    // (ids, axis values, status and message stay in the rows, constant or not).
    let mut movable: HashMap<String, bool> = HashMap::new();
    for line in lines {
        let Ok(v) = serde_json::from_str::<Value>(line) else {
            continue;
        };
        let mut cells: Vec<(String, Value, bool)> = vec![("id".into(), v["id"].clone(), false)];
        if let Some(p) = v["params"].as_object() {
            for (k, x) in p {
                cells.push((param_column(k, x.is_number()), x.clone(), false));
            }
        }
        cells.push(("status".into(), v["status"].clone(), false));
        cells.push((
            "message".into(),
            v.get("message").cloned().unwrap_or(Value::Null),
            false,
        ));
        for (prefix, part) in [
            ("", &v["reductions"]),
            ("sim", v.get("sim").unwrap_or(&Value::Null)),
        ] {
            let mut flat = Vec::new();
            flatten(&mut Vec::new(), part, &mut flat);
            for (path, x) in flat {
                if path.is_empty() {
                    continue;
                }
                cells.push((result_column(prefix, &path, x.is_number()), x, true));
            }
        }
        let mut row = HashMap::new();
        for (name, x, can_move) in cells {
            if !columns.contains(&name) {
                columns.push(name.clone());
                movable.insert(name.clone(), can_move);
            }
            row.insert(name, x);
        }
        rows.push(row);
    }
    // Constant text: the same string on every row.
    let constant: Vec<(String, String)> = columns
        .iter()
        .filter(|c| movable.get(*c).copied().unwrap_or(false) && rows.len() > 1)
        .filter_map(|c| {
            let first = rows.first()?.get(c)?.as_str()?;
            rows.iter()
                .all(|r| r.get(c).and_then(Value::as_str) == Some(first))
                .then(|| (c.clone(), first.to_string()))
        })
        .collect();
    let kept: Vec<&String> = columns
        .iter()
        .filter(|c| !constant.iter().any(|(k, _)| k == *c))
        .collect();
    let mut out = String::from(
        "# bearing-sweep variants: one row per variant; each numeric column's name ends with its unit (docs/outputs.md); read with pandas.read_csv(f, comment=\"#\")\n",
    );
    for (k, v) in &constant {
        out.push_str(&format!("# {k} = {}\n", v.replace(['\n', '\r'], " ")));
    }
    let header: Vec<String> = kept
        .iter()
        .map(|c| field(&Value::String((*c).clone())))
        .collect();
    out.push_str(&header.join(","));
    out.push('\n');
    for r in rows {
        let cells: Vec<String> = kept
            .iter()
            .map(|c| r.get(*c).map(field).unwrap_or_default())
            .collect();
        out.push_str(&cells.join(","));
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_names_with_units_constant_text_in_comments_and_quoted_text() {
        let lines = vec![
            r#"{"id":0,"params":{"bearings[*].clearance":0.0001},"status":"ok","reductions":{"h_min":{"value_m":1.5e-5,"t_s":0.1,"bearing":1},"bearings":[{"power_loss_w":2.0,"friction_torque_nm":{"mean":0.5},"eccentricity_max":{"value":0.3}}]},"sim":{"method":"dopri5","steps":10},"series":{"t":[0,1]}}"#.to_string(),
            r#"{"id":1,"params":{"bearings[*].clearance":0.0002},"status":"film_breakdown","message":"bearing 0, at t = 0.1 s","reductions":null,"sim":{"method":"dopri5","steps":3}}"#.to_string(),
        ];
        let csv = variants_csv(&lines);
        let rows: Vec<&str> = csv.lines().collect();
        assert!(rows[0].starts_with("# bearing-sweep variants"), "{csv}");
        assert_eq!(rows[1], "# sim_method = dopri5", "{csv}");
        assert_eq!(
            rows[2],
            "id,bearings_clearance_m,status,message,b0_eccentricity_max_1,b0_friction_torque_mean_nm,b0_power_loss_w,h_min_bearing_index,h_min_t_s,h_min_m,sim_steps_count",
            "header"
        );
        assert_eq!(
            rows[3], "0,0.0001,ok,,0.3,0.5,2.0,1,0.1,0.000015,10",
            "row 0"
        );
        assert_eq!(
            rows[4], "1,0.0002,film_breakdown,\"bearing 0, at t = 0.1 s\",,,,,,,3",
            "row 1"
        );
        assert_eq!(rows.len(), 5);
    }

    #[test]
    fn axis_paths_become_snake_case_with_units() {
        for (path, want) in [
            ("bearings[*].clearance", "bearings_clearance_m"),
            ("bearings[1].viscosity", "b1_viscosity_pa_s"),
            ("rotor.static_unbalance[0]", "rotor_static_unbalance_0_m"),
            ("initial.spin", "initial_spin_rad_s"),
            ("gravity[1]", "gravity_1_m_s2"),
            ("bearings[*].grooves[*].width", "bearings_grooves_width_deg"),
            ("bearings[0].grooves[1].angle", "b0_grooves_1_angle_deg"),
            (
                "bearings[0].grooves[1].supply_pressure",
                "b0_grooves_1_supply_pressure_pa",
            ),
            ("bearings[*].arcs[0].extent", "bearings_arcs_0_extent_deg"),
        ] {
            assert_eq!(param_column(path, true), want, "{path}");
        }
        assert_eq!(param_column("bearings[*].model", false), "bearings_model");
    }

    #[test]
    fn film_flows_and_the_decimated_window_have_their_units() {
        // reductions.bearings[0].film (JFO finite film) and a window from a decimated
        // record: m³/s is not read as seconds.
        let lines = vec![
            r#"{"id":0,"params":{},"status":"max_steps","reductions":{"window":{"samples":3,"sample_stride":4,"record_samples":9},"bearings":[{"film":{"side_flow_m3_per_s":{"mean":2e-7},"power_loss_w":{"max":3.0}}}]}}"#.to_string(),
        ];
        let csv = variants_csv(&lines);
        let header = csv.lines().find(|l| l.starts_with("id,")).unwrap();
        for col in [
            "b0_film_side_flow_mean_m3_per_s",
            "b0_film_power_loss_max_w",
            "window_sample_stride_count",
            "window_record_samples_count",
        ] {
            assert!(header.split(',').any(|c| c == col), "{col} not in {header}");
        }
    }
}
