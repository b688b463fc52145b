//! The sweep spec: parsing and validation on `serde_json::Value`, every error naming the
//! JSON path inside the spec and the reason, all before any computation.
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
//! The README's "Sweeps" section documents every field.

use std::collections::BTreeMap;
use std::path::Path;

use serde_json::{Map, Value};

use super::reduce::ReductionOptions;
use super::SweepError;

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
    /// integration; `crate::stability::StabilitySimulator`).
    Stability,
}

impl SweepKind {
    /// The name used in the spec's `kind` field.
    pub fn name(self) -> &'static str {
        match self {
            SweepKind::Rotor => "rotor",
            SweepKind::Synthetic => "synthetic",
            SweepKind::Stability => "stability",
        }
    }
}

/// One segment of an axis path.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum PathSeg {
    /// An object key.
    Key(String),
    /// One array element.
    Index(usize),
    /// Every element of an array (`[*]`).
    All,
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
pub enum Mode {
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
    pub mode: Mode,
    /// What each variant keeps.
    pub reductions: ReductionOptions,
    /// SVG plots written with a complete result.
    pub plots: Vec<super::plots::PlotSpec>,
    /// The spec with `base` inlined: echoed in outputs and hashed to recognise a resume.
    pub canonical: Value,
}

/// Top-level fields of a scene sweep spec.
const SPEC_FIELDS: &[&str] = &[
    "kind",
    "name",
    "description",
    "base",
    "axes",
    "mode",
    "reductions",
    "plots",
];

/// Rejects any key of `obj` not in `allowed`, naming its path.
pub fn deny_unknown(
    obj: &Map<String, Value>,
    prefix: &str,
    allowed: &[&str],
) -> Result<(), SweepError> {
    for key in obj.keys() {
        if !allowed.contains(&key.as_str()) {
            return Err(SweepError::spec(
                join(prefix, &crate::json::quote(key)),
                format!("unknown field (expected one of: {})", allowed.join(", ")),
            ));
        }
    }
    Ok(())
}

/// `prefix.key`, or `key` at the top level.
pub fn join(prefix: &str, key: &str) -> String {
    if prefix.is_empty() {
        key.to_string()
    } else {
        format!("{prefix}.{key}")
    }
}

/// A JSON type name for error messages.
pub fn type_name(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}

/// A finite number at `path`.
pub fn get_f64(v: &Value, path: &str) -> Result<f64, SweepError> {
    let x = v.as_f64().ok_or_else(|| {
        SweepError::spec(path, format!("expected a number, got {}", type_name(v)))
    })?;
    if !x.is_finite() {
        return Err(SweepError::spec(path, "must be finite"));
    }
    Ok(x)
}

/// A non-negative integer at `path`.
pub fn get_u64(v: &Value, path: &str) -> Result<u64, SweepError> {
    if let Some(n) = v.as_u64() {
        return Ok(n);
    }
    // Accept integral floats such as `5.0` or `1e3`.
    match v.as_f64() {
        Some(x) if x >= 0.0 && x.fract() == 0.0 && x <= u64::MAX as f64 => Ok(x as u64),
        Some(x) => Err(SweepError::spec(
            path,
            format!(
                "expected a non-negative integer, got {}",
                crate::json::num(x)
            ),
        )),
        None => Err(SweepError::spec(
            path,
            format!("expected a non-negative integer, got {}", type_name(v)),
        )),
    }
}

/// Parses a sweep spec document. `spec_dir` resolves a `base` given as a file name.
/// Detects the kind only; `kind: "friction_map"` documents are parsed by
/// [`super::friction_map`] (see [`spec_kind`]).
pub fn parse_spec(doc: &Value, spec_dir: Option<&Path>) -> Result<SweepSpec, SweepError> {
    let obj = doc.as_object().ok_or_else(|| {
        SweepError::spec("$", format!("expected an object, got {}", type_name(doc)))
    })?;
    deny_unknown(obj, "", SPEC_FIELDS)?;
    let kind = match obj.get("kind").map(|k| (k, k.as_str())) {
        None | Some((_, Some("rotor"))) => SweepKind::Rotor,
        Some((_, Some("synthetic"))) => SweepKind::Synthetic,
        Some((_, Some("stability"))) => SweepKind::Stability,
        Some((_, Some(other))) => {
            return Err(SweepError::spec(
                "kind",
                format!(
                    "unknown kind `{}` (expected rotor, synthetic, stability or friction_map)",
                    crate::json::quote(other)
                ),
            ))
        }
        Some((k, None)) => {
            return Err(SweepError::spec(
                "kind",
                format!("expected a string, got {}", type_name(k)),
            ))
        }
    };
    let name = match obj.get("name") {
        None => None,
        Some(Value::String(s)) => Some(s.clone()),
        Some(v) => {
            return Err(SweepError::spec(
                "name",
                format!("expected a string, got {}", type_name(v)),
            ))
        }
    };
    if let Some(v) = obj.get("description") {
        if !v.is_string() {
            return Err(SweepError::spec(
                "description",
                format!("expected a string, got {}", type_name(v)),
            ));
        }
    }
    let base = match obj.get("base") {
        None => return Err(SweepError::spec("base", "missing (the base scene)")),
        Some(Value::String(file)) => {
            let path = match spec_dir {
                Some(dir) => dir.join(file),
                None => Path::new(file).to_path_buf(),
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
        Some(v @ Value::Object(_)) => v.clone(),
        Some(v) => {
            return Err(SweepError::spec(
                "base",
                format!(
                    "expected the scene object or a file name, got {}",
                    type_name(v)
                ),
            ))
        }
    };
    let axes = match obj.get("axes") {
        None => Vec::new(),
        Some(Value::Array(list)) => list
            .iter()
            .enumerate()
            .map(|(k, a)| parse_axis(a, &format!("axes[{k}]"), &base))
            .collect::<Result<Vec<_>, _>>()?,
        Some(v) => {
            return Err(SweepError::spec(
                "axes",
                format!("expected an array, got {}", type_name(v)),
            ))
        }
    };
    check_overlaps(&axes, &base)?;
    let mode = parse_mode(obj.get("mode"))?;
    check_mode(&mode, &axes)?;
    let reductions = ReductionOptions::parse(obj.get("reductions"), "reductions")?;
    let plots = super::plots::parse_plots(obj.get("plots"), &axes)?;
    let mut canonical = obj.clone();
    canonical.insert("base".into(), base.clone());
    canonical.insert("kind".into(), Value::String(kind.name().into()));
    let spec = SweepSpec {
        kind,
        name,
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

/// The `kind` of a spec document, without parsing the rest: `"rotor"` when absent.
pub fn spec_kind(doc: &Value) -> Option<&str> {
    match doc.get("kind") {
        None => Some("rotor"),
        Some(k) => k.as_str(),
    }
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

fn parse_mode(v: Option<&Value>) -> Result<Mode, SweepError> {
    match v {
        None => Ok(Mode::Grid),
        Some(Value::String(s)) if s == "grid" => Ok(Mode::Grid),
        Some(Value::String(s)) if s == "zip" => Ok(Mode::Zip),
        Some(Value::Object(m)) => {
            deny_unknown(m, "mode", &["latin_hypercube"])?;
            let lhs = m
                .get("latin_hypercube")
                .ok_or_else(|| SweepError::spec("mode", "expected {\"latin_hypercube\": {...}}"))?;
            let o = lhs.as_object().ok_or_else(|| {
                SweepError::spec(
                    "mode.latin_hypercube",
                    format!("expected an object, got {}", type_name(lhs)),
                )
            })?;
            deny_unknown(o, "mode.latin_hypercube", &["samples", "seed"])?;
            let samples = get_u64(
                o.get("samples").ok_or_else(|| {
                    SweepError::spec("mode.latin_hypercube.samples", "missing")
                })?,
                "mode.latin_hypercube.samples",
            )?;
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
            let seed = match o.get("seed") {
                None => 0,
                Some(s) => get_u64(s, "mode.latin_hypercube.seed")?,
            };
            Ok(Mode::LatinHypercube { samples, seed })
        }
        Some(v) => Err(SweepError::spec(
            "mode",
            format!(
                "expected \"grid\", \"zip\" or {{\"latin_hypercube\": {{\"samples\": N, \"seed\": S}}}}, got {}",
                match v {
                    Value::String(s) => format!("\"{}\"", crate::json::quote(s)),
                    other => type_name(other).to_string(),
                }
            ),
        )),
    }
}

fn check_mode(mode: &Mode, axes: &[Axis]) -> Result<(), SweepError> {
    match mode {
        Mode::Zip => {
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
        Mode::Grid => {
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
        Mode::LatinHypercube { .. } => {}
    }
    Ok(())
}

fn parse_axis(v: &Value, at: &str, base: &Value) -> Result<Axis, SweepError> {
    let o = v
        .as_object()
        .ok_or_else(|| SweepError::spec(at, format!("expected an object, got {}", type_name(v))))?;
    deny_unknown(o, at, &["path", "values", "linspace", "logspace", "zip"])?;
    let path = match o.get("path") {
        Some(Value::String(s)) => s.clone(),
        Some(p) => {
            return Err(SweepError::spec(
                join(at, "path"),
                format!("expected a string, got {}", type_name(p)),
            ))
        }
        None => return Err(SweepError::spec(join(at, "path"), "missing")),
    };
    let segments = parse_path(&path).map_err(|r| SweepError::spec(join(at, "path"), r))?;
    let present: Vec<&str> = ["values", "linspace", "logspace"]
        .into_iter()
        .filter(|k| o.contains_key(*k))
        .collect();
    if present.len() != 1 {
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
        ));
    }
    let which = present[0];
    let field = join(at, which);
    let spec_v = &o[which];
    let values = if which == "values" {
        let list = spec_v.as_array().ok_or_else(|| {
            SweepError::spec(
                &field,
                format!("expected an array, got {}", type_name(spec_v)),
            )
        })?;
        if list.is_empty() {
            return Err(SweepError::spec(&field, "must hold at least one value"));
        }
        AxisValues::List(list.clone())
    } else {
        let arr = spec_v
            .as_array()
            .filter(|a| a.len() == 3)
            .ok_or_else(|| SweepError::spec(&field, "expected [first, last, count]"))?;
        let a = get_f64(&arr[0], &format!("{field}[0]"))?;
        let b = get_f64(&arr[1], &format!("{field}[1]"))?;
        let n = get_u64(&arr[2], &format!("{field}[2]"))?;
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
        if which == "logspace" {
            for (k, x) in [(0, a), (1, b)] {
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
                a,
                b,
                n: n as usize,
            }
        } else {
            AxisValues::Linspace {
                a,
                b,
                n: n as usize,
            }
        }
    };
    let zip = match o.get("zip") {
        None => None,
        Some(Value::String(s)) => Some(s.clone()),
        Some(z) => {
            return Err(SweepError::spec(
                join(at, "zip"),
                format!("expected a group name (string), got {}", type_name(z)),
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
        path,
        segments,
        values,
        zip,
    })
}

/// Parses `key(.key|[n]|[*])*`.
pub fn parse_path(path: &str) -> Result<Vec<PathSeg>, String> {
    let bad = |pos: usize, why: &str| {
        format!(
            "cannot parse path `{}` at character {pos}: {why}",
            crate::json::quote(path)
        )
    };
    let bytes = path.as_bytes();
    let mut segs = Vec::new();
    let mut i = 0;
    let key_char = |c: u8| c.is_ascii_alphanumeric() || c == b'_' || c == b'-';
    let mut expect_key = true;
    while i < bytes.len() {
        if expect_key {
            let start = i;
            while i < bytes.len() && key_char(bytes[i]) {
                i += 1;
            }
            if i == start {
                return Err(bad(i, "expected a field name"));
            }
            segs.push(PathSeg::Key(path[start..i].to_string()));
            expect_key = false;
        } else if bytes[i] == b'.' {
            i += 1;
            expect_key = true;
            if i == bytes.len() {
                return Err(bad(i, "expected a field name after `.`"));
            }
        } else if bytes[i] == b'[' {
            let close = path[i..]
                .find(']')
                .map(|k| i + k)
                .ok_or_else(|| bad(i, "unclosed `[`"))?;
            let inner = &path[i + 1..close];
            if inner == "*" {
                segs.push(PathSeg::All);
            } else {
                let n: usize = inner
                    .parse()
                    .map_err(|_| bad(i + 1, "expected an index or `*` inside `[]`"))?;
                segs.push(PathSeg::Index(n));
            }
            i = close + 1;
        } else {
            return Err(bad(i, "expected `.` or `[`"));
        }
    }
    if segs.is_empty() {
        return Err("empty path".into());
    }
    Ok(segs)
}

/// Every concrete location `segments` addresses in `root`, as (path, value). Errors name
/// the first missing part.
pub fn resolve<'a>(
    root: &'a Value,
    segments: &[PathSeg],
) -> Result<Vec<(String, &'a Value)>, String> {
    let mut out = Vec::new();
    resolve_into(root, segments, String::new(), &mut out)?;
    Ok(out)
}

fn resolve_into<'a>(
    v: &'a Value,
    segments: &[PathSeg],
    at: String,
    out: &mut Vec<(String, &'a Value)>,
) -> Result<(), String> {
    let Some((seg, rest)) = segments.split_first() else {
        out.push((at, v));
        return Ok(());
    };
    let shown = if at.is_empty() {
        "the base scene".to_string()
    } else {
        format!("`{}`", crate::json::quote(&at))
    };
    match seg {
        PathSeg::Key(k) => {
            let o = v
                .as_object()
                .ok_or_else(|| format!("{shown} is {}, not an object", type_name(v)))?;
            let child = o.get(k).ok_or_else(|| {
                format!(
                    "{shown} has no field `{}` (write the field into `base` to sweep it; it has: {})",
                    crate::json::quote(k),
                    crate::json::shorten(&o.keys().cloned().collect::<Vec<_>>().join(", "), 400)
                )
            })?;
            resolve_into(child, rest, join(&at, k), out)
        }
        PathSeg::Index(n) => {
            let a = v
                .as_array()
                .ok_or_else(|| format!("{shown} is {}, not an array", type_name(v)))?;
            let child = a
                .get(*n)
                .ok_or_else(|| format!("{shown} has {} elements, no index {n}", a.len()))?;
            resolve_into(child, rest, format!("{at}[{n}]"), out)
        }
        PathSeg::All => {
            let a = v
                .as_array()
                .ok_or_else(|| format!("{shown} is {}, not an array", type_name(v)))?;
            if a.is_empty() {
                return Err(format!("{shown} is an empty array"));
            }
            for (k, child) in a.iter().enumerate() {
                resolve_into(child, rest, format!("{at}[{k}]"), out)?;
            }
            Ok(())
        }
    }
}

/// Sets every location `segments` addresses in `root` to `value` (the locations exist:
/// checked against the base at parse time).
pub fn set_path(root: &mut Value, segments: &[PathSeg], value: &Value) {
    let Some((seg, rest)) = segments.split_first() else {
        *root = value.clone();
        return;
    };
    match seg {
        PathSeg::Key(k) => {
            if let Some(child) = root.get_mut(k.as_str()) {
                set_path(child, rest, value);
            }
        }
        PathSeg::Index(n) => {
            if let Some(child) = root.get_mut(*n) {
                set_path(child, rest, value);
            }
        }
        PathSeg::All => {
            if let Some(arr) = root.as_array_mut() {
                for child in arr {
                    set_path(child, rest, value);
                }
            }
        }
    }
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
        assert_eq!(s.mode, Mode::Grid);
    }
}
