//! Spec errors in the project's words: serde's errors reworded with the JSON path in the
//! project's format, and the spec leaves whose `Deserialize` is hand-written with the
//! project's messages (finite numbers, counts, `[first, last, count]`, named choices).

use serde::de::{self, DeserializeOwned, SeqAccess, Visitor};
use serde::{Deserialize, Deserializer};
use serde_json::Value;

use super::schema::{self, hand_schema};
use super::SweepError;

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

// ---------------------------------------------------------------------------------------
// The spec documents are typed by serde derive: unknown fields are refused by
// `deny_unknown_fields`, the JSON path of any error is tracked by serde_path_to_error, and
// the same types give the service's OpenAPI schema (utoipa). Leaves with a project rule
// (numbers, counts, `[first, last, count]`, named choices) have the small hand-written
// `Deserialize` impls below, with the project's messages; checks serde cannot express
// (ranges, exactly one of, axis paths against the base, mode lengths) are functions over
// the typed document in `super::spec`.

/// Deserialises `v` as the document type `T`; an error names its JSON path under `at`
/// (`""` for the document itself) in the project's format (`axes[1].logspace[0]`).
pub fn from_value<T: DeserializeOwned>(v: &Value, at: &str) -> Result<T, SweepError> {
    crate::json::deserialize_located(v).map_err(|e| serde_error(&e, v, at))
}

/// A serde_path_to_error error as a [`SweepError::Spec`]: the path in the project's
/// format, serde's message reworded in the project's terms (`expected an array, got an
/// object`, `unknown field (expected one of: ...)`, `missing`), user input cut short.
fn serde_error(
    e: &serde_path_to_error::Error<serde_json::Error>,
    root: &Value,
    at: &str,
) -> SweepError {
    use serde_path_to_error::Segment;
    let mut path = at.to_string();
    let mut here = Some(root);
    let mut last_key: Option<&str> = None;
    for seg in e.path().iter() {
        last_key = None;
        match seg {
            Segment::Seq { index } => {
                path = format!("{path}[{index}]");
                here = here.and_then(|h| h.get(*index));
            }
            Segment::Map { key } => {
                path = join(&path, &crate::json::quote(key));
                here = here.and_then(|h| h.get(key.as_str()));
                last_key = Some(key);
            }
            Segment::Enum { variant } => {
                path = join(&path, &crate::json::quote(variant));
                here = here.and_then(|h| h.get(variant.as_str()));
            }
            Segment::Unknown => {
                path = join(&path, "?");
                here = None;
            }
        }
    }
    let msg = e.inner().to_string();
    let mut reason = crate::json::shorten(&msg, crate::json::MAX_ECHO_CHARS * 4);
    if let Some(field) = msg
        .strip_prefix("missing field `")
        .and_then(|r| r.strip_suffix('`'))
    {
        path = join(&path, field);
        reason = "missing".into();
    } else if let Some(allowed) =
        last_key.and_then(|k| msg.strip_prefix(&format!("unknown field `{k}`, ")))
    {
        // serde: "expected one of `a`, `b`" / "expected `a` or `b`" / "there are no fields".
        let names: Vec<&str> = allowed.split('`').skip(1).step_by(2).collect();
        reason = if names.is_empty() {
            "unknown field (no fields are allowed here)".into()
        } else {
            format!("unknown field (expected one of: {})", names.join(", "))
        };
        if let Some(hint) = crate::json::unknown_field_hint(&msg) {
            reason.push_str(&hint);
        }
    } else if let Some((_, expected)) = msg
        .strip_prefix("invalid type: ")
        .and_then(|r| r.rsplit_once(", expected "))
    {
        let got = here.map_or("something else", type_name);
        reason = format!("expected {}, got {got}", expected_in_words(expected));
    } else if let Some((_, expected)) = msg
        .strip_prefix("invalid length ")
        .and_then(|r| r.split_once(", expected "))
    {
        reason = format!("expected {}", expected_in_words(expected));
    }
    SweepError::spec(if path.is_empty() { "$".into() } else { path }, reason)
}

/// serde's `expected ...` phrase for the types used here, in the project's words.
fn expected_in_words(expected: &str) -> &str {
    match expected {
        "a sequence" | "sequence" => "an array",
        "a map" | "map" => "an object",
        "f64" | "f32" => "a number",
        "u64" | "u32" | "usize" => "a non-negative integer",
        e if e.starts_with("struct ") => "an object",
        e => e,
    }
}

/// For optional fields: absent means `None` (with `#[serde(default)]`), but `null` is
/// refused like any other wrong type (`expected a string, got null`), as before.
pub fn present<'de, D: Deserializer<'de>, T: Deserialize<'de>>(
    d: D,
) -> Result<Option<T>, D::Error> {
    T::deserialize(d).map(Some)
}

/// A JSON number (finite: `crate::json::parse_json` refuses the rest).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Num(pub f64);

impl<'de> Deserialize<'de> for Num {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = Value::deserialize(d)?;
        let x = v.as_f64().ok_or_else(|| {
            de::Error::custom(format!("expected a number, got {}", type_name(&v)))
        })?;
        if !x.is_finite() {
            return Err(de::Error::custom("must be finite"));
        }
        Ok(Num(x))
    }
}

/// A non-negative integer; integral floats such as `5.0` or `1e3` are accepted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Count(pub u64);

impl<'de> Deserialize<'de> for Count {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = Value::deserialize(d)?;
        if let Some(n) = v.as_u64() {
            return Ok(Count(n));
        }
        let got = match v.as_f64() {
            Some(x) if x >= 0.0 && x.fract() == 0.0 && x <= u64::MAX as f64 => {
                return Ok(Count(x as u64))
            }
            Some(x) => crate::json::num(x),
            None => type_name(&v).to_string(),
        };
        Err(de::Error::custom(format!(
            "expected a non-negative integer, got {got}"
        )))
    }
}

/// `[first, last, count]` of a `linspace` or `logspace`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range3 {
    /// First value.
    pub first: f64,
    /// Last value.
    pub last: f64,
    /// Number of values (checked by the caller: >= 1).
    pub count: u64,
}

impl<'de> Deserialize<'de> for Range3 {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Range3;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("[first, last, count]")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Range3, A::Error> {
                let short = || de::Error::custom("expected [first, last, count]");
                let first = seq.next_element::<Num>()?.ok_or_else(short)?.0;
                let last = seq.next_element::<Num>()?.ok_or_else(short)?.0;
                let count = seq.next_element::<Count>()?.ok_or_else(short)?.0;
                if seq.next_element::<de::IgnoredAny>()?.is_some() {
                    return Err(short());
                }
                Ok(Range3 { first, last, count })
            }
        }
        d.deserialize_seq(V)
    }
}

hand_schema!(
    Num,
    "SpecNumber",
    schema::typed(utoipa::openapi::Type::Number, "A finite number")
);
hand_schema!(
    Count,
    "SpecCount",
    schema::count("A non-negative integer (integral floats such as 1e3 are accepted)")
);
hand_schema!(
    Range3,
    "SpecRange",
    schema::range3("[first, last, count]: count values from first to last, both included")
);

/// One of `names` (a string), for the hand-written `Deserialize` of named choices; the
/// error lists them: `expected "run" or "window", got "all"`.
pub fn one_of_names<T: Copy>(v: &Value, names: &[(&str, T)]) -> Result<T, String> {
    if let Some(t) = v
        .as_str()
        .and_then(|s| names.iter().find(|(n, _)| *n == s).map(|(_, t)| *t))
    {
        return Ok(t);
    }
    let quoted: Vec<String> = names.iter().map(|(n, _)| format!("\"{n}\"")).collect();
    let list = match quoted.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
        _ => quoted.join(""),
    };
    let got = match v {
        Value::String(s) => format!("\"{}\"", crate::json::quote(s)),
        other => type_name(other).to_string(),
    };
    Err(format!("expected {list}, got {got}"))
}
