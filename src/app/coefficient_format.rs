//! The output formats of `coefficients`: JSON, or ROSS's bearing CSV and TOML tables
//! (ROSS 2.x and 3.x), parsed from `--format` and rendered from the coefficient document.

use serde_json::Value;

use super::coefficients::{ross_csv, ross_toml, RossVersion, ROSS_TILT_NOTICE};

/// What `coefficients --format` writes on stdout.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CoefficientFormat {
    /// The coefficient document, pretty JSON (the default).
    Json,
    /// ROSS's bearing CSV (`ross-csv`).
    RossCsv,
    /// ROSS 2.x TOML (`ross-toml`).
    RossToml,
    /// ROSS 3.x TOML (`ross3-toml`).
    Ross3Toml,
}

impl std::str::FromStr for CoefficientFormat {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Ok(match s {
            "json" => CoefficientFormat::Json,
            "ross-csv" => CoefficientFormat::RossCsv,
            "ross-toml" => CoefficientFormat::RossToml,
            "ross3-toml" => CoefficientFormat::Ross3Toml,
            other => {
                return Err(format!(
                    "`{other}`: expected json, ross-csv, ross-toml or ross3-toml"
                ))
            }
        })
    }
}

impl CoefficientFormat {
    /// The notice printed on stderr with this format: the ROSS tilt notice for the CSV
    /// and the 2.x TOML (the 3.x TOML carries the tilt terms itself).
    pub fn notice(self) -> Option<&'static str> {
        match self {
            CoefficientFormat::RossCsv | CoefficientFormat::RossToml => Some(ROSS_TILT_NOTICE),
            CoefficientFormat::Json | CoefficientFormat::Ross3Toml => None,
        }
    }

    /// The text written on stdout for the coefficient document `out`.
    pub fn render(self, out: &Value) -> String {
        match self {
            CoefficientFormat::Json => serde_json::to_string_pretty(out).unwrap_or_default() + "\n",
            CoefficientFormat::RossCsv => ross_csv(out),
            CoefficientFormat::RossToml => ross_toml(out, RossVersion::V2),
            CoefficientFormat::Ross3Toml => ross_toml(out, RossVersion::V3),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_parse_by_name_and_refuse_others_naming_the_choices() {
        for (name, f) in [
            ("json", CoefficientFormat::Json),
            ("ross-csv", CoefficientFormat::RossCsv),
            ("ross-toml", CoefficientFormat::RossToml),
            ("ross3-toml", CoefficientFormat::Ross3Toml),
        ] {
            assert_eq!(name.parse::<CoefficientFormat>(), Ok(f));
        }
        assert_eq!(
            "ross".parse::<CoefficientFormat>(),
            Err("`ross`: expected json, ross-csv, ross-toml or ross3-toml".to_string())
        );
        assert_eq!(CoefficientFormat::Ross3Toml.notice(), None);
        assert!(CoefficientFormat::RossCsv.notice().is_some());
    }
}
