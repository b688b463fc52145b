//! JSON input helpers shared by every command: deserialisation errors located at their
//! JSON path (`bearings[1].clearance`, `film.thresh`), so messages name the field.

use serde::de::DeserializeOwned;
use serde_json::Value;

/// Deserialises `value` as `T`; on failure returns the JSON path of the offending field
/// (`"$"` for the document itself) and serde's reason.
pub fn deserialize_at<T: DeserializeOwned>(value: &Value) -> Result<T, (String, String)> {
    serde_path_to_error::deserialize(value).map_err(|e| {
        let path = e.path().to_string();
        let path = if path == "." || path.is_empty() {
            "$".to_string()
        } else {
            path
        };
        (path, e.into_inner().to_string())
    })
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
    use crate::bearing::BearingParams;

    #[derive(Debug, serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct Doc {
        bearings: Vec<BearingParams>,
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
}
