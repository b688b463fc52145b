//! Issue 23 item 3: figures fit for a report. Every figure the code draws is parsed back
//! from its SVG and checked: at least 3 labelled ticks on each axis (log axes included),
//! a legend box that covers no plotted point or line, names with units in the labels and
//! legend, clean tick labels (`0`, never `-1.11e-16`), no yellow on white. The checker is
//! itself shown to fail on a figure that breaks the rules.

use bearing_sweep::plot::{
    line_plot_svg, line_plot_svg_equal_aspect, Figure, Guide, Scale, Series,
};
use bearing_sweep::sweep::plots::render;
use bearing_sweep::sweep::spec::parse_spec;
use serde_json::{json, Value};

/// What a figure's SVG shows, read back from the classes `src/plot.rs` writes.
#[derive(Debug, Default)]
struct Parsed {
    x_labels: Vec<String>,
    y_labels: Vec<String>,
    legend: Option<(f64, f64, f64, f64)>,
    lines: Vec<Vec<(f64, f64)>>,
    markers: Vec<(f64, f64)>,
    texts: Vec<String>,
    colours: Vec<String>,
}

fn attr(tag: &str, name: &str) -> Option<String> {
    let key = format!(" {name}=\"");
    let at = tag.find(&key)? + key.len();
    Some(tag[at..].split('"').next()?.to_string())
}

fn num(tag: &str, name: &str) -> f64 {
    attr(tag, name)
        .and_then(|v| v.parse().ok())
        .unwrap_or(f64::NAN)
}

fn parse(svg: &str) -> Parsed {
    let mut p = Parsed::default();
    for piece in svg.split('<').skip(1) {
        let tag = piece.split('>').next().unwrap_or("");
        let text = piece.split('>').nth(1).unwrap_or("").trim().to_string();
        let class = attr(tag, "class").unwrap_or_default();
        if let Some(c) = attr(tag, "stroke").or_else(|| attr(tag, "fill")) {
            if class == "data" || class == "marker" {
                p.colours.push(c.to_lowercase());
            }
        }
        match (tag.split_whitespace().next().unwrap_or(""), class.as_str()) {
            ("text", "tick x") => p.x_labels.push(text),
            ("text", "tick y") => p.y_labels.push(text),
            ("text", _) => p.texts.push(text),
            ("rect", "legend") => {
                p.legend = Some((
                    num(tag, "x"),
                    num(tag, "y"),
                    num(tag, "width"),
                    num(tag, "height"),
                ))
            }
            ("polyline", "data") => p.lines.push(
                attr(tag, "points")
                    .unwrap_or_default()
                    .split_whitespace()
                    .filter_map(|xy| {
                        let (x, y) = xy.split_once(',')?;
                        Some((x.parse().ok()?, y.parse().ok()?))
                    })
                    .collect(),
            ),
            ("circle", "marker") => p.markers.push((num(tag, "cx"), num(tag, "cy"))),
            ("path", "marker") => {
                // "M x,y ..." : the first point is within the marker.
                let d = attr(tag, "d").unwrap_or_default();
                let first = d.trim_start_matches('M');
                let xy: Vec<f64> = first
                    .split(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-'))
                    .filter(|s| !s.is_empty())
                    .take(2)
                    .filter_map(|s| s.parse().ok())
                    .collect();
                if xy.len() == 2 {
                    p.markers.push((xy[0], xy[1]));
                }
            }
            _ => {}
        }
    }
    p
}

/// Whether segment a-b meets the rectangle (sampled finely: the check must not share the
/// code under test).
fn meets(r: (f64, f64, f64, f64), a: (f64, f64), b: (f64, f64)) -> bool {
    let n = 200;
    (0..=n).any(|k| {
        let t = k as f64 / n as f64;
        let (x, y) = (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1));
        (r.0..=r.0 + r.2).contains(&x) && (r.1..=r.1 + r.3).contains(&y)
    })
}

/// The rules; an error names the figure, the rule and the offending item.
fn check(name: &str, svg: &str) -> Result<Parsed, String> {
    let p = parse(svg);
    let labelled = |v: &[String]| v.iter().filter(|s| !s.is_empty()).count();
    if labelled(&p.x_labels) < 3 {
        return Err(format!(
            "{name}: x axis has {} labelled ticks (at least 3): {:?}",
            labelled(&p.x_labels),
            p.x_labels
        ));
    }
    if labelled(&p.y_labels) < 3 {
        return Err(format!(
            "{name}: y axis has {} labelled ticks (at least 3): {:?}",
            labelled(&p.y_labels),
            p.y_labels
        ));
    }
    for l in p.x_labels.iter().chain(&p.y_labels) {
        if l.contains("e-1") && l.parse::<f64>().is_ok_and(|v| v.abs() < 1e-12) {
            return Err(format!("{name}: tick label {l} where 0 belongs"));
        }
    }
    if let Some(r) = p.legend {
        for (i, m) in p.markers.iter().enumerate() {
            if (r.0..=r.0 + r.2).contains(&m.0) && (r.1..=r.1 + r.3).contains(&m.1) {
                return Err(format!(
                    "{name}: legend box {r:?} covers marker {i} at {m:?}"
                ));
            }
        }
        for (j, line) in p.lines.iter().enumerate() {
            for (i, w) in line.windows(2).enumerate() {
                if meets(r, w[0], w[1]) {
                    return Err(format!(
                        "{name}: legend box {r:?} covers line {j}, segment {i} {:?}-{:?}",
                        w[0], w[1]
                    ));
                }
            }
        }
    }
    for c in &p.colours {
        // Yellow: high red and green, low blue (e.g. #fde725, #ffff00, #CCBB44).
        if let Ok(v) = u32::from_str_radix(c.trim_start_matches('#'), 16) {
            let (r, g, b) = ((v >> 16) & 255, (v >> 8) & 255, v & 255);
            if r > 180 && g > 180 && b < 120 {
                return Err(format!("{name}: yellow {c} on white"));
            }
        }
    }
    Ok(p)
}

fn must(name: &str, svg: &str) -> Parsed {
    check(name, svg).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn the_checker_fails_on_a_figure_that_breaks_the_rules() {
    let few_ticks = r#"<svg><text class="tick x">1</text><text class="tick x">10</text><text class="tick y">0</text><text class="tick y">1</text><text class="tick y">2</text></svg>"#;
    let e = check("two x labels", few_ticks).unwrap_err();
    assert!(e.contains("x axis has 2"), "{e}");
    let covered = r##"<svg><text class="tick x">1</text><text class="tick x">2</text><text class="tick x">3</text>
      <text class="tick y">1</text><text class="tick y">2</text><text class="tick y">3</text>
      <rect class="legend" x="100" y="100" width="50" height="20"/>
      <polyline class="data" points="90,90 160,130" stroke="#0072B2"/></svg>"##;
    let e = check("covered", covered).unwrap_err();
    assert!(e.contains("covers line 0"), "{e}");
    let marker = covered.replace(
        r##"<polyline class="data" points="90,90 160,130" stroke="#0072B2"/>"##,
        r##"<circle class="marker" cx="120" cy="110" r="3" fill="#0072B2"/>"##,
    );
    let e = check("marker", &marker).unwrap_err();
    assert!(e.contains("covers marker 0"), "{e}");
    let yellow = covered
        .replace("90,90 160,130", "10,10 20,20")
        .replace("#0072B2", "#fde725");
    let e = check("yellow", &yellow).unwrap_err();
    assert!(e.contains("yellow"), "{e}");
}

/// The h_min map of `sweeps/clearance-viscosity.json`: log-log, film thickness in m from
/// the reductions shown in µm, one curve per viscosity, the lowest curves below 1 µm.
#[test]
fn sweep_plots_have_units_readable_log_axes_and_a_free_legend() {
    let doc = json!({"base": {"bearings": [{"clearance": 1e-4, "viscosity": 0.01}]},
        "axes": [{"path": "bearings[*].clearance", "values": [5e-5, 8e-5, 1.2e-4, 2e-4, 3e-4]},
                 {"path": "bearings[*].viscosity", "values": [0.002, 0.005, 0.0242, 0.05]}],
        "plots": [{"name": "h-min", "x": "bearings[*].clearance", "series": "bearings[*].viscosity",
                   "y": "h_min.value_m", "x_scale": "log", "y_scale": "log",
                   "x_label": "radial clearance (m)", "y_label": "h_min (m)"},
                  {"name": "friction", "x": "bearings[*].clearance", "series": "bearings[*].viscosity",
                   "y": "bearings[0].friction_coefficient.mean", "x_scale": "log", "y_scale": "log"}]});
    let spec = parse_spec(&doc, None).unwrap();
    let mut variants: Vec<Value> = Vec::new();
    for (i, c) in [5e-5_f64, 8e-5, 1.2e-4, 2e-4, 3e-4].iter().enumerate() {
        for (j, mu) in [0.002_f64, 0.005, 0.0242, 0.05].iter().enumerate() {
            // h_min grows with viscosity, falls with clearance ratio: 0.3 .. 40 µm.
            let h = 2e-7 * (mu / 0.002_f64).powf(1.3) * (1e-4 / c).powf(0.6) * 1.5;
            let f = 0.002 * (mu / 0.002_f64).sqrt() * (c / 5e-5);
            variants.push(json!({"id": i * 4 + j, "params": {"bearings[*].clearance": c, "bearings[*].viscosity": mu},
                "reductions": {"h_min": {"value_m": h}, "bearings": [{"friction_coefficient": {"mean": f}}]}}));
        }
    }
    let svg = render(&variants, &spec.plots[0]).unwrap();
    let p = must("h-min", &svg);
    let all = p.texts.join("\n");
    for want in [
        "viscosity = 5 mPa·s",
        "viscosity = 24.2 mPa·s",
        "(µm)",
        "radial clearance (µm)",
    ] {
        assert!(
            all.contains(want),
            "h-min: no `{want}` in the texts:\n{all}"
        );
    }
    assert!(
        !all.contains("bearings[*]"),
        "raw path in the texts:\n{all}"
    );
    let svg = render(&variants, &spec.plots[1]).unwrap();
    let p = must("friction", &svg);
    assert!(
        p.texts.iter().any(|t| t == "clearance (µm)"),
        "{:?}",
        p.texts
    );
}

#[test]
fn log_axes_with_narrow_ranges_label_three_ticks() {
    // A stability curve over one decade and a bit; a work-precision plot below 0.1 s.
    let curve: Vec<(f64, f64)> = (0..15)
        .map(|k| {
            let e = 0.05 + 0.05 * k as f64;
            (e, 1.5 + 30.0 * e.powi(3))
        })
        .collect();
    let svg = line_plot_svg(
        "stability curve",
        "eccentricity ratio",
        "threshold speed × √(c/g)",
        &[
            Series {
                label: "closed form",
                points: curve.clone(),
            },
            Series {
                label: "this code",
                points: curve
                    .iter()
                    .step_by(3)
                    .map(|&(x, y)| (x, y * 1.01))
                    .collect(),
            },
        ],
        Scale::Linear,
        Scale::Log,
    )
    .unwrap();
    must("stability curve", &svg);
    let wp: Vec<(f64, f64)> = [0.003, 0.006, 0.011, 0.02, 0.04, 0.08]
        .iter()
        .enumerate()
        .map(|(k, &t)| (t, 10f64.powi(-3 - k as i32)))
        .collect();
    let svg = line_plot_svg(
        "work-precision",
        "wall time (s)",
        "error",
        &[Series {
            label: "RK45",
            points: wp,
        }],
        Scale::Log,
        Scale::Log,
    )
    .unwrap();
    let p = must("work-precision", &svg);
    let x: Vec<f64> = p.x_labels.iter().filter_map(|s| s.parse().ok()).collect();
    assert!(
        x.iter().filter(|&&v| v < 0.1).count() >= 3,
        "x labels below 0.1 s: {x:?}"
    );
    // A narrow log range (a factor 1.3) still labels three values.
    let svg = line_plot_svg(
        "narrow",
        "x",
        "y",
        &[Series {
            label: "",
            points: vec![(1.0, 2.0), (2.0, 2.6)],
        }],
        Scale::Log,
        Scale::Log,
    )
    .unwrap();
    must("narrow", &svg);
}

#[test]
fn a_legend_goes_where_the_data_is_not() {
    // Data in every corner and edge: no inside spot is free, so the legend goes outside.
    let full: Vec<Series<'_>> = (0..5)
        .map(|k| Series {
            label: ["a", "b", "c", "d", "e"][k],
            points: (0..=100)
                .map(|i| {
                    let x = i as f64 / 100.0;
                    (x, ((x * 12.0 + k as f64).sin() + 1.0) * 0.5)
                })
                .collect(),
        })
        .collect();
    let svg = line_plot_svg("full", "x", "y", &full, Scale::Linear, Scale::Linear).unwrap();
    let p = must("full", &svg);
    assert!(p.legend.is_some(), "no legend");
    // Data rising to the top right: the legend goes to a free corner (top left).
    let rising = [
        Series {
            label: "rising",
            points: (0..20).map(|i| (i as f64, (i * i) as f64)).collect(),
        },
        Series {
            label: "flat",
            points: (0..20).map(|i| (i as f64, 100.0)).collect(),
        },
    ];
    let svg = line_plot_svg("rising", "x", "y", &rising, Scale::Linear, Scale::Linear).unwrap();
    let p = must("rising", &svg);
    let (lx, _, _, _) = p.legend.unwrap();
    assert!(lx < 200.0, "legend at x = {lx}, not the free left side");
    // Float noise around zero reads 0.
    let noisy = [Series {
        label: "",
        points: vec![(0.0, -1.11e-16), (1.0, 1.0), (2.0, -1.0)],
    }];
    let p = must(
        "noisy",
        &line_plot_svg("noisy", "x", "y", &noisy, Scale::Linear, Scale::Linear).unwrap(),
    );
    assert!(p.y_labels.iter().any(|s| s == "0"), "{:?}", p.y_labels);
}

#[test]
fn an_orbit_shows_its_clearance_circle_in_equal_units() {
    let orbit: Vec<(f64, f64)> = (0..400)
        .map(|i| {
            let a = i as f64 * 0.05;
            (60.0 + 20.0 * a.cos(), -70.0 + 25.0 * a.sin())
        })
        .collect();
    let mut fig = bearing_sweep::plot::simple(
        "orbit",
        "x (µm)",
        "y (µm)",
        &[Series {
            label: "journal",
            points: orbit,
        }],
        Scale::Linear,
        Scale::Linear,
        true,
    );
    fig.guides.push(Guide::Circle {
        centre: (0.0, 0.0),
        radius: 150.0,
        label: "clearance circle".into(),
    });
    let svg = fig.svg().unwrap();
    must("orbit", &svg);
    assert!(svg.contains("class=\"guide\" cx="), "no circle drawn");
    // The circle lies inside the plot: the range covers ±150 µm.
    let l = fig.layout().unwrap();
    assert!(
        l.x_range.0 <= -150.0 && l.x_range.1 >= 150.0,
        "{:?}",
        l.x_range
    );
    assert!(
        l.y_range.0 <= -150.0 && l.y_range.1 >= 150.0,
        "{:?}",
        l.y_range
    );
    // Equal aspect: data units per px match on both axes within 1 %.
    let (sx, sy) = (
        (l.x_range.1 - l.x_range.0) / l.plot.w,
        (l.y_range.1 - l.y_range.0) / l.plot.h,
    );
    assert!((sx / sy - 1.0).abs() < 0.01, "x {sx} vs y {sy} per px");
    // The old single-series path still works.
    must(
        "equal",
        &line_plot_svg_equal_aspect(
            "t",
            "x",
            "y",
            &[Series {
                label: "",
                points: vec![(0.0, 0.0), (1.0, 2.0), (2.0, 1.0)],
            }],
        )
        .unwrap(),
    );
    let _ = Figure::new("", "", "", Scale::Linear, Scale::Linear);
}
