//! `bearing_sweep._core`: the Rust core of bearing-sweep linked into Python (PyO3). The
//! Python package `bearing_sweep` wraps these functions with numpy and pandas; here the
//! data crosses as JSON text (documents) or packed little-endian `f64` bytes (states and
//! loads), and every error becomes `bearing_sweep.InputError(path, reason)` (or
//! `OSError` / `RuntimeError` for files and backends). The GIL is released while the
//! core computes.

use std::path::PathBuf;

use pyo3::exceptions::{PyOSError, PyRuntimeError};
use pyo3::prelude::*;
use pyo3::types::PyBytes;
use serde_json::Value;

use bearing_sweep::app::{
    coefficients_json_with, merge_command, ross_toml, run_command, stability_scene_file, AppError,
    CoefficientOptions, RossVersion, StabilityOptions, SweepRunOptions, EVAL_CHUNK,
};
use bearing_sweep::backend::{choose_backend, BackendKind, LoadEvaluator, LoadRequest};
use bearing_sweep::bearing::{Accuracy, BearingParams, BearingState, FilmModel};
use bearing_sweep::sweep::runner::{BatchSize, RunnerOptions, Shard};
use bearing_sweep::sweep::{RequestedAccuracy, SweepOptions};

/// Columns of a state row, in order (as `eval` reads a state object).
const STATE_FIELDS: [&str; 9] = ["xi", "yi", "xj", "yj", "vxi", "vyi", "vxj", "vyj", "omega"];

/// Columns of a load row, in order (as `eval` writes a load object); a missing optional
/// (`friction_coefficient`, `sommerfeld` where undefined, or a state without loads) is NaN.
const LOAD_FIELDS: [&str; 9] = [
    "wx",
    "wy",
    "mx",
    "my",
    "mz",
    "friction_coefficient",
    "sommerfeld",
    "h_min",
    "power_loss",
];

/// An error of the core as a Python exception: input errors carry their JSON path.
fn py_error(py: Python<'_>, e: AppError) -> PyErr {
    let (path, reason) = match &e {
        AppError::Input { path, reason } => (path.clone(), reason.clone()),
        AppError::Sweep(bearing_sweep::sweep::SweepError::Spec { path, reason }) => {
            (path.clone(), reason.clone())
        }
        AppError::Sweep(bearing_sweep::sweep::SweepError::Variant {
            id,
            assignment,
            path,
            reason,
        }) => (
            path.clone(),
            format!("variant {id} ({assignment}): {reason}"),
        ),
        AppError::Io { .. } | AppError::Sweep(bearing_sweep::sweep::SweepError::Io { .. }) => {
            return PyOSError::new_err(e.to_string())
        }
        _ => return PyRuntimeError::new_err(e.to_string()),
    };
    input_error(py, &path, &reason)
}

/// `bearing_sweep.InputError(path, reason)`.
fn input_error(py: Python<'_>, path: &str, reason: &str) -> PyErr {
    let made = py
        .import("bearing_sweep._errors")
        .and_then(|m| m.getattr("InputError"))
        .and_then(|cls| cls.call1((path, reason)));
    match made {
        Ok(obj) => PyErr::from_value(obj),
        Err(e) => e,
    }
}

fn backend_kind(py: Python<'_>, backend: &str) -> PyResult<BackendKind> {
    backend
        .parse()
        .map_err(|reason: String| input_error(py, "backend", &reason))
}

fn accuracy_of(py: Python<'_>, accuracy: f64) -> PyResult<Accuracy> {
    Accuracy::new(accuracy).ok_or_else(|| {
        input_error(
            py,
            "accuracy",
            &format!("{accuracy} is not a positive number >= 1e-12"),
        )
    })
}

/// Film loads of `n` states of one bearing, as `eval` computes them (same evaluator, same
/// chunks of `EVAL_CHUNK` states, so the numbers are bit for bit the CLI's).
///
/// `bearing`: the bearing object as JSON text; `states`: `n * 9` little-endian f64
/// (`xi, yi, xj, yj, vxi, vyi, vxj, vyj, omega` per state, SI). Returns
/// `(header_json, loads_bytes, faults, finite)`: the header as `eval` writes it (backend,
/// accuracy, ...) with the notices, `n * 9` f64 in `LOAD_FIELDS` order, a list of
/// `(index, status, message)` for states without loads, and for a film model other than
/// `short` a pair `(film_model_codes: bytes (0 short, 1 finite), error_estimates: bytes of
/// n f64, NaN where none)`, else `None`.
#[pyfunction]
#[pyo3(signature = (bearing, states, n, backend = "auto", accuracy = 1e-6))]
#[allow(clippy::type_complexity)]
fn eval_states<'py>(
    py: Python<'py>,
    bearing: &str,
    states: &[u8],
    n: usize,
    backend: &str,
    accuracy: f64,
) -> PyResult<(
    String,
    Bound<'py, PyBytes>,
    Vec<(usize, String, String)>,
    Option<(Bound<'py, PyBytes>, Bound<'py, PyBytes>)>,
)> {
    let kind = backend_kind(py, backend)?;
    let accuracy = accuracy_of(py, accuracy)?;
    if states.len() != n * 9 * 8 {
        return Err(input_error(
            py,
            "states",
            &format!("{} bytes for {n} states of 9 f64", states.len()),
        ));
    }
    let doc: Value = serde_json::from_str(bearing)
        .map_err(|e| input_error(py, "bearing", &format!("not valid JSON: {e}")))?;
    let params: BearingParams =
        bearing_sweep::app::from_value(&doc, "bearing").map_err(|e| py_error(py, e))?;
    params.validate().map_err(|e| {
        input_error(
            py,
            &format!("bearing.{}", e.field),
            &format!("{} (got {})", e.reason, bearing_sweep::json::num(e.value)),
        )
    })?;
    let mut reqs = Vec::with_capacity(n);
    for k in 0..n {
        let mut v = [0.0f64; 9];
        for (j, x) in v.iter_mut().enumerate() {
            let at = (k * 9 + j) * 8;
            let mut b = [0u8; 8];
            b.copy_from_slice(&states[at..at + 8]);
            *x = f64::from_le_bytes(b);
            if !x.is_finite() {
                return Err(input_error(
                    py,
                    &format!("states[{k}].{}", STATE_FIELDS[j]),
                    &format!("must be a finite number (got {x})"),
                ));
            }
        }
        let state = BearingState {
            xi: v[0],
            yi: v[1],
            xj: v[2],
            yj: v[3],
            vxi: v[4],
            vyi: v[5],
            vxj: v[6],
            vyj: v[7],
            omega: v[8],
        };
        reqs.push(LoadRequest { bearing: 0, state });
    }
    let finite_model = params.model != FilmModel::Short;
    let computed = py.detach(move || -> Result<_, AppError> {
        // As `eval`: the backend is chosen knowing the first chunk's size.
        let (backend, notices) = choose_backend(kind, accuracy, Some(n.min(EVAL_CHUNK)))?;
        let mut ev = LoadEvaluator::new(backend);
        let header = serde_json::json!({
            "rule": "closed-form loaded arcs, graded Gauss-Legendre panels in z",
            "accuracy": accuracy.rtol(),
            "nodes_per_panel": accuracy.settings().nodes,
            "backend": ev.info(),
            "backend_choice": ev.choice(),
            "clearance_convention": params.clearance_convention.name(),
            "film_model": params.model.name(),
            "units": "SI (N, N·m, m, W)",
        });
        let mut loads = vec![f64::NAN; n * 9];
        let mut faults = Vec::new();
        let mut models = if finite_model {
            vec![0u8; n]
        } else {
            Vec::new()
        };
        let mut estimates = if finite_model {
            vec![f64::NAN; n]
        } else {
            Vec::new()
        };
        let mut results = Vec::new();
        for (c, chunk) in reqs.chunks(EVAL_CHUNK).enumerate() {
            ev.evaluate(&[params], chunk, &mut results);
            for (i, (r, req)) in results.iter().zip(chunk).enumerate() {
                let k = c * EVAL_CHUNK + i;
                match r {
                    Ok(l) => {
                        let row = [
                            l.wx,
                            l.wy,
                            l.mx,
                            l.my,
                            l.mz,
                            l.friction_coefficient.unwrap_or(f64::NAN),
                            l.sommerfeld.unwrap_or(f64::NAN),
                            l.h_min,
                            l.power_loss,
                        ];
                        loads[k * 9..k * 9 + 9].copy_from_slice(&row);
                        if finite_model {
                            let used = bearing_sweep::backend::effective_model(&params, &req.state);
                            if used == FilmModel::Finite {
                                models[k] = 1;
                                estimates[k] = bearing_sweep::bearing::finite::richardson_estimate(
                                    &params,
                                    &req.state,
                                    &params.finite,
                                    l,
                                )
                                .unwrap_or(f64::NAN);
                            }
                        }
                    }
                    Err(fault) => {
                        faults.push((k, fault.code().to_string(), format!("states[{k}]: {fault}")))
                    }
                }
            }
        }
        let mut all_notices = notices;
        all_notices.extend(ev.take_notices());
        let mut header = header;
        header["notices"] = serde_json::json!(all_notices);
        Ok((header.to_string(), loads, faults, models, estimates))
    });
    let (header, loads, faults, models, estimates) = computed.map_err(|e| py_error(py, e))?;
    let bytes: Vec<u8> = loads.iter().flat_map(|x| x.to_le_bytes()).collect();
    let finite = finite_model.then(|| {
        let est: Vec<u8> = estimates.iter().flat_map(|x| x.to_le_bytes()).collect();
        (PyBytes::new(py, &models), PyBytes::new(py, &est))
    });
    Ok((header, PyBytes::new(py, &bytes), faults, finite))
}

/// `coefficients` on an input document (JSON text): `(output_json, notices)`.
#[pyfunction]
#[pyo3(signature = (input, backend = "auto", accuracy = 1e-12))]
fn coefficients(
    py: Python<'_>,
    input: &str,
    backend: &str,
    accuracy: f64,
) -> PyResult<(String, Vec<String>)> {
    let kind = backend_kind(py, backend)?;
    let input = input.to_string();
    let r = py.detach(move || {
        coefficients_json_with(
            &input,
            CoefficientOptions {
                backend: kind,
                accuracy,
            },
        )
    });
    let (out, notices) = r.map_err(|e| py_error(py, e))?;
    Ok((out.to_string(), notices))
}

/// A `coefficients` output (JSON text) as the ROSS TOML file's text (`version` 2 or 3).
#[pyfunction]
fn ross_toml_text(py: Python<'_>, output: &str, version: u32) -> PyResult<String> {
    let out: Value = serde_json::from_str(output)
        .map_err(|e| input_error(py, "$", &format!("not valid JSON: {e}")))?;
    let v = match version {
        2 => RossVersion::V2,
        3 => RossVersion::V3,
        other => {
            return Err(input_error(
                py,
                "version",
                &format!("{other}: expected 2 or 3 (the ROSS major version)"),
            ))
        }
    };
    Ok(ross_toml(&out, v))
}

/// `run` of a sweep spec (file name `spec_file` for the output folder's name and relative
/// paths, contents `text`) into `out`: `(lines, notices)`; the result is
/// `out/<stem>/result.json` (`.../shard-K-of-N/` for a shard).
#[pyfunction]
#[pyo3(signature = (spec_file, text, out, shard = None, backend = "auto", accuracy = 1e-6, progress = false, full_model = false))]
#[allow(clippy::too_many_arguments)]
fn run_sweep(
    py: Python<'_>,
    spec_file: &str,
    text: &str,
    out: PathBuf,
    shard: Option<(u32, u32)>,
    backend: &str,
    accuracy: f64,
    progress: bool,
    full_model: bool,
) -> PyResult<(Vec<String>, Vec<String>)> {
    let kind = backend_kind(py, backend)?;
    let shard = match shard {
        None => None,
        Some((index, count)) => {
            let s: Shard = format!("{index}/{count}")
                .parse()
                .map_err(|reason: String| input_error(py, "shard", &reason))?;
            Some(s)
        }
    };
    let accuracy = RequestedAccuracy::new(accuracy)
        .map_err(|reason| py_error(py, AppError::input("--accuracy", reason)))?;
    let opts = SweepRunOptions {
        out,
        quiet: !progress,
        runner: RunnerOptions {
            shard,
            batch: BatchSize::Auto,
        },
        sweep: SweepOptions {
            backend: kind,
            accuracy,
            full_model,
            // The CLI's default budget (`run --max-memory`, 2 GiB).
            max_memory: Default::default(),
        },
    };
    let (spec_file, text) = (spec_file.to_string(), text.to_string());
    let r = py.detach(move || {
        let mut notices = Vec::new();
        let lines = run_command(&spec_file, &text, &opts, &mut |n| notices.push(n));
        lines.map(|l| (l, notices))
    });
    r.map_err(|e| py_error(py, e))
}

/// `merge OUT SHARD...`: the merged result written to `out`; the lines `merge` prints.
#[pyfunction]
fn merge(py: Python<'_>, out: &str, shards: Vec<String>) -> PyResult<Vec<String>> {
    let out = out.to_string();
    py.detach(move || merge_command(&out, &shards))
        .map_err(|e| py_error(py, e))
}

/// `stability` of a scene file (name `path`, contents `text`): `(output_json, files,
/// notices)`; files are written under `out/<stem>/` when `out` is given.
#[pyfunction]
#[pyo3(signature = (path, text, speeds = Vec::new(), out = None, backend = "auto", accuracy = 1e-12))]
fn stability(
    py: Python<'_>,
    path: &str,
    text: &str,
    speeds: Vec<f64>,
    out: Option<PathBuf>,
    backend: &str,
    accuracy: f64,
) -> PyResult<(String, Vec<String>, Vec<String>)> {
    let kind = backend_kind(py, backend)?;
    let opts = StabilityOptions {
        backend: kind,
        accuracy,
        speeds,
        out,
    };
    let (path, text) = (path.to_string(), text.to_string());
    let r = py.detach(move || stability_scene_file(&path, &text, &opts));
    let (doc, files, notices) = r.map_err(|e| py_error(py, e))?;
    Ok((
        doc.to_string(),
        files.iter().map(|f| f.display().to_string()).collect(),
        notices,
    ))
}

/// The state and load columns, in the packed order.
#[pyfunction]
fn columns() -> (Vec<&'static str>, Vec<&'static str>) {
    (STATE_FIELDS.to_vec(), LOAD_FIELDS.to_vec())
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(eval_states, m)?)?;
    m.add_function(wrap_pyfunction!(coefficients, m)?)?;
    m.add_function(wrap_pyfunction!(ross_toml_text, m)?)?;
    m.add_function(wrap_pyfunction!(run_sweep, m)?)?;
    m.add_function(wrap_pyfunction!(merge, m)?)?;
    m.add_function(wrap_pyfunction!(stability, m)?)?;
    m.add_function(wrap_pyfunction!(columns, m)?)?;
    m.add("EVAL_CHUNK", EVAL_CHUNK)?;
    m.add("VERSION", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
