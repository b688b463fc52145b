//! The service's work and memory budget: every request's memory is estimated from its
//! size before any work (422 naming the field over [`ServiceConfig::max_request_bytes`]),
//! request bodies and evaluation states in flight are bounded across requests (503 with
//! `Retry-After` while the budget is in use), and memory is handed back to the
//! operating system once a large request is answered (docs/service-limits.md).

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use tokio::sync::{OwnedSemaphorePermit, Semaphore};

use super::error::ApiError;
use super::ServiceConfig;
use crate::budget::show_bytes;

/// Peak memory per evaluated state of `/api/eval`, bytes: the request's parsed states,
/// the coalesced call's input text, the backend's results, the answer as text and as
/// JSON values. Measured 8.1 kB: 8 concurrent requests of 30 000 states took the server
/// from 13 MB to 1.9 GB (issue 22); rounded up.
pub const EVAL_BYTES_PER_STATE: u64 = 9 << 10;

/// Peak memory per operating point of `/api/coefficients`, bytes: the point's JSON
/// object (state, equilibrium, loads, four 4×4 matrices, ROSS row). Measured 34 kB per
/// speed (400 000 speeds on their way to 14 GB, issue 22); rounded up.
pub const COEFF_BYTES_PER_SPEED: u64 = 36 << 10;

/// Parsed JSON per byte of body, at most (numbers and keys become tagged values and map
/// entries): the body's share of a request's estimate.
pub const PARSED_BYTES_PER_BODY_BYTE: u64 = 12;

/// Request bodies of the largest size held at once (being read or parsed): more wait
/// their turn as 503 with `Retry-After`.
pub const BODIES_IN_FLIGHT: u64 = 8;

/// `Retry-After` of a 503 for a budget in use, s (requests take well under a second).
pub const BUSY_RETRY_AFTER_S: u64 = 1;

/// Answers larger than this are streamed in chunks rather than built whole, bytes.
pub const STREAM_CHUNK_BYTES: usize = 64 << 10;

/// A request estimated above this is followed by handing freed memory back (glibc keeps
/// freed arenas otherwise), bytes.
const TRIM_ABOVE_BYTES: u64 = 16 << 20;

/// The budgets shared by the handlers.
pub struct Limits {
    /// Largest estimated memory of one request, bytes.
    pub max_request_bytes: u64,
    /// Most states (eval states, coefficient speeds) in flight across requests.
    pub max_states: u64,
    states: Arc<Semaphore>,
    /// Body bytes in flight, in KiB permits.
    bodies: Arc<Semaphore>,
    /// Estimated bytes of large requests in flight (to trim once they are all answered).
    large_in_flight: Arc<AtomicU64>,
}

/// A share of the budget, given back on drop.
pub struct Held {
    _permit: Option<OwnedSemaphorePermit>,
    large: Option<(u64, Arc<AtomicU64>)>,
}

impl Drop for Held {
    fn drop(&mut self) {
        if let Some((bytes, counter)) = self.large.take() {
            // The last large request out hands the freed memory back.
            if counter.fetch_sub(bytes, Ordering::AcqRel) == bytes {
                trim_heap();
            }
        }
    }
}

/// Hands freed heap memory back to the operating system (glibc only; elsewhere the
/// allocator does it itself or not at all).
pub fn trim_heap() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only walks the allocator's own free lists.
    unsafe {
        libc::malloc_trim(0);
    }
}

impl Limits {
    /// The budgets of `config`.
    pub fn new(config: &ServiceConfig) -> Self {
        let body_kib = (config.max_body_bytes as u64).div_ceil(1024).max(1);
        Limits {
            max_request_bytes: config.max_request_bytes,
            max_states: config.max_states_in_flight.max(1),
            states: Arc::new(Semaphore::new(
                config.max_states_in_flight.clamp(1, u32::MAX as u64) as usize,
            )),
            bodies: Arc::new(Semaphore::new(
                (body_kib * BODIES_IN_FLIGHT).min(u32::MAX as u64) as usize,
            )),
            large_in_flight: Arc::new(AtomicU64::new(0)),
        }
    }

    /// Room for a body of `bytes` (the Content-Length, else the body limit) while it is
    /// read and parsed; 503 with `Retry-After` while other bodies fill the budget.
    pub fn take_body(&self, bytes: u64) -> Result<Held, ApiError> {
        let kib = bytes.div_ceil(1024).max(1).min(u32::MAX as u64) as u32;
        let permit = self.bodies.clone().try_acquire_many_owned(kib).map_err(|_| {
            ApiError::unavailable(
                format!(
                    "the server is reading other request bodies (at most {BODIES_IN_FLIGHT} of the largest size at once); retry shortly"
                ),
                BUSY_RETRY_AFTER_S,
            )
        })?;
        Ok(Held {
            _permit: Some(permit),
            large: None,
        })
    }

    /// Checks a request of `count` items (`what`, at the JSON path `field`) costing
    /// `bytes_per_item` each and a body of `body_bytes` against the per-request budget
    /// (422 naming the field), then takes `count` states from the budget shared by all
    /// requests (503 with `Retry-After` while it is in use).
    pub fn take_work(
        &self,
        field: &str,
        what: &str,
        count: u64,
        bytes_per_item: u64,
        body_bytes: u64,
    ) -> Result<Held, ApiError> {
        let estimate = count
            .saturating_mul(bytes_per_item)
            .saturating_add(body_bytes.saturating_mul(PARSED_BYTES_PER_BODY_BYTE));
        if estimate > self.max_request_bytes {
            let fit = self
                .max_request_bytes
                .saturating_sub(body_bytes.saturating_mul(PARSED_BYTES_PER_BODY_BYTE))
                / bytes_per_item.max(1);
            return Err(ApiError::invalid(
                field,
                format!(
                    "{count} {what} need about {}, over the per-request memory budget of {} (at most about {fit} {what} per request: split the request, or raise `serve --max-request-memory`)",
                    show_bytes(estimate as f64),
                    show_bytes(self.max_request_bytes as f64)
                ),
            ));
        }
        if count > self.max_states {
            return Err(ApiError::invalid(
                field,
                format!(
                    "{count} {what} exceed the {} the server evaluates at once (split the request, or raise `serve --max-states-in-flight`)",
                    self.max_states
                ),
            ));
        }
        let permit = if count == 0 {
            None
        } else {
            Some(
                self.states
                    .clone()
                    .try_acquire_many_owned(count.min(u32::MAX as u64) as u32)
                    .map_err(|_| {
                        ApiError::unavailable(
                            format!(
                                "the server is evaluating other requests (at most {} states or speeds in flight); retry shortly",
                                self.max_states
                            ),
                            BUSY_RETRY_AFTER_S,
                        )
                    })?,
            )
        };
        let large = (estimate >= TRIM_ABOVE_BYTES).then(|| {
            self.large_in_flight.fetch_add(estimate, Ordering::AcqRel);
            (estimate, self.large_in_flight.clone())
        });
        Ok(Held {
            _permit: permit,
            large,
        })
    }
}
