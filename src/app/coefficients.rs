//! `bearing-sweep coefficients`: the linearised 4×4 stiffness and damping of a bearing at
//! its static equilibrium under a load (one speed or a list), or at a given journal state;
//! also as ROSS `BearingElement` rows (CSV) or a TOML file `ross.BearingElement.load` reads.

use serde_json::{json, Map, Value};

use super::{from_value, AppError};
use crate::backend::{create_backend, BackendKind};
use crate::bearing::{BearingParams, BearingState};
use crate::stability::{
    aligned_state, bearing_equilibria, coefficients_batch, BearingCoefficients, CoefficientJob,
    DiffOptions, StabilityError, ORDER,
};

/// Options of `coefficients` beyond the input document.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CoefficientOptions {
    /// Backend to run on.
    pub backend: BackendKind,
    /// Relative accuracy of the film loads (the differences need the tightest: 1e-12).
    pub accuracy: f64,
}

impl Default for CoefficientOptions {
    fn default() -> Self {
        CoefficientOptions {
            backend: BackendKind::Cpu,
            accuracy: 1e-12,
        }
    }
}

/// The service's entry point: `coefficients` on the CPU at accuracy 1e-12.
pub fn coefficients_json(input: &str) -> Result<Value, AppError> {
    coefficients_json_with(input, CoefficientOptions::default()).map(|(v, _)| v)
}

fn stability_error(e: StabilityError) -> AppError {
    match e {
        StabilityError::Input { path, reason } => AppError::input(path, reason),
        other => AppError::input("$", other.to_string()),
    }
}

fn finite_number(v: &Value, path: &str) -> Result<f64, AppError> {
    let x = v
        .as_f64()
        .ok_or_else(|| AppError::input(path, format!("expected a number, got {v}")))?;
    if !x.is_finite() {
        return Err(AppError::input(path, "must be finite"));
    }
    Ok(x)
}

fn matrix(m: &[[f64; 4]; 4]) -> Value {
    json!(m.iter().map(|r| r.to_vec()).collect::<Vec<_>>())
}

/// One operating point's output object.
fn point_json(
    params: &BearingParams,
    speed: f64,
    load: Option<[f64; 2]>,
    eq: Option<&crate::stability::BearingEquilibrium>,
    state: &BearingState,
    c: &BearingCoefficients,
) -> Value {
    let d = params.clearance;
    let (ei, ej) = state.eccentricity_ratios(d);
    let mut equilibrium = Map::new();
    let (xm, ym) = (0.5 * (state.xi + state.xj), 0.5 * (state.yi + state.yj));
    equilibrium.insert("x".into(), json!(xm));
    equilibrium.insert("y".into(), json!(ym));
    equilibrium.insert("eccentricity_ratio".into(), json!(xm.hypot(ym) / d));
    equilibrium.insert("eccentricity_ratio_max_end".into(), json!(ei.max(ej)));
    if let Some(eq) = eq {
        equilibrium.insert("attitude_angle_rad".into(), json!(eq.attitude_angle));
        equilibrium.insert(
            "attitude_angle_deg".into(),
            json!(eq.attitude_angle.to_degrees()),
        );
        equilibrium.insert("load_residual".into(), json!(eq.residual));
        equilibrium.insert("newton_iterations".into(), json!(eq.iterations));
    }
    equilibrium.insert("h_min".into(), json!(c.loads.h_min));
    // The classical Sommerfeld number (μ N L D / P)(R/c)², N in rev/s, P the load.
    let p = match load {
        Some(l) => l[0].hypot(l[1]),
        None => c.loads.wx.hypot(c.loads.wy),
    };
    let classical = (p > 0.0).then(|| {
        params.viscosity * speed.abs() / std::f64::consts::TAU * params.length * 2.0 * params.radius
            / p
            * (params.radius / params.clearance).powi(2)
    });
    json!({
        "speed": speed,
        "load": load,
        "state": state,
        "equilibrium": equilibrium,
        "loads": c.loads,
        "mid_plane_loads": c.mid_plane_loads,
        "sommerfeld": c.loads.sommerfeld,
        "sommerfeld_classical": classical,
        "friction_coefficient": c.loads.friction_coefficient,
        "friction_torque": c.loads.mz,
        "power_loss": c.loads.power_loss,
        "friction_model": c.loads.friction_model.name(),
        "film_friction_torque_nm": c.loads.film.friction_torque_nm,
        "film_power_loss_w": c.loads.film.power_loss_w,
        "film_friction_variable": c.loads.film.friction_variable,
        "side_flow_m3_per_s": c.loads.film.side_flow_m3_per_s,
        "inlet_flow_m3_per_s": c.loads.film.inlet_flow_m3_per_s,
        "order": ORDER,
        "stiffness": matrix(&c.stiffness),
        "damping": matrix(&c.damping),
        "stiffness_error": matrix(&c.stiffness_error),
        "damping_error": matrix(&c.damping_error),
        "steps": c.steps,
    })
}

/// One ROSS row per point: `[speed, kxx, kxy, kyx, kyy, cxx, cxy, cyx, cyy]` (the force
/// block of our K and C; SI).
fn ross_row(speed: f64, c: &BearingCoefficients) -> Vec<f64> {
    let (k, d) = (&c.stiffness, &c.damping);
    vec![
        speed, k[0][0], k[0][1], k[1][0], k[1][1], d[0][0], d[0][1], d[1][0], d[1][1],
    ]
}

/// Column names of the ROSS rows.
pub const ROSS_COLUMNS: [&str; 9] = [
    "speed", "kxx", "kxy", "kyx", "kyy", "cxx", "cxy", "cyx", "cyy",
];

/// `coefficients` on an input document; returns the output and notices for stderr.
pub fn coefficients_json_with(
    input: &str,
    options: CoefficientOptions,
) -> Result<(Value, Vec<String>), AppError> {
    let doc: Value = serde_json::from_str(input)
        .map_err(|e| AppError::input("$", format!("not valid JSON: {e}")))?;
    let obj = doc
        .as_object()
        .ok_or_else(|| AppError::input("$", "expected an object"))?;
    const FIELDS: [&str; 5] = ["bearing", "speed", "speeds", "load", "state"];
    for key in obj.keys() {
        if !FIELDS.contains(&key.as_str()) {
            let hint = crate::json::did_you_mean(key, &FIELDS)
                .map_or(String::new(), |n| format!("; did you mean `{n}`?"));
            return Err(AppError::input(
                key.clone(),
                format!("unknown field (expected `bearing` with `speed` or `speeds` and `load`, or `bearing` and `state`){hint}"),
            ));
        }
    }
    let params: BearingParams = from_value(
        obj.get("bearing")
            .ok_or_else(|| AppError::input("bearing", "missing"))?,
        "bearing",
    )?;
    params.validate().map_err(|e| {
        AppError::input(
            format!("bearing.{}", e.field),
            format!("{} ({})", e.reason, e.value),
        )
    })?;
    let accuracy = super::accuracy(options.accuracy)?;
    let (backend, notice) = create_backend(options.backend, accuracy)?;
    let mut notices: Vec<String> = notice.into_iter().collect();
    let (mut ev, swap) = crate::stability::difference_evaluator(backend, accuracy);
    notices.extend(swap);
    let info = ev.info();
    let head = json!({
        "bearing": params,
        "frame": "bearing frame (MODEL.md section 1): x, y across the bore, z along it, spin positive from +x toward +y; q = (x, y) of the journal centre at the mid-plane (m), tilt_x, tilt_y right-handed rotations of the journal axis about x and y (rad); loads = film force on the journal (N) and its moment about the mid-plane centre (N·m)",
        "signs": "K = −∂W/∂q, C = −∂W/∂q̇ (W the film load on the journal): direct stiffness positive",
        "method": "central differences with Richardson extrapolation: steps h, h/2, h/4 (two levels) for the short film and explicit finite grids; on the finite film's held accuracy-mode grid h, h/2 (one level) for positions and tilts, and for the rates steps 400 times larger (s, s/2, s/4, two levels) so that the cavitation boundary's node-to-node kinks average out; *_error = change of the last level plus rounding, plus the finite grid's discretisation error where a grid is held",
        "accuracy": accuracy.rtol(),
        "backend": info,
        "clearance_convention": params.clearance_convention.name(),
        "units": "SI: N/m, N/rad, N·m/m, N·m/rad (stiffness); N·s/m, N·s/rad, N·m·s/m, N·m·s/rad (damping)",
    });
    let mut out = head.as_object().cloned().unwrap_or_default();
    if let Some(st) = obj.get("state") {
        for key in ["speed", "speeds", "load"] {
            if obj.contains_key(key) {
                return Err(AppError::input(
                    key,
                    "not with `state` (the state fixes position, velocity and spin)",
                ));
            }
        }
        let state: BearingState = from_value(st, "state")?;
        let c = coefficients_batch(
            &mut ev,
            &[CoefficientJob { params, state }],
            &DiffOptions::default(),
        )
        .remove(0)
        .map_err(|e| AppError::input("state", e.to_string()))?;
        let p = point_json(&params, state.omega, None, None, &state, &c);
        out.extend(p.as_object().cloned().unwrap_or_default());
        out.insert("ross".into(), json!([ross_row(state.omega, &c)]));
        out.insert("ross_columns".into(), json!(ROSS_COLUMNS));
        notices.extend(ev.take_notices());
        return Ok((Value::Object(out), notices));
    }
    let load_v = obj.get("load").ok_or_else(|| {
        AppError::input(
            "load",
            "missing (the static load on the journal [W_x, W_y], N)",
        )
    })?;
    let arr = load_v
        .as_array()
        .filter(|a| a.len() == 2)
        .ok_or_else(|| AppError::input("load", "expected [W_x, W_y] (N)"))?;
    let load = [
        finite_number(&arr[0], "load[0]")?,
        finite_number(&arr[1], "load[1]")?,
    ];
    let (speeds, list) = match (obj.get("speed"), obj.get("speeds")) {
        (Some(s), None) => (vec![finite_number(s, "speed")?], false),
        (None, Some(Value::Array(a))) if !a.is_empty() => (
            a.iter()
                .enumerate()
                .map(|(k, v)| finite_number(v, &format!("speeds[{k}]")))
                .collect::<Result<Vec<_>, _>>()?,
            true,
        ),
        (None, Some(_)) => {
            return Err(AppError::input(
                "speeds",
                "expected a non-empty array of rad/s",
            ))
        }
        (Some(_), Some(_)) => {
            return Err(AppError::input(
                "speeds",
                "give `speed` or `speeds`, not both",
            ))
        }
        (None, None) => return Err(AppError::input("speed", "missing (rad/s)")),
    };
    // With a lubricant: per speed, the equilibrium and the effective-temperature balance
    // solved together (each balance step an equilibrium at μ(T); docs/thermal.md); the
    // coefficients at μ(T_eff).
    let mut per_speed = vec![params; speeds.len()];
    let mut balances = vec![None; speeds.len()];
    if let (Some(lub), Some(supply)) = (params.lubricant, params.supply_temperature) {
        let rule = crate::bearing::FilmRule::new(accuracy.settings());
        for (k, &w) in speeds.iter().enumerate() {
            let b = crate::bearing::solve_balance(&lub, supply, &params.thermal, |mu| {
                // A field assignment, not `..params`: the struct update inside this
                // closure trips a rustc ICE (broken MIR with the const-generic groove list).
                let mut pm = params;
                pm.viscosity = mu;
                let eq = bearing_equilibria(&mut ev, &[(pm, w, load)])
                    .remove(0)
                    .map_err(|e| e.to_string())?;
                let st = aligned_state(eq.x, eq.y, w);
                let l = crate::bearing::film_flow::bearing_loads(&pm, &st, &rule)
                    .map_err(|e| e.to_string())?;
                // Heat: the film's own friction power (not the paper's law).
                Ok((l.film.power_loss_w, l.film.side_flow_m3_per_s))
            })
            .map_err(|e| {
                AppError::input(
                    if list {
                        format!("speeds[{k}]")
                    } else {
                        "speed".into()
                    },
                    format!("thermal balance: {e}"),
                )
            })?;
            per_speed[k].viscosity = b.viscosity_pa_s;
            balances[k] = Some(b);
        }
    }
    let cases: Vec<(BearingParams, f64, [f64; 2])> = speeds
        .iter()
        .zip(&per_speed)
        .map(|(&w, p)| (*p, w, load))
        .collect();
    let eqs = bearing_equilibria(&mut ev, &cases);
    let mut states = Vec::new();
    let mut good = Vec::new();
    for (k, e) in eqs.into_iter().enumerate() {
        let eq = e.map_err(|e| match e {
            StabilityError::Input { .. } => stability_error(e),
            other => AppError::input(
                if list {
                    format!("speeds[{k}]")
                } else {
                    "speed".into()
                },
                other.to_string(),
            ),
        })?;
        states.push(aligned_state(eq.x, eq.y, speeds[k]));
        good.push(eq);
    }
    let jobs: Vec<CoefficientJob> = states
        .iter()
        .zip(&per_speed)
        .map(|(s, p)| CoefficientJob {
            params: *p,
            state: *s,
        })
        .collect();
    let coeffs = coefficients_batch(&mut ev, &jobs, &DiffOptions::default());
    let mut points = Vec::new();
    let mut rows = Vec::new();
    for (k, c) in coeffs.into_iter().enumerate() {
        let c = c.map_err(|e| {
            AppError::input(
                if list {
                    format!("speeds[{k}]")
                } else {
                    "speed".into()
                },
                e.to_string(),
            )
        })?;
        rows.push(ross_row(speeds[k], &c));
        let mut p = point_json(
            &per_speed[k],
            speeds[k],
            Some(load),
            Some(&good[k]),
            &states[k],
            &c,
        );
        if let (Some(b), Some(m)) = (&balances[k], p.as_object_mut()) {
            m.insert(
                "thermal".into(),
                crate::bearing::thermal::balance_json(b, &params),
            );
        }
        points.push(p);
    }
    if list {
        out.insert("points".into(), json!(points));
    } else {
        out.extend(points[0].as_object().cloned().unwrap_or_default());
    }
    out.insert("ross".into(), json!(rows));
    out.insert("ross_columns".into(), json!(ROSS_COLUMNS));
    notices.extend(ev.take_notices());
    Ok((Value::Object(out), notices))
}

/// The ROSS rows of a `coefficients` output as CSV (header line, then one row per speed).
pub fn ross_csv(out: &Value) -> String {
    let mut s = ROSS_COLUMNS.join(",");
    s.push('\n');
    for row in out["ross"].as_array().into_iter().flatten() {
        let cells: Vec<String> = row
            .as_array()
            .into_iter()
            .flatten()
            .map(|v| format!("{:e}", v.as_f64().unwrap_or(f64::NAN)))
            .collect();
        s.push_str(&cells.join(","));
        s.push('\n');
    }
    s
}

/// What ROSS's `BearingElement` cannot hold, said on stderr with every ROSS export.
pub const ROSS_TILT_NOTICE: &str = "notice: ROSS's BearingElement holds the x-y force block only (kxx..cyy); the tilt blocks of K and C (film moments against tilt and the force-tilt coupling, rows and columns tilt_x, tilt_y) are not part of a ROSS bearing and are left out of its model (the TOML export records them under `bearing_sweep`)";

/// The TOML table ROSS's `BearingElement.load` reads (the first table of the file).
pub const ROSS_TOML_TABLE: &str = "BearingElement_bearing_sweep";

/// Which ROSS the TOML export is for: the rotor-speed argument of `BearingElement` is
/// `frequency` in ross-rotordynamics 2.x (the last release for Python < 3.13) and `speed`
/// in 3.x, where `frequency` means the whirl frequency (a 2.x file read by ROSS 3 would
/// be silently wrong, so the two are separate formats).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RossVersion {
    /// ross-rotordynamics 2.x: `frequency` = rotor speed (`--format ross-toml`).
    V2,
    /// ross-rotordynamics 3.x: `speed` = rotor speed (`--format ross3-toml`).
    V3,
}

impl RossVersion {
    /// The constructor argument that holds the rotor speeds.
    pub fn speed_key(self) -> &'static str {
        match self {
            RossVersion::V2 => "frequency",
            RossVersion::V3 => "speed",
        }
    }
}

/// A `coefficients` output as a TOML file in the layout of ross-rotordynamics
/// `Element.save` (one table `[BearingElement_<tag>]` holding the constructor's arguments;
/// `BearingElement.load(file)` builds the element from the file's first table). The
/// speeds go to the rotor-speed argument of `version` (rad/s). Everything
/// ROSS has no argument for (static load, equilibrium, ε, attitude angle, geometry, the
/// full 4×4 K and C with their tilt blocks and error estimates) is recorded in the
/// sub-table `bearing_sweep`, which ROSS passes to the constructor's `**kwargs` and
/// ignores.
pub fn ross_toml(out: &Value, version: RossVersion) -> String {
    let single = [out.clone()];
    let points: &[Value] = match out.get("points").and_then(Value::as_array) {
        Some(p) => p,
        None => &single,
    };
    let rows: Vec<&Vec<Value>> = out["ross"]
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(Value::as_array)
        .collect();
    let column = |j: usize| -> Value {
        Value::Array(
            rows.iter()
                .map(|r| r.get(j).cloned().unwrap_or(Value::Null))
                .collect(),
        )
    };
    let per_point =
        |f: &dyn Fn(&Value) -> Value| -> Value { Value::Array(points.iter().map(f).collect()) };
    let mut s = String::new();
    s.push_str(
        "# ROSS bearing from `bearing-sweep coefficients --format ross-toml`.\n\
         # Python: brg = ross.BearingElement.load(\"this.toml\"); brg.n = <node>  (n is 0 here)\n\
         # Frame: x, y across the bore, spin from +x toward +y (ROSS's positive spin about +z);\n\
         # K = -dW/dq, C = -dW/dq' (W the film load on the journal); SI units.\n\
         # ROSS's BearingElement holds the x-y force block only. The tilt blocks of our 4x4 K and C\n\
         # (film moments against tilt, force-tilt coupling) cannot be held by it and are NOT used by\n\
         # ROSS; they are recorded in [",
    );
    s.push_str(ROSS_TOML_TABLE);
    s.push_str(".bearing_sweep] with the static load, ε, attitude angle and geometry.\n");
    s.push_str(&match version {
        RossVersion::V2 => "# Layout of ross-rotordynamics 2.x: `frequency` is the ROTOR SPEED (rad/s) at which each\n\
                            # coefficient set was linearised (for ROSS 3 use --format ross3-toml).\n"
            .to_string(),
        RossVersion::V3 => "# Layout of ross-rotordynamics 3.x: `speed` is the rotor speed (rad/s) at which each\n\
                            # coefficient set was linearised (for ROSS 2 use --format ross-toml).\n"
            .to_string(),
    });
    s.push('[');
    s.push_str(ROSS_TOML_TABLE);
    s.push_str("]\nn = 0\n");
    s.push_str(&format!(
        "{} = {}\n",
        version.speed_key(),
        toml_value(&column(0))
    ));
    for (j, name) in ROSS_COLUMNS.iter().enumerate().skip(1) {
        s.push_str(&format!("{name} = {}\n", toml_value(&column(j))));
    }
    let mut meta = Map::new();
    meta.insert(
        "note".into(),
        json!("read by bearing-sweep, ignored by ROSS (passed to BearingElement's **kwargs)"),
    );
    for key in [
        "frame",
        "signs",
        "units",
        "method",
        "accuracy",
        "clearance_convention",
    ] {
        if let Some(v) = out.get(key) {
            meta.insert(key.into(), v.clone());
        }
    }
    meta.insert("speed_rad_s".into(), column(0));
    meta.insert("load_N".into(), per_point(&|p| p["load"].clone()));
    for (key, field) in [
        ("eccentricity_ratio", "eccentricity_ratio"),
        ("eccentricity_ratio_max_end", "eccentricity_ratio_max_end"),
        ("attitude_angle_rad", "attitude_angle_rad"),
        ("attitude_angle_deg", "attitude_angle_deg"),
        ("journal_x_m", "x"),
        ("journal_y_m", "y"),
        ("load_residual_N", "load_residual"),
    ] {
        meta.insert(key.into(), per_point(&|p| p["equilibrium"][field].clone()));
    }
    for key in [
        "sommerfeld",
        "sommerfeld_classical",
        "friction_coefficient",
        "friction_torque",
        "power_loss",
        "film_friction_torque_nm",
        "film_power_loss_w",
        "film_friction_variable",
        "side_flow_m3_per_s",
        "inlet_flow_m3_per_s",
    ] {
        meta.insert(key.into(), per_point(&|p| p[key].clone()));
    }
    meta.insert(
        "h_min_m".into(),
        per_point(&|p| p["loads"]["h_min"].clone()),
    );
    meta.insert("order".into(), json!(ORDER));
    for key in ["stiffness", "damping", "stiffness_error", "damping_error"] {
        meta.insert(key.into(), per_point(&|p| p[key].clone()));
    }
    if let Some(b) = out.get("bearing") {
        meta.insert("bearing".into(), b.clone());
    }
    s.push_str(&format!("\n[{ROSS_TOML_TABLE}.bearing_sweep]\n"));
    for (k, v) in &meta {
        // A key whose values are all missing (no load or attitude for a given state) is
        // left out: TOML has no null.
        if is_all_null(v) {
            continue;
        }
        s.push_str(&format!("{} = {}\n", toml_key(k), toml_value(v)));
    }
    s
}

fn is_all_null(v: &Value) -> bool {
    match v {
        Value::Null => true,
        Value::Array(a) => a.iter().all(is_all_null),
        _ => false,
    }
}

fn toml_key(k: &str) -> String {
    if !k.is_empty()
        && k.chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
    {
        k.to_string()
    } else {
        toml_string(k)
    }
}

fn toml_string(text: &str) -> String {
    let mut s = String::with_capacity(text.len() + 2);
    s.push('"');
    for c in text.chars() {
        match c {
            '"' => s.push_str("\\\""),
            '\\' => s.push_str("\\\\"),
            '\n' => s.push_str("\\n"),
            '\t' => s.push_str("\\t"),
            c if (c as u32) < 0x20 || c == '\u{7f}' => s.push_str(&format!("\\u{:04X}", c as u32)),
            c => s.push(c),
        }
    }
    s.push('"');
    s
}

/// A JSON value as a TOML value: numbers keep every bit (`{:?}` is Rust's shortest
/// round-trip form, always with a `.` or an exponent for floats), objects become inline
/// tables, `null` (only inside arrays here) becomes `nan`.
fn toml_value(v: &Value) -> String {
    match v {
        Value::Null => "nan".into(),
        Value::Bool(b) => b.to_string(),
        Value::Number(n) => match (n.as_i64(), n.as_u64(), n.as_f64()) {
            (Some(i), _, _) if !n.is_f64() => i.to_string(),
            (_, Some(u), _) if !n.is_f64() => u.to_string(),
            (_, _, Some(x)) if x.is_finite() => format!("{x:?}"),
            _ => "nan".into(),
        },
        Value::String(t) => toml_string(t),
        Value::Array(a) => {
            let items: Vec<String> = a.iter().map(toml_value).collect();
            format!("[{}]", items.join(", "))
        }
        Value::Object(m) => {
            let items: Vec<String> = m
                .iter()
                .filter(|(_, v)| !v.is_null())
                .map(|(k, v)| format!("{} = {}", toml_key(k), toml_value(v)))
                .collect();
            format!("{{ {} }}", items.join(", "))
        }
    }
}
