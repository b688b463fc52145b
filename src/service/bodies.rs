//! Request-body schemas of `POST /api/eval` for the OpenAPI document. Documentation only:
//! the body is parsed by the same code as `bearing-sweep eval` (`app::eval`), which names
//! the JSON path and the reason of any bad field; these types only describe it.

use serde_json::Value;

/// One bearing, as in an `eval` file, a `coefficients` file and a scene's `bearings[k]`
/// (docs/cli.md "eval"). SI units. The oil is given either as `viscosity` or as
/// `lubricant` + `supply_temperature` (exactly one of the two ways; docs/thermal.md).
#[derive(utoipa::ToSchema)]
#[allow(dead_code)] // a schema only
pub struct BearingBody {
    /// Journal radius `r0`, m (the paper's 0.02).
    radius: f64,
    /// Bearing length `B`, m (the paper's 0.02).
    length: f64,
    /// Radial clearance `δ`, m (the paper's 0.0003).
    clearance: f64,
    /// Dynamic viscosity `μ`, Pa·s; required unless `lubricant` is given.
    viscosity: Option<f64>,
    /// Oil grade by name (`"ISO VG 22"`, `"ISO VG 32"`, `"ISO VG 46"`, `"ISO VG 68"`,
    /// `"ISO VG 100"`, `"ISO VG 150"`, `"ISO VG 220"`) or a custom oil
    /// `{"nu40", "nu100" (mm²/s), "density" (kg/m³ at 15 °C), "expansion" (1/K),
    /// "specific_heat" (J/(kg K))}`; with `supply_temperature`, instead of `viscosity`.
    /// `eval` then solves the effective-temperature balance and reports a `thermal` block
    /// per state (`effective_temperature_c`, `temperature_rise_k`, `effective_viscosity_pa_s`,
    /// `power_loss_w`, `side_flow_m3_s`).
    lubricant: Option<Value>,
    /// Oil supply temperature, °C (-30 to 200); required with `lubricant`.
    supply_temperature: Option<f64>,
    /// Thermal balance settings, all optional: `effective_factor` (share of the rise that
    /// sets `T_eff`, default 0.8), `housing_conductance` (W/K, default 0: adiabatic),
    /// `thermal_capacity` (J/K, rotor scenes' lumped oil temperature), `tolerance` (K).
    thermal: Option<Value>,
    /// Film model: `"short"` (default), `"finite"` or `"auto"` (docs/finite-film.md).
    model: Option<String>,
    /// Finite-film settings: `accuracy` (default 5e-4), or `n_theta`/`n_z` for an explicit
    /// grid, `inlet`, `cavitation` (`"reynolds"` or `"jfo"`), ... (docs/finite-film.md).
    finite: Option<Value>,
    /// Axial oil-supply grooves, at most 8: `[{"angle" (°), "width" (°), "supply_pressure"
    /// (Pa gauge), "length" (m, default the bearing's)}]`; finite film (docs/grooves.md).
    grooves: Option<Vec<Value>>,
    /// Lands of a partial-arc bearing: `[{"start" (°), "extent" (°)}]`; finite film.
    arcs: Option<Vec<Value>>,
    /// Relative clearance of the paper's friction law: `"paper"` (default) or
    /// `"vogelpohl"`.
    clearance_convention: Option<String>,
}

/// Body of `POST /api/eval`: a bearing and its states, as an `eval` file.
#[derive(utoipa::ToSchema)]
#[allow(dead_code)] // a schema only
pub struct EvalBody {
    /// The bearing.
    bearing: BearingBody,
    /// Journal states: `{"xi", "yi", "xj", "yj"}` (m, journal centre at the two end faces),
    /// `{"vxi", "vyi", "vxj", "vyj"}` (m/s) and `"omega"` (rad/s), as in docs/cli.md "eval".
    states: Vec<Value>,
}
