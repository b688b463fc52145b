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

use serde::{de, Deserialize, Deserializer};
use serde_json::Value;
use utoipa::ToSchema;

use super::spec::{
    hand_schema, join, one_of_names, parse_path, present, resolve, schema, type_name, Axis,
    PathSeg, SweepKind,
};
use super::SweepError;
use crate::plot::{
    label_in, name_of_path, name_of_reduction, unit_of_path, unit_of_reduction, value_in, Curve,
    Dash, Figure, Marker, Scale, ONE, PALETTE,
};

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
        // Not reached: a friction map is not parsed as a scene sweep.
        SweepKind::FrictionMap => return Err("a friction map draws its own figure".into()),
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

/// Renders `plot` from a complete result's variants, in display units (film thickness
/// and clearances in µm, viscosity in mPa·s: [`crate::plot::unit_of_path`]); legend entries
/// read `viscosity = 5 mPa·s`. More curves than palette colours, all of a numeric series
/// axis, take a sequential colour ramp (ordered like their values).
pub fn render(variants: &[Value], plot: &PlotSpec) -> Result<String, String> {
    figure(variants, plot)?.svg()
}

/// The [`Figure`] of [`render`].
pub fn figure(variants: &[Value], plot: &PlotSpec) -> Result<Figure, String> {
    let ux = unit_of_path(&plot.x);
    let uy = unit_of_reduction(&plot.y);
    let us = plot.series.as_deref().map(unit_of_path).unwrap_or(ONE);
    // (label, numeric series value, points)
    // (legend label, numeric series value, points)
    let mut curves: Vec<SeriesCurve> = Vec::new();
    for v in variants {
        let params = &v["params"];
        let Some(x) = params.get(&plot.x).and_then(Value::as_f64) else {
            continue;
        };
        let (label, key) = match &plot.series {
            Some(s) => match params.get(s) {
                Some(Value::Number(n)) => {
                    let val = n.as_f64().unwrap_or(f64::NAN);
                    (
                        format!("{} = {}", name_of_path(s), value_in(val, us)),
                        Some(val),
                    )
                }
                other => (
                    format!(
                        "{} = {}",
                        name_of_path(s),
                        crate::json::shorten(
                            &other.cloned().unwrap_or(Value::Null).to_string(),
                            40
                        )
                    ),
                    None,
                ),
            },
            None => (String::new(), None),
        };
        let y = resolve(&v["reductions"], &plot.y_path)
            .ok()
            .and_then(|r| r.first().and_then(|(_, val)| val.as_f64()));
        let at = match curves.iter().position(|c| c.0 == label) {
            Some(i) => i,
            None => {
                curves.push((label, key, Vec::new()));
                curves.len() - 1
            }
        };
        if let Some(y) = y {
            curves[at].2.push((x * ux.scale, y * uy.scale));
        }
    }
    curves.retain(|c| !c.2.is_empty());
    if curves.iter().all(|c| c.1.is_some()) {
        curves.sort_by(|a, b| a.1.unwrap_or(0.0).total_cmp(&b.1.unwrap_or(0.0)));
    }
    let sequential = curves.len() > PALETTE.len() && curves.iter().all(|c| c.1.is_some());
    let x_name = name_of_path(&plot.x);
    let y_name = name_of_reduction(&plot.y);
    let title = plot
        .title
        .clone()
        .unwrap_or_else(|| format!("{y_name} against {x_name}"));
    let mut fig = Figure::new(
        &title,
        &label_in(plot.x_label.as_deref().unwrap_or(&x_name), ux),
        &label_in(plot.y_label.as_deref().unwrap_or(&y_name), uy),
        plot.x_scale,
        plot.y_scale,
    );
    let n = curves.len();
    for (k, (label, _, mut pts)) in curves.into_iter().enumerate() {
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        let few = pts.len() <= 40;
        let mut c = Curve::line(label, pts, k);
        if sequential {
            c.colour = ramp(k as f64 / (n - 1).max(1) as f64);
            c.dash = Some(Dash::Solid);
        }
        c.marker = few.then_some(Marker::Circle);
        fig.curves.push(c);
    }
    Ok(fig)
}

/// A curve of a plot: legend label, its numeric series value, points.
type SeriesCurve = (String, Option<f64>, Vec<(f64, f64)>);

/// Viridis from its dark end to 85 % (the yellow end is unreadable on white), `t` in 0..1.
pub fn ramp(t: f64) -> String {
    const STOPS: [(u8, u8, u8); 7] = [
        (0x44, 0x01, 0x54),
        (0x46, 0x33, 0x7e),
        (0x36, 0x5c, 0x8d),
        (0x27, 0x7f, 0x8e),
        (0x1f, 0xa1, 0x87),
        (0x4a, 0xc1, 0x6d),
        (0x7a, 0xd1, 0x51),
    ];
    let t = t.clamp(0.0, 1.0) * (STOPS.len() - 1) as f64;
    let i = (t.floor() as usize).min(STOPS.len() - 2);
    let f = t - i as f64;
    let mix = |a: u8, b: u8| (a as f64 + (b as f64 - a as f64) * f).round() as u8;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    format!(
        "#{:02x}{:02x}{:02x}",
        mix(a.0, b.0),
        mix(a.1, b.1),
        mix(a.2, b.2)
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
        assert!(svg.contains("b = 10") && svg.contains("b = 20"), "{svg}");
    }
}
