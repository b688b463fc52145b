//! Variant records as CSV: one flat row per variant (id, axis values, status, every scalar
//! of the reductions and the simulator counters), the unit of each column in its header
//! (`name [unit]`), read by `pandas.read_csv` as is. Series (arrays) are left out.

use serde_json::Value;

/// Unit of a scene parameter (the last key of an axis path), where known.
fn scene_unit(key: &str) -> Option<&'static str> {
    Some(match key {
        "clearance" | "radius" | "length" | "axial_position" => "m",
        "viscosity" => "Pa·s",
        "mass" => "kg",
        "spin" | "omega" => "rad/s",
        "t_end" | "sample_interval" | "duration" => "s",
        _ => return None,
    })
}

/// Unit of a reduction or counter column, from its last key (the naming rules of the
/// result's `units`).
fn result_unit(column: &str) -> Option<&'static str> {
    let parts: Vec<&str> = column.split('.').collect();
    let leaf = parts.last().copied().unwrap_or("");
    let has = |k: &str| {
        parts
            .iter()
            .any(|p| p.trim_end_matches(|c: char| c == ']' || c.is_ascii_digit() || c == '[') == k)
    };
    if leaf.ends_with("_s") {
        return Some("s");
    }
    if leaf.ends_with("_m") {
        return Some("m");
    }
    if leaf.ends_with("_nm") || has("friction_torque_nm") {
        return Some("N·m");
    }
    if leaf.ends_with("_n") || has("force_n") || has("force_peak_n") {
        return Some("N");
    }
    if leaf.ends_with("_w") {
        return Some("W");
    }
    if has("friction_coefficient") || has("eccentricity_max") || leaf.ends_with("ratio") {
        return Some("1");
    }
    None
}

/// Flattens `v` into `(dotted path, scalar)` pairs; arrays of objects get `[k]`, arrays of
/// numbers (series) are skipped.
fn flatten(prefix: &str, v: &Value, out: &mut Vec<(String, Value)>) {
    match v {
        Value::Object(m) => {
            for (k, x) in m {
                let p = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                flatten(&p, x, out);
            }
        }
        Value::Array(a) => {
            if a.iter().all(|x| x.is_object()) {
                for (k, x) in a.iter().enumerate() {
                    flatten(&format!("{prefix}[{k}]"), x, out);
                }
            }
        }
        scalar => out.push((prefix.to_string(), scalar.clone())),
    }
}

fn field(v: &Value) -> String {
    let text = match v {
        Value::Null => return String::new(),
        Value::String(s) => s.clone(),
        other => other.to_string(),
    };
    if text.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text
    }
}

/// The CSV of variant lines (compact JSON, id order).
pub fn variants_csv(lines: &[String]) -> String {
    let mut columns: Vec<String> = Vec::new();
    let mut units: Vec<Option<&'static str>> = Vec::new();
    let mut rows: Vec<std::collections::HashMap<String, Value>> = Vec::with_capacity(lines.len());
    for line in lines {
        let Ok(v) = serde_json::from_str::<Value>(line) else {
            continue;
        };
        let mut cells = Vec::new();
        cells.push(("id".to_string(), v["id"].clone()));
        if let Some(p) = v["params"].as_object() {
            for (k, x) in p {
                cells.push((k.clone(), x.clone()));
            }
        }
        cells.push(("status".to_string(), v["status"].clone()));
        cells.push((
            "message".to_string(),
            v.get("message").cloned().unwrap_or(Value::Null),
        ));
        let mut rest = Vec::new();
        flatten("reductions", &v["reductions"], &mut rest);
        flatten("sim", v.get("sim").unwrap_or(&Value::Null), &mut rest);
        cells.extend(
            rest.into_iter()
                .filter(|(k, _)| k != "reductions" && k != "sim"),
        );
        let param_keys: Vec<String> = v["params"]
            .as_object()
            .map(|o| o.keys().cloned().collect())
            .unwrap_or_default();
        for (k, _) in &cells {
            if !columns.contains(k) {
                let unit = if param_keys.contains(k) {
                    scene_unit(k.rsplit(['.', ']']).next().unwrap_or(k))
                } else if k.starts_with("reductions.") {
                    result_unit(k)
                } else {
                    None
                };
                columns.push(k.clone());
                units.push(unit);
            }
        }
        rows.push(cells.into_iter().collect());
    }
    let mut out = String::new();
    let header: Vec<String> = columns
        .iter()
        .zip(&units)
        .map(|(c, u)| {
            field(&Value::String(match u {
                Some(u) => format!("{c} [{u}]"),
                None => c.clone(),
            }))
        })
        .collect();
    out.push_str(&header.join(","));
    out.push('\n');
    for r in rows {
        let cells: Vec<String> = columns
            .iter()
            .map(|c| r.get(c).map(field).unwrap_or_default())
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
    fn flat_rows_with_units_and_quoted_text() {
        let lines = vec![
            r#"{"id":0,"params":{"bearings[*].clearance":0.0001},"status":"ok","reductions":{"h_min":{"value_m":1.5e-5,"t_s":0.1},"bearings":[{"power_loss_w":2.0}]},"series":{"t":[0,1]}}"#.to_string(),
            r#"{"id":1,"params":{"bearings[*].clearance":0.0002},"status":"film_breakdown","message":"bearing 0, at t = 0.1 s","reductions":null}"#.to_string(),
        ];
        let csv = variants_csv(&lines);
        let rows: Vec<&str> = csv.lines().collect();
        assert_eq!(
            rows[0],
            "id,bearings[*].clearance [m],status,message,reductions.bearings[0].power_loss_w [W],reductions.h_min.t_s [s],reductions.h_min.value_m [m]",
            "header"
        );
        assert_eq!(rows[1], "0,0.0001,ok,,2.0,0.1,0.000015", "row 0");
        assert_eq!(
            rows[2], "1,0.0002,film_breakdown,\"bearing 0, at t = 0.1 s\",,,",
            "row 1"
        );
        assert_eq!(rows.len(), 3);
    }
}
