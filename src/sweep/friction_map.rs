//! Friction maps (the paper's Fig. 4): friction coefficient over a load × speed grid for
//! one bearing. No dynamics: model `"sommerfeld"` evaluates eqs. 10-11 directly; model
//! `"film"` first finds the static equilibrium of the aligned journal under the load
//! (eccentricity ratio `ε` with `|W_film(ε)| = load`, by bisection on the film kernel),
//! reports `ε`, the attitude angle and `h_min`, and takes the friction from those film
//! loads. Eqs. 10-11 depend on the load only through `|W|`, so both models give the same
//! `f` up to the bisection tolerance; the film model adds where the journal sits.
//!
//! ```json
//! {"kind": "friction_map",
//!  "bearing": {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242},
//!  "load": {"logspace": [1, 10000, 61]},
//!  "speed": [10, 30, 100, 300, 1000],
//!  "model": "sommerfeld"}
//! ```

use serde::de::{self, MapAccess, SeqAccess, Visitor};
use serde::{Deserialize, Deserializer};
use serde_json::{json, Map, Value};
use utoipa::ToSchema;

use super::spec::{
    from_value, hand_schema, join, one_of_names, present, schema, Num, Range3, MAX_VARIANTS,
};
use super::SweepError;
use crate::bearing::{film_loads, friction, Accuracy, BearingParams, BearingState, FilmRule};
use crate::plot::{line_plot_svg, Scale, Series};

/// Format tag of a friction-map result.
pub const FORMAT: &str = "bearing-sweep/friction-map/1";

/// How the friction coefficient is obtained.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MapModel {
    /// Eqs. 10-11 with `|W|` = the load.
    Sommerfeld,
    /// Static film equilibrium under the load, then eqs. 10-11 on the film loads.
    Film,
}

/// A parsed friction-map spec.
#[derive(Clone, Debug)]
pub struct FrictionMapSpec {
    /// Optional name.
    pub name: Option<String>,
    /// The bearing.
    pub bearing: BearingParams,
    /// Loads, N.
    pub load: Vec<f64>,
    /// Relative spins, rad/s.
    pub speed: Vec<f64>,
    /// Model.
    pub model: MapModel,
    /// The spec as given.
    pub canonical: Value,
}

/// Numbers as written: `[..]`, `{"linspace": [a, b, n]}` or `{"logspace": [a, b, n]}`.
#[derive(Clone, Debug, PartialEq)]
pub enum NumbersDoc {
    /// An explicit list.
    List(Vec<f64>),
    /// `{"linspace": [a, b, n]}`.
    Linspace(Range3),
    /// `{"logspace": [a, b, n]}`.
    Logspace(Range3),
    /// An object naming neither or both (refused by [`numbers_from_doc`]).
    Other,
}

/// What numbers must look like, for messages.
const NUMBER_FORMS: &str =
    "a list of numbers, {\"linspace\": [a, b, n]} or {\"logspace\": [a, b, n]}";

impl<'de> Deserialize<'de> for NumbersDoc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct RangeObj {
            #[serde(default, deserialize_with = "present")]
            linspace: Option<Range3>,
            #[serde(default, deserialize_with = "present")]
            logspace: Option<Range3>,
        }
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = NumbersDoc;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str(NUMBER_FORMS)
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<NumbersDoc, A::Error> {
                let mut out = Vec::new();
                while let Some(x) = seq.next_element::<Num>()? {
                    out.push(x.0);
                }
                Ok(NumbersDoc::List(out))
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<NumbersDoc, A::Error> {
                // Through a derived struct: unknown keys are refused with their path.
                let o = RangeObj::deserialize(de::value::MapAccessDeserializer::new(map))?;
                Ok(match (o.linspace, o.logspace) {
                    (Some(r), None) => NumbersDoc::Linspace(r),
                    (None, Some(r)) => NumbersDoc::Logspace(r),
                    _ => NumbersDoc::Other,
                })
            }
        }
        d.deserialize_any(V)
    }
}

hand_schema!(NumbersDoc, "SpecNumbers", {
    use utoipa::openapi::schema::{ArrayBuilder, ObjectBuilder, SchemaType, Type};
    let range = |key: &str| -> utoipa::openapi::schema::Schema {
        ObjectBuilder::new()
            .schema_type(SchemaType::Type(Type::Object))
            .property(key, schema::range3("[first, last, count]"))
            .required(key)
            .additional_properties(Some(
                utoipa::openapi::schema::AdditionalProperties::FreeForm(false),
            ))
            .into()
    };
    schema::any_of(
        [
            ArrayBuilder::new()
                .items(ObjectBuilder::new().schema_type(SchemaType::Type(Type::Number)))
                .min_items(Some(1))
                .into(),
            range("linspace"),
            range("logspace"),
        ],
        "A list of numbers, or count values evenly (linspace) or geometrically (logspace) spaced",
    )
});

/// The only `kind` of a friction map.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrictionMapKind;

impl<'de> Deserialize<'de> for FrictionMapKind {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        one_of_names(
            &Value::deserialize(d)?,
            &[("friction_map", FrictionMapKind)],
        )
        .map_err(de::Error::custom)
    }
}

hand_schema!(
    FrictionMapKind,
    "FrictionMapKind",
    schema::one_of_names(&["friction_map"], "A friction map (no dynamics)")
);

/// The friction model of a map.
impl<'de> Deserialize<'de> for MapModel {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        one_of_names(
            &Value::deserialize(d)?,
            &[
                ("sommerfeld", MapModel::Sommerfeld),
                ("film", MapModel::Film),
            ],
        )
        .map_err(de::Error::custom)
    }
}

hand_schema!(
    MapModel,
    "FrictionMapModel",
    schema::one_of_names(
        &["sommerfeld", "film"],
        "sommerfeld: eqs. 10-11 with |W| = load (default); film: static film equilibrium first"
    )
);

/// A friction-map spec as written (docs/cli.md "Friction maps").
#[derive(Clone, Debug, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct FrictionMapDoc {
    /// `"friction_map"`.
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = FrictionMapKind, required = true)]
    pub kind: Option<FrictionMapKind>,
    /// Name for the result and the plot.
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = String)]
    pub name: Option<String>,
    /// Free text.
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = String)]
    pub description: Option<String>,
    /// The bearing (`radius`, `length`, `clearance`, `viscosity` or `lubricant` with
    /// `supply_temperature` (docs/thermal.md), SI units; as in a scene).
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = Object, required = true)]
    pub bearing: Option<Value>,
    /// Loads, N.
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = NumbersDoc, required = true)]
    pub load: Option<NumbersDoc>,
    /// Relative spins, rad/s.
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = NumbersDoc, required = true)]
    pub speed: Option<NumbersDoc>,
    /// Friction model (default sommerfeld).
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = MapModel)]
    pub model: Option<MapModel>,
}

/// The numbers of a typed [`NumbersDoc`] at `at`: a list of at least one, or 1 to
/// [`MAX_VARIANTS`] spaced values (logspace bounds positive) within the memory budget.
pub fn numbers_from_doc(
    d: &NumbersDoc,
    at: &str,
    budget: crate::budget::MemoryBudget,
) -> Result<Vec<f64>, SweepError> {
    let (k, r) = match d {
        NumbersDoc::List(a) => {
            if a.is_empty() {
                return Err(SweepError::spec(at, "must hold at least one value"));
            }
            return Ok(a.clone());
        }
        NumbersDoc::Linspace(r) => ("linspace", r),
        NumbersDoc::Logspace(r) => ("logspace", r),
        NumbersDoc::Other => {
            return Err(SweepError::spec(
                at,
                format!("expected {NUMBER_FORMS}, got an object"),
            ))
        }
    };
    let p = join(at, k);
    let (a, b, n) = (r.first, r.last, r.count);
    if n == 0 || n > MAX_VARIANTS {
        return Err(SweepError::spec(
            format!("{p}[2]"),
            format!("count must be in 1..={MAX_VARIANTS}, got {n}"),
        ));
    }
    // Every value makes at least one point of the map: check before building them.
    budget
        .check(
            &format!("{n} values (one map point each at least)"),
            n as f64 * crate::budget::BYTES_PER_MAP_POINT as f64,
        )
        .map_err(|r| SweepError::spec(format!("{p}[2]"), r))?;
    let values = if k == "logspace" {
        for (i, x) in [(0, a), (1, b)] {
            if x <= 0.0 {
                return Err(SweepError::spec(
                    format!("{p}[{i}]"),
                    format!(
                        "logspace bounds must be positive, got {}",
                        crate::json::num(x)
                    ),
                ));
            }
        }
        super::AxisValues::Logspace {
            a,
            b,
            n: n as usize,
        }
    } else {
        super::AxisValues::Linspace {
            a,
            b,
            n: n as usize,
        }
    };
    Ok((0..n as usize)
        .map(|i| values.value(i).as_f64().unwrap_or(f64::NAN))
        .collect())
}

impl FrictionMapSpec {
    /// Parses and checks a `kind: "friction_map"` document within the default memory
    /// budget (2 GiB).
    pub fn parse(doc: &Value) -> Result<Self, SweepError> {
        Self::parse_within(doc, crate::budget::MemoryBudget::default())
    }

    /// [`FrictionMapSpec::parse`] within the memory budget `budget`.
    pub fn parse_within(
        doc: &Value,
        budget: crate::budget::MemoryBudget,
    ) -> Result<Self, SweepError> {
        let d: FrictionMapDoc = from_value(doc, "")?;
        let b = d
            .bearing
            .as_ref()
            .ok_or_else(|| SweepError::spec("bearing", "missing"))?;
        let bearing: BearingParams = crate::json::deserialize_at(b).map_err(|(at, reason)| {
            SweepError::spec(crate::json::join_path("bearing", &at), reason)
        })?;
        bearing.validate().map_err(|e| {
            SweepError::spec(
                format!("bearing.{}", e.field),
                format!("{} (got {})", e.reason, crate::json::num(e.value)),
            )
        })?;
        let load = numbers_from_doc(
            d.load
                .as_ref()
                .ok_or_else(|| SweepError::spec("load", "missing (loads in N)"))?,
            "load",
            budget,
        )?;
        let speed = numbers_from_doc(
            d.speed
                .as_ref()
                .ok_or_else(|| SweepError::spec("speed", "missing (speeds in rad/s)"))?,
            "speed",
            budget,
        )?;
        let points = load.len() as f64 * speed.len() as f64;
        budget
            .check(
                &format!("a map of {} loads x {} speeds", load.len(), speed.len()),
                points * crate::budget::BYTES_PER_MAP_POINT as f64,
            )
            .map_err(|r| SweepError::spec("speed", r))?;
        for (k, &w) in load.iter().enumerate() {
            if w < 0.0 {
                return Err(SweepError::spec(
                    format!("load[{k}]"),
                    format!(
                        "a load is a magnitude, must not be negative (got {})",
                        crate::json::num(w)
                    ),
                ));
            }
        }
        let model = d.model.unwrap_or(MapModel::Sommerfeld);
        if bearing.is_thermal() && model == MapModel::Sommerfeld {
            return Err(SweepError::spec(
                "model",
                "a bearing with a lubricant needs \"model\": \"film\" (the thermal balance's side flow needs the film's eccentricity; docs/thermal.md)",
            ));
        }
        if model == MapModel::Film {
            if let Some(k) = speed.iter().position(|&w| w == 0.0) {
                return Err(SweepError::spec(
                    format!("speed[{k}]"),
                    "the film model needs a nonzero speed (a still journal carries no load)",
                ));
            }
        }
        Ok(FrictionMapSpec {
            name: d.name,
            bearing,
            load,
            speed,
            model,
            canonical: doc.clone(),
        })
    }
}

/// Static equilibrium of the aligned journal under `load` (N) at spin `omega` (rad/s):
/// the eccentricity ratio with `|W_film| = load`, by bisection (the Ocvirk force grows
/// monotonically with `ε`) to a relative load error of 1e-12 or 200 halvings.
pub fn equilibrium_eccentricity(
    params: &BearingParams,
    rule: &FilmRule,
    load: f64,
    omega: f64,
) -> Option<(f64, crate::bearing::Loads)> {
    let at = |eps: f64| {
        let state = BearingState {
            xi: eps * params.clearance,
            xj: eps * params.clearance,
            omega,
            ..Default::default()
        };
        film_loads(params, &state, rule).ok()
    };
    if load == 0.0 {
        return at(0.0).map(|l| (0.0, l));
    }
    let (mut lo, mut hi) = (0.0_f64, 1.0_f64);
    let mut best = None;
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        let l = at(mid)?;
        let w = l.wx.hypot(l.wy);
        best = Some((mid, l));
        if (w - load).abs() <= 1e-12 * load {
            break;
        }
        if w < load {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    best
}

/// The effective-temperature balance of the aligned journal carrying `load` (N) at
/// `omega` (rad/s): every balance step solves the static equilibrium at `μ(T)`; heat
/// from the film's own friction power and side flow the film's own at the equilibrium
/// ([`crate::bearing::Loads::film`]; the paper's law stays the map's `power_loss_w`).
pub fn map_balance(
    params: &BearingParams,
    rule: &FilmRule,
    load: f64,
    omega: f64,
) -> Result<crate::bearing::Balance, crate::bearing::ThermalError> {
    let (Some(lub), Some(supply)) = (params.lubricant, params.supply_temperature) else {
        return Err(crate::bearing::ThermalError::Film {
            celsius: f64::NAN,
            reason: "no lubricant".into(),
        });
    };
    crate::bearing::solve_balance(&lub, supply, &params.thermal, |mu| {
        let pm = BearingParams {
            viscosity: mu,
            ..*params
        };
        let (_, l) = equilibrium_eccentricity(&pm, rule, load, omega)
            .ok_or_else(|| "no film equilibrium under this load".to_string())?;
        // Heat: the film's own friction power at the equilibrium (not the paper's law,
        // 1.91 × Petroff at S < 1).
        Ok((l.film.power_loss_w, l.film.side_flow_m3_per_s))
    })
}

fn num(x: Option<f64>) -> Value {
    x.filter(|v| v.is_finite())
        .and_then(serde_json::Number::from_f64)
        .map_or(Value::Null, Value::Number)
}

/// Computes the map: the result document (JSON) and its SVG plot.
/// The friction map's figure, drawn on demand: callers write the result first, so a figure
/// that cannot be drawn never holds the numbers back (issue 13 item 1).
pub struct FrictionMapPlot {
    title: String,
    labels: Vec<String>,
    series: Vec<Vec<(f64, f64)>>,
}

impl FrictionMapPlot {
    /// The SVG (f against the load on log axes, one line per speed), or why it cannot be
    /// drawn (e.g. a range plotters cannot draw in bounded time).
    pub fn render(&self) -> Result<String, String> {
        let plot_series: Vec<Series<'_>> = self
            .series
            .iter()
            .zip(&self.labels)
            .map(|(points, label)| Series {
                label,
                points: points.clone(),
            })
            .collect();
        line_plot_svg(
            &self.title,
            "load |W| (N)",
            "friction coefficient f",
            &plot_series,
            Scale::Log,
            Scale::Log,
        )
    }
}

/// Evaluates the map: the result document and its figure (drawn by
/// [`FrictionMapPlot::render`]).
pub fn friction_map(spec: &FrictionMapSpec, accuracy: Accuracy) -> (Value, FrictionMapPlot) {
    let p = &spec.bearing;
    let rule = FilmRule::new(accuracy.settings());
    let mut curves = Vec::new();
    let mut series = Vec::new();
    let labels: Vec<String> = spec
        .speed
        .iter()
        .map(|w| format!("ω = {w} rad/s"))
        .collect();
    for &omega in &spec.speed {
        let mut points = Vec::new();
        let mut plot_pts = Vec::new();
        for &load in &spec.load {
            let mut m = Map::new();
            m.insert("load_n".into(), num(Some(load)));
            // With a lubricant: the balance and the equilibrium solved together (each
            // balance step an equilibrium at μ(T)); the rest of the point at μ(T_eff).
            let mut pe = *p;
            let mut thermal_err = None;
            if let (true, MapModel::Film) = (p.is_thermal(), spec.model) {
                match map_balance(p, &rule, load, omega) {
                    Ok(b) => {
                        pe.viscosity = b.viscosity_pa_s;
                        m.insert(
                            "thermal".into(),
                            crate::bearing::thermal::balance_json(&b, p),
                        );
                    }
                    Err(e) => thermal_err = Some(e.to_string()),
                }
            }
            let p = &pe;
            let (w_abs, extra) = match spec.model {
                MapModel::Sommerfeld => (load, None),
                MapModel::Film if thermal_err.is_some() => (f64::NAN, None),
                MapModel::Film => match equilibrium_eccentricity(p, &rule, load, omega) {
                    Some((eps, l)) => {
                        let w = l.wx.hypot(l.wy);
                        // Attitude: angle from the applied load (−W) to the line of centres
                        // (+x here), in the spin's direction.
                        let attitude = (omega.signum() * l.wy).atan2(-l.wx).to_degrees();
                        (
                            w,
                            Some(json!({"eccentricity": num(Some(eps)),
                                        "attitude_deg": num(Some(if eps > 0.0 { attitude } else { 90.0 })),
                                        "h_min_m": num(Some(l.h_min)),
                                        "film_force_n": num(Some(w)),
                                        // The film's own friction and flow (issue 24).
                                        "film_friction_coefficient": num(l.film.friction_coefficient),
                                        "film_friction_variable": num(l.film.friction_variable),
                                        "film_friction_torque_nm": num(Some(l.film.friction_torque_nm.abs())),
                                        "film_power_loss_w": num(Some(l.film.power_loss_w)),
                                        "side_flow_m3_per_s": num(Some(l.film.side_flow_m3_per_s))})),
                        )
                    }
                    None => (f64::NAN, None),
                },
            };
            let fr = friction(p, w_abs, omega);
            let ok = w_abs.is_finite();
            m.insert(
                "friction_coefficient".into(),
                num(fr.coefficient.filter(|_| ok)),
            );
            m.insert("sommerfeld".into(), num(fr.sommerfeld.filter(|_| ok)));
            m.insert(
                "friction_torque_nm".into(),
                num(Some(fr.mz.abs()).filter(|_| ok)),
            );
            m.insert(
                "power_loss_w".into(),
                num(Some((fr.mz * omega).abs()).filter(|_| ok)),
            );
            if let Some(reason) = thermal_err {
                m.insert("status".into(), json!("thermal_error"));
                m.insert("error".into(), json!(reason));
            } else if let Some(Value::Object(e)) = extra {
                m.extend(e);
            } else if spec.model == MapModel::Film {
                m.insert("status".into(), json!("no_equilibrium"));
            }
            if let (Some(f), true) = (fr.coefficient, ok) {
                plot_pts.push((load, f));
            }
            points.push(Value::Object(m));
        }
        curves.push(json!({"speed_rad_s": omega, "points": points}));
        series.push(plot_pts);
    }
    let title = format!(
        "Friction coefficient, r0 = {} m, B = {} m, δ = {} m, μ = {} Pa·s ({})",
        p.radius,
        p.length,
        p.clearance,
        p.viscosity,
        match spec.model {
            MapModel::Sommerfeld => "eqs. 10-11",
            MapModel::Film => "film equilibrium",
        }
    );
    let doc = json!({
        "format": FORMAT,
        "name": spec.name,
        "spec": spec.canonical,
        "model": match spec.model { MapModel::Sommerfeld => "sommerfeld", MapModel::Film => "film" },
        "integrator": "none (no dynamics: eqs. 10-11 evaluated directly)",
        "clearance_convention": p.clearance_convention.name(),
        "friction_model": "paper (friction_coefficient, friction_torque_nm, power_loss_w: eqs. 10-11); film_*: the short film's shear stress (model film only)",
        "accuracy": match spec.model { MapModel::Film => json!(accuracy.rtol()), MapModel::Sommerfeld => Value::Null },
        "units": {"load_n": "N", "speed_rad_s": "rad/s", "friction_torque_nm": "N·m (magnitude)",
                  "power_loss_w": "W", "film_power_loss_w": "W", "film_friction_torque_nm": "N·m (magnitude)",
                  "side_flow_m3_per_s": "m³/s", "film_friction_coefficient, film_friction_variable": "dimensionless", "h_min_m": "m", "film_force_n": "N", "attitude_deg": "degrees, from the load to the line of centres",
                  "friction_coefficient, sommerfeld, eccentricity": "dimensionless"},
        "curves": curves,
    });
    let plot = FrictionMapPlot {
        title,
        labels,
        series,
    };
    (doc, plot)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(model: &str) -> FrictionMapSpec {
        FrictionMapSpec::parse(&json!({"kind": "friction_map",
            "bearing": {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242},
            "load": {"logspace": [1, 10000, 5]}, "speed": [10, 100, 1000], "model": model}))
        .unwrap()
    }

    #[test]
    fn sommerfeld_map_matches_eqs_10_11() {
        let (doc, plot) = friction_map(&spec("sommerfeld"), Accuracy::default());
        let svg = plot.render();
        // Table 2 bearing: φ = δ/2r0 = 0.0075; S = (W / 8e-4) φ² / (μ ω) = 2.9055 W / ω.
        let phi = 0.0075;
        for c in doc["curves"].as_array().unwrap() {
            let w = c["speed_rad_s"].as_f64().unwrap();
            for p in c["points"].as_array().unwrap() {
                let load = p["load_n"].as_f64().unwrap();
                let s = load / (2.0 * 0.02 * 0.02) * phi * phi / (0.0242 * w);
                let f = if s < 1.0 {
                    3.0 * phi / s
                } else {
                    3.0 * phi / s.sqrt()
                };
                let got = p["friction_coefficient"].as_f64().unwrap();
                assert!(
                    (got / f - 1.0).abs() < 1e-14,
                    "ω {w} load {load}: f = {got}, expected {f} (rtol 1e-14)"
                );
            }
        }
        let svg = svg.unwrap();
        assert!(svg.matches("<polyline").count() >= 3);
    }

    #[test]
    fn film_equilibrium_matches_ocvirk_and_gives_the_same_friction() {
        let s = spec("film");
        let (doc, _) = friction_map(&s, Accuracy::default());
        let p = s.bearing;
        for c in doc["curves"].as_array().unwrap() {
            let w = c["speed_rad_s"].as_f64().unwrap();
            for pt in c["points"].as_array().unwrap() {
                let load = pt["load_n"].as_f64().unwrap();
                let eps = pt["eccentricity"].as_f64().unwrap();
                // Ocvirk force magnitude at eps (MODEL.md section 7).
                let k = p.viscosity * w * p.radius * p.length.powi(3) / (p.clearance * p.clearance);
                let wx = k * eps * eps / (1.0 - eps * eps).powi(2);
                let wy = k * std::f64::consts::PI * eps / (4.0 * (1.0 - eps * eps).powf(1.5));
                let w_abs = wx.hypot(wy);
                assert!(
                    (w_abs / load - 1.0).abs() < 1e-6,
                    "ω {w} load {load}: Ocvirk |W|(ε = {eps}) = {w_abs} (rtol 1e-6)"
                );
                // Ocvirk attitude angle: atan(π √(1 − ε²) / (4 ε)).
                let att = (std::f64::consts::PI * (1.0 - eps * eps).sqrt() / (4.0 * eps))
                    .atan()
                    .to_degrees();
                let got = pt["attitude_deg"].as_f64().unwrap();
                assert!(
                    (got - att).abs() < 1e-6,
                    "ω {w} load {load}: attitude {got}°, expected {att}° (tol 1e-6)"
                );
                let h = pt["h_min_m"].as_f64().unwrap();
                assert!(
                    (h - p.clearance * (1.0 - eps)).abs() < 1e-15,
                    "h_min {h} vs δ(1 − ε)"
                );
                let fr = friction(&p, load, w).coefficient.unwrap();
                let got = pt["friction_coefficient"].as_f64().unwrap();
                assert!(
                    (got / fr - 1.0).abs() < 1e-6,
                    "film f {got} vs eqs. 10-11 {fr} (rtol 1e-6)"
                );
            }
        }
    }

    #[test]
    fn spec_errors_name_paths() {
        let base = json!({"kind": "friction_map",
            "bearing": {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242},
            "load": [1, 2], "speed": [10]});
        let with = |k: &str, v: Value| {
            let mut d = base.clone();
            d[k] = v;
            d
        };
        let cases = [
            (with("loads", json!([1])), "loads", "unknown field"),
            (with("load", json!([1, -2])), "load[1]", "negative"),
            (
                with("load", json!({"logspace": [0, 10, 3]})),
                "load.logspace[0]",
                "positive",
            ),
            (with("speed", json!("fast")), "speed", "expected a list"),
            (with("model", json!("exact")), "model", "sommerfeld"),
            (
                with(
                    "bearing",
                    json!({"radius": 0.02, "length": 0.02, "clearance": -1.0, "viscosity": 0.0242}),
                ),
                "bearing.clearance",
                "positive",
            ),
        ];
        for (k, (doc, path, reason)) in cases.iter().enumerate() {
            match FrictionMapSpec::parse(doc) {
                Err(SweepError::Spec { path: p, reason: r }) => assert!(
                    p == *path && r.contains(reason),
                    "case {k}: got `{p}: {r}`, expected `{path}` with `{reason}`"
                ),
                other => panic!("case {k}: expected an error, got {other:?}"),
            }
        }
        let mut d = with("model", json!("film"));
        d["speed"] = json!([0, 10]);
        assert!(
            matches!(FrictionMapSpec::parse(&d), Err(SweepError::Spec { path, .. }) if path == "speed[0]")
        );
    }
}
