//! Campbell diagram and log-decrement-vs-speed figures (SVG strings; no I/O).
//!
//! Modes are followed by the continuity of their shapes ([`track_modes`]), not by
//! frequency rank, so a curve keeps its mode where two modes cross. On the Campbell
//! diagram a solid line is a forward whirl, a dashed one a backward whirl; as ROSS does,
//! points are marked by their logarithmic decrement (filled triangles: unstable, log dec
//! < 0; rings: below the usual margin of 0.1). The `1x` and `0.5x` lines, the operating
//! speed and the threshold speed are drawn; the frequency window covers the modes that
//! matter over the speed range (one mode far above does not flatten the rest; a note says
//! what is left out).

use super::analysis::SpeedAnalysis;
use super::modes::{track_modes, Mode};
use crate::plot::{palette, tick_label, Curve, Dash, Figure, Guide, Key, Marker, Scale};

/// Log decrement below which a mode is marked as lightly damped (the usual design margin,
/// e.g. API 684's 0.1).
pub const LOG_DEC_MARGIN: f64 = 0.1;

/// Top of the log-decrement window: above ~10 (amplitude down e^10 per cycle) a mode is
/// as good as overdamped, and showing it would flatten the margin region near 0.
const LOG_DEC_TOP: f64 = 10.0;

/// A mode followed over the speeds: `(speed, mode)` where it exists.
struct Track<'a> {
    points: Vec<(f64, &'a Mode)>,
}

fn tracks(runs: &[SpeedAnalysis]) -> Vec<Track<'_>> {
    let mut order: Vec<usize> = (0..runs.len()).collect();
    order.sort_by(|&a, &b| runs[a].speed_rad_s.total_cmp(&runs[b].speed_rad_s));
    let steps: Vec<(&[Mode], &super::M4)> = order
        .iter()
        .map(|&k| (runs[k].modes.as_slice(), &runs[k].linear.mass))
        .collect();
    track_modes(&steps)
        .into_iter()
        .map(|idx| Track {
            points: idx
                .iter()
                .enumerate()
                .filter_map(|(s, i)| {
                    i.map(|i| (runs[order[s]].speed_rad_s, &runs[order[s]].modes[i]))
                })
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

/// How far above the top speed a mode may start and still be drawn: a mode whose lowest
/// frequency exceeds this many times the top speed cannot be met by 1x or sub-synchronous
/// excitation in the range.
const RELEVANT_ABOVE_SPEED: f64 = 1.5;
/// The frequency window's top at most this many times the top speed.
const WINDOW_ABOVE_SPEED: f64 = 2.5;

/// The tracks worth drawing and the frequency window's top, rad/s, with a note of what is
/// left out.
fn window<'a>(
    all: Vec<Track<'a>>,
    top_speed: f64,
) -> (Vec<(usize, Track<'a>)>, f64, Option<String>) {
    let lowest = |t: &Track| {
        t.points
            .iter()
            .map(|(_, m)| m.frequency_rad_s.abs())
            .fold(f64::INFINITY, f64::min)
    };
    let highest = |t: &Track| {
        t.points
            .iter()
            .map(|(_, m)| m.frequency_rad_s.abs())
            .fold(0.0, f64::max)
    };
    let mut keep: Vec<(usize, Track)> = Vec::new();
    let mut left_out: Vec<f64> = Vec::new();
    for (k, t) in all.into_iter().enumerate() {
        if lowest(&t) <= RELEVANT_ABOVE_SPEED * top_speed {
            keep.push((k, t));
        } else {
            left_out.push(lowest(&t));
        }
    }
    if keep.is_empty() {
        // Every mode lies far above the speeds: the caller shows the lowest one alone.
        return (Vec::new(), 0.0, None);
    }
    let top = keep
        .iter()
        .map(|(_, t)| highest(t))
        .fold(top_speed, f64::max)
        .min(WINDOW_ABOVE_SPEED * top_speed)
        * 1.06;
    let clipped = keep.iter().any(|(_, t)| highest(t) > top);
    let mut notes = Vec::new();
    if !left_out.is_empty() {
        let low = left_out.iter().copied().fold(f64::INFINITY, f64::min);
        notes.push(format!(
            "{} mode{} above {} rad/s not shown",
            left_out.len(),
            if left_out.len() == 1 { "" } else { "s" },
            tick_label(low.floor())
        ));
    }
    if clipped {
        notes.push(format!(
            "frequencies above {} rad/s cut off",
            tick_label(top.round())
        ));
    }
    (keep, top, (!notes.is_empty()).then(|| notes.join("; ")))
}

/// The tracks to draw with their palette index and the frequency window: the relevant
/// ones, or the lowest one when every mode is far above the speeds.
fn drawn(runs: &[SpeedAnalysis]) -> (Vec<(usize, Track<'_>)>, f64, Option<String>) {
    let (_, hi) = speed_range(runs);
    let all = tracks(runs);
    let n = all.len();
    let lowest_track = all
        .iter()
        .enumerate()
        .map(|(k, t)| {
            (
                k,
                t.points
                    .iter()
                    .map(|(_, m)| m.frequency_rad_s.abs())
                    .fold(f64::INFINITY, f64::min),
            )
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(k, _)| k);
    let (keep, top, note) = window(all, hi);
    if !keep.is_empty() || n == 0 {
        return (keep, top, note);
    }
    // Every mode far above: the lowest alone, its own window.
    let mut all = tracks(runs);
    let k = lowest_track.expect("n > 0");
    let t = all.swap_remove(k);
    let top = t
        .points
        .iter()
        .map(|(_, m)| m.frequency_rad_s.abs())
        .fold(hi, f64::max)
        * 1.06;
    let note = (n > 1).then(|| format!("{} higher modes not shown", n - 1));
    (vec![(k, t)], top, note)
}

fn track_label(k: usize) -> String {
    format!("mode {}", k + 1)
}

/// Markers of a track's points by log decrement: unstable (< 0) filled triangles, lightly
/// damped (< [`LOG_DEC_MARGIN`]) rings.
fn stability_markers(t: &Track, colour: &str, y: impl Fn(&Mode) -> f64) -> [Curve; 2] {
    let pick = |lo: f64, hi: f64| -> Vec<(f64, f64)> {
        t.points
            .iter()
            .filter(|(_, m)| m.log_dec.is_some_and(|d| (lo..hi).contains(&d)))
            .map(|(w, m)| (*w, y(m)))
            .collect()
    };
    let curve = |points, marker| Curve {
        label: String::new(),
        points,
        colour: colour.to_string(),
        dash: None,
        width: 0.0,
        marker: Some(marker),
        legend: false,
    };
    [
        curve(pick(f64::NEG_INFINITY, 0.0), Marker::Triangle),
        curve(pick(0.0, LOG_DEC_MARGIN), Marker::Ring),
    ]
}

/// Keys for the markers that appear.
fn marker_keys(curves: &[Curve]) -> Vec<Key> {
    let mut keys = Vec::new();
    let has = |m: Marker| {
        curves
            .iter()
            .any(|c| c.marker == Some(m) && c.dash.is_none() && !c.points.is_empty())
    };
    if has(Marker::Triangle) {
        keys.push(Key {
            label: "unstable (log dec < 0)".into(),
            colour: "#555555".into(),
            dash: None,
            marker: Some(Marker::Triangle),
        });
    }
    if has(Marker::Ring) {
        keys.push(Key {
            label: format!("log dec < {LOG_DEC_MARGIN}"),
            colour: "#555555".into(),
            dash: None,
            marker: Some(Marker::Ring),
        });
    }
    keys
}

/// Whirl frequency (absolute; solid forward, dashed backward) of the modes against
/// speed, with the `1x` and `0.5x` lines, the operating speed and the threshold (if any)
/// as vertical lines.
pub fn campbell_svg(
    title: &str,
    runs: &[SpeedAnalysis],
    threshold: Option<f64>,
    operating: Option<f64>,
) -> Result<String, String> {
    campbell_figure(title, runs, threshold, operating)?.svg()
}

/// The [`Figure`] of [`campbell_svg`].
pub fn campbell_figure(
    title: &str,
    runs: &[SpeedAnalysis],
    threshold: Option<f64>,
    operating: Option<f64>,
) -> Result<Figure, String> {
    let (lo, hi) = speed_range(runs);
    let (tracks, top, note) = drawn(runs);
    if tracks.is_empty() {
        return Err("no oscillating mode at any speed".into());
    }
    let mut fig = Figure::new(
        title,
        "spin speed (rad/s)",
        "whirl frequency (rad/s)",
        Scale::Linear,
        Scale::Linear,
    );
    fig.note = note;
    let mut any_backward = false;
    let mut markers = Vec::new();
    for (k, t) in &tracks {
        let colour = palette(*k).to_string();
        // One polyline per run of the same direction; the first carries the legend.
        let mut first = true;
        let mut start = 0;
        while start < t.points.len() {
            let dir = t.points[start].1.frequency_rad_s > 0.0;
            let mut end = start + 1;
            while end < t.points.len() && (t.points[end].1.frequency_rad_s > 0.0) == dir {
                end += 1;
            }
            // Include the next point so that the runs join.
            let upto = (end + 1).min(t.points.len());
            any_backward |= !dir;
            fig.curves.push(Curve {
                label: if first {
                    track_label(*k)
                } else {
                    String::new()
                },
                points: t.points[start..upto]
                    .iter()
                    .map(|(w, m)| (*w, m.frequency_rad_s.abs()))
                    .collect(),
                colour: colour.clone(),
                dash: Some(if dir { Dash::Solid } else { Dash::Dashed }),
                width: 2.0,
                marker: None,
                legend: first,
            });
            first = false;
            start = end;
        }
        markers.extend(stability_markers(t, &colour, |m| m.frequency_rad_s.abs()));
    }
    let keys = marker_keys(&markers);
    fig.curves.extend(markers);
    if any_backward {
        fig.keys.push(Key {
            label: "dashed: backward whirl".into(),
            colour: "#555555".into(),
            dash: Some(Dash::Dashed),
            marker: None,
        });
    }
    fig.keys.extend(keys);
    let grey = "#555555".to_string();
    fig.guides.push(Guide::Ray {
        slope: 1.0,
        label: "1x".into(),
        colour: grey.clone(),
        dash: Dash::DashDot,
    });
    fig.guides.push(Guide::Ray {
        slope: 0.5,
        label: "0.5x".into(),
        colour: "#999999".into(),
        dash: Dash::Dotted,
    });
    if let Some(w) = operating.filter(|w| w.is_finite() && *w > 0.0) {
        fig.guides.push(Guide::VLine {
            x: w,
            label: format!("operating speed {} rad/s", tick_label(w)),
            colour: "#000000".into(),
            dash: Dash::Solid,
        });
    }
    if let Some(t) = threshold.filter(|t| t.is_finite()) {
        fig.guides.push(Guide::VLine {
            x: t,
            label: format!("threshold {} rad/s", tick_label(t.round())),
            colour: "#D55E00".into(),
            dash: Dash::Dashed,
        });
    }
    let x_lo = lo.min(operating.unwrap_or(lo)).min(0.0);
    let x_hi = hi.max(operating.unwrap_or(hi));
    fig.x_range = Some((x_lo, x_hi + 0.03 * (x_hi - x_lo)));
    fig.y_range = Some((0.0, top));
    Ok(fig)
}

/// Logarithmic decrement of the drawn modes against speed (negative: unstable), with the
/// stability limit and the operating speed.
pub fn damping_svg(
    title: &str,
    runs: &[SpeedAnalysis],
    operating: Option<f64>,
) -> Result<String, String> {
    damping_figure(title, runs, operating)?.svg()
}

/// The [`Figure`] of [`damping_svg`].
pub fn damping_figure(
    title: &str,
    runs: &[SpeedAnalysis],
    operating: Option<f64>,
) -> Result<Figure, String> {
    let (tracks, _, note) = drawn(runs);
    if tracks.is_empty() {
        return Err("no oscillating mode at any speed".into());
    }
    let mut fig = Figure::new(
        title,
        "spin speed (rad/s)",
        "logarithmic decrement",
        Scale::Linear,
        Scale::Linear,
    );
    fig.note = note;
    let mut values = Vec::new();
    let mut markers = Vec::new();
    for (k, t) in &tracks {
        let colour = palette(*k).to_string();
        let pts: Vec<(f64, f64)> = t
            .points
            .iter()
            .map(|(w, m)| (*w, m.log_dec.unwrap_or(f64::NAN)))
            .collect();
        values.extend(pts.iter().map(|p| p.1).filter(|v| v.is_finite()));
        fig.curves.push(Curve::line(track_label(*k), pts, *k));
        fig.curves.last_mut().expect("pushed").colour = colour.clone();
        fig.curves.last_mut().expect("pushed").dash = Some(Dash::Solid);
        markers.extend(stability_markers(t, &colour, |m| {
            m.log_dec.unwrap_or(f64::NAN)
        }));
    }
    let keys = marker_keys(&markers);
    fig.curves.extend(markers);
    fig.keys.extend(keys);
    fig.guides.push(Guide::HLine {
        y: 0.0,
        label: "stability limit".into(),
        colour: "#000000".into(),
        dash: Dash::Solid,
    });
    if let Some(w) = operating.filter(|w| w.is_finite() && *w > 0.0) {
        fig.guides.push(Guide::VLine {
            x: w,
            label: format!("operating speed {} rad/s", tick_label(w)),
            colour: "#000000".into(),
            dash: Dash::Dashed,
        });
    }
    // Window: strongly damped modes (log dec of tens near a speed where a pair turns
    // almost real) do not squash the region near 0 that decides stability.
    values.sort_by(f64::total_cmp);
    if let (Some(&lo), Some(&hi)) = (values.first(), values.last()) {
        let top = hi.clamp(0.5, LOG_DEC_TOP);
        let bottom = lo.min(0.0);
        let pad = 0.05 * (top - bottom);
        fig.y_range = Some((bottom - pad, top + pad));
        // A mode entirely above the window is not drawn: no legend entry for it.
        for c in fig.curves.iter_mut() {
            if !c.points.iter().any(|p| p.1 <= top + pad) {
                c.legend = false;
            }
        }
        if hi > top + pad {
            let n = fig.note.take();
            fig.note = Some(
                [
                    n,
                    Some(format!(
                        "log dec above {} (strongly damped) cut off",
                        tick_label(top)
                    )),
                ]
                .into_iter()
                .flatten()
                .collect::<Vec<_>>()
                .join("; "),
            );
        }
    }
    Ok(fig)
}
