//! What a sweep's `reductions` section asks for: the evaluation window, the kept series and
//! their points, the whirl search; the typed documents (serde, JSON paths in every error)
//! and their checked form [`ReductionOptions`].

use std::collections::BTreeSet;

use serde::de::{self, SeqAccess, Visitor};
use serde::{Deserialize, Deserializer};
use serde_json::Value;
use utoipa::ToSchema;

use super::spec::{
    from_value, hand_schema, join, one_of_names, present, schema, type_name, Count, Num,
};
use super::SweepError;

/// The evaluation window.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Window {
    /// The last `N` revolutions of the rotor.
    Revolutions(f64),
    /// The last fraction of the simulated time, in `(0, 1]`.
    Fraction(f64),
    /// The last seconds.
    Seconds(f64),
}

/// Which samples kept series cover.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Span {
    /// The evaluation window.
    Window,
    /// The whole run.
    Run,
}

/// Groups of time series a variant may keep.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum SeriesGroup {
    /// `x_g, y_g` and per bearing `xi, yi, xj, yj`.
    Orbit,
    /// Per bearing `h_min`, `eccentricity_max`.
    Film,
    /// Per bearing `friction_coefficient`, `mz`.
    Friction,
    /// Per bearing `wx`, `wy`.
    Forces,
    /// `spin`.
    Spin,
}

impl SeriesGroup {
    const ALL: [(&'static str, SeriesGroup); 5] = [
        ("orbit", SeriesGroup::Orbit),
        ("film", SeriesGroup::Film),
        ("friction", SeriesGroup::Friction),
        ("forces", SeriesGroup::Forces),
        ("spin", SeriesGroup::Spin),
    ];
}

/// Whirl detection settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WhirlOptions {
    /// Sub-synchronous band of whirl ratios (forward), default `(0.3, 0.6)`.
    pub band: (f64, f64),
    /// Largest `|ratio|` searched, default 2.5.
    pub max_ratio: f64,
    /// Oil whirl when the band peak >= this × the dominant amplitude, default 0.2.
    pub relative_threshold: f64,
    /// ... and >= this × the radial clearance, default 0.01.
    pub min_amplitude_ratio: f64,
}

impl Default for WhirlOptions {
    fn default() -> Self {
        WhirlOptions {
            band: (0.3, 0.6),
            max_ratio: 2.5,
            relative_threshold: 0.2,
            min_amplitude_ratio: 0.01,
        }
    }
}

/// What each variant computes and keeps.
#[derive(Clone, Debug, PartialEq)]
pub struct ReductionOptions {
    /// Evaluation window, default the last half of the run.
    pub window: Window,
    /// Kept series groups, default none.
    pub keep: BTreeSet<SeriesGroup>,
    /// Most samples per kept series (decimated evenly), default 200.
    pub points: usize,
    /// Samples the kept series cover, default the whole run.
    pub span: Span,
    /// Whirl detection.
    pub whirl: WhirlOptions,
}

impl Default for ReductionOptions {
    fn default() -> Self {
        ReductionOptions {
            window: Window::Fraction(0.5),
            keep: BTreeSet::new(),
            points: 200,
            span: Span::Run,
            whirl: WhirlOptions::default(),
        }
    }
}

impl<'de> Deserialize<'de> for SeriesGroup {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = Value::deserialize(d)?;
        SeriesGroup::ALL
            .iter()
            .find(|(n, _)| Some(*n) == v.as_str())
            .map(|(_, g)| *g)
            .ok_or_else(|| {
                let shown = match &v {
                    Value::String(s) => format!("\"{}\"", crate::json::quote(s)),
                    other => type_name(other).to_string(),
                };
                de::Error::custom(format!(
                    "unknown series group {shown} (expected orbit, film, friction, forces or spin)"
                ))
            })
    }
}

hand_schema!(
    SeriesGroup,
    "SeriesGroup",
    schema::one_of_names(
        &["orbit", "film", "friction", "forces", "spin"],
        "A group of time series a variant keeps"
    )
);

impl Span {
    const NAMES: [(&'static str, Span); 2] = [("run", Span::Run), ("window", Span::Window)];
}

impl<'de> Deserialize<'de> for Span {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        one_of_names(&Value::deserialize(d)?, &Span::NAMES).map_err(de::Error::custom)
    }
}

hand_schema!(
    Span,
    "SeriesSpan",
    schema::one_of_names(
        &["run", "window"],
        "Samples the kept series cover: the whole run (default) or the evaluation window"
    )
);

/// `[low, high]` of the whirl band.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BandDoc(pub f64, pub f64);

impl<'de> Deserialize<'de> for BandDoc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = BandDoc;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("[low, high]")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<BandDoc, A::Error> {
                let short = || de::Error::custom("expected [low, high]");
                let lo = seq.next_element::<Num>()?.ok_or_else(short)?.0;
                let hi = seq.next_element::<Num>()?.ok_or_else(short)?.0;
                if seq.next_element::<de::IgnoredAny>()?.is_some() {
                    return Err(short());
                }
                Ok(BandDoc(lo, hi))
            }
        }
        d.deserialize_seq(V)
    }
}

hand_schema!(
    BandDoc,
    "WhirlBand",
    utoipa::openapi::ArrayBuilder::new()
        .prefix_items([
            schema::typed(utoipa::openapi::Type::Number, "low whirl ratio, > 0"),
            schema::typed(utoipa::openapi::Type::Number, "high whirl ratio, > low"),
        ])
        .items(utoipa::openapi::schema::ArrayItems::False)
        .min_items(Some(2))
        .description(Some(
            "[low, high]: the sub-synchronous band of whirl ratios"
        ))
        .into()
);

/// The evaluation window as written: exactly one of the three.
#[derive(Clone, Copy, Debug, Default, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
// At most one key in the schema (utoipa 5.5 renders `min_properties` as `maxProperties`, so
// the lower bound, also 1, is left to `ReductionOptions::from_doc`).
#[schema(max_properties = 1)]
pub struct WindowDoc {
    /// The last `N` revolutions, > 0.
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = Num)]
    pub revolutions: Option<Num>,
    /// The last fraction of the run, in (0, 1].
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = Num)]
    pub fraction: Option<Num>,
    /// The last seconds, > 0.
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = Num)]
    pub seconds: Option<Num>,
}

/// Whirl detection settings as written.
#[derive(Clone, Copy, Debug, Default, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct WhirlDoc {
    /// Sub-synchronous band `[low, high]`, default `[0.3, 0.6]`.
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = BandDoc)]
    pub band: Option<BandDoc>,
    /// Largest `|ratio|` searched (> 0, default 2.5).
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = Num)]
    pub max_ratio: Option<Num>,
    /// Band peak / dominant amplitude for oil whirl (> 0, default 0.2).
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = Num)]
    pub relative_threshold: Option<Num>,
    /// Band peak / radial clearance for oil whirl (>= 0, default 0.01).
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = Num)]
    pub min_amplitude_ratio: Option<Num>,
}

/// The spec's `reductions` as written (docs/cli.md "Sweeps" documents the fields).
#[derive(Clone, Debug, Default, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ReductionsDoc {
    /// Evaluation window (default the last half of the run).
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = WindowDoc)]
    pub window: Option<WindowDoc>,
    /// Series groups kept per variant (default none).
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = Vec<SeriesGroup>)]
    pub keep: Option<Vec<SeriesGroup>>,
    /// Most samples per kept series, >= 2 (default 200).
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = Count)]
    pub points: Option<Count>,
    /// Samples the kept series cover (default run).
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = Span)]
    pub span: Option<Span>,
    /// Whirl detection.
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = WhirlDoc)]
    pub whirl: Option<WhirlDoc>,
}

/// `x` at `path` when positive.
fn positive(x: f64, path: &str) -> Result<f64, SweepError> {
    if x <= 0.0 {
        return Err(SweepError::spec(
            path,
            format!("must be positive, got {}", crate::json::num(x)),
        ));
    }
    Ok(x)
}

impl ReductionOptions {
    /// Parses the spec's `reductions` object at `at` (absent: defaults).
    pub fn parse(v: Option<&Value>, at: &str) -> Result<Self, SweepError> {
        match v {
            None => Ok(ReductionOptions::default()),
            Some(v) => ReductionOptions::from_doc(&from_value(v, at)?, at),
        }
    }

    /// Checks the typed `reductions` at `at`: a window of exactly one kind with a positive
    /// length (a fraction at most 1), at least 2 points, a whirl band `0 < low < high <=
    /// max_ratio`, positive thresholds.
    pub fn from_doc(d: &ReductionsDoc, at: &str) -> Result<Self, SweepError> {
        let mut o = ReductionOptions::default();
        if let Some(w) = &d.window {
            let p = join(at, "window");
            o.window =
                match (w.revolutions, w.fraction, w.seconds) {
                    (Some(x), None, None) => {
                        Window::Revolutions(positive(x.0, &join(&p, "revolutions"))?)
                    }
                    (None, None, Some(x)) => Window::Seconds(positive(x.0, &join(&p, "seconds"))?),
                    (None, Some(x), None) => {
                        let q = join(&p, "fraction");
                        let x = positive(x.0, &q)?;
                        if x > 1.0 {
                            return Err(SweepError::spec(
                                q,
                                format!("must be at most 1, got {}", crate::json::num(x)),
                            ));
                        }
                        Window::Fraction(x)
                    }
                    _ => return Err(SweepError::spec(
                        &p,
                        "expected one of {\"revolutions\": N}, {\"fraction\": F}, {\"seconds\": T}",
                    )),
                };
        }
        if let Some(keep) = &d.keep {
            o.keep = keep.iter().copied().collect();
        }
        if let Some(n) = d.points {
            if n.0 < 2 {
                return Err(SweepError::spec(join(at, "points"), "must be at least 2"));
            }
            // Bounded so a typo cannot ask for a huge buffer per series.
            o.points = n.0.min(1 << 24) as usize;
        }
        if let Some(s) = d.span {
            o.span = s;
        }
        if let Some(w) = &d.whirl {
            let p = join(at, "whirl");
            if let Some(BandDoc(lo, hi)) = w.band {
                let q = join(&p, "band");
                let lo = positive(lo, &format!("{q}[0]"))?;
                let hi = positive(hi, &format!("{q}[1]"))?;
                if hi <= lo {
                    return Err(SweepError::spec(
                        q,
                        format!(
                            "needs low < high, got [{}, {}]",
                            crate::json::num(lo),
                            crate::json::num(hi)
                        ),
                    ));
                }
                o.whirl.band = (lo, hi);
            }
            if let Some(x) = w.max_ratio {
                o.whirl.max_ratio = positive(x.0, &join(&p, "max_ratio"))?;
            }
            if let Some(x) = w.relative_threshold {
                o.whirl.relative_threshold = positive(x.0, &join(&p, "relative_threshold"))?;
            }
            if let Some(x) = w.min_amplitude_ratio {
                if x.0 < 0.0 {
                    return Err(SweepError::spec(
                        join(&p, "min_amplitude_ratio"),
                        format!("must not be negative, got {}", crate::json::num(x.0)),
                    ));
                }
                o.whirl.min_amplitude_ratio = x.0;
            }
            if o.whirl.band.1 > o.whirl.max_ratio {
                return Err(SweepError::spec(
                    join(&p, "band"),
                    format!(
                        "upper end {} exceeds max_ratio {}",
                        crate::json::num(o.whirl.band.1),
                        crate::json::num(o.whirl.max_ratio)
                    ),
                ));
            }
        }
        Ok(o)
    }
}
