//! SVG plots of a finished sweep: a reduction against one axis, one curve per value of
//! another axis (e.g. minimum film thickness over clearance, one line per viscosity).
//!
//! ```json
//! "plots": [{"name": "h-min", "x": "bearings[*].clearance", "series": "bearings[*].viscosity",
//!            "y": "h_min.value_m", "x_scale": "linear", "y_scale": "log",
//!            "title": "...", "x_label": "...", "y_label": "..."}]
//! ```
//! `x` and `series` name axes of the spec; `y` is a path into each variant's
//! `reductions` (e.g. `bearings[0].friction_coefficient.mean`). Variants whose `y` is
//! null (failed before the window, or undefined) are left out of their curve. The plot of
//! result `R.json` is written to `R.<name>.svg`.

use std::collections::BTreeMap;

use serde::{de, Deserialize, Deserializer};
use serde_json::Value;
use utoipa::ToSchema;

use super::spec::{
    hand_schema, join, one_of_names, parse_path, present, resolve, schema, type_name, Axis,
    PathSeg, SweepKind,
};
use super::SweepError;
use crate::plot::{line_plot_svg, Scale, Series};

/// One plot.
#[derive(Clone, Debug, PartialEq)]
pub struct PlotSpec {
    /// File-name part.
    pub name: String,
    /// Axis path on the horizontal axis.
    pub x: String,
    /// Axis path whose values make the curves (none: one curve).
    pub series: Option<String>,
    /// Path into a variant's `reductions`.
    pub y: String,
    /// Parsed `y`.
    pub y_path: Vec<PathSeg>,
    /// Horizontal scale.
    pub x_scale: Scale,
    /// Vertical scale.
    pub y_scale: Scale,
    /// Title.
    pub title: Option<String>,
    /// Horizontal label.
    pub x_label: Option<String>,
    /// Vertical label.
    pub y_label: Option<String>,
}

/// A plot's axis scale as written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ScaleDoc(pub Scale);

impl<'de> Deserialize<'de> for ScaleDoc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        one_of_names(
            &Value::deserialize(d)?,
            &[("linear", Scale::Linear), ("log", Scale::Log)],
        )
        .map(ScaleDoc)
        .map_err(de::Error::custom)
    }
}

hand_schema!(
    ScaleDoc,
    "PlotScale",
    schema::one_of_names(&["linear", "log"], "Axis scale (default linear)")
);

/// One plot as written in the spec's `plots`.
#[derive(Clone, Debug, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct PlotDoc {
    /// File-name part: letters, digits, `-`, `_`; unique.
    pub name: String,
    /// Axis path on the horizontal axis (an axis of the spec).
    pub x: String,
    /// Axis path whose values make the curves (default: one curve).
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = String)]
    pub series: Option<String>,
    /// Path into a variant's `reductions`, naming a number (e.g. `h_min.value_m`).
    pub y: String,
    /// Horizontal scale.
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = ScaleDoc)]
    pub x_scale: Option<ScaleDoc>,
    /// Vertical scale.
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = ScaleDoc)]
    pub y_scale: Option<ScaleDoc>,
    /// Title (default `y over x`).
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = String)]
    pub title: Option<String>,
    /// Horizontal label (default the axis path).
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = String)]
    pub x_label: Option<String>,
    /// Vertical label (default `y`).
    #[serde(default, deserialize_with = "present")]
    #[schema(value_type = String)]
    pub y_label: Option<String>,
}

/// Checks a plot's `y` against the shape of a variant's reductions of sweep kind `kind`
/// (rotor and synthetic variants share the signal reductions, stability variants have
/// their own; any bearing index stands for bearing 0 there: the count is the scene's): it
/// must name a number.
fn check_y(y_path: &[PathSeg], kind: SweepKind) -> Result<(), String> {
    let (schema, example) = match kind {
        SweepKind::Rotor | SweepKind::Synthetic => (
            super::reduce::Reductions::schema(),
            "`h_min.value_m`, `bearings[0].whirl.subsync_amplitude_m`",
        ),
        SweepKind::Stability => (
            super::stability_sim::reductions_schema(),
            "`threshold_speed_rad_s`, `log_dec_min`",
        ),
    };
    let as_first: Vec<PathSeg> = y_path
        .iter()
        .map(|s| match s {
            PathSeg::Index(_) => PathSeg::Index(0),
            other => other.clone(),
        })
        .collect();
    let leaf = resolve(&schema, &as_first).map_err(|r| {
        format!(
            "not a reduction of a {} variant: {}",
            kind.name(),
            r.replace("the base scene", "`reductions`")
                .replace(" (write the field into `base` to sweep it;", " (")
        )
    })?;
    match leaf.first() {
        Some((_, v)) if v.is_number() => Ok(()),
        Some((_, v)) => Err(format!(
            "names {}, not a number (e.g. {example})",
            type_name(v)
        )),
        None => Err("names nothing".into()),
    }
}

/// Checks the spec's typed `plots` against its axes: names usable in a file name and
/// unique, `x` and `series` axes of the sweep, `y` a number of the reductions of a variant
/// of `kind`.
pub fn plots_from_doc(
    list: &[PlotDoc],
    axes: &[Axis],
    kind: SweepKind,
) -> Result<Vec<PlotSpec>, SweepError> {
    let mut out: Vec<PlotSpec> = Vec::new();
    let axis_names: Vec<&str> = axes.iter().map(|a| a.path.as_str()).collect();
    for (k, p) in list.iter().enumerate() {
        let at = format!("plots[{k}]");
        let name = p.name.clone();
        if name.is_empty()
            || !name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
        {
            return Err(SweepError::spec(
                join(&at, "name"),
                "use letters, digits, `-` and `_` (it becomes part of a file name)",
            ));
        }
        if out.iter().any(|q| q.name == name) {
            return Err(SweepError::spec(
                join(&at, "name"),
                format!("`{}` is used twice", crate::json::quote(&name)),
            ));
        }
        let check_axis = |key: &str, path: &str| -> Result<(), SweepError> {
            if axis_names.contains(&path) {
                Ok(())
            } else {
                Err(SweepError::spec(
                    join(&at, key),
                    format!(
                        "`{}` is not an axis of this sweep (axes: {})",
                        crate::json::quote(path),
                        crate::json::shorten(&axis_names.join(", "), 400)
                    ),
                ))
            }
        };
        check_axis("x", &p.x)?;
        if let Some(s) = &p.series {
            check_axis("series", s)?;
        }
        let y_path = parse_path(&p.y).map_err(|r| SweepError::spec(join(&at, "y"), r))?;
        if y_path.contains(&PathSeg::All) {
            return Err(SweepError::spec(
                join(&at, "y"),
                "`[*]` is not allowed here: name one bearing, e.g. bearings[0]",
            ));
        }
        check_y(&y_path, kind).map_err(|r| SweepError::spec(join(&at, "y"), r))?;
        let scale = |s: Option<ScaleDoc>| s.map_or(Scale::Linear, |s| s.0);
        out.push(PlotSpec {
            name,
            x: p.x.clone(),
            series: p.series.clone(),
            y: p.y.clone(),
            y_path,
            x_scale: scale(p.x_scale),
            y_scale: scale(p.y_scale),
            title: p.title.clone(),
            x_label: p.x_label.clone(),
            y_label: p.y_label.clone(),
        });
    }
    Ok(out)
}

/// Renders `plot` from a complete result's variants.
pub fn render(variants: &[Value], plot: &PlotSpec) -> Result<String, String> {
    let mut curves: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
    let mut order: Vec<String> = Vec::new();
    for v in variants {
        let params = &v["params"];
        let Some(x) = params.get(&plot.x).and_then(Value::as_f64) else {
            continue;
        };
        let label = match &plot.series {
            Some(s) => match params.get(s) {
                Some(Value::Number(n)) => {
                    format!(
                        "{s} = {}",
                        crate::plot::tick_label(n.as_f64().unwrap_or(f64::NAN))
                    )
                }
                other => format!("{s} = {}", other.cloned().unwrap_or(Value::Null)),
            },
            None => plot.y.clone(),
        };
        let y = resolve(&v["reductions"], &plot.y_path)
            .ok()
            .and_then(|r| r.first().and_then(|(_, val)| val.as_f64()));
        if !order.contains(&label) {
            order.push(label.clone());
        }
        if let Some(y) = y {
            curves.entry(label).or_default().push((x, y));
        }
    }
    let series: Vec<Series<'_>> = order
        .iter()
        .filter_map(|label| {
            let mut pts = curves.get(label)?.clone();
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            Some(Series {
                label: label.as_str(),
                points: pts,
            })
        })
        .collect();
    let title = plot
        .title
        .clone()
        .unwrap_or_else(|| format!("{} over {}", plot.y, plot.x));
    line_plot_svg(
        &title,
        plot.x_label.as_deref().unwrap_or(&plot.x),
        plot.y_label.as_deref().unwrap_or(&plot.y),
        &series,
        plot.x_scale,
        plot.y_scale,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep::spec::parse_spec;
    use serde_json::json;

    #[test]
    fn plots_are_checked_against_the_axes_and_render_one_curve_per_series() {
        let base = json!({"a": 0.0, "b": 0.0});
        let doc = json!({"base": base, "axes": [{"path": "a", "values": [1, 2, 3]}, {"path": "b", "values": [10, 20]}],
                         "plots": [{"name": "p", "x": "a", "series": "b", "y": "bearings[0].h_min_m.value"}]});
        let spec = parse_spec(&doc, None).unwrap();
        assert_eq!(spec.plots.len(), 1);
        let bad = json!({"base": {"a": 0.0}, "axes": [{"path": "a", "values": [1]}],
                         "plots": [{"name": "p", "x": "c", "y": "h"}]});
        match parse_spec(&bad, None) {
            Err(SweepError::Spec { path, reason }) => {
                assert_eq!(path, "plots[0].x");
                assert!(reason.contains("not an axis"), "{reason}");
            }
            other => panic!("{other:?}"),
        }
        let variants: Vec<Value> = (0..6)
            .map(|i| {
                let (a, b) = ([1, 2, 3][i % 3], [10, 20][i / 3]);
                let y = if i == 4 { Value::Null } else { json!(a * b) };
                json!({"id": i, "params": {"a": a, "b": b},
                       "reductions": {"bearings": [{"h_min_m": {"value": y}}]}})
            })
            .collect();
        let svg = render(&variants, &spec.plots[0]).unwrap();
        assert!(
            svg.matches("<polyline").count() >= 2,
            "one line per value of b"
        );
        assert!(svg.contains("b = 10") && svg.contains("b = 20"));
    }
}
