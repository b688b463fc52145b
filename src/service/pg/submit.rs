//! Enqueueing a sweep spec (as `run` reads it) on the PostgreSQL queue: parsed once by
//! the caller ([`parse_queued`]) and every variant validated before anything is stored.

use serde_json::Value;

use super::error::PgError;
use super::queue::{PgQueue, QueuedSweep, SweepOptions};
use crate::sweep::spec::{parse_spec, SweepSpec};
use crate::sweep::Expansion;

pub use crate::service::sweeps::new_sweep_id;

/// A spec document parsed for the queue as `run` parses it (no base file: the document
/// is what every worker expands); a bad one is a [`PgError::Spec`] naming the JSON path.
/// Parse once and keep it: [`submit_spec`] and [`super::result_document`] take the parsed
/// spec.
pub fn parse_queued(doc: &Value) -> Result<SweepSpec, PgError> {
    parse_spec(doc, None).map_err(PgError::Spec)
}

/// Validates the parsed `spec` (every variant, within `options.max_memory`) and enqueues
/// it in work batches of `batch_variants`; returns (id, variants). A bad variant is a
/// [`PgError::Spec`] naming the JSON path.
pub async fn submit_spec(
    queue: &PgQueue,
    spec: &SweepSpec,
    options: SweepOptions,
    batch_variants: i32,
) -> Result<(String, u64), PgError> {
    let exp = Expansion::new(spec);
    crate::service::sweeps::validate_variants(spec, options.max_memory).map_err(PgError::Spec)?;
    let id = new_sweep_id();
    let total = exp.count();
    queue
        .submit(&QueuedSweep {
            id: id.clone(),
            name: spec.name.clone().unwrap_or_default(),
            kind: spec.kind.name().to_string(),
            spec: spec.canonical.clone(),
            options,
            total,
            batch_variants,
            posted: None,
            local: false,
            created_unix_s: None,
        })
        .await?;
    Ok((id, total))
}
