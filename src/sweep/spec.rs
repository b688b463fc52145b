//! The sweep spec: typed by serde derive ([`SweepSpecDoc`], unknown fields refused) from the
//! `serde_json::Value` that `crate::json::parse_json` read (duplicate keys refused), then
//! checked by small functions over the typed document; every error names the JSON path
//! inside the spec and the reason, all before any computation. The same types give the
//! service's OpenAPI schema ([`SpecDocument`]).
//!
//! ```json
//! {"kind": "rotor", "name": "clearance x viscosity",
//!  "base": {...scene...} | "path/to/scene.json",
//!  "axes": [{"path": "bearings[*].clearance", "linspace": [1e-4, 5e-4, 5]},
//!           {"path": "bearings[*].viscosity", "logspace": [0.005, 0.1, 4]},
//!           {"path": "rotor.mass", "values": [0.5, 1.0, 2.0], "zip": "m"}],
//!  "mode": "grid" | "zip" | {"latin_hypercube": {"samples": 100, "seed": 7}},
//!  "reductions": {...}}
//! ```
//!
//! docs/cli.md "Sweeps" documents every field.

use std::collections::BTreeMap;
use std::path::Path;

use serde::de::{self, MapAccess, Visitor};
use serde::{Deserialize, Deserializer};
use serde_json::{Map, Value};
use utoipa::{PartialSchema, ToSchema};

use super::reduce::ReductionOptions;
use super::SweepError;

// The spec's helpers live by concern; re-exported here, where the spec types use them.
pub use super::json_path::{parse_path, resolve, set_path, PathSeg};
pub use super::schema;
pub(crate) use super::schema::hand_schema;
pub use super::wording::{from_value, join, one_of_names, present, type_name, Count, Num, Range3};

/// Most variants one spec may expand to (a guard against typos such as `1e9` points).
pub const MAX_VARIANTS: u64 = 100_000_000;

/// What a sweep's variants are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SweepKind {
    /// Rotor scenes simulated by the integrator (the default).
    Rotor,
    /// Analytic stand-in signals with known reductions (tests, trying the machinery).
    Synthetic,
    /// Rotor scenes analysed by linear stability (threshold speed, least log-dec; no time
    /// integration; `crate::sweep::stability_sim::StabilitySimulator`).
    Stability,
    /// A friction map over load and speed (Fig. 4): no scenes and no dynamics, one
    /// document (`crate::sweep::friction_map`); not a [`SweepSpec`], so
    /// [`parse_spec`] refuses it and [`super::job::parse_sweep`] parses either.
    FrictionMap,
}

impl SweepKind {
    /// The name used in the spec's `kind` field.
    pub fn name(self) -> &'static str {
        match self {
            SweepKind::Rotor => "rotor",
            SweepKind::Synthetic => "synthetic",
            SweepKind::Stability => "stability",
            SweepKind::FrictionMap => "friction_map",
        }
    }

    /// The kind of a spec document, without parsing the rest: [`SweepKind::Rotor`] when
    /// `kind` is absent, `None` when it is not one of the names (the parser then says
    /// why).
    pub fn of(doc: &Value) -> Option<SweepKind> {
        match doc.get("kind") {
            None => Some(SweepKind::Rotor),
            Some(k) => {
                let k = k.as_str()?;
                SweepKind::NAMES
                    .iter()
                    .map(|(_, kind)| *kind)
                    .chain([SweepKind::FrictionMap])
                    .find(|kind| kind.name() == k)
            }
        }
    }
}

/// The values an axis takes.
#[derive(Clone, Debug, PartialEq)]
pub enum AxisValues {
    /// Explicit JSON values (any type: numbers, strings, whole objects).
    List(Vec<Value>),
    /// `n` evenly spaced numbers from `a` to `b`, both included.
    Linspace {
        /// First value.
        a: f64,
        /// Last value.
        b: f64,
        /// Number of values, >= 1.
        n: usize,
    },
    /// `n` geometrically spaced numbers from `a` to `b` (the values, not exponents).
    Logspace {
        /// First value, > 0.
        a: f64,
        /// Last value, > 0.
        b: f64,
        /// Number of values, >= 1.
        n: usize,
    },
}

impl AxisValues {
    /// Number of values (the number of strata in Latin hypercube mode).
    pub fn len(&self) -> usize {
        match self {
            AxisValues::List(v) => v.len(),
            AxisValues::Linspace { n, .. } | AxisValues::Logspace { n, .. } => *n,
        }
    }

    /// Never empty after parsing; here for clippy's `len_without_is_empty`.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The `k`-th value (`k < len`). Endpoints are exact; logspace is spaced in log10.
    pub fn value(&self, k: usize) -> Value {
        match self {
            AxisValues::List(v) => v[k].clone(),
            AxisValues::Linspace { a, b, n } => number(lerp(*a, *b, frac(k, *n))),
            AxisValues::Logspace { a, b, n } => number(log_lerp(*a, *b, frac(k, *n))),
        }
    }

    /// The value at the continuous position `u` in `[0, 1]` (Latin hypercube sampling of
    /// a range); `None` for a list axis, which is sampled by index.
    pub fn continuous(&self, u: f64) -> Option<f64> {
        match self {
            AxisValues::List(_) => None,
            AxisValues::Linspace { a, b, .. } => Some(lerp(*a, *b, u)),
            AxisValues::Logspace { a, b, .. } => Some(log_lerp(*a, *b, u)),
        }
    }
}

fn frac(k: usize, n: usize) -> f64 {
    if n <= 1 {
        0.0
    } else {
        k as f64 / (n - 1) as f64
    }
}

/// `a + (b - a) u`, exact at both ends; never overflows for finite `a`, `b` (a span
/// wider than `f64::MAX`, e.g. `[-1e308, 1e308]`, is interpolated as `a (1 − u) + b u`).
fn lerp(a: f64, b: f64, u: f64) -> f64 {
    if u == 1.0 {
        return b;
    }
    let span = b - a;
    if span.is_finite() {
        a + span * u
    } else {
        a * (1.0 - u) + b * u
    }
}

/// Geometric interpolation in base 10 (so `logspace [1e-3, 1e-1, 3]` gives 0.01 exactly
/// where the platform's `powf` is correctly rounded), exact at both ends.
fn log_lerp(a: f64, b: f64, u: f64) -> f64 {
    if u == 0.0 {
        a
    } else if u == 1.0 {
        b
    } else {
        let (la, lb) = (a.log10(), b.log10());
        // Clamped to the bounds: near f64::MAX the rounding of powf may step past them.
        10f64.powf(la + (lb - la) * u).clamp(a.min(b), a.max(b))
    }
}

fn number(x: f64) -> Value {
    serde_json::Number::from_f64(x)
        .map(Value::Number)
        .unwrap_or(Value::Null)
}

/// One axis of the sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    /// The path as written, e.g. `bearings[*].clearance`.
    pub path: String,
    /// Parsed path.
    pub segments: Vec<PathSeg>,
    /// Its values.
    pub values: AxisValues,
    /// Zip group: in grid and Latin hypercube modes, axes naming the same group move
    /// together (equal lengths required in grid mode).
    pub zip: Option<String>,
}

/// How axes combine into variants.
#[derive(Clone, Debug, PartialEq)]
pub enum AxisMode {
    /// Full Cartesian product; the first axis (group) varies slowest.
    Grid,
    /// Axes taken in lockstep: variant `k` takes the `k`-th value of every axis.
    Zip,
    /// Seeded Latin hypercube: `samples` variants, every axis stratified into `samples`
    /// equal-probability strata, each stratum used exactly once.
    LatinHypercube {
        /// Number of variants.
        samples: u64,
        /// PRNG seed.
        seed: u64,
    },
}

/// A parsed, checked sweep spec.
#[derive(Clone, Debug)]
pub struct SweepSpec {
    /// What the variants are.
    pub kind: SweepKind,
    /// Optional name for reports and plots.
    pub name: Option<String>,
    /// The base scene (with a `base` file reference resolved).
    pub base: Value,
    /// The axes, in spec order.
    pub axes: Vec<Axis>,
    /// How the axes combine.
    pub mode: AxisMode,
    /// What each variant keeps.
    pub reductions: ReductionOptions,
    /// SVG plots written with a complete result.
    pub plots: Vec<super::plots::PlotSpec>,
    /// The spec with `base` inlined: echoed in outputs and hashed to recognise a resume.
    pub canonical: Value,
}

impl SweepKind {
    const NAMES: [(&'static str, SweepKind); 3] = [
        ("rotor", SweepKind::Rotor),
        ("synthetic", SweepKind::Synthetic),
        ("stability", SweepKind::Stability),
    ];
}

impl<'de> Deserialize<'de> for SweepKind {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = Value::deserialize(d)?;
        match v.as_str() {
            Some(s) => SweepKind::NAMES
                .iter()
                .find(|(n, _)| *n == s)
                .map(|(_, k)| *k)
                .ok_or_else(|| {
                    de::Error::custom(format!(
                        "unknown kind `{}` (expected rotor, synthetic, stability or friction_map)",
                        crate::json::quote(s)
                    ))
                }),
            None => Err(de::Error::custom(format!(
                "expected a string, got {}",
                type_name(&v)
            ))),
        }
    }
}

hand_schema!(
    SweepKind,
    "SweepKind",
    schema::one_of_names(
        &["rotor", "synthetic", "stability"],
        "What the variants are: rotor (default), synthetic, stability (friction maps are the FrictionMapDoc)"
    )
);

/// The base scene: an object, or the name of a JSON file holding it (relative to the spec's
/// folder; not accepted by the service).
#[derive(Clone, Debug, PartialEq)]
pub enum BaseDoc {
    /// A file name.
    File(String),
    /// The scene itself (checked per variant by the kind's scene validator).
    Scene(Map<String, Value>),
}

impl<'de> Deserialize<'de> for BaseDoc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        match Value::deserialize(d)? {
            Value::String(s) => Ok(BaseDoc::File(s)),
            Value::Object(m) => Ok(BaseDoc::Scene(m)),
            v => Err(de::Error::custom(format!(
                "expected the scene object or a file name, got {}",
                type_name(&v)
            ))),
        }
    }
}

hand_schema!(
    BaseDoc,
    "SpecBase",
    schema::any_of(
        [
            schema::typed(
                utoipa::openapi::Type::Object,
                "The scene (docs/cli.md \"Scene files\"); axes set its values"
            ),
            schema::typed(
                utoipa::openapi::Type::String,
                "A scene file next to the spec (the run command only: the service wants the object)"
            ),
        ],
        "The base scene of every variant"
    )
);

/// A zip group name.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GroupName(pub String);

impl<'de> Deserialize<'de> for GroupName {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        match Value::deserialize(d)? {
            Value::String(s) => Ok(GroupName(s)),
            v => Err(de::Error::custom(format!(
                "expected a group name (string), got {}",
                type_name(&v)
            ))),
        }
    }
}

hand_schema!(
    GroupName,
    "SpecZipGroup",
    schema::typed(
        utoipa::openapi::Type::String,
        "Zip group: axes naming the same group move together"
    )
);

/// One axis as written: a path into the base and exactly one of `values`, `linspace`,
/// `logspace`.
#[derive(Clone, Debug, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct AxisDoc {
    /// Path into the base scene, e.g. `bearings[*].clearance` (`[*]`: every element).
    pub path: String,
    /// Explicit values (any JSON: numbers, strings, whole objects), at least one.
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = Vec<serde_json::Value>, min_items = 1)]
    pub values: Option<Vec<Value>>,
    /// `[first, last, count]` evenly spaced, both ends included.
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = Range3)]
    pub linspace: Option<Range3>,
    /// `[first, last, count]` geometrically spaced (positive values, not exponents).
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = Range3)]
    pub logspace: Option<Range3>,
    /// Zip group (grid and Latin hypercube modes).
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = GroupName)]
    pub zip: Option<GroupName>,
}

/// `{"samples": N, "seed": S}` of a Latin hypercube.
#[derive(Clone, Copy, Debug, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct LatinHypercubeDoc {
    /// Number of variants, 1 to 10^8.
    #[schema(value_type = Count)]
    pub samples: Count,
    /// PRNG seed (default 0).
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = Count)]
    pub seed: Option<Count>,
}

/// How the axes combine: `"grid"` (default), `"zip"` or `{"latin_hypercube": {...}}`.
#[derive(Clone, Copy, Debug, ToSchema)]
#[schema(rename_all = "snake_case")]
pub enum ModeDoc {
    /// Full Cartesian product.
    Grid,
    /// Axes in lockstep.
    Zip,
    /// Seeded Latin hypercube.
    LatinHypercube(LatinHypercubeDoc),
}

/// What a mode must look like, for messages.
const MODE_FORMS: &str =
    "\"grid\", \"zip\" or {\"latin_hypercube\": {\"samples\": N, \"seed\": S}}";

impl<'de> Deserialize<'de> for ModeDoc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct Lhs {
            latin_hypercube: LatinHypercubeDoc,
        }
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = ModeDoc;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str(MODE_FORMS)
            }
            fn visit_str<E: de::Error>(self, s: &str) -> Result<ModeDoc, E> {
                match s {
                    "grid" => Ok(ModeDoc::Grid),
                    "zip" => Ok(ModeDoc::Zip),
                    _ => Err(E::custom(format!(
                        "expected {MODE_FORMS}, got \"{}\"",
                        crate::json::quote(s)
                    ))),
                }
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<ModeDoc, A::Error> {
                // The object form through a derived struct: its keys stay in the path.
                let o = Lhs::deserialize(de::value::MapAccessDeserializer::new(map))?;
                Ok(ModeDoc::LatinHypercube(o.latin_hypercube))
            }
        }
        d.deserialize_any(V)
    }
}

/// A scene sweep spec as written (kinds rotor, synthetic, stability); docs/cli.md "Sweeps"
/// section documents every field.
#[derive(Clone, Debug, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct SweepSpecDoc {
    /// What the variants are (default rotor).
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = SweepKind)]
    pub kind: Option<SweepKind>,
    /// Name for reports and plots.
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = String)]
    pub name: Option<String>,
    /// Free text.
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = String)]
    pub description: Option<String>,
    /// The base scene (required).
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = BaseDoc, required = true)]
    pub base: Option<BaseDoc>,
    /// The axes, the first varying slowest in a grid.
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = Vec<AxisDoc>)]
    pub axes: Option<Vec<AxisDoc>>,
    /// How the axes combine (default grid).
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = ModeDoc)]
    pub mode: Option<ModeDoc>,
    /// What each variant computes and keeps.
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = super::reduce::ReductionsDoc)]
    pub reductions: Option<super::reduce::ReductionsDoc>,
    /// SVG plots written with a complete result.
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = Vec<super::plots::PlotDoc>)]
    pub plots: Option<Vec<super::plots::PlotDoc>>,
}

/// The body of `POST /api/sweeps` and `POST /api/validate`: a scene sweep spec or a
/// friction map (`kind: "friction_map"`). A schema only.
pub struct SpecDocument;

impl utoipa::PartialSchema for SpecDocument {
    fn schema() -> utoipa::openapi::RefOr<utoipa::openapi::schema::Schema> {
        use utoipa::openapi::{OneOfBuilder, Ref};
        OneOfBuilder::new()
            .item(Ref::from_schema_name(SweepSpecDoc::name()))
            .item(Ref::from_schema_name(
                super::friction_map::FrictionMapDoc::name(),
            ))
            .description(Some(
                "A sweep spec exactly as `run` reads it (docs/cli.md \"Sweeps\"; sweeps/ has examples), with the base scene inline",
            ))
            .into()
    }
}

impl ToSchema for SpecDocument {
    fn name() -> std::borrow::Cow<'static, str> {
        std::borrow::Cow::Borrowed("SpecDocument")
    }
    fn schemas(
        out: &mut Vec<(
            String,
            utoipa::openapi::RefOr<utoipa::openapi::schema::Schema>,
        )>,
    ) {
        use super::friction_map::FrictionMapDoc;
        out.push((SweepSpecDoc::name().into(), SweepSpecDoc::schema()));
        SweepSpecDoc::schemas(out);
        out.push((FrictionMapDoc::name().into(), FrictionMapDoc::schema()));
        FrictionMapDoc::schemas(out);
    }
}

/// Parses a sweep spec document. `spec_dir` resolves a `base` given as a file name.
/// Detects the kind only; `kind: "friction_map"` documents are parsed by
/// [`super::friction_map`] (see [`SweepKind::of`] and [`super::job::parse_sweep`]).
pub fn parse_spec(doc: &Value, spec_dir: Option<&Path>) -> Result<SweepSpec, SweepError> {
    let d: SweepSpecDoc = from_value(doc, "")?;
    let kind = d.kind.unwrap_or(SweepKind::Rotor);
    let base = match d.base {
        None => return Err(SweepError::spec("base", "missing (the base scene)")),
        Some(BaseDoc::File(file)) => {
            let path = match spec_dir {
                Some(dir) => dir.join(&file),
                None => Path::new(&file).to_path_buf(),
            };
            let text = std::fs::read_to_string(&path).map_err(|e| {
                SweepError::spec("base", format!("cannot read `{}`: {e}", path.display()))
            })?;
            let v: Value = crate::json::parse_json(&text).map_err(|e| {
                SweepError::spec(
                    "base",
                    format!("`{}`: {}: {}", path.display(), e.path, e.reason),
                )
            })?;
            if !v.is_object() {
                return Err(SweepError::spec(
                    "base",
                    format!("`{}` must hold a JSON object", path.display()),
                ));
            }
            v
        }
        Some(BaseDoc::Scene(m)) => Value::Object(m),
    };
    let axes = d
        .axes
        .unwrap_or_default()
        .into_iter()
        .enumerate()
        .map(|(k, a)| axis_from_doc(a, &format!("axes[{k}]"), &base))
        .collect::<Result<Vec<_>, _>>()?;
    check_overlaps(&axes, &base)?;
    let mode = mode_from_doc(d.mode)?;
    check_mode(&mode, &axes)?;
    let reductions = match &d.reductions {
        None => ReductionOptions::default(),
        Some(r) => ReductionOptions::from_doc(r, "reductions")?,
    };
    let plots = super::plots::plots_from_doc(d.plots.as_deref().unwrap_or_default(), &axes, kind)?;
    // Echoed and hashed as given (a resume compares it), with the base and the kind inlined.
    let mut canonical = doc.as_object().cloned().unwrap_or_default();
    canonical.insert("base".into(), base.clone());
    canonical.insert("kind".into(), Value::String(kind.name().into()));
    let spec = SweepSpec {
        kind,
        name: d.name,
        base,
        axes,
        mode,
        reductions,
        plots,
        canonical: Value::Object(canonical),
    };
    let count = super::Expansion::new(&spec).count();
    if count > MAX_VARIANTS {
        return Err(SweepError::spec(
            "axes",
            format!("{count} variants exceed the limit of {MAX_VARIANTS}"),
        ));
    }
    Ok(spec)
}

/// Whether concrete path `a` is `b` or lies inside it (or the other way round):
/// `bearings[0].clearance` overlaps `bearings[0]` and itself, not `bearings[0].clearance2`.
fn paths_overlap(a: &str, b: &str) -> bool {
    let (short, long) = if a.len() <= b.len() { (a, b) } else { (b, a) };
    long.starts_with(short)
        && matches!(
            long.as_bytes().get(short.len()),
            None | Some(b'.') | Some(b'[')
        )
}

/// Refuses two axes that set the same parameter (`bearings[*].clearance` and
/// `bearings[0].clearance`, or `rotor` and `rotor.mass`): the later would silently
/// overwrite the earlier. Compared on the concrete paths each axis sets in the base.
fn check_overlaps(axes: &[Axis], base: &Value) -> Result<(), SweepError> {
    let targets: Vec<Vec<String>> = axes
        .iter()
        .map(|a| {
            resolve(base, &a.segments)
                .map(|t| t.into_iter().map(|(p, _)| p).collect())
                .unwrap_or_default()
        })
        .collect();
    for (k, tk) in targets.iter().enumerate() {
        for (j, tj) in targets[..k].iter().enumerate() {
            if let Some((p, q)) = tk
                .iter()
                .find_map(|p| tj.iter().find(|q| paths_overlap(p, q)).map(|q| (p, q)))
            {
                let quote = crate::json::quote;
                let what = if p == q {
                    format!("`{}` is", quote(p))
                } else {
                    format!("`{}` overlaps `{}`,", quote(p), quote(q))
                };
                return Err(SweepError::spec(
                    format!("axes[{k}].path"),
                    format!(
                        "{what} already swept by axes[{j}] (`{}`): two axes would set one parameter; keep one",
                        quote(&axes[j].path),
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// The mode of the typed document, checked: a Latin hypercube needs 1 to
/// [`MAX_VARIANTS`] samples.
fn mode_from_doc(m: Option<ModeDoc>) -> Result<AxisMode, SweepError> {
    Ok(match m {
        None | Some(ModeDoc::Grid) => AxisMode::Grid,
        Some(ModeDoc::Zip) => AxisMode::Zip,
        Some(ModeDoc::LatinHypercube(l)) => {
            let samples = l.samples.0;
            if samples == 0 {
                return Err(SweepError::spec(
                    "mode.latin_hypercube.samples",
                    "must be at least 1",
                ));
            }
            if samples > MAX_VARIANTS {
                return Err(SweepError::spec(
                    "mode.latin_hypercube.samples",
                    format!("{samples} exceeds the limit of {MAX_VARIANTS}"),
                ));
            }
            AxisMode::LatinHypercube {
                samples,
                seed: l.seed.map_or(0, |s| s.0),
            }
        }
    })
}

fn check_mode(mode: &AxisMode, axes: &[Axis]) -> Result<(), SweepError> {
    match mode {
        AxisMode::Zip => {
            if let Some(first) = axes.first() {
                for (k, a) in axes.iter().enumerate() {
                    if a.zip.is_some() {
                        return Err(SweepError::spec(
                            format!("axes[{k}].zip"),
                            "zip groups are meaningless in zip mode (every axis is zipped)",
                        ));
                    }
                    if a.values.len() != first.values.len() {
                        return Err(SweepError::spec(
                            format!("axes[{k}]"),
                            format!(
                                "zip mode needs axes of equal length: {} values here, {} in axes[0]",
                                a.values.len(),
                                first.values.len()
                            ),
                        ));
                    }
                }
            }
        }
        AxisMode::Grid => {
            let mut group_len: BTreeMap<&str, (usize, usize)> = BTreeMap::new();
            for (k, a) in axes.iter().enumerate() {
                if let Some(g) = &a.zip {
                    let (first, len) = *group_len.entry(g).or_insert((k, a.values.len()));
                    if a.values.len() != len {
                        return Err(SweepError::spec(
                            format!("axes[{k}]"),
                            format!(
                                "zip group `{g}` needs axes of equal length: {} values here, {len} in axes[{first}]",
                                a.values.len()
                            ),
                        ));
                    }
                }
            }
        }
        AxisMode::LatinHypercube { .. } => {}
    }
    Ok(())
}

/// One axis of the typed document, checked at `at` (`axes[k]`): a parsable path that
/// addresses existing values of the base, exactly one kind of values, counts in
/// 1..=[`MAX_VARIANTS`], positive logspace bounds, numbers under a range axis.
fn axis_from_doc(a: AxisDoc, at: &str, base: &Value) -> Result<Axis, SweepError> {
    let segments = parse_path(&a.path).map_err(|r| SweepError::spec(join(at, "path"), r))?;
    let present: Vec<&str> = [
        ("values", a.values.is_some()),
        ("linspace", a.linspace.is_some()),
        ("logspace", a.logspace.is_some()),
    ]
    .into_iter()
    .filter_map(|(k, there)| there.then_some(k))
    .collect();
    let field = join(at, present.first().copied().unwrap_or("values"));
    let values = match (a.values, a.linspace, a.logspace) {
        (Some(list), None, None) => {
            if list.is_empty() {
                return Err(SweepError::spec(&field, "must hold at least one value"));
            }
            AxisValues::List(list)
        }
        (None, Some(r), None) => AxisValues::Linspace {
            a: r.first,
            b: r.last,
            n: range_count(&r, &field)?,
        },
        (None, None, Some(r)) => {
            let n = range_count(&r, &field)?;
            for (k, x) in [(0, r.first), (1, r.last)] {
                if x <= 0.0 {
                    return Err(SweepError::spec(
                        format!("{field}[{k}]"),
                        format!(
                            "logspace bounds must be positive, got {}",
                            crate::json::num(x)
                        ),
                    ));
                }
            }
            AxisValues::Logspace {
                a: r.first,
                b: r.last,
                n,
            }
        }
        _ => {
            return Err(SweepError::spec(
                at,
                format!(
                    "needs exactly one of `values`, `linspace`, `logspace` (found {})",
                    if present.is_empty() {
                        "none".to_string()
                    } else {
                        present.join(" and ")
                    }
                ),
            ))
        }
    };
    // The path must address existing values of the base scene; a range axis must
    // replace numbers.
    let targets = resolve(base, &segments).map_err(|r| SweepError::spec(join(at, "path"), r))?;
    if !matches!(values, AxisValues::List(_)) {
        for (p, t) in &targets {
            if !t.is_number() {
                return Err(SweepError::spec(
                    field.clone(),
                    format!("the base value at `{p}` is {}, not a number", type_name(t)),
                ));
            }
        }
    }
    Ok(Axis {
        path: a.path,
        segments,
        values,
        zip: a.zip.map(|g| g.0),
    })
}

/// The count of a `[first, last, count]` at `field`: 1 to [`MAX_VARIANTS`].
fn range_count(r: &Range3, field: &str) -> Result<usize, SweepError> {
    let n = r.count;
    if n == 0 {
        return Err(SweepError::spec(
            format!("{field}[2]"),
            "count must be at least 1",
        ));
    }
    if n > MAX_VARIANTS {
        return Err(SweepError::spec(
            format!("{field}[2]"),
            format!("count {n} exceeds the limit of {MAX_VARIANTS}"),
        ));
    }
    Ok(n as usize)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn base() -> Value {
        json!({"rotor": {"mass": 1.0, "name": "paper"},
               "bearings": [{"clearance": 3e-4, "viscosity": 0.0242},
                            {"clearance": 3e-4, "viscosity": 0.0242}],
               "speed": 100.0})
    }

    fn err(doc: Value) -> (String, String) {
        match parse_spec(&doc, None) {
            Err(SweepError::Spec { path, reason }) => (path, reason),
            other => panic!("expected a spec error, got {other:?}"),
        }
    }

    #[test]
    fn parses_paths() {
        assert_eq!(
            parse_path("bearings[*].clearance").unwrap(),
            vec![
                PathSeg::Key("bearings".into()),
                PathSeg::All,
                PathSeg::Key("clearance".into())
            ]
        );
        assert_eq!(
            parse_path("a[2][0].b").unwrap(),
            vec![
                PathSeg::Key("a".into()),
                PathSeg::Index(2),
                PathSeg::Index(0),
                PathSeg::Key("b".into())
            ]
        );
        for bad in ["", ".a", "a.", "a[", "a[x]", "a..b", "[0]", "a b"] {
            assert!(parse_path(bad).is_err(), "`{bad}` should not parse");
        }
    }

    #[test]
    fn set_path_with_star_sets_every_element() {
        let mut b = base();
        set_path(
            &mut b,
            &parse_path("bearings[*].clearance").unwrap(),
            &json!(1e-4),
        );
        assert_eq!(b["bearings"][0]["clearance"], json!(1e-4));
        assert_eq!(b["bearings"][1]["clearance"], json!(1e-4));
        set_path(
            &mut b,
            &parse_path("bearings[1].viscosity").unwrap(),
            &json!(0.1),
        );
        assert_eq!(b["bearings"][0]["viscosity"], json!(0.0242));
        assert_eq!(b["bearings"][1]["viscosity"], json!(0.1));
    }

    #[test]
    fn errors_name_the_json_path_and_reason() {
        let cases: Vec<(Value, &str, &str)> = vec![
            (json!({"base": base(), "axis": []}), "axis", "unknown field"),
            (json!({"axes": []}), "base", "missing"),
            (json!({"base": 3}), "base", "got a number"),
            (
                json!({"base": base(), "axes": {}}),
                "axes",
                "expected an array",
            ),
            (
                json!({"base": base(), "axes": [{"path": "speed"}]}),
                "axes[0]",
                "exactly one of",
            ),
            (
                json!({"base": base(), "axes": [{"path": "speed", "values": [1], "linspace": [1, 2, 3]}]}),
                "axes[0]",
                "values and linspace",
            ),
            (
                json!({"base": base(), "axes": [{"path": "speed", "values": []}]}),
                "axes[0].values",
                "at least one",
            ),
            (
                json!({"base": base(), "axes": [{"path": "speed", "linspace": [1, 2, 0]}]}),
                "axes[0].linspace[2]",
                "at least 1",
            ),
            (
                json!({"base": base(), "axes": [{"path": "speed", "linspace": [1, 2, 2.5]}]}),
                "axes[0].linspace[2]",
                "non-negative integer",
            ),
            (
                json!({"base": base(), "axes": [{"path": "speed", "linspace": [1, "x", 2]}]}),
                "axes[0].linspace[1]",
                "expected a number, got a string",
            ),
            (
                json!({"base": base(), "axes": [{"path": "speed", "logspace": [0, 2, 3]}]}),
                "axes[0].logspace[0]",
                "must be positive",
            ),
            (
                json!({"base": base(), "axes": [{"path": "speed", "logspace": [1, 2]}]}),
                "axes[0].logspace",
                "[first, last, count]",
            ),
            (
                json!({"base": base(), "axes": [{"path": "bearings[*].clerance", "values": [1]}]}),
                "axes[0].path",
                "`bearings[0]` has no field `clerance`",
            ),
            (
                json!({"base": base(), "axes": [{"path": "bearings[5].clearance", "values": [1]}]}),
                "axes[0].path",
                "has 2 elements, no index 5",
            ),
            (
                json!({"base": base(), "axes": [{"path": "rotor.name", "linspace": [1, 2, 2]}]}),
                "axes[0].linspace",
                "`rotor.name` is a string, not a number",
            ),
            (
                json!({"base": base(), "axes": [{"path": "speed", "values": [1]}, {"path": "speed", "values": [2]}]}),
                "axes[1].path",
                "already swept by axes[0]",
            ),
            (
                json!({"base": base(), "mode": "zip", "axes": [{"path": "speed", "values": [1, 2]}, {"path": "rotor.mass", "values": [2]}]}),
                "axes[1]",
                "equal length",
            ),
            (
                json!({"base": base(), "axes": [{"path": "speed", "values": [1, 2], "zip": "g"}, {"path": "rotor.mass", "values": [2], "zip": "g"}]}),
                "axes[1]",
                "zip group `g`",
            ),
            (
                json!({"base": base(), "mode": "random"}),
                "mode",
                "\"random\"",
            ),
            (
                json!({"base": base(), "mode": {"latin_hypercube": {"samples": 0}}}),
                "mode.latin_hypercube.samples",
                "at least 1",
            ),
            (
                json!({"base": base(), "mode": {"latin_hypercube": {"samples": 4, "sead": 1}}}),
                "mode.latin_hypercube.sead",
                "unknown field",
            ),
            (
                json!({"base": base(), "kind": "thing"}),
                "kind",
                "unknown kind",
            ),
            (
                json!({"base": base(), "reductions": {"window": {"revolutions": -1}}}),
                "reductions.window.revolutions",
                "positive",
            ),
            (
                json!({"base": base(), "axes": [{"path": "speed", "linspace": [1, 2, 1e5]}, {"path": "rotor.mass", "linspace": [1, 2, 1e4]}]}),
                "axes",
                "exceed the limit",
            ),
            // Wordings built from serde's errors (issue 14).
            (json!(3), "$", "expected an object, got a number"),
            (
                json!({"base": base(), "name": null}),
                "name",
                "expected a string, got null",
            ),
            (
                json!({"base": base(), "mode": {}}),
                "mode.latin_hypercube",
                "missing",
            ),
            (
                json!({"base": base(), "mode": [1]}),
                "mode",
                "or {\"latin_hypercube\": {\"samples\": N, \"seed\": S}}, got an array",
            ),
            (
                json!({"base": base(), "axes": [["speed", [1]]]}),
                "axes[0]",
                "expected an object",
            ),
            (
                json!({"base": base(), "axes": [{"path": "speed", "linspace": [1, 2, 3, 4]}]}),
                "axes[0].linspace",
                "expected [first, last, count]",
            ),
            (
                json!({"base": base(), "axes": [{"values": [1]}]}),
                "axes[0].path",
                "missing",
            ),
            (
                json!({"base": base(), "axes": [{"path": "speed", "values": [1], "zip": 2}]}),
                "axes[0].zip",
                "expected a group name (string), got a number",
            ),
            (
                json!({"base": base(), "axes": [{"path": "speed", "values": [1]}], "mode": {"latin_hypercube": {"samples": 2.5}}}),
                "mode.latin_hypercube.samples",
                "expected a non-negative integer, got 2.5",
            ),
        ];
        for (k, (doc, path, reason)) in cases.into_iter().enumerate() {
            let (p, r) = err(doc);
            assert!(
                p == path && r.contains(reason),
                "case {k}: got `{p}: {r}`, expected path `{path}` and a reason containing `{reason}`"
            );
        }
    }

    #[test]
    fn unknown_keys_are_cut_short_and_the_allowed_ones_listed() {
        let huge = "k".repeat(10_000);
        let mut doc = json!({"base": base()});
        doc[huge.as_str()] = json!(1);
        let (p, r) = err(doc);
        assert!(
            p.len() < 200 && p.contains("more characters"),
            "path not cut: {} bytes",
            p.len()
        );
        assert_eq!(
            r,
            "unknown field (expected one of: kind, name, description, base, axes, mode, reductions, plots)"
        );
        let (p, r) = err(json!({"base": base(), "kind": huge}));
        assert!(
            p == "kind" && r.len() < 300 && r.contains("unknown kind"),
            "{p}: {r}"
        );
    }

    #[test]
    fn linspace_and_logspace_values() {
        let lin = AxisValues::Linspace {
            a: 1.0,
            b: 2.0,
            n: 5,
        };
        let got: Vec<f64> = (0..5).map(|k| lin.value(k).as_f64().unwrap()).collect();
        assert_eq!(got, vec![1.0, 1.25, 1.5, 1.75, 2.0]);
        let log = AxisValues::Logspace {
            a: 1e-3,
            b: 1e-1,
            n: 3,
        };
        let got: Vec<f64> = (0..3).map(|k| log.value(k).as_f64().unwrap()).collect();
        for (k, (g, e)) in got.iter().zip([1e-3, 1e-2, 1e-1]).enumerate() {
            assert!(
                (g / e - 1.0).abs() < 1e-15,
                "logspace[{k}] = {g}, expected {e} (rtol 1e-15)"
            );
        }
        let one = AxisValues::Linspace {
            a: 3.0,
            b: 9.0,
            n: 1,
        };
        assert_eq!(one.value(0).as_f64(), Some(3.0));
    }

    #[test]
    fn canonical_spec_inlines_the_base_and_the_kind() {
        let s = parse_spec(
            &json!({"base": base(), "axes": [{"path": "speed", "values": [1, 2]}]}),
            None,
        )
        .unwrap();
        assert_eq!(s.canonical["kind"], json!("rotor"));
        assert_eq!(s.canonical["base"], base());
        assert_eq!(s.axes.len(), 1);
        assert_eq!(s.mode, AxisMode::Grid);
    }
}
