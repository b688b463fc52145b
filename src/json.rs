//! JSON input helpers shared by every command: deserialisation errors located at their
//! JSON path (`bearings[1].clearance`, `film.thresh`), so messages name the field.
//!
//! Every JSON input (spec, scene, eval) is read with [`parse_json`], which refuses
//! duplicate keys (serde_json alone keeps the last one silently), and deserialised with
//! [`deserialize_at`], which refuses a struct written as an array (serde's derive alone
//! accepts `[0.02, 0.02, 3e-4, 0.0242]` for a bearing). Messages quote user input through
//! [`quote`] and numbers through [`num`], so they stay short.

use std::fmt;

use serde::de::{
    self, DeserializeOwned, DeserializeSeed, IntoDeserializer, MapAccess, SeqAccess, Visitor,
};
use serde::Deserializer;
use serde_json::{Map, Value};

/// Most characters of user input echoed in a message (keys, strings, paths).
pub const MAX_ECHO_CHARS: usize = 80;

/// Most characters of a whole error message (a backstop for messages built elsewhere).
pub const MAX_MESSAGE_CHARS: usize = 2000;

/// `text` cut to `max` characters, with the number of characters left out.
pub fn shorten(text: &str, max: usize) -> String {
    match text.char_indices().nth(max) {
        None => text.to_string(),
        Some((cut, _)) => {
            let rest = text[cut..].chars().count();
            format!("{}… ({rest} more characters)", &text[..cut])
        }
    }
}

/// User input echoed in a message: cut to [`MAX_ECHO_CHARS`].
pub fn quote(text: &str) -> String {
    shorten(text, MAX_ECHO_CHARS)
}

/// A number for a message: plain where short (`0.5`, `120`), scientific otherwise
/// (`1e308` instead of 309 digits), `infinity`/`NaN` spelled out.
pub fn num(x: f64) -> String {
    if x.is_nan() {
        "NaN".into()
    } else if x.is_infinite() {
        if x > 0.0 { "infinity" } else { "-infinity" }.into()
    } else if x == 0.0 || (1e-4..1e7).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// A JSON document that cannot be used: the path inside it and the reason.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct JsonError {
    /// JSON path (`$` for the document itself).
    pub path: String,
    /// What is wrong.
    pub reason: String,
}

/// One step of the path being parsed, kept on the stack (no allocation per value).
#[derive(Clone, Copy)]
enum Step<'a> {
    Root,
    Key(&'a Step<'a>, &'a str),
    Index(&'a Step<'a>, usize),
}

impl Step<'_> {
    fn path(&self) -> String {
        match self {
            Step::Root => String::new(),
            Step::Key(parent, k) => join_path(&parent.path(), &quote(k)),
            Step::Index(parent, i) => format!("{}[{i}]", parent.path()),
        }
    }
}

/// Marker that separates our located errors from serde_json's own (syntax) errors.
pub(crate) const LOCATED_MARK: &str = "\u{1}located\u{1}";

fn located<E: de::Error>(at: &Step<'_>, reason: &str) -> E {
    let p = at.path();
    E::custom(format!(
        "{LOCATED_MARK}{}{LOCATED_MARK}{reason}",
        if p.is_empty() { "$" } else { &p }
    ))
}

/// Builds a `Value`, refusing duplicate keys.
struct StrictValue<'a>(Step<'a>);

impl<'de> DeserializeSeed<'de> for StrictValue<'_> {
    type Value = Value;
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<Value, D::Error> {
        d.deserialize_any(self)
    }
}

impl<'de> Visitor<'de> for StrictValue<'_> {
    type Value = Value;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("any JSON value")
    }
    fn visit_bool<E>(self, v: bool) -> Result<Value, E> {
        Ok(Value::Bool(v))
    }
    fn visit_i64<E>(self, v: i64) -> Result<Value, E> {
        Ok(Value::from(v))
    }
    fn visit_u64<E>(self, v: u64) -> Result<Value, E> {
        Ok(Value::from(v))
    }
    fn visit_f64<E: de::Error>(self, v: f64) -> Result<Value, E> {
        serde_json::Number::from_f64(v)
            .map(Value::Number)
            .ok_or_else(|| located(&self.0, "number out of range"))
    }
    fn visit_str<E>(self, v: &str) -> Result<Value, E> {
        Ok(Value::String(v.to_string()))
    }
    fn visit_string<E>(self, v: String) -> Result<Value, E> {
        Ok(Value::String(v))
    }
    fn visit_unit<E>(self) -> Result<Value, E> {
        Ok(Value::Null)
    }
    fn visit_none<E>(self) -> Result<Value, E> {
        Ok(Value::Null)
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Value, A::Error> {
        let mut out = Vec::new();
        loop {
            let step = Step::Index(&self.0, out.len());
            match seq.next_element_seed(StrictValue(step))? {
                Some(v) => out.push(v),
                None => return Ok(Value::Array(out)),
            }
        }
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Value, A::Error> {
        let mut out = Map::new();
        while let Some(key) = map.next_key::<String>()? {
            let step = Step::Key(&self.0, &key);
            if out.contains_key(&key) {
                return Err(located(
                    &step,
                    "duplicate key (JSON objects must not repeat a key; which one was meant?)",
                ));
            }
            let v = map.next_value_seed(StrictValue(step))?;
            out.insert(key, v);
        }
        Ok(Value::Object(out))
    }
}

/// Splits an error from the strict parse into its path and reason.
pub(crate) fn split_error(e: serde_json::Error) -> JsonError {
    let text = e.to_string();
    if let Some(rest) = text.strip_prefix(LOCATED_MARK) {
        if let Some((path, reason)) = rest.split_once(LOCATED_MARK) {
            // serde_json appends " at line L column C": keep it, it helps in big files.
            return JsonError {
                path: path.to_string(),
                reason: reason.to_string(),
            };
        }
    }
    let reason = shorten(&text, MAX_ECHO_CHARS * 4);
    JsonError {
        path: "$".into(),
        reason: match e.classify() {
            // Valid JSON of the wrong shape (e.g. an array where an object belongs).
            serde_json::error::Category::Data => reason,
            _ => format!("not valid JSON: {reason}"),
        },
    }
}

/// Parses JSON text into a `Value`, refusing duplicate keys (naming the key's path) and
/// anything after the document.
pub fn parse_json(text: &str) -> Result<Value, JsonError> {
    let mut de = serde_json::Deserializer::from_str(text);
    let v = StrictValue(Step::Root)
        .deserialize(&mut de)
        .map_err(split_error)?;
    de.end().map_err(split_error)?;
    Ok(v)
}

/// Parses one value of a larger document at `key` or `key[index]` (e.g. one element of
/// `states` while streaming), refusing duplicate keys with their full path. For use
/// inside a serde visitor.
#[derive(Clone, Copy, Debug)]
pub struct StrictSeed<'a> {
    /// Top-level key the value sits under.
    pub key: &'a str,
    /// Index inside that key's array, if any.
    pub index: Option<usize>,
}

impl<'de> DeserializeSeed<'de> for StrictSeed<'_> {
    type Value = Value;
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<Value, D::Error> {
        let root = Step::Root;
        let key = Step::Key(&root, self.key);
        match self.index {
            Some(i) => StrictValue(Step::Index(&key, i)).deserialize(d),
            None => StrictValue(key).deserialize(d),
        }
    }
}

/// A `Value` deserializer that refuses a sequence where a struct is expected; otherwise
/// exactly `serde_json::Value`'s behaviour.
struct Strict<'a>(&'a Value);

type VErr = serde_json::Error;

macro_rules! forward {
    ($($m:ident),*) => {$(
        fn $m<V: Visitor<'de>>(self, v: V) -> Result<V::Value, VErr> {
            self.0.$m(v)
        }
    )*};
}

impl<'de, 'a> Deserializer<'de> for Strict<'a>
where
    'a: 'de,
{
    type Error = VErr;

    fn deserialize_any<V: Visitor<'de>>(self, v: V) -> Result<V::Value, VErr> {
        match self.0 {
            Value::Array(a) => v.visit_seq(StrictSeq(a.iter())),
            Value::Object(m) => v.visit_map(StrictMap {
                iter: m.iter(),
                value: None,
            }),
            other => other.deserialize_any(v),
        }
    }

    fn deserialize_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        _fields: &'static [&'static str],
        v: V,
    ) -> Result<V::Value, VErr> {
        match self.0 {
            Value::Object(_) => self.deserialize_any(v),
            Value::Array(_) => Err(de::Error::custom(
                "expected an object with named fields, got an array (write {\"field\": value, ...})",
            )),
            other => other.deserialize_any(v),
        }
    }

    fn deserialize_map<V: Visitor<'de>>(self, v: V) -> Result<V::Value, VErr> {
        self.deserialize_any(v)
    }
    fn deserialize_seq<V: Visitor<'de>>(self, v: V) -> Result<V::Value, VErr> {
        self.deserialize_any(v)
    }
    fn deserialize_tuple<V: Visitor<'de>>(self, _len: usize, v: V) -> Result<V::Value, VErr> {
        self.deserialize_any(v)
    }
    fn deserialize_tuple_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        _len: usize,
        v: V,
    ) -> Result<V::Value, VErr> {
        self.deserialize_any(v)
    }
    fn deserialize_option<V: Visitor<'de>>(self, v: V) -> Result<V::Value, VErr> {
        match self.0 {
            Value::Null => v.visit_none(),
            _ => v.visit_some(self),
        }
    }
    fn deserialize_newtype_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        v: V,
    ) -> Result<V::Value, VErr> {
        v.visit_newtype_struct(self)
    }
    fn deserialize_enum<V: Visitor<'de>>(
        self,
        name: &'static str,
        variants: &'static [&'static str],
        v: V,
    ) -> Result<V::Value, VErr> {
        match self.0 {
            Value::String(s) => v.visit_enum(s.as_str().into_deserializer()),
            other => other.deserialize_enum(name, variants, v),
        }
    }
    forward!(
        deserialize_bool,
        deserialize_i8,
        deserialize_i16,
        deserialize_i32,
        deserialize_i64,
        deserialize_u8,
        deserialize_u16,
        deserialize_u32,
        deserialize_u64,
        deserialize_f32,
        deserialize_f64,
        deserialize_char,
        deserialize_str,
        deserialize_string,
        deserialize_bytes,
        deserialize_byte_buf,
        deserialize_unit,
        deserialize_identifier,
        deserialize_ignored_any
    );
    fn deserialize_unit_struct<V: Visitor<'de>>(
        self,
        name: &'static str,
        v: V,
    ) -> Result<V::Value, VErr> {
        self.0.deserialize_unit_struct(name, v)
    }
}

struct StrictSeq<'a>(std::slice::Iter<'a, Value>);

impl<'de, 'a: 'de> SeqAccess<'de> for StrictSeq<'a> {
    type Error = VErr;
    fn next_element_seed<T: DeserializeSeed<'de>>(
        &mut self,
        seed: T,
    ) -> Result<Option<T::Value>, VErr> {
        self.0
            .next()
            .map(|v| seed.deserialize(Strict(v)))
            .transpose()
    }
    fn size_hint(&self) -> Option<usize> {
        Some(self.0.len())
    }
}

struct StrictMap<'a> {
    iter: serde_json::map::Iter<'a>,
    value: Option<&'a Value>,
}

impl<'de, 'a: 'de> MapAccess<'de> for StrictMap<'a> {
    type Error = VErr;
    fn next_key_seed<K: DeserializeSeed<'de>>(
        &mut self,
        seed: K,
    ) -> Result<Option<K::Value>, VErr> {
        match self.iter.next() {
            Some((k, v)) => {
                self.value = Some(v);
                seed.deserialize(k.as_str().into_deserializer()).map(Some)
            }
            None => Ok(None),
        }
    }
    fn next_value_seed<S: DeserializeSeed<'de>>(&mut self, seed: S) -> Result<S::Value, VErr> {
        let v = self
            .value
            .take()
            .ok_or_else(|| <VErr as de::Error>::custom("value without a key"))?;
        seed.deserialize(Strict(v))
    }
}

/// Deserialises `value` as `T`; on failure returns the JSON path of the offending field
/// (`"$"` for the document itself) and serde's reason (user input in it cut short; an
/// unknown field's reason ends with the nearest allowed name, [`did_you_mean`]).
/// A struct given as an array is refused.
pub fn deserialize_at<T: DeserializeOwned>(value: &Value) -> Result<T, (String, String)> {
    serde_path_to_error::deserialize(Strict(value)).map_err(|e| {
        let path = e.path().to_string();
        let path = if path == "." || path.is_empty() {
            "$".to_string()
        } else {
            shorten(&path, MAX_ECHO_CHARS * 2)
        };
        let msg = e.into_inner().to_string();
        let mut reason = shorten(&msg, MAX_ECHO_CHARS * 3);
        if let Some(hint) = unknown_field_hint(&msg) {
            reason.push_str(&hint);
        }
        (path, reason)
    })
}

/// For serde's "unknown field `x`, expected one of `a`, `b`" (or "expected `a` or `b`"):
/// `"; did you mean `a`?"` when an allowed name is near `x`, else `None`.
pub fn unknown_field_hint(serde_message: &str) -> Option<String> {
    let rest = serde_message.strip_prefix("unknown field `")?;
    let (unknown, allowed) = rest.split_once("`, ")?;
    let names: Vec<&str> = allowed.split('`').skip(1).step_by(2).collect();
    did_you_mean(unknown, &names).map(|n| format!("; did you mean `{n}`?"))
}

/// The allowed name nearest to the unknown one `unknown`, if near enough to be a typo:
/// edit distance (insertions, deletions, substitutions, adjacent swaps; ASCII case
/// ignored) at most 1 for names up to 4 characters, 2 up to 8, 3 beyond, or `unknown` a
/// prefix of at least 3 characters of exactly one name (`visc` for `viscosity`).
pub fn did_you_mean<'a>(unknown: &str, allowed: &[&'a str]) -> Option<&'a str> {
    let u = unknown.to_ascii_lowercase();
    let limit = match u.chars().count() {
        0..=4 => 1,
        5..=8 => 2,
        _ => 3,
    };
    let best = allowed
        .iter()
        .map(|a| (edit_distance(&u, &a.to_ascii_lowercase()), *a))
        .min_by_key(|(d, _)| *d);
    if let Some((d, name)) = best {
        if d <= limit {
            return Some(name);
        }
    }
    let prefixed: Vec<&&str> = allowed
        .iter()
        .filter(|a| u.len() >= 3 && a.to_ascii_lowercase().starts_with(&u))
        .collect();
    match prefixed.as_slice() {
        [one] => Some(one),
        _ => None,
    }
}

/// Optimal-string-alignment distance (Levenshtein with adjacent transpositions).
fn edit_distance(a: &str, b: &str) -> usize {
    let a: Vec<char> = a.chars().collect();
    let b: Vec<char> = b.chars().collect();
    let mut d = vec![vec![0usize; b.len() + 1]; a.len() + 1];
    for (i, row) in d.iter_mut().enumerate() {
        row[0] = i;
    }
    for (j, cell) in d[0].iter_mut().enumerate() {
        *cell = j;
    }
    for i in 1..=a.len() {
        for j in 1..=b.len() {
            let cost = usize::from(a[i - 1] != b[j - 1]);
            let mut v = (d[i - 1][j] + 1)
                .min(d[i][j - 1] + 1)
                .min(d[i - 1][j - 1] + cost);
            if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                v = v.min(d[i - 2][j - 2] + 1);
            }
            d[i][j] = v;
        }
    }
    d[a.len()][b.len()]
}

/// Deserialises `value` as `T` exactly as [`deserialize_at`] does (a struct given as an
/// array is refused), keeping serde_path_to_error's structured error: the path segments and
/// serde's own error, for callers that word their messages themselves (the sweep spec).
pub fn deserialize_located<T: DeserializeOwned>(
    value: &Value,
) -> Result<T, serde_path_to_error::Error<serde_json::Error>> {
    serde_path_to_error::deserialize(Strict(value))
}

/// `prefix` joined with a path from [`deserialize_at`] (`"$"` means the prefix itself).
pub fn join_path(prefix: &str, path: &str) -> String {
    match (prefix, path) {
        ("" | "$", p) => p.to_string(),
        (pre, "$") => pre.to_string(),
        (pre, p) if p.starts_with('[') => format!("{pre}{p}"),
        (pre, p) => format!("{pre}.{p}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bearing-like leaf (this module sits below `bearing`, so it does not use
    /// `BearingParams` itself).
    #[derive(Debug, serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct Bearing {
        radius: f64,
        length: f64,
        clearance: f64,
        viscosity: f64,
    }

    #[test]
    fn unknown_fields_get_the_nearest_allowed_name() {
        let names = [
            "radius",
            "length",
            "clearance",
            "viscosity",
            "clearance_convention",
            "model",
        ];
        for (typo, want) in [
            ("viscosty", Some("viscosity")),
            ("Viscosity", Some("viscosity")),
            ("clearence", Some("clearance")),
            ("lenght", Some("length")),
            ("radus", Some("radius")),
            ("visc", Some("viscosity")),
            ("mdoel", Some("model")),
            ("speed", None),
            ("xyz", None),
        ] {
            assert_eq!(did_you_mean(typo, &names), want, "{typo}");
        }
        // Through the deserialiser: the reason ends with the hint, the path is the field's.
        #[derive(serde::Deserialize, Debug)]
        #[serde(deny_unknown_fields)]
        #[allow(dead_code)]
        struct B {
            radius: f64,
            viscosity: f64,
        }
        let v: Value = serde_json::from_str(r#"{"radius": 1, "viscosty": 2}"#).unwrap();
        let (path, reason) = deserialize_at::<B>(&v).unwrap_err();
        assert_eq!(path, "viscosty", "{reason}");
        assert!(
            reason.contains("unknown field") && reason.ends_with("did you mean `viscosity`?"),
            "{reason}"
        );
    }

    #[derive(Debug, serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct Doc {
        bearings: Vec<Bearing>,
    }

    #[test]
    fn unknown_and_mistyped_fields_are_located() {
        let v: Value = serde_json::from_str(
            r#"{"bearings": [{"radius": 0.02, "length": 0.02, "clearance": 3e-4, "viscosity": 0.02},
                             {"radius": 0.02, "length": 0.02, "clerance": 3e-4, "viscosity": 0.02}]}"#,
        )
        .unwrap();
        let (path, reason) = deserialize_at::<Doc>(&v).unwrap_err();
        assert_eq!(path, "bearings[1].clerance", "{reason}");
        assert!(reason.contains("unknown field"), "{reason}");
        let v: Value = serde_json::from_str(
            r#"{"bearings": [{"radius": "big", "length": 1, "clearance": 1, "viscosity": 1}]}"#,
        )
        .unwrap();
        let (path, _) = deserialize_at::<Doc>(&v).unwrap_err();
        assert_eq!(path, "bearings[0].radius");
        assert_eq!(
            join_path("scenes[2]", "film.thresh"),
            "scenes[2].film.thresh"
        );
        assert_eq!(join_path("scenes[2]", "$"), "scenes[2]");
        assert_eq!(join_path("$", "a[1]"), "a[1]");
    }

    #[test]
    fn duplicate_keys_are_refused_with_their_path() {
        let e = parse_json(r#"{"a": [1, {"b": 1, "c": {"d": 2, "d": 3}}]}"#).unwrap_err();
        assert_eq!(e.path, "a[1].c.d", "{e:?}");
        assert!(e.reason.contains("duplicate key"), "{e:?}");
        let e = parse_json(r#"{"k": 1, "k": 1}"#).unwrap_err();
        assert_eq!(e.path, "k");
        let e = parse_json(r#"{"k": 1} x"#).unwrap_err();
        assert_eq!(e.path, "$");
        assert!(e.reason.contains("not valid JSON"), "{e:?}");
        let v = parse_json(r#"{"a": [1, 2.5, -3, null, true, "s", {}]}"#).unwrap();
        assert_eq!(
            v,
            serde_json::json!({"a": [1, 2.5, -3, null, true, "s", {}]})
        );
    }

    #[test]
    fn a_struct_written_as_an_array_is_refused() {
        let v = serde_json::json!({"bearings": [[0.02, 0.02, 3e-4, 0.0242]]});
        let (path, reason) = deserialize_at::<Doc>(&v).unwrap_err();
        assert_eq!(path, "bearings[0]", "{reason}");
        assert!(reason.contains("got an array"), "{reason}");
    }

    #[test]
    fn echoed_input_and_numbers_stay_short() {
        let long = "x".repeat(10_000);
        assert!(quote(&long).len() < 200);
        assert!(quote(&long).contains("9920 more characters"));
        assert_eq!(num(1e308), "1e308");
        assert_eq!(num(0.5), "0.5");
        assert_eq!(num(f64::INFINITY), "infinity");
        assert_eq!(num(-2.5e-9), "-2.5e-9");
    }
}
