//! What a submitted sweep is: the spec document parsed exactly as `run` parses it (a
//! `base` must be inline: no path from a request reaches the filesystem), and the run
//! options of the query (`backend`, `accuracy`, `full_model`, mirroring `run`'s flags).

use serde_json::{json, Value};

use super::error::ApiError;
use crate::backend::BackendKind;
use crate::bearing::Accuracy;
use crate::sweep::friction_map::FrictionMapSpec;
use crate::sweep::simulator::SimulatorChoice;
use crate::sweep::spec::{parse_spec, spec_kind};
use crate::sweep::{Expansion, SweepError, SweepSpec};

/// A parsed submission.
pub enum ParsedSweep {
    /// A rotor or synthetic sweep (runs through the runner).
    Runner(Box<SweepSpec>),
    /// A friction map (no dynamics; one document).
    FrictionMap(Box<FrictionMapSpec>),
}

impl ParsedSweep {
    /// Variants (friction-map points) in it.
    pub fn count(&self) -> u64 {
        match self {
            ParsedSweep::Runner(s) => Expansion::new(s).count(),
            ParsedSweep::FrictionMap(f) => (f.load.len() * f.speed.len()) as u64,
        }
    }

    /// The spec's name.
    pub fn name(&self) -> String {
        match self {
            ParsedSweep::Runner(s) => s.name.clone().unwrap_or_default(),
            ParsedSweep::FrictionMap(f) => f.name.clone().unwrap_or_default(),
        }
    }
}

/// Parses a spec document as `run` does, refusing a `base` given as a file name.
pub fn parse_sweep_doc(doc: &Value) -> Result<ParsedSweep, SweepError> {
    if doc.get("base").is_some_and(Value::is_string) {
        return Err(SweepError::spec(
            "base",
            "a file name is not accepted by the service (no request reaches its filesystem); put the scene object inline",
        ));
    }
    match spec_kind(doc) {
        Some("friction_map") => Ok(ParsedSweep::FrictionMap(Box::new(FrictionMapSpec::parse(
            doc,
        )?))),
        _ => Ok(ParsedSweep::Runner(Box::new(parse_spec(doc, None)?))),
    }
}

/// Checks every variant of a runner sweep (so a bad variant gets 422 before anything is
/// stored).
pub fn validate_variants(spec: &SweepSpec) -> Result<(), SweepError> {
    let validator = crate::sweep::simulator::scene_validator(spec.kind);
    Expansion::new(spec).validate_all(spec, validator)
}

/// Run options from the query parameters, as stored JSON: `{"backend", "accuracy",
/// "full_model"}` with `run`'s defaults (auto, 1e-6, false).
pub fn options_from_query(
    backend: Option<&str>,
    accuracy: Option<&str>,
    full_model: Option<&str>,
) -> Result<Value, ApiError> {
    let backend = backend.unwrap_or("auto");
    backend
        .parse::<BackendKind>()
        .map_err(|e| ApiError::invalid("?backend", e))?;
    let accuracy = match accuracy {
        None => Accuracy::default().rtol(),
        Some(a) => {
            let v: f64 = a
                .parse()
                .map_err(|_| ApiError::invalid("?accuracy", format!("`{a}` is not a number")))?;
            Accuracy::new(v).ok_or_else(|| {
                ApiError::invalid(
                    "?accuracy",
                    format!("{v} is not a positive number >= 1e-12"),
                )
            })?;
            v
        }
    };
    let full_model = match full_model {
        None | Some("false") | Some("0") => false,
        Some("true") | Some("1") | Some("") => true,
        Some(other) => {
            return Err(ApiError::invalid(
                "?full_model",
                format!("`{other}`: expected true or false"),
            ))
        }
    };
    Ok(json!({"backend": backend, "accuracy": accuracy, "full_model": full_model}))
}

/// The simulator choice of stored options.
pub fn parse_options(options: &Value) -> Result<SimulatorChoice, ApiError> {
    let backend = options
        .get("backend")
        .and_then(Value::as_str)
        .unwrap_or("auto")
        .parse::<BackendKind>()
        .map_err(|e| ApiError::invalid("?backend", e))?;
    let rtol = options
        .get("accuracy")
        .and_then(Value::as_f64)
        .unwrap_or(Accuracy::default().rtol());
    let accuracy = Accuracy::new(rtol)
        .ok_or_else(|| ApiError::invalid("?accuracy", format!("{rtol} is out of range")))?;
    Ok(SimulatorChoice {
        backend,
        accuracy,
        full_model: options
            .get("full_model")
            .and_then(Value::as_bool)
            .unwrap_or(false),
    })
}
