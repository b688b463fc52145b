//! The result document of a sweep stored in PostgreSQL: the same JSON `run` writes to
//! result.json for the same spec and settings (everything but the `run` section, which
//! describes the workers and leases instead of one process).

use serde_json::Value;

use super::error::PgError;
use super::monitor::run_section;
use super::queue::PgQueue;
use crate::sweep::job;
use crate::sweep::spec::SweepSpec;

/// Variants read per query while assembling a result.
const PAGE: u64 = 1000;

/// The complete result of sweep `id` (status `done`), variants in id order. `spec` is the
/// sweep's parsed spec, as the caller parsed it once ([`super::parse_queued`]) to submit
/// it: it is not parsed again here, only checked to be the stored one (the canonical
/// text compared in the database).
pub async fn result_document(
    queue: &PgQueue,
    id: &str,
    spec: &SweepSpec,
) -> Result<Value, PgError> {
    let row = queue
        .sweep(id)
        .await?
        .ok_or_else(|| PgError::NotFound(id.to_string()))?;
    if !is_stored_spec(queue, id, spec).await? {
        return Err(PgError::Sweep {
            id: id.to_string(),
            reason: "the spec given is not the one stored with the sweep".into(),
        });
    }
    if row.status != "done" {
        return Err(PgError::Sweep {
            id: id.to_string(),
            reason: format!(
                "the result is complete only when the sweep is done; it is {} ({} of {} variants)",
                row.status, row.done, row.total
            ),
        });
    }
    let run = match &row_run(queue, id).await? {
        Some(r) => r.clone(),
        None => run_section(queue, id).await?,
    };
    let settings = row.settings.clone().unwrap_or(Value::Null);
    let mut doc = job::result_document(spec, &settings, None, row.total, run);
    let mut variants = Vec::with_capacity(row.total as usize);
    let mut next = 0u64;
    loop {
        let page = queue.variants(id, next, PAGE).await?;
        let Some(last) = page.last().map(|r| r.id) else {
            break;
        };
        for r in page {
            let v: Value = serde_json::from_str(&r.line).map_err(|e| PgError::Sweep {
                id: id.to_string(),
                reason: format!("variant {}: stored line is not JSON: {e}", r.id),
            })?;
            variants.push(v);
        }
        next = last + 1;
    }
    if variants.len() as u64 != row.total {
        return Err(PgError::Sweep {
            id: id.to_string(),
            reason: format!(
                "{} variant results stored for {} variants",
                variants.len(),
                row.total
            ),
        });
    }
    doc["variants"] = Value::Array(variants);
    Ok(doc)
}

/// The stored `run` section (written when the server saw the sweep done).
async fn row_run(queue: &PgQueue, id: &str) -> Result<Option<Value>, PgError> {
    let c = queue.connection("reading the run section").await?;
    let r = c
        .query_opt("SELECT run FROM sweeps WHERE id = $1", &[&id])
        .await
        .map_err(|e| queue.db_error("reading the run section", e))?;
    Ok(r.and_then(|r| r.get::<_, Option<String>>(0))
        .and_then(|t| serde_json::from_str(&t).ok()))
}

/// Whether `spec` is the canonical spec stored with sweep `id` (as [`super::submit_spec`]
/// and the service's store write it: its compact JSON text).
async fn is_stored_spec(queue: &PgQueue, id: &str, spec: &SweepSpec) -> Result<bool, PgError> {
    let text = serde_json::to_string(&spec.canonical).unwrap_or_default();
    let c = queue.connection("reading the sweep's spec").await?;
    let r = c
        .query_opt("SELECT spec = $2 FROM sweeps WHERE id = $1", &[&id, &text])
        .await
        .map_err(|e| queue.db_error("reading the sweep's spec", e))?;
    Ok(r.is_some_and(|r| r.get::<_, bool>(0)))
}
