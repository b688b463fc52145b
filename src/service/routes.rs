//! The HTTP routes: thin handlers over the store, the scheduler and the eval coalescer.
//! Every error is an [`ApiError`] (JSON body naming the path); the OpenAPI document is
//! generated from the handler annotations below.

use std::collections::HashMap;
use std::convert::Infallible;
use std::io::Write;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use axum::body::Body;
use axum::extract::{Path, Request, State};
use axum::http::{header, HeaderMap, StatusCode, Uri};
use axum::middleware::Next;
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use serde::Serialize;
use serde_json::{json, Value};
use subtle::ConstantTimeEq;
use utoipa::OpenApi;

use super::error::{ApiError, ErrorBody};
use super::limits::{Held, COEFF_BYTES_PER_SPEED, EVAL_BYTES_PER_STATE, STREAM_CHUNK_BYTES};
use super::scheduler::{now_unix_s, SweepEvent};
use super::store::{SweepRow, SweepStatus};
use super::sweeps::{options_from_query, ParsedSweep};
use super::{csv, AppState};
use crate::sweep::job::result_document;
use crate::sweep::progress::ProgressSnapshot;
use crate::sweep::runner::write_result_doc;

/// Variant records per page when `limit` is not given.
const DEFAULT_PAGE: u64 = 100;
/// Largest page of variant records.
const MAX_PAGE: u64 = 10_000;
/// How often an event stream checks the store for an end it was not told of.
const RECHECK: Duration = Duration::from_secs(5);
/// SSE keep-alive comment interval.
const KEEP_ALIVE: Duration = Duration::from_secs(15);

/// The API description.
#[derive(OpenApi)]
#[openapi(
    info(title = "bearing-sweep service", description = "Sweeps of rigid rotors in hydrodynamic journal bearings, and batched film-load evaluation."),
    paths(submit_sweep, list_sweeps, get_sweep, delete_sweep, sweep_result, sweep_variants,
          list_plots, get_plot, sweep_events, cancel_sweep, eval, coefficients, healthz),
    components(schemas(ErrorBody, BackendParam, FormatParam, StreamEvent, Created, SweepSummary, SweepList, SweepInfo, ProgressSnapshot, SweepStatus, PlotList,
        crate::sweep::spec::SpecDocument, crate::sweep::spec::SweepSpecDoc, crate::sweep::friction_map::FrictionMapDoc,
        super::bodies::EvalBody, super::bodies::BearingBody)),
    modifiers(&BearerAuth)
)]
pub struct ApiDoc;

struct BearerAuth;

impl utoipa::Modify for BearerAuth {
    fn modify(&self, openapi: &mut utoipa::openapi::OpenApi) {
        use utoipa::openapi::security::{HttpAuthScheme, HttpBuilder, SecurityScheme};
        if let Some(c) = openapi.components.as_mut() {
            c.add_security_scheme(
                "bearer",
                SecurityScheme::Http(HttpBuilder::new().scheme(HttpAuthScheme::Bearer).build()),
            );
        }
    }
}

/// The router with every route, the auth layer on `/api` and the latency layer.
pub fn router(state: AppState) -> Router {
    let api = Router::new()
        .route("/sweeps", post(submit_sweep).get(list_sweeps))
        .route("/sweeps/{id}", get(get_sweep).delete(delete_sweep))
        .route("/sweeps/{id}/result", get(sweep_result))
        .route("/sweeps/{id}/variants", get(sweep_variants))
        .route("/sweeps/{id}/plots", get(list_plots))
        .route("/sweeps/{id}/plots/{name}", get(get_plot))
        .route("/sweeps/{id}/events", get(sweep_events))
        .route("/sweeps/{id}/cancel", post(cancel_sweep))
        .route("/eval", post(eval))
        .route("/coefficients", post(coefficients))
        .route("/openapi.json", get(openapi))
        .merge(super::web::api())
        .layer(axum::middleware::from_fn_with_state(state.clone(), auth));
    Router::new()
        .merge(super::web::pages())
        .route("/healthz", get(healthz))
        .route("/metrics", get(metrics))
        .nest("/api", api)
        .fallback(not_found)
        .method_not_allowed_fallback(method_not_allowed)
        .layer(axum::middleware::from_fn(json_errors))
        .layer(axum::middleware::from_fn_with_state(state.clone(), guard))
        .layer(axum::middleware::from_fn_with_state(state.clone(), timing))
        // gzip for clients that ask (CSV and results compress well; event streams are left
        // alone by the default predicate), and a span per request for
        // `RUST_LOG=tower_http=debug` (headers, hence tokens, are not recorded).
        .layer(tower_http::compression::CompressionLayer::new())
        .layer(tower_http::trace::TraceLayer::new_for_http())
        .with_state(state)
}

async fn not_found(uri: Uri) -> ApiError {
    ApiError::not_found(format!("no route {}", uri.path()))
}

async fn method_not_allowed(uri: Uri) -> ApiError {
    ApiError::new(
        StatusCode::METHOD_NOT_ALLOWED,
        "$",
        format!("method not allowed on {}", uri.path()),
    )
}

/// Every error answer is the JSON error body: the framework's own rejections (a path that
/// is not UTF-8 once decoded, a malformed query) come as plain text and are rewrapped,
/// their text as the message.
async fn json_errors(req: Request, next: Next) -> Response {
    let r = next.run(req).await;
    let status = r.status();
    let is_json = r
        .headers()
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| v.starts_with("application/json"));
    if !(status.is_client_error() || status.is_server_error()) || is_json {
        return r;
    }
    let (parts, body) = r.into_parts();
    // Framework messages are one line; anything longer is cut.
    let text = axum::body::to_bytes(body, 4096).await.unwrap_or_default();
    let message = String::from_utf8_lossy(&text).trim().to_string();
    let message = if message.is_empty() {
        status.canonical_reason().unwrap_or("error").to_string()
    } else {
        message
    };
    let mut e = ApiError::new(status, "$", message).into_response();
    for (k, v) in parts.headers.iter() {
        if k != header::CONTENT_TYPE && k != header::CONTENT_LENGTH {
            e.headers_mut().insert(k.clone(), v.clone());
        }
    }
    e
}

/// Whether `host` (a Host header value or an Origin's authority, with or without port)
/// names this machine's loopback interface.
fn is_local_host(host: &str) -> bool {
    let name = if let Some(rest) = host.strip_prefix('[') {
        rest.split(']').next().unwrap_or("")
    } else {
        host.rsplit_once(':').map_or(host, |(h, _)| h)
    };
    name.eq_ignore_ascii_case("localhost")
        || name
            .parse::<std::net::IpAddr>()
            .is_ok_and(|ip| ip.is_loopback())
}

/// Guards applied before any handler:
/// - on a loopback bind, a `Host` that is not a loopback name is refused (403): a page
///   of another site whose name was rebound to 127.0.0.1 cannot read the API;
/// - an `Origin` other than the server's own (authority = `Host`) is
///   refused (403): a foreign page cannot write, even with a "simple" request that
///   browsers send without asking;
/// - a body whose `Content-Length` exceeds the body limit is refused from the header
///   (413, the body is not read);
/// - a request with a body must say `Content-Type: application/json` (415).
async fn guard(State(st): State<AppState>, req: Request, next: Next) -> Response {
    match check_request(&st, req.headers()) {
        Ok(()) => next.run(req).await,
        Err(e) => {
            let mut r = e.into_response();
            // The client may still be sending a body we will not read.
            r.headers_mut().insert(
                header::CONNECTION,
                header::HeaderValue::from_static("close"),
            );
            r
        }
    }
}

fn check_request(st: &AppState, h: &HeaderMap) -> Result<(), ApiError> {
    let host = h.get(header::HOST).and_then(|v| v.to_str().ok());
    if st.config.bind.ip().is_loopback() {
        if let Some(host) = host {
            if !is_local_host(host) {
                return Err(ApiError::new(
                    StatusCode::FORBIDDEN,
                    "Host",
                    format!(
                        "`{}` is not this machine: a server bound to loopback answers only requests addressed to localhost, 127.0.0.1 or [::1]",
                        crate::json::quote(host)
                    ),
                ));
            }
        }
    }
    if let Some(origin) = h.get(header::ORIGIN) {
        let origin = origin.to_str().unwrap_or("");
        // The server's own pages: scheme http (or https behind a proxy that keeps the
        // Host), authority = Host.
        let same = origin
            .strip_prefix("http://")
            .or_else(|| origin.strip_prefix("https://"))
            .is_some_and(|authority| host.is_some_and(|h| h.eq_ignore_ascii_case(authority)));
        if !same {
            return Err(ApiError::new(
                StatusCode::FORBIDDEN,
                "Origin",
                format!(
                    "requests from the page `{}` are refused: only the server's own pages may call it from a browser",
                    crate::json::quote(origin)
                ),
            ));
        }
    }
    let length = h
        .get(header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.trim().parse::<u64>().ok());
    if let Some(n) = length {
        if n > st.config.max_body_bytes as u64 {
            return Err(too_large(st.config.max_body_bytes));
        }
    }
    let has_body = length.is_some_and(|n| n > 0) || h.contains_key(header::TRANSFER_ENCODING);
    if has_body {
        let ct = h
            .get(header::CONTENT_TYPE)
            .and_then(|v| v.to_str().ok())
            .unwrap_or("");
        let media = ct.split(';').next().unwrap_or("").trim();
        if !media.eq_ignore_ascii_case("application/json") {
            return Err(ApiError::new(
                StatusCode::UNSUPPORTED_MEDIA_TYPE,
                "Content-Type",
                format!(
                    "a request body must be sent as `Content-Type: application/json` (got `{}`)",
                    crate::json::quote(ct)
                ),
            ));
        }
    }
    Ok(())
}

fn too_large(limit: usize) -> ApiError {
    ApiError::new(
        StatusCode::PAYLOAD_TOO_LARGE,
        "$",
        format!("the body is larger than {limit} bytes (raise it with `serve --max-body-bytes`)"),
    )
}

/// Records every request's latency for `/metrics`.
async fn timing(State(st): State<AppState>, req: Request, next: Next) -> Response {
    let t = Instant::now();
    let r = next.run(req).await;
    st.latency.observe(t.elapsed());
    r
}

/// With a token configured, every `/api` route needs `Authorization: Bearer <token>`
/// (compared in constant time over sha2 digests, so neither content nor length leaks).
async fn auth(
    State(st): State<AppState>,
    headers: HeaderMap,
    req: Request,
    next: Next,
) -> Response {
    let Some(token) = &st.config.token else {
        return next.run(req).await;
    };
    let given = headers
        .get(header::AUTHORIZATION)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.strip_prefix("Bearer "))
        .unwrap_or("");
    use sha2::{Digest, Sha256};
    let a = Sha256::digest(token.as_bytes());
    let b = Sha256::digest(given.as_bytes());
    if bool::from(a.as_slice().ct_eq(b.as_slice())) && !given.is_empty() {
        return next.run(req).await;
    }
    let mut r = ApiError::new(
        StatusCode::UNAUTHORIZED,
        "Authorization",
        "missing or wrong bearer token (send `Authorization: Bearer <token>`)",
    )
    .into_response();
    r.headers_mut().insert(
        header::WWW_AUTHENTICATE,
        "Bearer".parse().expect("static header"),
    );
    r
}

/// Liveness: 200 once the server is ready.
#[utoipa::path(get, path = "/healthz", responses((status = 200, description = "Ready", body = serde_json::Value)))]
async fn healthz() -> Json<Value> {
    Json(json!({"status": "ok"}))
}

async fn metrics(State(st): State<AppState>) -> Result<Response, ApiError> {
    let store = st.store.clone();
    // One count query: the cost does not grow with the sweeps stored.
    let queued = blocking(move || Ok(store.count_queued()?)).await?;
    let c = &st.scheduler.counters;
    let e = &st.coalescer.counters;
    let text = super::metrics::render(
        &super::metrics::Scrape {
            queued,
            running: st.scheduler.running(),
            variants_done: c.variants_done.load(Ordering::Relaxed),
            variants_failed: c.variants_failed.load(Ordering::Relaxed),
            eval_states_per_s: e.states_per_s(),
            eval_states: e.states.load(Ordering::Relaxed),
            eval_backend_calls: e.backend_calls.load(Ordering::Relaxed),
            eval_requests: e.requests.load(Ordering::Relaxed),
        },
        &st.latency,
    );
    Ok((
        [(
            header::CONTENT_TYPE,
            "text/plain; version=0.0.4; charset=utf-8",
        )],
        text,
    )
        .into_response())
}

async fn openapi() -> Json<utoipa::openapi::OpenApi> {
    Json(ApiDoc::openapi().merge_from(super::web::WebApiDoc::openapi()))
}

/// Runs a blocking store call off the async threads.
async fn blocking<T: Send + 'static>(
    f: impl FnOnce() -> Result<T, ApiError> + Send + 'static,
) -> Result<T, ApiError> {
    tokio::task::spawn_blocking(f)
        .await
        .map_err(|e| ApiError::internal(format!("internal: {e}")))?
}

/// Query parameters as a map; a malformed query is a 400 naming it.
fn query(uri: &Uri) -> Result<HashMap<String, String>, ApiError> {
    axum::extract::Query::<HashMap<String, String>>::try_from_uri(uri)
        .map(|q| q.0)
        .map_err(|e| ApiError::bad_request("?", format!("malformed query: {e}")))
}

/// The body, at most the body limit (413 beyond), read under the budget of bodies in
/// flight (503 while it is full; the share is held as long as the returned guard).
async fn read_body(
    st: &AppState,
    headers: &HeaderMap,
    body: Body,
) -> Result<(axum::body::Bytes, Held), ApiError> {
    let limit = st.config.max_body_bytes;
    let declared = headers
        .get(header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.trim().parse::<u64>().ok())
        .unwrap_or(limit as u64)
        .min(limit as u64);
    let held = st.limits.take_body(declared)?;
    let bytes = axum::body::to_bytes(body, limit)
        .await
        .map_err(|_| too_large(limit))?;
    Ok((bytes, held))
}

/// A JSON body parsed as `run` parses its files: duplicate keys refused, naming the path.
fn parse_body(bytes: &[u8]) -> Result<Value, ApiError> {
    let text = std::str::from_utf8(bytes)
        .map_err(|_| ApiError::bad_request("$", "the body is not UTF-8"))?;
    crate::json::parse_json(text).map_err(|e| {
        if e.reason.contains("duplicate") {
            ApiError::invalid(e.path, e.reason)
        } else {
            ApiError::bad_request(e.path, format!("not valid JSON: {}", e.reason))
        }
    })
}

/// Film backend of a sweep (query `backend`).
#[derive(utoipa::ToSchema)]
#[schema(rename_all = "lowercase")]
#[allow(dead_code)] // a schema only: the query is parsed by `options_from_query`
pub enum BackendParam {
    /// The CPU kernel (`run`'s default).
    Cpu,
    /// The WGSL kernel.
    Gpu,
    /// A GPU when one exists, else the CPU.
    Auto,
}

/// One server-sent event of `GET /api/sweeps/{id}/events`, as a client parses it (OpenAPI
/// before 3.2 reads a `text/event-stream` schema as the schema of each event).
#[derive(utoipa::ToSchema)]
#[allow(dead_code)] // a schema only: the events are written by `status_event` and `sweep_events`
pub struct StreamEvent {
    /// Event name.
    #[schema(pattern = "^(status|variant|deleted)$")]
    event: String,
    /// The event's JSON object as text: `{"status", "progress"}` for `status`,
    /// `{"id", "ok", "progress"}` for `variant`, `{"status": "deleted"}` for `deleted`.
    data: String,
}

/// Answer format of the variant records (query `format`).
#[derive(utoipa::ToSchema)]
#[schema(rename_all = "lowercase")]
#[allow(dead_code)] // a schema only
pub enum FormatParam {
    /// JSON page.
    Json,
    /// CSV, one flat row per variant.
    Csv,
}

/// `201` answer to a submission.
#[derive(Serialize, utoipa::ToSchema)]
pub struct Created {
    /// Opaque id.
    id: String,
    /// Always `queued`.
    status: SweepStatus,
    /// Variants in the sweep.
    variants: u64,
}

/// Submit a sweep: the body is a sweep spec exactly as `run` reads it.
#[utoipa::path(post, path = "/api/sweeps",
    params(
        ("backend" = Option<BackendParam>, Query, description = "Film backend: cpu (default), gpu or auto (as `run --backend`)"),
        ("accuracy" = Option<f64>, Query, minimum = 1e-12, description = "Film accuracy (as `run --accuracy`; default 1e-6)"),
        ("full_model" = Option<bool>, Query, description = "Every model reduction off (as `run --full-model`)"),
    ),
    request_body(content = crate::sweep::spec::SpecDocument, description = "A sweep spec (see sweeps/ and docs/cli.md \"Sweeps\")", content_type = "application/json"),
    responses(
        (status = 201, description = "Queued", body = Created),
        (status = 400, description = "Not JSON", body = ErrorBody),
        (status = 401, description = "Token required", body = ErrorBody),
        (status = 413, description = "Body too large", body = ErrorBody),
        (status = 415, description = "The body is not sent as application/json", body = ErrorBody),
        (status = 422, description = "Invalid spec or option: the JSON path and why", body = ErrorBody),
        (status = 429, description = "Too many queued sweeps (Retry-After)", body = ErrorBody),
        (status = 503, description = "Busy or store unavailable (Retry-After)", body = ErrorBody),
    ),
    security((), ("bearer" = [])))]
async fn submit_sweep(
    State(st): State<AppState>,
    uri: Uri,
    headers: HeaderMap,
    body: Body,
) -> Result<Response, ApiError> {
    let q = query(&uri)?;
    let options = options_from_query(
        q.get("backend").map(String::as_str),
        q.get("accuracy").map(String::as_str),
        q.get("full_model").map(String::as_str),
    )?;
    let (bytes, _held) = read_body(&st, &headers, body).await?;
    let doc = parse_body(&bytes)?;
    drop(bytes);
    let (max_variants, max_queued) = (st.config.max_variants, st.config.max_queued);
    let scheduler = st.scheduler.clone();
    let created =
        blocking(move || scheduler.submit(doc, &options, max_variants, max_queued)).await?;
    Ok((
        StatusCode::CREATED,
        Json(Created {
            id: created.id,
            status: SweepStatus::Queued,
            variants: created.total,
        }),
    )
        .into_response())
}

/// One line of the sweep list.
#[derive(Serialize, utoipa::ToSchema)]
pub struct SweepSummary {
    /// Opaque id.
    id: String,
    /// The spec's name.
    name: String,
    /// Status.
    status: SweepStatus,
    /// Submission time (RFC 3339, UTC).
    created: String,
    /// Variants finished.
    done: u64,
    /// Variants in the sweep.
    total: u64,
    /// Finished variants whose status is not ok.
    failed: u64,
}

/// The sweep list.
#[derive(Serialize, utoipa::ToSchema)]
pub struct SweepList {
    /// Oldest first.
    sweeps: Vec<SweepSummary>,
}

/// List every sweep.
#[utoipa::path(get, path = "/api/sweeps",
    responses((status = 200, description = "Every sweep, oldest first", body = SweepList),
              (status = 401, description = "Token required", body = ErrorBody)),
    security((), ("bearer" = [])))]
async fn list_sweeps(State(st): State<AppState>) -> Result<Json<SweepList>, ApiError> {
    let store = st.store.clone();
    let rows = blocking(move || Ok(store.list_sweeps()?)).await?;
    Ok(Json(SweepList {
        sweeps: rows
            .into_iter()
            .map(|r| {
                let p = progress_of(&st, &r);
                SweepSummary {
                    created: rfc3339(r.created_unix_s),
                    id: r.id,
                    name: r.name,
                    status: r.status,
                    done: p.done,
                    total: p.total,
                    failed: p.failed,
                }
            })
            .collect(),
    }))
}

/// A sweep's status.
#[derive(Serialize, utoipa::ToSchema)]
pub struct SweepInfo {
    /// Opaque id.
    id: String,
    /// The spec's name.
    name: String,
    /// Status.
    status: SweepStatus,
    /// Why it failed, or a note.
    #[schema(nullable)]
    message: Option<String>,
    /// Progress (live while running).
    progress: ProgressSnapshot,
    /// Variants computed and committed over the sweep's life (resumes included): equals
    /// `progress.done` unless a finished variant was computed twice.
    variants_computed: u64,
    /// Submission time (RFC 3339, UTC).
    created: String,
    /// Start of the latest run (RFC 3339, UTC).
    #[schema(nullable)]
    started: Option<String>,
    /// End (RFC 3339, UTC).
    #[schema(nullable)]
    finished: Option<String>,
    /// Timings: `queued_s`, `wall_s` (from start to end), and the run's own figures.
    #[schema(value_type = Object)]
    timings: Value,
    /// Run options (backend, accuracy, full_model).
    #[schema(value_type = Object)]
    options: Value,
}

fn progress_of(st: &AppState, r: &SweepRow) -> ProgressSnapshot {
    if r.status == SweepStatus::Running {
        if let Some(p) = st.scheduler.live_progress(&r.id) {
            return p;
        }
    }
    let rate = r
        .run
        .as_ref()
        .and_then(|v| v["variants_per_s"].as_f64())
        .unwrap_or(0.0);
    ProgressSnapshot {
        done: r.done,
        failed: r.failed,
        total: r.total,
        variants_per_s: rate,
        eta_s: None,
    }
}

/// Seconds since the Unix epoch as RFC 3339 UTC with milliseconds.
pub fn rfc3339(t: f64) -> String {
    let ms = (t * 1000.0).round() as i64;
    let (secs, milli) = (ms.div_euclid(1000), ms.rem_euclid(1000));
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    // Civil date from days since 1970-01-01 (H. Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}.{milli:03}Z",
        rem / 3600,
        rem / 60 % 60,
        rem % 60
    )
}

/// A sweep's summary row (no spec, header or result: status and progress only).
async fn row_or_404(st: &AppState, id: &str) -> Result<SweepRow, ApiError> {
    let store = st.store.clone();
    let key = id.to_string();
    blocking(move || {
        store
            .sweep_summary(&key)?
            .ok_or_else(|| ApiError::not_found(format!("no sweep `{key}`")))
    })
    .await
}

/// A sweep's whole row (spec and header: what rebuilding its result needs).
async fn full_row_or_404(st: &AppState, id: &str) -> Result<SweepRow, ApiError> {
    let store = st.store.clone();
    let key = id.to_string();
    blocking(move || {
        store
            .sweep(&key)?
            .ok_or_else(|| ApiError::not_found(format!("no sweep `{key}`")))
    })
    .await
}

/// One piece of a streamed answer.
enum Piece {
    Chunk(axum::body::Bytes),
    Fail(ApiError),
}

/// A `Write` that sends what it is given as chunks of about [`STREAM_CHUNK_BYTES`] to a
/// streamed answer (from a blocking thread).
struct ChunkWriter {
    tx: tokio::sync::mpsc::Sender<Piece>,
    buf: Vec<u8>,
}

impl ChunkWriter {
    fn send(&mut self) -> std::io::Result<()> {
        if self.buf.is_empty() {
            return Ok(());
        }
        let chunk = std::mem::replace(&mut self.buf, Vec::with_capacity(STREAM_CHUNK_BYTES));
        self.tx
            .blocking_send(Piece::Chunk(chunk.into()))
            .map_err(|_| std::io::Error::new(std::io::ErrorKind::BrokenPipe, "client gone"))
    }
}

impl std::io::Write for ChunkWriter {
    fn write(&mut self, data: &[u8]) -> std::io::Result<usize> {
        self.buf.extend_from_slice(data);
        if self.buf.len() >= STREAM_CHUNK_BYTES {
            self.send()?;
        }
        Ok(data.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// An answer written by `write` on a blocking thread and sent in chunks as it is
/// written (memory: a few chunks, whatever the answer's size). An error before the first
/// chunk is the answer; a later one cuts the body short (the client sees a truncated
/// transfer, never a wrong document).
async fn stream_blocking(
    content_type: &'static str,
    write: impl FnOnce(&mut ChunkWriter) -> Result<(), ApiError> + Send + 'static,
) -> Result<Response, ApiError> {
    let (tx, mut rx) = tokio::sync::mpsc::channel::<Piece>(4);
    tokio::task::spawn_blocking(move || {
        let mut w = ChunkWriter {
            tx: tx.clone(),
            buf: Vec::with_capacity(STREAM_CHUNK_BYTES),
        };
        let out = write(&mut w).and_then(|()| {
            w.send()
                .map_err(|e| ApiError::internal(format!("streaming: {e}")))
        });
        if let Err(e) = out {
            let _ = tx.blocking_send(Piece::Fail(e));
        }
    });
    let first = match rx.recv().await {
        None => axum::body::Bytes::new(),
        Some(Piece::Fail(e)) => return Err(e),
        Some(Piece::Chunk(c)) => c,
    };
    let rest = futures_util::stream::unfold(rx, |mut rx| async move {
        match rx.recv().await? {
            Piece::Chunk(c) => Some((Ok::<_, std::io::Error>(c), rx)),
            Piece::Fail(e) => Some((Err(std::io::Error::other(e.message)), rx)),
        }
    });
    // Fused: the gzip layer polls the body once more after its end, and an unfused
    // `unfold` panics when polled after it returned `None`.
    let stream = futures_util::StreamExt::fuse(futures_util::StreamExt::chain(
        futures_util::stream::once(async move { Ok::<_, std::io::Error>(first) }),
        rest,
    ));
    Ok((
        [(header::CONTENT_TYPE, content_type)],
        Body::from_stream(stream),
    )
        .into_response())
}

/// A sweep's status, progress and timings.
#[utoipa::path(get, path = "/api/sweeps/{id}",
    params(("id" = String, Path, description = "Sweep id")),
    responses((status = 200, description = "Status", body = SweepInfo),
              (status = 401, description = "Token required", body = ErrorBody),
              (status = 404, description = "No such sweep", body = ErrorBody)),
    security((), ("bearer" = [])))]
async fn get_sweep(
    State(st): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<SweepInfo>, ApiError> {
    let r = row_or_404(&st, &id).await?;
    let progress = progress_of(&st, &r);
    let mut timings = json!({
        "queued_s": r.started_unix_s.map(|s| s - r.created_unix_s),
        "wall_s": match (r.started_unix_s, r.finished_unix_s) {
            (Some(a), Some(b)) => Some(b - a),
            (Some(a), None) => Some(now_unix_s() - a),
            _ => None,
        },
    });
    if let Some(run) = &r.run {
        for k in ["simulation_wall_s", "variants_per_s", "peak_rss_bytes"] {
            timings[k] = run[k].clone();
        }
    }
    Ok(Json(SweepInfo {
        message: r.message.clone(),
        progress,
        variants_computed: r.computed,
        created: rfc3339(r.created_unix_s),
        started: r.started_unix_s.map(rfc3339),
        finished: r.finished_unix_s.map(rfc3339),
        timings,
        options: r.options.clone(),
        id: r.id,
        name: r.name,
        status: r.status,
    }))
}

/// Delete a sweep and everything stored for it (a running one is cancelled first).
#[utoipa::path(delete, path = "/api/sweeps/{id}",
    params(("id" = String, Path, description = "Sweep id")),
    responses((status = 204, description = "Deleted"),
              (status = 401, description = "Token required", body = ErrorBody),
              (status = 404, description = "No such sweep", body = ErrorBody)),
    security((), ("bearer" = [])))]
async fn delete_sweep(
    State(st): State<AppState>,
    Path(id): Path<String>,
) -> Result<StatusCode, ApiError> {
    let store = st.store.clone();
    let key = id.clone();
    let gone = blocking(move || Ok(store.delete_sweep(&key)?)).await;
    // After the store forgot it: a stream that subscribed before sees `Deleted`, one
    // that subscribes after finds no sweep (404).
    st.scheduler.forget(&id);
    if !gone? {
        return Err(ApiError::not_found(format!("no sweep `{id}`")));
    }
    Ok(StatusCode::NO_CONTENT)
}

/// Cancel a sweep: running variants stop within a second; finished ones stay readable.
#[utoipa::path(post, path = "/api/sweeps/{id}/cancel",
    params(("id" = String, Path, description = "Sweep id")),
    responses((status = 200, description = "Cancelling (or already final)", body = SweepSummary),
              (status = 401, description = "Token required", body = ErrorBody),
              (status = 404, description = "No such sweep", body = ErrorBody)),
    security((), ("bearer" = [])))]
async fn cancel_sweep(
    State(st): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<SweepSummary>, ApiError> {
    let r = row_or_404(&st, &id).await?;
    let scheduler = st.scheduler.clone();
    let (key, was) = (id.clone(), r.status);
    let status = blocking(move || Ok(scheduler.cancel_sweep(&key, was)?)).await?;
    let p = progress_of(&st, &r);
    Ok(Json(SweepSummary {
        created: rfc3339(r.created_unix_s),
        id: r.id,
        name: r.name,
        status,
        done: p.done,
        total: p.total,
        failed: p.failed,
    }))
}

/// The result document, as `run` writes result.json (409 until done).
#[utoipa::path(get, path = "/api/sweeps/{id}/result",
    params(("id" = String, Path, description = "Sweep id")),
    responses((status = 200, description = "result.json of `run` (the `run` section describes this run)", body = serde_json::Value),
              (status = 401, description = "Token required", body = ErrorBody),
              (status = 404, description = "No such sweep", body = ErrorBody),
              (status = 409, description = "Not done yet", body = ErrorBody)),
    security((), ("bearer" = [])))]
async fn sweep_result(
    State(st): State<AppState>,
    Path(id): Path<String>,
) -> Result<Response, ApiError> {
    let r = row_or_404(&st, &id).await?;
    if r.status != SweepStatus::Done {
        return Err(ApiError::new(
            StatusCode::CONFLICT,
            "$",
            format!(
                "sweep `{id}` is {}; the result exists once it is done",
                r.status.name()
            ),
        ));
    }
    let store = st.store.clone();
    let scheduler = st.scheduler.clone();
    let r = full_row_or_404(&st, &id).await?;
    stream_blocking("application/json", move |w| {
        if let Some(text) = store.result_doc_text(&r.id)? {
            // Stored as served (pretty, newline); a compact one of an older store is
            // pretty-printed on the way.
            if text.starts_with("{\n") {
                w.write_all(text.as_bytes())
            } else {
                let doc: Value = serde_json::from_str(&text)
                    .map_err(|e| ApiError::internal(format!("stored result: {e}")))?;
                serde_json::to_writer_pretty(&mut *w, &doc)
                    .map_err(std::io::Error::other)
                    .and_then(|()| w.write_all(b"\n"))
            }
            .map_err(|e| ApiError::internal(format!("streaming: {e}")))?;
            return Ok(());
        }
        let parsed = scheduler.spec_of(&r)?;
        let ParsedSweep::Runner(spec) = &*parsed else {
            return Err(ApiError::internal(
                "internal: a friction map without its document",
            ));
        };
        let header = r.header.clone().unwrap_or(Value::Null);
        let doc = result_document(
            spec,
            &header["settings"],
            None,
            r.total,
            r.run.clone().unwrap_or(Value::Null),
        );
        let mut sink = super::store::StoreSink::new(store, &r.id, Box::new(|_, _| {}));
        write_result_doc(w, &doc, &mut sink, &mut |_| {})?;
        Ok(())
    })
    .await
}

/// Variant records (result.jsonl lines), readable while the sweep runs; `format=csv`
/// gives one flat row per variant.
#[utoipa::path(get, path = "/api/sweeps/{id}/variants",
    params(("id" = String, Path, description = "Sweep id"),
           ("offset" = Option<u64>, Query, description = "First record (in id order), default 0"),
           ("limit" = Option<u64>, Query, maximum = 10000, description = "Records, default 100, at most 10000"),
           ("format" = Option<FormatParam>, Query, description = "json (default) or csv")),
    responses((status = 200, description = "`{offset, variants: [...]}`, or with `format=csv` one flat row per variant",
               content((serde_json::Value = "application/json"), (String = "text/csv"))),
              (status = 401, description = "Token required", body = ErrorBody),
              (status = 404, description = "No such sweep", body = ErrorBody),
              (status = 422, description = "Bad query", body = ErrorBody)),
    security((), ("bearer" = [])))]
async fn sweep_variants(
    State(st): State<AppState>,
    Path(id): Path<String>,
    uri: Uri,
) -> Result<Response, ApiError> {
    let q = query(&uri)?;
    let num = |name: &str, default: u64| -> Result<u64, ApiError> {
        match q.get(name) {
            None => Ok(default),
            Some(v) => v.parse::<u64>().map_err(|_| {
                ApiError::invalid(
                    format!("?{name}"),
                    format!("`{v}` is not a non-negative integer"),
                )
            }),
        }
    };
    let offset = num("offset", 0)?;
    let limit = num("limit", DEFAULT_PAGE)?;
    if limit > MAX_PAGE {
        return Err(ApiError::invalid("?limit", format!("at most {MAX_PAGE}")));
    }
    let csv_wanted = match q.get("format").map(String::as_str) {
        None | Some("json") => false,
        Some("csv") => true,
        Some(other) => {
            return Err(ApiError::invalid(
                "?format",
                format!("`{other}`: expected json or csv"),
            ))
        }
    };
    let r = row_or_404(&st, &id).await?;
    let store = st.store.clone();
    if csv_wanted {
        return stream_blocking("text/csv; charset=utf-8", move |w| {
            let text = csv::sweep_csv(store.as_ref(), &r.id)?;
            w.write_all(text.as_bytes())
                .map_err(|e| ApiError::internal(format!("streaming: {e}")))
        })
        .await;
    }
    let total = r.total;
    let page = blocking(move || Ok(store.variant_lines(&r.id, offset, limit)?)).await?;
    let body = crate::sweep::job::variant_page(offset, total, &page);
    Ok(([(header::CONTENT_TYPE, "application/json")], body).into_response())
}

/// Names of a sweep's figures.
#[derive(Serialize, utoipa::ToSchema)]
pub struct PlotList {
    /// Figure names (`/plots/{name}` gives the SVG).
    plots: Vec<String>,
}

/// The figures `run` draws for the spec (available once done).
#[utoipa::path(get, path = "/api/sweeps/{id}/plots",
    params(("id" = String, Path, description = "Sweep id")),
    responses((status = 200, description = "Figure names", body = PlotList),
              (status = 401, description = "Token required", body = ErrorBody),
              (status = 404, description = "No such sweep", body = ErrorBody)),
    security((), ("bearer" = [])))]
async fn list_plots(
    State(st): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<PlotList>, ApiError> {
    let r = row_or_404(&st, &id).await?;
    let store = st.store.clone();
    let plots = blocking(move || Ok(store.plot_names(&r.id)?)).await?;
    Ok(Json(PlotList { plots }))
}

/// One figure (SVG). Names come from the stored set only: nothing of the request reaches
/// a file path.
#[utoipa::path(get, path = "/api/sweeps/{id}/plots/{name}",
    params(("id" = String, Path, description = "Sweep id"), ("name" = String, Path, description = "Figure name")),
    responses((status = 200, description = "SVG", content_type = "image/svg+xml", body = String),
              (status = 401, description = "Token required", body = ErrorBody),
              (status = 404, description = "No such sweep or figure", body = ErrorBody)),
    security((), ("bearer" = [])))]
async fn get_plot(
    State(st): State<AppState>,
    Path((id, name)): Path<(String, String)>,
) -> Result<Response, ApiError> {
    let store = st.store.clone();
    let key = id.clone();
    let wanted = name.trim_end_matches(".svg").to_string();
    let svg = blocking(move || Ok(store.plot(&key, &wanted)?)).await?;
    match svg {
        Some(svg) => Ok(([(header::CONTENT_TYPE, "image/svg+xml")], svg).into_response()),
        None => Err(ApiError::not_found(format!(
            "sweep `{id}` has no figure `{name}`"
        ))),
    }
}

fn status_event(status: SweepStatus, p: &ProgressSnapshot) -> Event {
    Event::default()
        .event("status")
        .data(json!({"status": status, "progress": p}).to_string())
}

/// Server-Sent Events: `status` first (and on every change: `{"status", "progress"}`), one
/// `variant` per committed variant (`{"id", "ok", "progress"}`), and the stream ends after a
/// final status (`done`, `failed`, `cancelled`) or a `deleted` event.
#[utoipa::path(get, path = "/api/sweeps/{id}/events",
    params(("id" = String, Path, description = "Sweep id")),
    responses((status = 200, description = "An event stream; the schema describes each event", content_type = "text/event-stream", body = StreamEvent),
              (status = 401, description = "Token required", body = ErrorBody),
              (status = 404, description = "No such sweep", body = ErrorBody)),
    security((), ("bearer" = [])))]
async fn sweep_events(
    State(st): State<AppState>,
    Path(id): Path<String>,
) -> Result<Response, ApiError> {
    // Only known sweeps get an event channel.
    row_or_404(&st, &id).await?;
    // Subscribe before reading the status, so no change falls between the two.
    let job = st.scheduler.job(&id);
    let rx = job.events.subscribe();
    let r = row_or_404(&st, &id).await?;
    let first = status_event(r.status, &progress_of(&st, &r));
    let shutdown = st.shutdown.clone();
    enum Phase {
        Live(
            tokio::sync::broadcast::Receiver<SweepEvent>,
            tokio::sync::watch::Receiver<bool>,
        ),
        End,
    }
    let start = if r.status.is_final() {
        Phase::End
    } else {
        Phase::Live(rx, shutdown)
    };
    let live = futures_util::stream::unfold(start, move |phase| {
        let (st, sweep) = (st.clone(), id.clone());
        async move {
            let Phase::Live(mut rx, mut shutdown) = phase else {
                return None;
            };
            loop {
                tokio::select! {
                    ev = rx.recv() => match ev {
                        Ok(SweepEvent::Variant { id, ok, progress }) => {
                            let e = Event::default().event("variant").data(
                                json!({"id": id, "ok": ok, "progress": progress}).to_string());
                            return Some((Ok::<_, Infallible>(e), Phase::Live(rx, shutdown)));
                        }
                        Ok(SweepEvent::Deleted) => {
                            let e = Event::default().event("deleted").data(
                                json!({"status": "deleted"}).to_string());
                            return Some((Ok(e), Phase::End));
                        }
                        Ok(SweepEvent::Status(s)) => {
                            let p = match row_or_404(&st, &sweep).await {
                                Ok(r) => progress_of(&st, &r),
                                Err(_) => ProgressSnapshot::default(),
                            };
                            let next = if s.is_final() { Phase::End } else { Phase::Live(rx, shutdown) };
                            return Some((Ok(status_event(s, &p)), next));
                        }
                        Err(tokio::sync::broadcast::error::RecvError::Lagged(_)) => continue,
                        Err(tokio::sync::broadcast::error::RecvError::Closed) => return None,
                    },
                    _ = shutdown.changed() => return None,
                    // A safety net: a stream whose sweep ended or vanished without an
                    // event reaching it (a race, another server) ends with what the
                    // store says.
                    _ = tokio::time::sleep(RECHECK) => match row_or_404(&st, &sweep).await {
                        Err(e) if e.status == StatusCode::NOT_FOUND => {
                            let e = Event::default().event("deleted").data(
                                json!({"status": "deleted"}).to_string());
                            return Some((Ok(e), Phase::End));
                        }
                        Ok(r) if r.status.is_final() => {
                            return Some((Ok(status_event(r.status, &progress_of(&st, &r))), Phase::End));
                        }
                        _ => continue,
                    },
                }
            }
        }
    });
    // Fused, like the chunked bodies: nothing may poll `unfold` after its end.
    let stream = futures_util::StreamExt::fuse(futures_util::StreamExt::chain(
        futures_util::stream::once(async move { Ok::<_, Infallible>(first) }),
        live,
    ));
    Ok(Sse::new(stream)
        .keep_alive(KeepAlive::new().interval(KEEP_ALIVE))
        .into_response())
}

/// Film loads of bearing states: body and answer as `eval`'s input and output.
/// Concurrent requests are coalesced into shared backend calls.
#[utoipa::path(post, path = "/api/eval",
    params(("accuracy" = Option<f64>, Query, minimum = 1e-12, description = "Relative accuracy (as `eval --accuracy`; default 1e-6)")),
    request_body(content = super::bodies::EvalBody, description = "A bearing and its states, as an `eval` file (docs/cli.md \"eval\")", content_type = "application/json"),
    responses((status = 200, description = "`eval`'s output: per state `status`, `wx, wy` (N), `mx, my, mz` (N·m), `friction_coefficient`, `sommerfeld`, `h_min` (m), `power_loss` (W), `friction_model` (`paper`: the law of `mz`, `friction_coefficient`, `power_loss`) and `film`: `{friction_torque_nm, power_loss_w, friction_coefficient, friction_variable, side_flow_i_m3_per_s, side_flow_j_m3_per_s, side_flow_m3_per_s, inlet_flow_m3_per_s}` from the shear stress over the film and its flows (docs/outputs.md)", body = serde_json::Value),
              (status = 400, description = "Not JSON", body = ErrorBody),
              (status = 401, description = "Token required", body = ErrorBody),
              (status = 413, description = "Body too large", body = ErrorBody),
              (status = 415, description = "The body is not sent as application/json", body = ErrorBody),
              (status = 422, description = "Invalid input (the JSON path and why), or over the per-request memory budget", body = ErrorBody),
              (status = 503, description = "The evaluation budget is in use (Retry-After)", body = ErrorBody)),
    security((), ("bearer" = [])))]
async fn eval(
    State(st): State<AppState>,
    uri: Uri,
    headers: HeaderMap,
    body: Body,
) -> Result<Response, ApiError> {
    let q = query(&uri)?;
    let accuracy = match q.get("accuracy") {
        None => crate::bearing::Accuracy::default().rtol(),
        Some(a) => a
            .parse::<f64>()
            .ok()
            .filter(|v| crate::bearing::Accuracy::new(*v).is_some())
            .ok_or_else(|| {
                ApiError::invalid(
                    "?accuracy",
                    crate::sweep::options::refusal(format!("`{a}`")),
                )
            })?,
    };
    let (bytes, _body) = read_body(&st, &headers, body).await?;
    let doc = parse_body(&bytes)?;
    let states = doc
        .get("states")
        .and_then(Value::as_array)
        .map_or(0, Vec::len) as u64;
    let _work = st.limits.take_work(
        "states",
        "states",
        states,
        EVAL_BYTES_PER_STATE,
        bytes.len() as u64,
    )?;
    let text = String::from_utf8(bytes.to_vec())
        .map_err(|_| ApiError::bad_request("$", "the body is not UTF-8"))?;
    drop(bytes);
    let out = st.coalescer.eval(text, doc, accuracy).await?;
    let body = serde_json::to_vec(&out).map_err(|e| ApiError::internal(e.to_string()))?;
    drop(out);
    Ok(([(header::CONTENT_TYPE, "application/json")], body).into_response())
}

/// Linearised bearing coefficients: body and answer as `coefficients`' input and JSON
/// output (docs/cli.md "Coefficients and stability"), computed on a blocking thread.
#[utoipa::path(post, path = "/api/coefficients",
    request_body(content = serde_json::Value, description = "`{\"bearing\", \"speed\" (or \"speeds\"), \"load\"}` or `{\"bearing\", \"state\"}` as for `coefficients`", content_type = "application/json"),
    responses((status = 200, description = "`coefficients`' JSON output", body = serde_json::Value),
              (status = 400, description = "Not JSON", body = ErrorBody),
              (status = 401, description = "Token required", body = ErrorBody),
              (status = 413, description = "Body too large", body = ErrorBody),
              (status = 415, description = "The body is not sent as application/json", body = ErrorBody),
              (status = 422, description = "Invalid input (the JSON path and why), or over the per-request memory budget", body = ErrorBody),
              (status = 503, description = "The evaluation budget is in use (Retry-After)", body = ErrorBody)),
    security((), ("bearer" = [])))]
async fn coefficients(
    State(st): State<AppState>,
    headers: HeaderMap,
    body: Body,
) -> Result<Response, ApiError> {
    let (bytes, _body) = read_body(&st, &headers, body).await?;
    let doc = parse_body(&bytes)?;
    let (field, speeds) = match doc.get("speeds").and_then(Value::as_array) {
        Some(a) => ("speeds", a.len() as u64),
        None => ("speed", 1),
    };
    drop(doc);
    let _work = st.limits.take_work(
        field,
        "speeds",
        speeds,
        COEFF_BYTES_PER_SPEED,
        bytes.len() as u64,
    )?;
    let text = String::from_utf8(bytes.to_vec())
        .map_err(|_| ApiError::bad_request("$", "the body is not UTF-8"))?;
    drop(bytes);
    let out = tokio::task::spawn_blocking(move || crate::app::coefficients_json(&text))
        .await
        .map_err(|e| ApiError::internal(format!("coefficients task: {e}")))??;
    Ok(Json(out).into_response())
}
