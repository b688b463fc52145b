//! The service's one error type: every failure maps to an HTTP status and the body
//! `{"error": {"path": "...", "message": "..."}}` (`path`: the JSON path of the bad field
//! inside the request body, a query parameter as `?name`, or `$`).

use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use serde::Serialize;

use super::store::StoreError;
use crate::app::AppError;
use crate::sweep::SweepError;

/// `Retry-After` of a 503 for an unreachable store, s (a database restart takes a few).
pub const STORE_RETRY_AFTER_S: u64 = 5;
/// `Retry-After` of a 429 for a full sweep queue, s.
pub const QUEUE_RETRY_AFTER_S: u64 = 10;

/// An API failure.
#[derive(Debug, thiserror::Error)]
#[error("{status}: {path}: {message}")]
pub struct ApiError {
    /// HTTP status.
    pub status: StatusCode,
    /// Where in the request (JSON path, `?param`, `$`).
    pub path: String,
    /// What is wrong, for a person.
    pub message: String,
    /// Seconds after which a retry may succeed (sent as `Retry-After` on 429 and 503).
    pub retry_after_s: Option<u64>,
}

/// The error body.
#[derive(Debug, Serialize, utoipa::ToSchema)]
pub struct ErrorBody {
    /// The error.
    pub error: ErrorDetail,
}

/// Where and what.
#[derive(Debug, Serialize, utoipa::ToSchema)]
pub struct ErrorDetail {
    /// JSON path of the bad field (`$` for the whole body, `?name` for a query parameter).
    pub path: String,
    /// Why.
    pub message: String,
}

impl ApiError {
    /// An error with `status` at `path`.
    pub fn new(status: StatusCode, path: impl Into<String>, message: impl Into<String>) -> Self {
        ApiError {
            status,
            path: path.into(),
            message: message.into(),
            retry_after_s: None,
        }
    }

    /// 503: the server cannot take this now (store unreachable, work budget in use);
    /// `Retry-After: retry_after_s`.
    pub fn unavailable(message: impl Into<String>, retry_after_s: u64) -> Self {
        ApiError {
            retry_after_s: Some(retry_after_s),
            ..Self::new(StatusCode::SERVICE_UNAVAILABLE, "$", message)
        }
    }

    /// 429: too many of something queued by clients; `Retry-After: retry_after_s`.
    pub fn too_many(
        path: impl Into<String>,
        message: impl Into<String>,
        retry_after_s: u64,
    ) -> Self {
        ApiError {
            retry_after_s: Some(retry_after_s),
            ..Self::new(StatusCode::TOO_MANY_REQUESTS, path, message)
        }
    }

    /// 422: a well-formed request whose content is invalid.
    pub fn invalid(path: impl Into<String>, message: impl Into<String>) -> Self {
        Self::new(StatusCode::UNPROCESSABLE_ENTITY, path, message)
    }

    /// 400: a malformed request (not JSON, bad query syntax).
    pub fn bad_request(path: impl Into<String>, message: impl Into<String>) -> Self {
        Self::new(StatusCode::BAD_REQUEST, path, message)
    }

    /// 404 for a missing thing.
    pub fn not_found(what: impl Into<String>) -> Self {
        Self::new(StatusCode::NOT_FOUND, "$", what)
    }

    /// 500: a fault of the server (store, thread), with its message.
    pub fn internal(message: impl Into<String>) -> Self {
        Self::new(StatusCode::INTERNAL_SERVER_ERROR, "$", message)
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        let body = ErrorBody {
            error: ErrorDetail {
                path: self.path,
                message: self.message,
            },
        };
        let mut r = (self.status, axum::Json(body)).into_response();
        if let Some(s) = self.retry_after_s {
            r.headers_mut()
                .insert(axum::http::header::RETRY_AFTER, s.into());
        }
        r
    }
}

impl From<StoreError> for ApiError {
    fn from(e: StoreError) -> Self {
        match e {
            StoreError::NotFound(id) => ApiError::not_found(format!("no sweep `{id}`")),
            StoreError::Unavailable(m) => ApiError::unavailable(m, STORE_RETRY_AFTER_S),
            StoreError::QueueFull { open, limit } => ApiError::too_many(
                "$",
                format!("{open} sweeps are queued or running, the limit is {limit} (wait, or raise it with `serve --max-queued`)"),
                QUEUE_RETRY_AFTER_S,
            ),
            other => ApiError::internal(other.to_string()),
        }
    }
}

impl From<SweepError> for ApiError {
    fn from(e: SweepError) -> Self {
        match e {
            SweepError::Spec { path, reason } => ApiError::invalid(path, reason),
            SweepError::Variant {
                id,
                assignment,
                path,
                reason,
            } => ApiError::invalid(path, format!("variant {id} ({assignment}): {reason}")),
            other => ApiError::invalid("$", other.to_string()),
        }
    }
}

impl From<AppError> for ApiError {
    fn from(e: AppError) -> Self {
        match e {
            AppError::Input { path, reason } => ApiError::invalid(path, reason),
            AppError::Sweep(s) => s.into(),
            other => ApiError::internal(other.to_string()),
        }
    }
}
