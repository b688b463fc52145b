//! `bearing-sweep eval`: film loads of a list of bearing states.

use serde_json::{json, Map, Value};

use super::{from_value, CliError};
use crate::backend::{choose_backend, BackendKind, LoadEvaluator, LoadRequest};
use crate::bearing::{Accuracy, BearingParams, BearingState};

/// Options of `eval` beyond the input document.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EvalOptions {
    /// Backend to run on.
    pub backend: BackendKind,
    /// Requested relative accuracy of the load vector.
    pub accuracy: f64,
}

impl Default for EvalOptions {
    fn default() -> Self {
        EvalOptions {
            backend: BackendKind::Auto,
            accuracy: Accuracy::default().rtol(),
        }
    }
}

/// Runs `eval` on an input document; returns the output document and notices for stderr.
pub fn eval_json(input: &str, options: EvalOptions) -> Result<(Value, Vec<String>), CliError> {
    let doc: Value =
        crate::json::parse_json(input).map_err(|e| CliError::input(e.path, e.reason))?;
    let obj = doc
        .as_object()
        .ok_or_else(|| CliError::input("$", "expected an object"))?;
    for key in obj.keys() {
        if key != "bearing" && key != "states" {
            return Err(CliError::input(
                key.clone(),
                "unknown field (expected `bearing` and `states`)",
            ));
        }
    }
    let bearing: BearingParams = from_value(
        obj.get("bearing")
            .ok_or_else(|| CliError::input("bearing", "missing"))?,
        "bearing",
    )?;
    bearing.validate().map_err(|e| {
        CliError::input(
            format!("bearing.{}", e.field),
            format!("{} (got {})", e.reason, crate::json::num(e.value)),
        )
    })?;
    let states = obj
        .get("states")
        .ok_or_else(|| CliError::input("states", "missing"))?
        .as_array()
        .ok_or_else(|| CliError::input("states", "expected an array"))?;
    let mut requests = Vec::with_capacity(states.len());
    for (k, s) in states.iter().enumerate() {
        let state: BearingState = from_value(s, &format!("states[{k}]"))?;
        requests.push(LoadRequest { bearing: 0, state });
    }
    let accuracy = Accuracy::new(options.accuracy).ok_or_else(|| {
        CliError::input(
            "--accuracy",
            format!("{} is not a positive number >= 1e-12", options.accuracy),
        )
    })?;
    let (backend, mut notices) = choose_backend(options.backend, accuracy, Some(requests.len()))?;
    let mut evaluator = LoadEvaluator::new(backend);
    let mut results = Vec::new();
    evaluator.evaluate(&[bearing], &requests, &mut results);
    notices.extend(evaluator.take_notices());
    let loads: Vec<Value> = results
        .iter()
        .enumerate()
        .map(|(k, r)| match r {
            Ok(l) => {
                let mut m = match serde_json::to_value(l) {
                    Ok(Value::Object(m)) => m,
                    _ => Map::new(),
                };
                m.insert("status".into(), json!("ok"));
                // Finite-film states: the model used and the Richardson error estimate.
                if bearing.model != crate::bearing::FilmModel::Short {
                    let used = crate::backend::effective_model(&bearing, &requests[k].state);
                    m.insert("film_model".into(), json!(used.name()));
                    if used == crate::bearing::FilmModel::Finite {
                        let est = crate::bearing::finite::richardson_estimate(
                            &bearing,
                            &requests[k].state,
                            &bearing.finite,
                            l,
                        );
                        m.insert("finite_error_estimate".into(), json!(est));
                    }
                }
                Value::Object(m)
            }
            Err(fault) => json!({
                "status": fault.code(),
                "error": format!("states[{k}]: {fault}"),
                "wx": null, "wy": null, "mx": null, "my": null, "mz": null,
                "friction_coefficient": null, "sommerfeld": null, "h_min": null, "power_loss": null,
            }),
        })
        .collect();
    let info = evaluator.info();
    let out = json!({
        "loads": loads,
        "rule": "closed-form loaded arcs, graded Gauss-Legendre panels in z",
        "accuracy": accuracy.rtol(),
        "nodes_per_panel": accuracy.settings().nodes,
        "backend": info,
        "backend_choice": evaluator.choice(),
        "clearance_convention": bearing.clearance_convention.name(),
        "film_model": bearing.model.name(),
        "units": "SI (N, N·m, m, W)",
    });
    Ok((out, notices))
}
