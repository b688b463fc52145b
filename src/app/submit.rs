//! `bearing-sweep submit`: posts a sweep spec to a running service (blocking HTTP via
//! ureq), prints the id; with `--wait`, a progress bar fed by polling the sweep's status,
//! then where the result is.

use std::time::Duration;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde_json::Value;

use super::AppError;
use crate::backend::BackendKind;
use crate::sweep::options::backend_name;

/// Environment variable holding the service's token when `--token` is not given (read by
/// `serve` and `submit`).
pub const TOKEN_ENV: &str = "BEARING_SWEEP_TOKEN";

/// Interval between status polls with `--wait`.
const POLL: Duration = Duration::from_millis(500);
/// Longest time one HTTP exchange may take.
const HTTP_TIMEOUT: Duration = Duration::from_secs(60);
/// Largest answer read (a status or error document), bytes.
const MAX_ANSWER: u64 = 16 << 20;

/// Options of `submit`.
#[derive(Clone, Debug)]
pub struct SubmitOptions {
    /// Service URL, e.g. `http://127.0.0.1:8080`.
    pub server: String,
    /// Bearer token (else `BEARING_SWEEP_TOKEN`).
    pub token: Option<String>,
    /// Wait for the end with a progress bar.
    pub wait: bool,
    /// Film-load backend asked of the service (`--backend`).
    pub backend: BackendKind,
    /// Film accuracy asked of the service, relative (`--accuracy`; the service checks it).
    pub accuracy: f64,
    /// Every model reduction off (`--full-model`).
    pub full_model: bool,
}

impl SubmitOptions {
    /// The run options as the service's query string: `backend=cpu&accuracy=1e-6`, and
    /// `&full_model=true` when set (the parameters of `POST /api/sweeps`).
    pub fn query(&self) -> String {
        let mut query = format!(
            "backend={}&accuracy={:e}",
            backend_name(self.backend),
            self.accuracy
        );
        if self.full_model {
            query.push_str("&full_model=true");
        }
        query
    }
}

fn agent() -> ureq::Agent {
    ureq::Agent::config_builder()
        .http_status_as_error(false)
        .timeout_global(Some(HTTP_TIMEOUT))
        .build()
        .into()
}

/// An answer's JSON (or the service's error as an `AppError` naming the path).
fn answer(
    resp: Result<ureq::http::Response<ureq::Body>, ureq::Error>,
    server: &str,
) -> Result<Value, AppError> {
    let mut resp = resp.map_err(|e| AppError::input("--server", format!("{server}: {e}")))?;
    let status = resp.status();
    let text = resp
        .body_mut()
        .with_config()
        .limit(MAX_ANSWER)
        .read_to_string()
        .map_err(|e| AppError::input("--server", format!("{server}: reading the answer: {e}")))?;
    let v: Value = serde_json::from_str(&text).unwrap_or(Value::String(text));
    if status.is_success() {
        return Ok(v);
    }
    let path = v["error"]["path"].as_str().unwrap_or("$").to_string();
    let message = v["error"]["message"]
        .as_str()
        .map(str::to_string)
        .unwrap_or_else(|| format!("HTTP {status}: {v}"));
    Err(AppError::input(path, message))
}

/// Submits `text` (a sweep spec) and returns the lines to print on stdout.
pub fn submit_command(text: &str, opts: &SubmitOptions) -> Result<Vec<String>, AppError> {
    let base = opts.server.trim_end_matches('/');
    let token = opts
        .token
        .clone()
        .or_else(|| std::env::var(TOKEN_ENV).ok())
        .filter(|t| !t.is_empty());
    let agent = agent();
    let with_auth = |r: ureq::RequestBuilder<ureq::typestate::WithBody>| match &token {
        Some(t) => r.header("Authorization", format!("Bearer {t}")),
        None => r,
    };
    let url = format!("{base}/api/sweeps?{}", opts.query());
    let created = answer(
        with_auth(agent.post(&url))
            .content_type("application/json")
            .send(text.as_bytes()),
        base,
    )?;
    let id = created["id"].as_str().unwrap_or_default().to_string();
    let mut lines = vec![id.clone()];
    if !opts.wait {
        return Ok(lines);
    }
    let total = created["variants"].as_u64().unwrap_or(0);
    let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
    bar.set_style(
        ProgressStyle::with_template(
            "[{bar:30}] {pos}/{len} variants  {per_sec}  {eta} left  {msg}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("#>-"),
    );
    let status = loop {
        let mut get = agent.get(format!("{base}/api/sweeps/{id}"));
        if let Some(t) = &token {
            get = get.header("Authorization", format!("Bearer {t}"));
        }
        let info = answer(get.call(), base)?;
        bar.set_position(info["progress"]["done"].as_u64().unwrap_or(0));
        let status = info["status"].as_str().unwrap_or("").to_string();
        bar.set_message(status.clone());
        if matches!(status.as_str(), "done" | "failed" | "cancelled") {
            bar.finish();
            if status == "failed" {
                lines.push(format!(
                    "failed: {}",
                    info["message"].as_str().unwrap_or("(no message)")
                ));
            }
            break status;
        }
        std::thread::sleep(POLL);
    };
    if status == "done" {
        lines.push(format!("result: {base}/api/sweeps/{id}/result"));
        lines.push(format!(
            "variants (CSV): {base}/api/sweeps/{id}/variants?format=csv"
        ));
        Ok(lines)
    } else {
        Err(AppError::input("$", format!("sweep {id} ended {status}")))
    }
}
