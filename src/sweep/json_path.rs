//! Axis paths into a JSON scene (`bearings[*].clearance`, `rotor.mass`): parsing, resolving
//! against the base scene, and setting every location a path addresses.

use serde_json::Value;

use super::wording::{join, type_name};

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
