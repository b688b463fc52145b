//! SVG figures (plotters' SVG backend, no fonts needed): shared line-plot helper.

use plotters::prelude::*;

/// One named curve of `(x, y)` points.
pub struct Series<'a> {
    /// Legend label.
    pub label: &'a str,
    /// Points in data units.
    pub points: Vec<(f64, f64)>,
}

/// Axis scaling.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scale {
    /// Linear axis.
    Linear,
    /// Base-10 logarithmic axis (non-positive values are dropped).
    Log,
}

/// A tick label with at most 4 significant digits (log-axis ticks such as
/// `0.0003000000000000003` become `3e-4`), in scientific notation outside 1e-3..1e5.
pub fn tick_label(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let a = v.abs();
    if (1e-3..1e5).contains(&a) {
        let s = format!("{:.*}", (3 - a.log10().floor() as i32).max(0) as usize, v);
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        let s = format!("{v:.3e}");
        match s.split_once('e') {
            Some((m, e)) if m.contains('.') => {
                format!("{}e{e}", m.trim_end_matches('0').trim_end_matches('.'))
            }
            _ => s,
        }
    }
}

/// Writes a line plot of `series` to an SVG string.
pub fn line_plot_svg(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series<'_>],
    x_scale: Scale,
    y_scale: Scale,
) -> Result<String, String> {
    plot_svg(title, x_label, y_label, series, x_scale, y_scale, false)
}

/// A linear plot with equal data units per pixel on both axes (orbits, trajectories).
pub fn line_plot_svg_equal_aspect(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series<'_>],
) -> Result<String, String> {
    plot_svg(
        title,
        x_label,
        y_label,
        series,
        Scale::Linear,
        Scale::Linear,
        true,
    )
}

/// Approximate plotting-area size in pixels of the 800 x 560 canvas (margins, caption
/// and label areas removed), for equal-aspect ranges.
const PLOT_AREA_PX: (f64, f64) = (700.0, 440.0);

/// Most decades a log axis may span: plotters' tick generation divides the range into
/// decades, and a ratio beyond f64::MAX (~308 decades) makes it loop without end.
const MAX_LOG_DECADES: f64 = 300.0;

/// Whether plotters can draw an axis over `[lo, hi]` in a bounded time: finite bounds,
/// a finite positive width, and for a log axis a positive start and at most
/// [`MAX_LOG_DECADES`]. Otherwise the figure is skipped with this reason (plotters'
/// tick loops do not terminate on infinite or NaN ranges).
fn drawable(lo: f64, hi: f64, scale: Scale) -> Result<(), String> {
    let shown = || format!("[{}, {}]", tick_label(lo), tick_label(hi));
    if !(lo.is_finite() && hi.is_finite() && hi > lo && (hi - lo).is_finite()) {
        return Err(format!("range {} cannot be drawn", shown()));
    }
    if scale == Scale::Log {
        let decades = (hi / lo).log10();
        if !(lo > 0.0 && decades.is_finite() && decades <= MAX_LOG_DECADES) {
            return Err(format!(
                "range {} spans more than {MAX_LOG_DECADES} decades; cannot be drawn",
                shown()
            ));
        }
    }
    Ok(())
}

fn plot_svg(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series<'_>],
    x_scale: Scale,
    y_scale: Scale,
    equal_aspect: bool,
) -> Result<String, String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (800, 560)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let keep = |v: f64, s: Scale| v.is_finite() && (s == Scale::Linear || v > 0.0);
        let pts: Vec<(f64, f64)> = series
            .iter()
            .flat_map(|s| s.points.iter().copied())
            .filter(|&(x, y)| keep(x, x_scale) && keep(y, y_scale))
            .collect();
        if pts.is_empty() {
            return Err("nothing to plot".into());
        }
        let range = |vals: Vec<f64>, scale: Scale| {
            let lo = vals.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = vals.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            match scale {
                Scale::Linear => {
                    // 0.05 hi − 0.05 lo: no overflow for a span wider than f64::MAX.
                    let pad = if hi > lo {
                        0.05 * hi - 0.05 * lo
                    } else {
                        lo.abs().max(1e-12) * 0.1
                    };
                    (lo - pad, hi + pad)
                }
                Scale::Log => (lo / 1.5, hi * 1.5),
            }
        };
        let (x0, x1) = range(pts.iter().map(|p| p.0).collect(), x_scale);
        let (mut y0, mut y1) = range(pts.iter().map(|p| p.1).collect(), y_scale);
        let (mut x0, mut x1) = (x0, x1);
        if equal_aspect {
            // Widen the tighter axis so one data unit spans as many pixels on both.
            let per_px = ((x1 - x0) / PLOT_AREA_PX.0).max((y1 - y0) / PLOT_AREA_PX.1);
            let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
            x0 = cx - 0.5 * per_px * PLOT_AREA_PX.0;
            x1 = cx + 0.5 * per_px * PLOT_AREA_PX.0;
            y0 = cy - 0.5 * per_px * PLOT_AREA_PX.1;
            y1 = cy + 0.5 * per_px * PLOT_AREA_PX.1;
        }
        drawable(x0, x1, x_scale).map_err(|e| format!("x axis: {e}"))?;
        drawable(y0, y1, y_scale).map_err(|e| format!("y axis: {e}"))?;
        macro_rules! draw {
            ($chart:expr) => {{
                let mut chart = $chart.map_err(|e| e.to_string())?;
                chart
                    .configure_mesh()
                    .x_desc(x_label)
                    .y_desc(y_label)
                    .x_label_formatter(&|v| tick_label(*v))
                    .y_label_formatter(&|v| tick_label(*v))
                    .draw()
                    .map_err(|e| e.to_string())?;
                for (k, s) in series.iter().enumerate() {
                    let color = Palette99::pick(k).to_rgba();
                    let data: Vec<(f64, f64)> = s
                        .points
                        .iter()
                        .copied()
                        .filter(|&(x, y)| keep(x, x_scale) && keep(y, y_scale))
                        .collect();
                    chart
                        .draw_series(LineSeries::new(data, color.stroke_width(2)))
                        .map_err(|e| e.to_string())?
                        .label(s.label)
                        .legend(move |(x, y)| {
                            PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
                        });
                }
                chart
                    .configure_series_labels()
                    .background_style(WHITE.mix(0.8))
                    .border_style(BLACK)
                    .draw()
                    .map_err(|e| e.to_string())?;
            }};
        }
        let mut builder = ChartBuilder::on(&root);
        builder
            .caption(title, ("sans-serif", 22))
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(70);
        match (x_scale, y_scale) {
            (Scale::Linear, Scale::Linear) => draw!(builder.build_cartesian_2d(x0..x1, y0..y1)),
            (Scale::Log, Scale::Log) => {
                draw!(builder.build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale()))
            }
            (Scale::Linear, Scale::Log) => {
                draw!(builder.build_cartesian_2d(x0..x1, (y0..y1).log_scale()))
            }
            (Scale::Log, Scale::Linear) => {
                draw!(builder.build_cartesian_2d((x0..x1).log_scale(), y0..y1))
            }
        }
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(svg)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels_are_short() {
        let cases = [
            (0.0003000000000000003, "3e-4"),
            (0.003000000000000001, "0.003"),
            (0.00012, "1.2e-4"),
            (100.0, "100"),
            (12345.678, "12346"),
            (0.0225, "0.0225"),
            (1e6, "1e6"),
            (-2.5, "-2.5"),
        ];
        for (v, e) in cases {
            assert_eq!(tick_label(v), e, "tick label of {v}");
        }
    }

    #[test]
    fn writes_an_svg_with_the_title_and_a_path_per_series() {
        let s = [
            Series {
                label: "a",
                points: vec![(1.0, 1.0), (10.0, 100.0)],
            },
            Series {
                label: "b",
                points: vec![(1.0, 2.0), (10.0, 3.0)],
            },
        ];
        let svg = line_plot_svg("T", "x", "y", &s, Scale::Log, Scale::Log).unwrap();
        assert!(svg.starts_with("<svg"), "{}", &svg[..40.min(svg.len())]);
        assert!(
            svg.contains("\nT\n</text>"),
            "title missing: {}",
            &svg[..600.min(svg.len())]
        );
        assert!(
            svg.matches("<polyline").count() >= 2,
            "expected a polyline per series"
        );
    }
}
