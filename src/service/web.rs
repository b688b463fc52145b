//! The web page at `/` (HTML, JS and CSS compiled into the binary: no build step, nothing
//! fetched from elsewhere), the bundled example specs of `sweeps/` (`GET /api/examples`,
//! `GET /api/examples/{name}`), which the page offers in its editor, and the dry-run check
//! of a spec behind its "Check spec" button (`POST /api/validate`).

use std::collections::HashMap;

use axum::body::Body;
use axum::extract::{Path, State};
use axum::http::{header, HeaderValue, StatusCode, Uri};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use serde_json::{json, Value};

use super::{options_from_query, ApiError, AppState, ErrorBody, ParsedSweep};

const INDEX_HTML: &str = include_str!("web/index.html");
const APP_JS: &str = include_str!("web/app.js");
const STYLE_CSS: &str = include_str!("web/style.css");

/// The page's own files only: scripts, styles and images from this server, images also
/// from `blob:` URLs (the server's SVG plots are fetched with the token, then shown).
const CSP: &str = "default-src 'self'; img-src 'self' blob: data:; style-src 'self'; \
                   script-src 'self'; connect-src 'self'; frame-ancestors 'none'";

/// The example files of `sweeps/`, compiled in: `(name, file text)`, name = file stem.
pub const EXAMPLES: &[(&str, &str)] = &[
    (
        "clearance-viscosity",
        include_str!("../../sweeps/clearance-viscosity.json"),
    ),
    (
        "synthetic-whirl",
        include_str!("../../sweeps/synthetic-whirl.json"),
    ),
    ("stress", include_str!("../../sweeps/stress.json")),
    (
        "friction-map",
        include_str!("../../sweeps/friction-map.json"),
    ),
    ("eval-states", include_str!("../../sweeps/eval-states.json")),
    (
        "paper-example",
        include_str!("../../sweeps/paper-example.json"),
    ),
    ("oil-whirl", include_str!("../../sweeps/oil-whirl.json")),
    (
        "stability-map",
        include_str!("../../sweeps/stability-map.json"),
    ),
    (
        "stability-map-timed",
        include_str!("../../sweeps/stability-map-timed.json"),
    ),
    ("finite-film", include_str!("../../sweeps/finite-film.json")),
    (
        "two-axial-groove",
        include_str!("../../sweeps/two-axial-groove.json"),
    ),
    (
        "clearance-oil-grade",
        include_str!("../../sweeps/clearance-oil-grade.json"),
    ),
    (
        "friction-map-thermal",
        include_str!("../../sweeps/friction-map-thermal.json"),
    ),
    (
        "thermal-run-up",
        include_str!("../../sweeps/thermal-run-up.json"),
    ),
];

/// What an example file is for: `"sweep"` (a spec `POST /api/sweeps` takes: it has `base`
/// or `kind`, as `run` decides), `"eval"` (`{"bearing", "states"}`, the `POST /api/eval`
/// body) or `"scene"` (a scene file for `run`, not a sweep).
pub fn example_role(doc: &Value) -> &'static str {
    if doc.get("base").is_some() || doc.get("kind").is_some() {
        "sweep"
    } else if doc.get("states").is_some() && doc.get("bearing").is_some() {
        "eval"
    } else {
        "scene"
    }
}

/// The page's routes (`/`, `/index.html`, `/app.js`, `/style.css`): merge into the
/// service's root router; they are open, like `/healthz` (the page holds no data).
pub fn pages<S: Clone + Send + Sync + 'static>() -> Router<S> {
    Router::new()
        .route(
            "/",
            get(|| async { asset(INDEX_HTML, "text/html; charset=utf-8") }),
        )
        .route(
            "/index.html",
            get(|| async { asset(INDEX_HTML, "text/html; charset=utf-8") }),
        )
        .route(
            "/app.js",
            get(|| async { asset(APP_JS, "text/javascript; charset=utf-8") }),
        )
        .route(
            "/style.css",
            get(|| async { asset(STYLE_CSS, "text/css; charset=utf-8") }),
        )
}

/// The page's routes relative to `/api` (`/examples`, `/examples/{name}`, `/validate`):
/// merge into the service's `/api` router, whose token check then guards them like every
/// `/api` route.
pub fn api() -> Router<AppState> {
    Router::new()
        .route("/examples", get(list_examples))
        .route("/examples/{name}", get(get_example))
        .route("/validate", post(validate))
        .route(
            "/sweeps/{id}/variants/{variant}/series",
            get(variant_series),
        )
}

/// The OpenAPI description of the page's `/api` routes, merged into the service's
/// document (`ApiDoc`) by its `/api/openapi.json` handler.
#[derive(utoipa::OpenApi)]
#[openapi(
    paths(list_examples, get_example, validate, variant_series),
    components(schemas(ErrorBody))
)]
pub struct WebApiDoc;

/// `POST /api/validate`: the checks of `POST /api/sweeps` (spec, every variant, run
/// options of the query, the variant limit) without storing or running anything; the page's
/// "Check spec". `200 {"valid": true, "kind", "name", "variants"}` or the same error as a
/// submission would get.
#[utoipa::path(post, path = "/api/validate",
    params(
        ("backend" = Option<String>, Query, description = "As for POST /api/sweeps"),
        ("accuracy" = Option<f64>, Query, description = "As for POST /api/sweeps"),
        ("full_model" = Option<bool>, Query, description = "As for POST /api/sweeps"),
    ),
    request_body(content = crate::sweep::spec::SpecDocument, description = "A sweep spec, as for POST /api/sweeps", content_type = "application/json"),
    responses(
        (status = 200, description = "Valid: `{valid, kind, name, variants}`; nothing stored", body = serde_json::Value),
        (status = 400, description = "Not JSON", body = ErrorBody),
        (status = 401, description = "Token required", body = ErrorBody),
        (status = 413, description = "Body too large", body = ErrorBody),
        (status = 422, description = "Invalid spec or option: the JSON path and why", body = ErrorBody),
    ),
    security((), ("bearer" = [])))]
async fn validate(
    State(st): State<AppState>,
    uri: Uri,
    body: Body,
) -> Result<Json<Value>, ApiError> {
    let q = axum::extract::Query::<HashMap<String, String>>::try_from_uri(&uri)
        .map_err(|e| ApiError::bad_request("?", format!("malformed query: {e}")))?
        .0;
    options_from_query(
        q.get("backend").map(String::as_str),
        q.get("accuracy").map(String::as_str),
        q.get("full_model").map(String::as_str),
    )?;
    let limit = st.config.max_body_bytes;
    let bytes = axum::body::to_bytes(body, limit).await.map_err(|_| {
        ApiError::new(
            StatusCode::PAYLOAD_TOO_LARGE,
            "$",
            format!(
                "the body is larger than {limit} bytes (raise it with `serve --max-body-bytes`)"
            ),
        )
    })?;
    let doc: Value = serde_json::from_slice(&bytes)
        .map_err(|e| ApiError::bad_request("$", format!("not valid JSON: {e}")))?;
    let max_variants = st.config.max_variants;
    let max_memory = st.config.max_memory;
    // Expanding and checking every variant is CPU work: off the async threads.
    tokio::task::spawn_blocking(move || {
        let (parsed, total) = super::sweeps::check_submission(&doc, max_variants, max_memory)?;
        let kind = parsed.kind().name();
        Ok(Json(
            json!({"valid": true, "kind": kind, "name": parsed.name(), "variants": total}),
        ))
    })
    .await
    .map_err(|e| ApiError::internal(format!("internal: {e}")))?
}

/// Samples a full-resolution series may have at most (a 20 k-point orbit is ~1 MB of JSON).
pub const MAX_SERIES_POINTS: usize = 20_000;
/// Samples a full-resolution series has by default.
const DEFAULT_SERIES_POINTS: usize = 4_000;

/// `GET /api/sweeps/{id}/variants/{variant}/series?points=N`: one variant of a rotor sweep
/// simulated again with the sweep's run options and every series group kept, decimated
/// to at most `N` samples (default 4000, at most [`MAX_SERIES_POINTS`]) instead of the
/// spec's `reductions.points`; the page's full-resolution orbit. The simulation is
/// deterministic, so the series is the one the stored variant's reductions came from.
/// `200 {"variant", "points", "status", "message", "series"}`.
#[utoipa::path(get, path = "/api/sweeps/{id}/variants/{variant}/series",
    params(
        ("id" = String, Path, description = "Sweep id"),
        ("variant" = u64, Path, description = "Variant id"),
        ("points" = Option<usize>, Query, description = "Samples at most (default 4000, at most 20000)"),
    ),
    responses(
        (status = 200, description = "`{variant, points, status, message, series}`: the kept series (t, x_g, y_g, spin, bearings[k].xi ...) at full resolution", body = serde_json::Value),
        (status = 400, description = "Malformed query", body = ErrorBody),
        (status = 401, description = "Token required", body = ErrorBody),
        (status = 404, description = "No such sweep or variant", body = ErrorBody),
        (status = 422, description = "Not a rotor sweep (no time series), or its options no longer parse", body = ErrorBody),
    ),
    security((), ("bearer" = [])))]
async fn variant_series(
    State(st): State<AppState>,
    Path((id, variant)): Path<(String, String)>,
    uri: Uri,
) -> Result<Json<Value>, ApiError> {
    let q = axum::extract::Query::<HashMap<String, String>>::try_from_uri(&uri)
        .map_err(|e| ApiError::bad_request("?", format!("malformed query: {e}")))?
        .0;
    let points = match q.get("points") {
        None => DEFAULT_SERIES_POINTS,
        Some(p) => match p.parse::<usize>() {
            Ok(n) if (2..=MAX_SERIES_POINTS).contains(&n) => n,
            _ => {
                return Err(ApiError::bad_request(
                    "points",
                    format!("must be a whole number from 2 to {MAX_SERIES_POINTS}, not {p:?}"),
                ))
            }
        },
    };
    let variant: u64 = variant
        .parse()
        .map_err(|_| ApiError::bad_request("variant", format!("not a variant id: {variant:?}")))?;
    let store = st.store.clone();
    let scheduler = st.scheduler.clone();
    tokio::task::spawn_blocking(move || {
        let row = store
            .sweep(&id)
            .map_err(|e| ApiError::internal(format!("store: {e}")))?
            .ok_or_else(|| ApiError::not_found(format!("no sweep {id:?}")))?;
        let mut spec = match &*scheduler.spec_of(&row)? {
            ParsedSweep::Runner(spec) if spec.kind == crate::sweep::SweepKind::Rotor => {
                spec.clone()
            }
            _ => return Err(ApiError::invalid(
                "kind",
                "only rotor sweeps have time series (stability sweeps and friction maps have none)",
            )),
        };
        let count = crate::sweep::Expansion::new(&spec).count();
        if variant >= count {
            return Err(ApiError::not_found(format!(
                "sweep {id:?} has variants 0 to {}, not {variant}",
                count.saturating_sub(1)
            )));
        }
        let choice = crate::sweep::SweepOptions {
            max_memory: st.config.max_memory,
            ..super::sweeps::parse_options(&row.options)?
        };
        use crate::sweep::reduce::SeriesGroup;
        spec.reductions.keep = [
            SeriesGroup::Orbit,
            SeriesGroup::Film,
            SeriesGroup::Friction,
            SeriesGroup::Forces,
            SeriesGroup::Spin,
        ]
        .into_iter()
        .collect();
        spec.reductions.points = points;
        let v = crate::sweep::Expansion::new(&spec).variant(&spec, variant);
        let mut prepared = crate::sweep::simulator::prepare_simulator(&spec, &choice, &mut |_| {})
            .map_err(|e| ApiError::invalid("$", e.to_string()))?;
        let mut outcome = None;
        prepared.sim.run_batch(
            &[crate::sweep::runner::VariantJob {
                id: variant,
                scene: v.scene,
            }],
            &mut |_, o| outcome = Some(o),
        );
        let o = outcome.ok_or_else(|| ApiError::internal("the simulator reported nothing"))?;
        let series = o.kept_series(&spec.reductions);
        Ok(Json(json!({
            "variant": variant,
            "points": points,
            "status": o.status,
            "message": o.message,
            "series": series,
        })))
    })
    .await
    .map_err(|e| ApiError::internal(format!("internal: {e}")))?
}

fn asset(body: &'static str, content_type: &'static str) -> Response {
    (
        [
            (header::CONTENT_TYPE, HeaderValue::from_static(content_type)),
            // Revalidate every time: a new binary serves a new page at once.
            (header::CACHE_CONTROL, HeaderValue::from_static("no-cache")),
            (
                header::CONTENT_SECURITY_POLICY,
                HeaderValue::from_static(CSP),
            ),
            (
                header::X_CONTENT_TYPE_OPTIONS,
                HeaderValue::from_static("nosniff"),
            ),
        ],
        body,
    )
        .into_response()
}

/// `[{"name", "role", "title", "description"}]` in a fixed order (sweeps first).
#[utoipa::path(get, path = "/api/examples",
    responses((status = 200, description = "The bundled examples of sweeps/: name, role (sweep, eval, scene), title, description", body = serde_json::Value),
              (status = 401, description = "Token required", body = ErrorBody)),
    security((), ("bearer" = [])))]
async fn list_examples() -> Json<Value> {
    Json(Value::Array(example_list()))
}

/// The list `GET /api/examples` answers.
pub fn example_list() -> Vec<Value> {
    let mut out: Vec<Value> = EXAMPLES
        .iter()
        .map(|(name, text)| {
            // The files are the repository's own examples, parsed by the tests; a file
            // that did not parse would still be listed, as role "scene".
            let doc: Value = serde_json::from_str(text).unwrap_or(Value::Null);
            json!({
                "name": name,
                "role": example_role(&doc),
                "title": doc.get("name").and_then(Value::as_str),
                "description": doc.get("description").and_then(Value::as_str),
            })
        })
        .collect();
    out.sort_by_key(|e| e["role"] != "sweep");
    out
}

/// The example file as it is in `sweeps/` (the editor shows its formatting).
#[utoipa::path(get, path = "/api/examples/{name}",
    params(("name" = String, Path, description = "Example name (file stem in sweeps/)")),
    responses((status = 200, description = "The file as it is", body = serde_json::Value),
              (status = 401, description = "Token required", body = ErrorBody),
              (status = 404, description = "No such example", body = ErrorBody)),
    security((), ("bearer" = [])))]
async fn get_example(Path(name): Path<String>) -> Response {
    match EXAMPLES.iter().find(|(n, _)| *n == name) {
        Some((_, text)) => (
            [(
                header::CONTENT_TYPE,
                HeaderValue::from_static("application/json"),
            )],
            *text,
        )
            .into_response(),
        None => {
            let names: Vec<&str> = EXAMPLES.iter().map(|(n, _)| *n).collect();
            (
                StatusCode::NOT_FOUND,
                Json(json!({"error": {
                    "path": "name",
                    "message": format!("no example named {name:?}; the examples are {}", names.join(", ")),
                }})),
            )
                .into_response()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_example_parses_and_sweeps_come_first() {
        let list = example_list();
        assert_eq!(list.len(), EXAMPLES.len());
        for (name, text) in EXAMPLES {
            let doc: Value = serde_json::from_str(text)
                .unwrap_or_else(|e| panic!("sweeps/{name}.json does not parse: {e}"));
            assert!(doc.is_object(), "sweeps/{name}.json is not an object");
        }
        let roles: Vec<&str> = list.iter().map(|e| e["role"].as_str().unwrap()).collect();
        let first_other = roles
            .iter()
            .position(|r| *r != "sweep")
            .unwrap_or(roles.len());
        assert!(
            roles[first_other..].iter().all(|r| *r != "sweep"),
            "sweeps not first: {roles:?}"
        );
        let role = |n: &str| {
            list.iter().find(|e| e["name"] == n).unwrap()["role"]
                .as_str()
                .unwrap()
                .to_string()
        };
        assert_eq!(role("clearance-viscosity"), "sweep");
        assert_eq!(role("friction-map"), "sweep");
        assert_eq!(role("eval-states"), "eval");
        assert_eq!(role("paper-example"), "scene");
    }

    #[test]
    fn every_sweep_file_is_listed() {
        // A new file in sweeps/ must be added to EXAMPLES (or the page would not offer it).
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("sweeps");
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().and_then(|e| e.to_str()) != Some("json") {
                continue;
            }
            let stem = path.file_stem().unwrap().to_str().unwrap().to_string();
            let listed = EXAMPLES.iter().find(|(n, _)| *n == stem);
            let (_, text) =
                listed.unwrap_or_else(|| panic!("sweeps/{stem}.json is not in web::EXAMPLES"));
            assert_eq!(
                *text,
                std::fs::read_to_string(&path).unwrap(),
                "sweeps/{stem}.json"
            );
        }
    }
}
