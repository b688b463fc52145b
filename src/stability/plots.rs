//! Campbell diagram and damping-vs-speed figures (SVG strings; no I/O).

use super::analysis::SpeedAnalysis;
use crate::plot::{line_plot_svg, Scale, Series};

/// Modes at each speed ranked by fixed-frame frequency (backward first), so that the
/// k-th curve follows the k-th mode while modes do not cross.
fn ranked(a: &SpeedAnalysis) -> Vec<&super::Mode> {
    let mut m: Vec<&super::Mode> = a
        .modes
        .iter()
        .filter(|m| m.frequency_rad_s != 0.0)
        .collect();
    m.sort_by(|x, y| x.frequency_rad_s.total_cmp(&y.frequency_rad_s));
    m
}

/// Labels of the mode curves: as many as the most oscillating modes at any speed.
fn mode_labels(runs: &[SpeedAnalysis]) -> Vec<String> {
    let n = runs.iter().map(|a| ranked(a).len()).max().unwrap_or(0);
    (0..n)
        .map(|k| format!("mode {} (by frequency)", k + 1))
        .collect()
}

/// One curve per ranked mode: `value` of the k-th mode against speed.
fn mode_curves<'a>(
    runs: &[SpeedAnalysis],
    labels: &'a [String],
    value: impl Fn(&super::Mode) -> f64,
) -> Vec<Series<'a>> {
    let ranks: Vec<Vec<&super::Mode>> = runs.iter().map(ranked).collect();
    labels
        .iter()
        .enumerate()
        .map(|(k, label)| Series {
            label,
            points: runs
                .iter()
                .zip(&ranks)
                .filter_map(|(a, r)| r.get(k).map(|m| (a.speed_rad_s, value(m))))
                .collect(),
        })
        .collect()
}

/// Smallest and largest speed of the runs, rad/s.
fn speed_range(runs: &[SpeedAnalysis]) -> (f64, f64) {
    runs.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), a| {
            (l.min(a.speed_rad_s), h.max(a.speed_rad_s))
        })
}

/// Whirl frequency of every oscillating mode against speed, with the `1×` and `0.5×`
/// lines; the threshold (if any) as a vertical line.
pub fn campbell_svg(
    title: &str,
    runs: &[SpeedAnalysis],
    threshold: Option<f64>,
) -> Result<String, String> {
    let labels = mode_labels(runs);
    let mut series = mode_curves(runs, &labels, |m| m.frequency_rad_s);
    let (lo, hi) = speed_range(runs);
    series.push(Series {
        label: "1x (synchronous)",
        points: vec![(lo, lo), (hi, hi)],
    });
    series.push(Series {
        label: "0.5x",
        points: vec![(lo, 0.5 * lo), (hi, 0.5 * hi)],
    });
    if let Some(t) = threshold {
        let (fmin, fmax) = series
            .iter()
            .flat_map(|s| s.points.iter().map(|p| p.1))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
                (l.min(v), h.max(v))
            });
        series.push(Series {
            label: "threshold speed",
            points: vec![(t, fmin), (t, fmax)],
        });
    }
    line_plot_svg(
        title,
        "spin speed (rad/s)",
        "whirl frequency (rad/s, forward > 0)",
        &series,
        Scale::Linear,
        Scale::Linear,
    )
}

/// Damping ratio of every oscillating mode against speed (negative: unstable).
pub fn damping_svg(title: &str, runs: &[SpeedAnalysis]) -> Result<String, String> {
    let labels = mode_labels(runs);
    let mut series = mode_curves(runs, &labels, |m| m.damping_ratio);
    let (lo, hi) = speed_range(runs);
    series.push(Series {
        label: "stability limit (0)",
        points: vec![(lo, 0.0), (hi, 0.0)],
    });
    line_plot_svg(
        title,
        "spin speed (rad/s)",
        "damping ratio",
        &series,
        Scale::Linear,
        Scale::Linear,
    )
}
