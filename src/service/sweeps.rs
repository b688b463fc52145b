//! What a submitted sweep is: the spec document parsed exactly as `run` parses it (a
//! `base` must be inline: no path from a request reaches the filesystem), and the run
//! options of the query (`backend`, `accuracy`, `full_model`, mirroring `run`'s flags).

use std::sync::atomic::{AtomicU64, Ordering};

use serde_json::Value;

use super::error::ApiError;
use crate::backend::BackendKind;
use crate::budget::MemoryBudget;
use crate::sweep::{Expansion, RequestedAccuracy, SweepError, SweepOptions, SweepSpec};

pub use crate::sweep::job::ParsedSweep;

static SUBMITTED: AtomicU64 = AtomicU64::new(0);

/// A fresh opaque sweep id (16 hex digits from the time, the process and a counter): the
/// one id scheme of the SQLite service and the PostgreSQL queue.
pub fn new_sweep_id() -> String {
    use sha2::{Digest, Sha256};
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos());
    let n = SUBMITTED.fetch_add(1, Ordering::Relaxed);
    let seed = format!("{nanos}/{}/{n}", std::process::id());
    Sha256::digest(seed.as_bytes())[..8]
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// Parses a spec document as `run` does within the memory budget `budget`, refusing a
/// `base` given as a file name.
pub fn parse_sweep_doc(doc: &Value, budget: MemoryBudget) -> Result<ParsedSweep, SweepError> {
    if doc.get("base").is_some_and(Value::is_string) {
        return Err(SweepError::spec(
            "base",
            "a file name is not accepted by the service (no request reaches its filesystem); put the scene object inline",
        ));
    }
    crate::sweep::job::parse_sweep_within(doc, None, budget)
}

/// A submission checked as `POST /api/sweeps` and `POST /api/validate` check it: parsed,
/// within the service's `max_variants`, and (a runner sweep) every variant valid. Returns
/// the parsed sweep and its variant count.
pub fn check_submission(
    doc: &Value,
    max_variants: u64,
    budget: MemoryBudget,
) -> Result<(ParsedSweep, u64), ApiError> {
    let parsed = parse_sweep_doc(doc, budget)?;
    let total = parsed.count();
    if total > max_variants {
        return Err(ApiError::invalid(
            "axes",
            format!("{total} variants exceed the service's limit of {max_variants} per sweep (raise it with `serve --max-variants`)"),
        ));
    }
    if let ParsedSweep::Runner(spec) = &parsed {
        validate_variants(spec, budget)?;
    }
    Ok((parsed, total))
}

/// Checks every variant of a runner sweep (so a bad variant gets 422 before anything is
/// stored).
pub fn validate_variants(spec: &SweepSpec, budget: MemoryBudget) -> Result<(), SweepError> {
    let validator = crate::sweep::simulator::scene_validator_within(spec.kind, budget);
    Expansion::new(spec).validate_all(spec, &*validator)
}

/// Run options from the query parameters (`backend`, `accuracy`, `full_model`) with
/// `run`'s defaults (auto, 1e-6, false); stored as their JSON.
pub fn options_from_query(
    backend: Option<&str>,
    accuracy: Option<&str>,
    full_model: Option<&str>,
) -> Result<SweepOptions, ApiError> {
    let backend = backend
        .unwrap_or("auto")
        .parse::<BackendKind>()
        .map_err(|e| ApiError::invalid("?backend", e))?;
    let accuracy = match accuracy {
        None => RequestedAccuracy::default(),
        Some(a) => {
            let v: f64 = a
                .parse()
                .map_err(|_| ApiError::invalid("?accuracy", format!("`{a}` is not a number")))?;
            RequestedAccuracy::new(v).map_err(|r| ApiError::invalid("?accuracy", r))?
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
    Ok(SweepOptions {
        backend,
        accuracy,
        full_model,
        ..SweepOptions::default()
    })
}

/// The run options stored with a sweep.
pub fn parse_options(options: &Value) -> Result<SweepOptions, ApiError> {
    serde_json::from_value(options.clone())
        .map_err(|e| ApiError::invalid("options", format!("stored run options: {e}")))
}
