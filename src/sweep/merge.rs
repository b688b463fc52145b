//! Merging shard results into the result of the unsharded run.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde_json::{json, Value};

use super::job::{without_series, RESULT_FORMAT};
use super::runner::{write_plots, write_result_streamed};
use super::SweepError;

/// The result minus its `run` section: the part that must be identical however a sweep
/// was sharded, batched or interrupted.
pub fn deterministic_part(doc: &Value) -> Value {
    let mut d = doc.clone();
    if let Some(o) = d.as_object_mut() {
        o.remove("run");
    }
    d
}

/// Merges shard results into the result of the unsharded run and writes it to `out`,
/// with the spec's plots.
pub fn merge(
    out: &Path,
    shards: &[PathBuf],
) -> Result<(Value, Vec<Result<PathBuf, String>>), SweepError> {
    if shards.is_empty() {
        return Err(SweepError::Output(
            "merge needs at least one shard result".into(),
        ));
    }
    let mut first: Option<Value> = None;
    let mut seen: BTreeMap<u64, PathBuf> = BTreeMap::new();
    let mut variants: BTreeMap<u64, Value> = BTreeMap::new();
    let mut runs = Vec::new();
    for path in shards {
        let text = std::fs::read_to_string(path).map_err(|e| SweepError::io(path, e))?;
        let doc: Value = serde_json::from_str(&text)
            .map_err(|e| SweepError::Output(format!("{}: not valid JSON: {e}", path.display())))?;
        if doc.get("format").and_then(Value::as_str) != Some(RESULT_FORMAT) {
            return Err(SweepError::Output(format!(
                "{}: not a bearing-sweep result (format `{RESULT_FORMAT}`)",
                path.display()
            )));
        }
        let shard = doc.get("shard").cloned().unwrap_or(Value::Null);
        let index = shard.get("index").and_then(Value::as_u64);
        let count = shard.get("count").and_then(Value::as_u64);
        if let Some(f) = &first {
            for key in [
                "spec_hash",
                "settings",
                "count",
                "kind",
                "name",
                "spec",
                "units",
            ] {
                if f.get(key) != doc.get(key) {
                    return Err(SweepError::Output(format!(
                        "{}: `{key}` differs from {}; shards of different sweeps cannot be merged",
                        path.display(),
                        shards[0].display()
                    )));
                }
            }
            if f["shard"].get("count").and_then(Value::as_u64) != count {
                return Err(SweepError::Output(format!(
                    "{}: shard count {} differs from {}",
                    path.display(),
                    count.map_or("missing".to_string(), |c| c.to_string()),
                    shards[0].display()
                )));
            }
        }
        if let Some(i) = index {
            if let Some(prev) = seen.insert(i, path.clone()) {
                return Err(SweepError::Output(format!(
                    "{}: shard {i} already given as {}",
                    path.display(),
                    prev.display()
                )));
            }
        }
        for v in doc["variants"].as_array().into_iter().flatten() {
            let id = v.get("id").and_then(Value::as_u64).ok_or_else(|| {
                SweepError::Output(format!("{}: a variant has no id", path.display()))
            })?;
            if let Some(prev) = variants.insert(id, v.clone()) {
                if &prev != v {
                    return Err(SweepError::Output(format!(
                        "{}: variant {id} differs from another shard's",
                        path.display()
                    )));
                }
            }
        }
        runs.push(
            json!({"file": path.display().to_string(), "shard": shard, "run": doc.get("run")}),
        );
        if first.is_none() {
            first = Some(doc);
        }
    }
    let f = first.expect("one shard");
    let total = f["count"].as_u64().unwrap_or(0);
    let missing: Vec<u64> = (0..total).filter(|id| !variants.contains_key(id)).collect();
    if !missing.is_empty() {
        return Err(SweepError::Output(format!(
            "{} of {total} variants missing (first: {}); give every shard's result",
            missing.len(),
            missing[..missing.len().min(10)]
                .iter()
                .map(u64::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        )));
    }
    let mut doc = f.clone();
    let o = doc.as_object_mut().expect("object");
    o.insert("shard".into(), Value::Null);
    o.insert("variants".into(), json!([]));
    o.insert("run".into(), json!({"merged_from": runs}));
    // The output's folder may not exist yet (`merge out/new/merged.json ...`). The result
    // goes through the runner's write helper (temporary file and rename).
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| SweepError::io(dir, e))?;
    }
    let mut iter = variants.values().map(|v| Ok(v.to_string()));
    write_result_streamed(out, &doc, &mut iter)?;
    let light: Vec<Value> = variants.into_values().map(without_series).collect();
    let plots = match super::spec::parse_spec(&doc["spec"], None) {
        Ok(spec) => write_plots(&spec, &light, out),
        Err(e) => vec![Err(format!(
            "plots: the spec in the shard results does not parse: {e}"
        ))],
    };
    doc.as_object_mut()
        .expect("object")
        .insert("variants".into(), Value::Array(light));
    Ok((doc, plots))
}
