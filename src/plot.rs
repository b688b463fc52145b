//! SVG figures, drawn by hand (no plotting crate, no fonts): one style shared by the CLI,
//! the service and the web page (`src/service/web/app.js` draws with the same palette,
//! font sizes and tick rules). A [`Figure`] holds curves, marker sets and guides (lines,
//! circles); [`Figure::layout`] places the axes, ticks and legend (in the emptiest spot
//! inside the plot, else outside on the right) and [`Figure::svg`] writes the SVG.
//!
//! The SVG marks what tests read: tick labels are `<text class="tick x|y">`, the legend
//! box `<rect class="legend">`, data lines `<polyline class="data">` and markers
//! `<path class="marker">` / `<circle class="marker">`.

use std::fmt::Write as _;

/// Colour-blind-safe qualitative palette (Okabe & Ito 2008, without their yellow, which
/// is unreadable on white), in the order curves take them.
pub const PALETTE: [&str; 7] = [
    "#0072B2", // blue
    "#D55E00", // vermillion
    "#009E73", // bluish green
    "#CC79A7", // reddish purple
    "#56B4E9", // sky blue
    "#E69F00", // orange
    "#000000", // black
];

/// Font family of every figure (the page's CSS uses the same).
pub const FONT: &str = "system-ui, -apple-system, 'Segoe UI', Roboto, 'DejaVu Sans', sans-serif";
/// Tick-label and legend font size, px.
pub const FONT_PX: f64 = 12.0;
/// Axis-label font size, px.
pub const LABEL_PX: f64 = 13.0;
/// Title font size, px.
pub const TITLE_PX: f64 = 15.0;
/// Mean advance of a character of the sans-serif font per px of font size (DejaVu Sans
/// averages ~0.55; 0.6 leaves room), for text widths without font metrics.
const CHAR_EM: f64 = 0.6;

/// One named curve of `(x, y)` points (the simple interface of [`line_plot_svg`]).
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

/// Line pattern.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dash {
    /// Solid.
    Solid,
    /// Long dashes.
    Dashed,
    /// Dots.
    Dotted,
    /// Dash and dot.
    DashDot,
}

impl Dash {
    fn array(self) -> Option<&'static str> {
        match self {
            Dash::Solid => None,
            Dash::Dashed => Some("7 4"),
            Dash::Dotted => Some("2 3"),
            Dash::DashDot => Some("9 3 2 3"),
        }
    }
}

/// Point marker.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Marker {
    /// Filled circle.
    Circle,
    /// Filled upward triangle.
    Triangle,
    /// Filled square.
    Square,
    /// Open circle.
    Ring,
}

/// One curve: a line through its points (a NaN point lifts the pen), markers, or both.
#[derive(Clone, Debug)]
pub struct Curve {
    /// Legend label (empty: not in the legend).
    pub label: String,
    /// Points in data units.
    pub points: Vec<(f64, f64)>,
    /// Stroke and fill colour (`#rrggbb`).
    pub colour: String,
    /// Line pattern; `None` draws markers only.
    pub dash: Option<Dash>,
    /// Line width, px.
    pub width: f64,
    /// Marker at every point.
    pub marker: Option<Marker>,
    /// Whether the legend lists it.
    pub legend: bool,
}

impl Curve {
    /// A solid line of palette colour `k` with a legend entry.
    pub fn line(label: impl Into<String>, points: Vec<(f64, f64)>, k: usize) -> Self {
        Curve {
            label: label.into(),
            points,
            colour: palette(k).to_string(),
            dash: Some(styles(k)),
            width: 2.0,
            marker: None,
            legend: true,
        }
    }
}

/// A reference drawn over the data (does not set the axis ranges unless `fit`).
#[derive(Clone, Debug)]
pub enum Guide {
    /// Vertical line at `x` across the plot.
    VLine {
        /// Position, data units.
        x: f64,
        /// Legend label (empty: none).
        label: String,
        /// Colour.
        colour: String,
        /// Pattern.
        dash: Dash,
    },
    /// Horizontal line at `y` across the plot.
    HLine {
        /// Position, data units.
        y: f64,
        /// Legend label (empty: none).
        label: String,
        /// Colour.
        colour: String,
        /// Pattern.
        dash: Dash,
    },
    /// Line from the origin with slope `k` (`y = k x`, e.g. the 1x line of a Campbell
    /// diagram), across the plot.
    Ray {
        /// Slope.
        slope: f64,
        /// Legend label (empty: none).
        label: String,
        /// Colour.
        colour: String,
        /// Pattern.
        dash: Dash,
    },
    /// Circle (linear axes only), included in the axis ranges.
    Circle {
        /// Centre, data units.
        centre: (f64, f64),
        /// Radius, data units.
        radius: f64,
        /// Legend label (empty: none).
        label: String,
    },
}

/// A legend entry with no data of its own (e.g. "dashed: backward whirl").
#[derive(Clone, Debug)]
pub struct Key {
    /// Text.
    pub label: String,
    /// Colour.
    pub colour: String,
    /// Line pattern (none: marker only).
    pub dash: Option<Dash>,
    /// Marker.
    pub marker: Option<Marker>,
}

/// A figure.
#[derive(Clone, Debug)]
pub struct Figure {
    /// Title.
    pub title: String,
    /// Horizontal axis label, with its unit.
    pub x_label: String,
    /// Vertical axis label, with its unit.
    pub y_label: String,
    /// Horizontal scale.
    pub x_scale: Scale,
    /// Vertical scale.
    pub y_scale: Scale,
    /// Equal data units per pixel on both axes (orbits).
    pub equal_aspect: bool,
    /// Curves, drawn in order.
    pub curves: Vec<Curve>,
    /// Guides, drawn under the curves.
    pub guides: Vec<Guide>,
    /// Extra legend entries, after the curves'.
    pub keys: Vec<Key>,
    /// Fixed horizontal range (else from the data).
    pub x_range: Option<(f64, f64)>,
    /// Fixed vertical range (else from the data); data outside is clipped.
    pub y_range: Option<(f64, f64)>,
    /// A line of small text under the plot (what the figure leaves out).
    pub note: Option<String>,
    /// Canvas size, px.
    pub size: (f64, f64),
}

/// Palette colour `k` (cycles).
pub fn palette(k: usize) -> &'static str {
    PALETTE[k % PALETTE.len()]
}

/// The pattern of curve `k`: solid for the first palette round, then others, so that
/// more curves than colours stay distinct.
pub fn styles(k: usize) -> Dash {
    [Dash::Solid, Dash::Dashed, Dash::DashDot, Dash::Dotted][(k / PALETTE.len()) % 4]
}

/// A rectangle in px (y down).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rect {
    /// Left.
    pub x: f64,
    /// Top.
    pub y: f64,
    /// Width.
    pub w: f64,
    /// Height.
    pub h: f64,
}

impl Rect {
    /// Whether `(px, py)` lies inside (borders included).
    pub fn contains(&self, px: f64, py: f64) -> bool {
        (self.x..=self.x + self.w).contains(&px) && (self.y..=self.y + self.h).contains(&py)
    }

    fn grown(&self, d: f64) -> Rect {
        Rect {
            x: self.x - d,
            y: self.y - d,
            w: self.w + 2.0 * d,
            h: self.h + 2.0 * d,
        }
    }

    /// Whether the segment `a`-`b` meets the rectangle (Liang-Barsky clipping).
    pub fn meets_segment(&self, a: (f64, f64), b: (f64, f64)) -> bool {
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let (mut t0, mut t1) = (0.0_f64, 1.0_f64);
        for (p, q) in [
            (-dx, a.0 - self.x),
            (dx, self.x + self.w - a.0),
            (-dy, a.1 - self.y),
            (dy, self.y + self.h - a.1),
        ] {
            if p == 0.0 {
                if q < 0.0 {
                    return false;
                }
            } else {
                let r = q / p;
                if p < 0.0 {
                    t0 = t0.max(r);
                } else {
                    t1 = t1.min(r);
                }
                if t0 > t1 {
                    return false;
                }
            }
        }
        true
    }
}

/// One tick: value, label (empty for a minor tick) and position along its axis, px.
#[derive(Clone, Debug, PartialEq)]
pub struct Tick {
    /// Data value.
    pub value: f64,
    /// Label; empty for an unlabelled (minor) tick.
    pub label: String,
    /// Pixel position (x for the horizontal axis, y for the vertical).
    pub px: f64,
}

/// Where everything of a figure goes.
#[derive(Clone, Debug)]
pub struct Layout {
    /// Canvas size, px.
    pub size: (f64, f64),
    /// The plotting area.
    pub plot: Rect,
    /// Data range shown horizontally.
    pub x_range: (f64, f64),
    /// Data range shown vertically.
    pub y_range: (f64, f64),
    /// Horizontal ticks.
    pub x_ticks: Vec<Tick>,
    /// Vertical ticks.
    pub y_ticks: Vec<Tick>,
    /// Legend box (none without legend entries).
    pub legend: Option<Rect>,
    /// Whether the legend sits outside the plotting area (no spot inside was free).
    pub legend_outside: bool,
}

impl Layout {
    /// Pixel position of a data point.
    pub fn to_px(&self, fig: &Figure, p: (f64, f64)) -> (f64, f64) {
        let f = |v: f64, (lo, hi): (f64, f64), s: Scale| match s {
            Scale::Linear => (v - lo) / (hi - lo),
            Scale::Log => (v / lo).ln() / (hi / lo).ln(),
        };
        (
            self.plot.x + f(p.0, self.x_range, fig.x_scale) * self.plot.w,
            self.plot.y + self.plot.h - f(p.1, self.y_range, fig.y_scale) * self.plot.h,
        )
    }
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

/// The label of linear tick `k · step`: exactly `0` at zero, as many decimals as the
/// step needs (so `-1.11e-16` never shows), scientific for magnitudes outside 1e-3..1e5.
fn linear_tick_label(k: i64, step: f64, magnitude: f64) -> String {
    if k == 0 {
        return "0".into();
    }
    let v = k as f64 * step;
    let step_exp = step.log10().floor() as i32;
    if (1e-3..1e5).contains(&magnitude) {
        // A step of 2.5 × 10^e needs one decimal more than 10^e (0.25, 2.5; not 250).
        let m = step / 10f64.powi(step_exp);
        let decimals = if (m - m.round()).abs() > 1e-6 {
            (1 - step_exp).max(0)
        } else {
            (-step_exp).max(0)
        } as usize;
        format!("{:.*}", decimals, v)
    } else {
        let e = v.abs().log10().floor() as i32;
        let digits = (e - step_exp).max(0) as usize;
        let s = format!("{:.*}", digits, v / 10f64.powi(e));
        format!("{s}e{e}")
    }
}

/// Nice linear ticks (steps 1, 2, 2.5, 5 × 10^n) over `[lo, hi]`, about `target` of them.
fn linear_ticks(lo: f64, hi: f64, target: usize) -> Vec<(f64, String)> {
    let raw = (hi - lo) / target.max(1) as f64;
    if !(raw > 0.0 && raw.is_finite()) {
        return vec![(lo, tick_label(lo))];
    }
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw * (1.0 - 1e-9))
        .unwrap_or(10.0 * mag);
    let (k0, k1) = ((lo / step).ceil() as i64, (hi / step).floor() as i64);
    let magnitude = lo.abs().max(hi.abs());
    (k0..=k1.min(k0 + 100))
        .map(|k| (k as f64 * step, linear_tick_label(k, step, magnitude)))
        .collect()
}

/// Log ticks over `[lo, hi]` with at least 3 labels: decades (every n-th over many
/// decades) with 2..9 as unlabelled minor ticks, else 1-2-5, else 1..9, else nice linear
/// values when the range is narrower than a factor ~2.
fn log_ticks(lo: f64, hi: f64) -> Vec<(f64, String)> {
    let (e0, e1) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    let inside = |v: f64| (lo * (1.0 - 1e-9)..=hi * (1.0 + 1e-9)).contains(&v);
    let decades = (hi / lo).log10();
    let every = ((decades / 8.0).ceil() as i32).max(1);
    let with = |mults: &[f64], labelled: bool| -> Vec<(f64, String)> {
        let mut out = Vec::new();
        for e in e0..=e1 {
            for &m in mults {
                let v = m * 10f64.powi(e);
                if inside(v) {
                    let label = if labelled && (m != 1.0 || e.rem_euclid(every) == 0) {
                        tick_label(v)
                    } else {
                        String::new()
                    };
                    out.push((v, label));
                }
            }
        }
        out
    };
    let count = |t: &[(f64, String)]| t.iter().filter(|(_, l)| !l.is_empty()).count();
    let decade = with(&[1.0], true);
    if count(&decade) >= 3 {
        if decades <= 8.0 {
            let mut all = decade;
            all.extend(
                with(&[2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0], false)
                    .into_iter()
                    .filter(|(v, _)| inside(*v)),
            );
            return all;
        }
        return decade;
    }
    let one_two_five = with(&[1.0, 2.0, 5.0], true);
    if count(&one_two_five) >= 3 {
        let mut all = one_two_five;
        all.extend(with(&[3.0, 4.0, 6.0, 7.0, 8.0, 9.0], false));
        return all;
    }
    let all = with(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0], true);
    if count(&all) >= 3 {
        return all;
    }
    // Narrower than a factor ~2: nice linear values, as many as give 3 labels.
    let mut out = Vec::new();
    for target in 4..=12 {
        out = linear_ticks(lo, hi, target)
            .into_iter()
            .filter(|(v, _)| *v > 0.0)
            .map(|(v, _)| (v, tick_label(v)))
            .collect();
        if out.len() >= 3 {
            break;
        }
    }
    out
}

/// Most decades a log axis may span (ticks are generated per decade).
const MAX_LOG_DECADES: f64 = 300.0;

/// Whether an axis over `[lo, hi]` can be drawn: finite bounds, a finite positive width,
/// and for a log axis a positive start and at most [`MAX_LOG_DECADES`]. Otherwise the
/// figure is skipped with this reason.
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
    // Ticks need a step the f64 grid resolves.
    if scale == Scale::Linear && (hi - lo) <= 1e-12 * lo.abs().max(hi.abs()) {
        return Err(format!("range {} is narrower than f64 resolves", shown()));
    }
    Ok(())
}

/// Width of `s` in px at `font` px (estimate).
fn text_w(s: &str, font: f64) -> f64 {
    s.chars().count() as f64 * CHAR_EM * font
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// A data range `(low, high)`.
type Span = (f64, f64);
/// A point in px.
type Px = (f64, f64);

/// Legend row height, px.
const LEGEND_ROW: f64 = 17.0;
/// Length of a legend's line sample, px.
const LEGEND_SAMPLE: f64 = 26.0;

impl Figure {
    /// An empty figure on the default 720 × 480 canvas.
    pub fn new(title: &str, x_label: &str, y_label: &str, x_scale: Scale, y_scale: Scale) -> Self {
        Figure {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            x_scale,
            y_scale,
            equal_aspect: false,
            curves: Vec::new(),
            guides: Vec::new(),
            keys: Vec::new(),
            x_range: None,
            y_range: None,
            note: None,
            size: (720.0, 480.0),
        }
    }

    fn keep(&self, p: (f64, f64)) -> bool {
        let ok = |v: f64, s: Scale| v.is_finite() && (s == Scale::Linear || v > 0.0);
        ok(p.0, self.x_scale) && ok(p.1, self.y_scale)
    }

    /// Legend entries: (label, colour, dash, marker).
    fn legend_entries(&self) -> Vec<Key> {
        let mut out: Vec<Key> = self
            .curves
            .iter()
            .filter(|c| c.legend && !c.label.is_empty() && c.points.iter().any(|&p| self.keep(p)))
            .map(|c| Key {
                label: c.label.clone(),
                colour: c.colour.clone(),
                dash: c.dash,
                marker: c.marker,
            })
            .collect();
        for g in &self.guides {
            let (label, colour, dash) = match g {
                Guide::VLine {
                    label,
                    colour,
                    dash,
                    ..
                }
                | Guide::HLine {
                    label,
                    colour,
                    dash,
                    ..
                }
                | Guide::Ray {
                    label,
                    colour,
                    dash,
                    ..
                } => (label, colour.as_str(), Some(*dash)),
                Guide::Circle { label, .. } => (label, "#777777", Some(Dash::Dashed)),
            };
            if !label.is_empty() {
                out.push(Key {
                    label: label.clone(),
                    colour: colour.into(),
                    dash,
                    marker: None,
                });
            }
        }
        out.extend(self.keys.iter().cloned());
        out
    }

    /// Data ranges (before the equal-aspect widening), padded.
    fn ranges(&self) -> Result<(Span, Span), String> {
        let pts: Vec<(f64, f64)> = self
            .curves
            .iter()
            .flat_map(|c| c.points.iter().copied())
            .filter(|&p| self.keep(p))
            .collect();
        if pts.is_empty() {
            return Err("nothing to plot".into());
        }
        let mut xs: Vec<f64> = pts.iter().map(|p| p.0).collect();
        let mut ys: Vec<f64> = pts.iter().map(|p| p.1).collect();
        for g in &self.guides {
            match g {
                Guide::Circle { centre, radius, .. } if radius.is_finite() => {
                    xs.extend([centre.0 - radius, centre.0 + radius]);
                    ys.extend([centre.1 - radius, centre.1 + radius]);
                }
                Guide::VLine { x, .. } if x.is_finite() => xs.push(*x),
                Guide::HLine { y, .. } if y.is_finite() => ys.push(*y),
                _ => {}
            }
        }
        let span = |v: &[f64], s: Scale| -> (f64, f64) {
            let v: Vec<f64> = v
                .iter()
                .copied()
                .filter(|x| s == Scale::Linear || *x > 0.0)
                .collect();
            let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            match s {
                Scale::Linear => {
                    // 0.04 hi − 0.04 lo: no overflow for a span wider than f64::MAX.
                    let pad = if hi > lo {
                        0.04 * hi - 0.04 * lo
                    } else {
                        lo.abs().max(1e-12) * 0.1
                    };
                    (lo - pad, hi + pad)
                }
                Scale::Log => {
                    if hi > lo {
                        // 4 % of the decades each side, at least a factor 1.1 (decades as
                        // a difference of logs: hi / lo may overflow).
                        let f = 10f64.powf(0.04 * (hi.log10() - lo.log10())).max(1.1);
                        (lo / f, hi * f)
                    } else {
                        (lo / 1.5, hi * 1.5)
                    }
                }
            }
        };
        let x = self.x_range.unwrap_or_else(|| span(&xs, self.x_scale));
        let y = self.y_range.unwrap_or_else(|| span(&ys, self.y_scale));
        drawable(x.0, x.1, self.x_scale).map_err(|e| format!("x axis: {e}"))?;
        drawable(y.0, y.1, self.y_scale).map_err(|e| format!("y axis: {e}"))?;
        Ok((x, y))
    }

    fn ticks(&self, (lo, hi): (f64, f64), s: Scale, target: usize) -> Vec<(f64, String)> {
        match s {
            Scale::Linear => linear_ticks(lo, hi, target),
            Scale::Log => log_ticks(lo, hi),
        }
    }

    /// Pixel points of every drawn mark (line vertices by segment, markers), for the
    /// legend's placement.
    fn marks(&self, l: &Layout) -> (Vec<(Px, Px)>, Vec<Px>) {
        let mut segs = Vec::new();
        let mut dots = Vec::new();
        for c in &self.curves {
            let mut prev: Option<(f64, f64)> = None;
            for &p in &c.points {
                if !self.keep(p) {
                    prev = None;
                    continue;
                }
                let q = l.to_px(self, p);
                if c.dash.is_some() {
                    if let Some(a) = prev {
                        segs.push((a, q));
                    }
                }
                if c.marker.is_some() || c.dash.is_none() {
                    dots.push(q);
                }
                prev = Some(q);
            }
        }
        for g in &self.guides {
            let p = &l.plot;
            match g {
                Guide::VLine { x, .. } => {
                    let (px, _) = l.to_px(self, (*x, l.y_range.0.max(1e-300)));
                    segs.push(((px, p.y), (px, p.y + p.h)));
                }
                Guide::HLine { y, .. } => {
                    let (_, py) = l.to_px(self, (l.x_range.0.max(1e-300), *y));
                    segs.push(((p.x, py), (p.x + p.w, py)));
                }
                Guide::Ray { slope, .. } => {
                    let pts = self.ray_points(l, *slope);
                    for w in pts.windows(2) {
                        segs.push((l.to_px(self, w[0]), l.to_px(self, w[1])));
                    }
                }
                Guide::Circle { centre, radius, .. } => {
                    let n = 48;
                    let pts: Vec<(f64, f64)> = (0..=n)
                        .map(|k| {
                            let a = std::f64::consts::TAU * k as f64 / n as f64;
                            l.to_px(
                                self,
                                (centre.0 + radius * a.cos(), centre.1 + radius * a.sin()),
                            )
                        })
                        .collect();
                    for w in pts.windows(2) {
                        segs.push((w[0], w[1]));
                    }
                }
            }
        }
        (segs, dots)
    }

    /// Points of `y = slope · x` across the shown x range (several on a log axis).
    fn ray_points(&self, l: &Layout, slope: f64) -> Vec<(f64, f64)> {
        let (a, b) = l.x_range;
        let n = if self.x_scale == Scale::Log { 32 } else { 1 };
        (0..=n)
            .map(|k| {
                let t = k as f64 / n as f64;
                let x = match self.x_scale {
                    Scale::Linear => a + t * (b - a),
                    Scale::Log => a * (b / a).powf(t),
                };
                (x, slope * x)
            })
            .filter(|&p| self.keep(p))
            .collect()
    }

    /// Places the plot, ticks and legend.
    pub fn layout(&self) -> Result<Layout, String> {
        let (xr, yr) = self.ranges()?;
        let entries = self.legend_entries();
        let legend_size = if entries.is_empty() {
            None
        } else {
            let w = entries
                .iter()
                .map(|k| text_w(&k.label, FONT_PX))
                .fold(0.0, f64::max)
                + LEGEND_SAMPLE
                + 20.0;
            Some((w, entries.len() as f64 * LEGEND_ROW + 8.0))
        };
        let inside = self.place(xr, yr, None)?;
        let Some((lw, lh)) = legend_size else {
            return Ok(inside);
        };
        // Inside: the first free spot of the corners, edges' middles; else outside right.
        let (segs, dots) = self.marks(&inside);
        let p = inside.plot;
        let inset = 6.0;
        let (l, r) = (p.x + inset, p.x + p.w - lw - inset);
        let (t, b) = (p.y + inset, p.y + p.h - lh - inset);
        let (cx, cy) = (p.x + 0.5 * (p.w - lw), p.y + 0.5 * (p.h - lh));
        let spots = [
            (r, t),
            (l, t),
            (r, b),
            (l, b),
            (cx, t),
            (cx, b),
            (r, cy),
            (l, cy),
        ];
        if lw + 2.0 * inset <= p.w && lh + 2.0 * inset <= p.h {
            for (x, y) in spots {
                let rect = Rect { x, y, w: lw, h: lh };
                let g = rect.grown(3.0);
                let hit = segs.iter().any(|&(a, b)| g.meets_segment(a, b))
                    || dots.iter().any(|&(dx, dy)| g.grown(2.0).contains(dx, dy));
                if !hit {
                    return Ok(Layout {
                        legend: Some(rect),
                        ..inside
                    });
                }
            }
        }
        // Outside: below the plot (the canvas grows) when beside it would squeeze an
        // equal-aspect plot or a wide legend; else on the right.
        if self.equal_aspect || lw > 0.35 * self.size.0 {
            let mut grown = self.clone();
            grown.size.1 += lh + 8.0;
            let mut out = grown.place_below(xr, yr, lh + 8.0)?;
            out.legend = Some(Rect {
                x: out.plot.x,
                y: out.plot.y + out.plot.h + 48.0,
                w: lw.min(out.size.0 - out.plot.x - 8.0),
                h: lh,
            });
            out.legend_outside = true;
            return Ok(out);
        }
        let mut out = self.place(xr, yr, Some(lw + 14.0))?;
        let h = lh.min(out.plot.h);
        out.legend = Some(Rect {
            x: out.plot.x + out.plot.w + 12.0,
            y: out.plot.y,
            w: lw,
            h,
        });
        out.legend_outside = true;
        Ok(out)
    }

    /// Axes and ticks with `right` px kept free on the right (an outside legend).
    fn place(&self, xr: (f64, f64), yr: (f64, f64), right: Option<f64>) -> Result<Layout, String> {
        self.place_with(xr, yr, right, 0.0)
    }

    /// Axes and ticks with `below` px kept free under the x label (an outside legend).
    fn place_below(&self, xr: (f64, f64), yr: (f64, f64), below: f64) -> Result<Layout, String> {
        self.place_with(xr, yr, None, below)
    }

    fn place_with(
        &self,
        xr: (f64, f64),
        yr: (f64, f64),
        right: Option<f64>,
        below: f64,
    ) -> Result<Layout, String> {
        let (w, h) = self.size;
        let top = if self.title.is_empty() { 14.0 } else { 40.0 };
        let bottom = 54.0 + below + if self.note.is_some() { 16.0 } else { 0.0 };
        let right_gap = 22.0 + right.unwrap_or(0.0);
        // Equal aspect: widen the tighter range so one data unit spans as many px on both.
        let widen = |left: f64| -> ((f64, f64), (f64, f64)) {
            if !self.equal_aspect {
                return (xr, yr);
            }
            let (pw, ph) = (w - left - right_gap, h - top - bottom);
            let per_px = ((xr.1 - xr.0) / pw).max((yr.1 - yr.0) / ph);
            let (cx, cy) = (0.5 * (xr.0 + xr.1), 0.5 * (yr.0 + yr.1));
            (
                (cx - 0.5 * per_px * pw, cx + 0.5 * per_px * pw),
                (cy - 0.5 * per_px * ph, cy + 0.5 * per_px * ph),
            )
        };
        // The widest y tick label sets the left margin (ticks depend on the range, which
        // depends on the margin for equal aspect: settle in a few rounds).
        let mut left = 80.0;
        for _ in 0..3 {
            if w - left - right_gap < 60.0 || h - top - bottom < 60.0 {
                return Err("canvas too small for the figure".into());
            }
            let (_, y) = widen(left);
            let ph = h - top - bottom;
            let widest = self
                .ticks(y, self.y_scale, (ph / 70.0).round().max(3.0) as usize)
                .iter()
                .map(|(_, s)| text_w(s, FONT_PX))
                .fold(0.0, f64::max);
            let need = (24.0 + widest + 10.0).max(48.0);
            if (need - left).abs() < 1.0 {
                break;
            }
            left = need;
        }
        if w - left - right_gap < 60.0 {
            return Err("canvas too small for the figure".into());
        }
        let (xr, yr) = widen(left);
        let plot = Rect {
            x: left,
            y: top,
            w: w - left - right_gap,
            h: h - top - bottom,
        };
        let mut layout = Layout {
            size: (w, h),
            plot,
            x_range: xr,
            y_range: yr,
            x_ticks: Vec::new(),
            y_ticks: Vec::new(),
            legend: None,
            legend_outside: false,
        };
        let xt = self.ticks(xr, self.x_scale, (plot.w / 90.0).round().max(3.0) as usize);
        let yt = self.ticks(yr, self.y_scale, (plot.h / 70.0).round().max(3.0) as usize);
        let lo_y = yr.0.max(f64::MIN_POSITIVE);
        let lo_x = xr.0.max(f64::MIN_POSITIVE);
        let mut x_ticks: Vec<Tick> = xt
            .into_iter()
            .map(|(v, s)| Tick {
                px: layout.to_px(self, (v, lo_y)).0,
                value: v,
                label: s,
            })
            .collect();
        x_ticks.sort_by(|a, b| a.px.total_cmp(&b.px));
        // Drop labels that would overlap their left neighbour's.
        let mut last_right = f64::NEG_INFINITY;
        for t in &mut x_ticks {
            if t.label.is_empty() {
                continue;
            }
            let half = 0.5 * text_w(&t.label, FONT_PX);
            if t.px - half < last_right + 6.0 {
                t.label.clear();
            } else {
                last_right = t.px + half;
            }
        }
        layout.x_ticks = x_ticks;
        layout.y_ticks = yt
            .into_iter()
            .map(|(v, s)| Tick {
                px: layout.to_px(self, (lo_x, v)).1,
                value: v,
                label: s,
            })
            .collect();
        Ok(layout)
    }

    /// The SVG.
    pub fn svg(&self) -> Result<String, String> {
        let l = self.layout()?;
        let (w, h) = l.size;
        let p = l.plot;
        let mut s = String::new();
        let _ = write!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="{}" font-size="{FONT_PX}">"#,
            esc(FONT)
        );
        let _ = write!(
            s,
            r##"<rect width="{w}" height="{h}" fill="#ffffff"/><defs><clipPath id="plot-area"><rect x="{:.1}" y="{:.1}" width="{:.1}" height="{:.1}"/></clipPath></defs>"##,
            p.x, p.y, p.w, p.h
        );
        if !self.title.is_empty() {
            let _ = write!(
                s,
                "<text class=\"title\" x=\"{:.1}\" y=\"24\" font-size=\"{TITLE_PX}\" font-weight=\"600\" fill=\"#1b1f24\">\n{}\n</text>",
                p.x,
                esc(&self.title)
            );
        }
        // Grid and ticks.
        s.push_str(r##"<g class="grid" stroke="#e4e7eb" stroke-width="1">"##);
        for t in &l.x_ticks {
            let op = if t.label.is_empty() { 0.5 } else { 1.0 };
            let _ = write!(
                s,
                r#"<line x1="{0:.1}" x2="{0:.1}" y1="{1:.1}" y2="{2:.1}" stroke-opacity="{op}"/>"#,
                t.px,
                p.y,
                p.y + p.h
            );
        }
        for t in &l.y_ticks {
            let op = if t.label.is_empty() { 0.5 } else { 1.0 };
            let _ = write!(
                s,
                r#"<line x1="{:.1}" x2="{:.1}" y1="{2:.1}" y2="{2:.1}" stroke-opacity="{op}"/>"#,
                p.x,
                p.x + p.w,
                t.px
            );
        }
        s.push_str("</g>");
        s.push_str(r##"<g class="axis" stroke="#444444" fill="#222222">"##);
        let _ = write!(
            s,
            r#"<rect x="{:.1}" y="{:.1}" width="{:.1}" height="{:.1}" fill="none"/>"#,
            p.x, p.y, p.w, p.h
        );
        for t in &l.x_ticks {
            let len = if t.label.is_empty() { 3.0 } else { 5.0 };
            let _ = write!(
                s,
                r#"<line x1="{0:.1}" x2="{0:.1}" y1="{1:.1}" y2="{2:.1}"/>"#,
                t.px,
                p.y + p.h,
                p.y + p.h + len
            );
            if !t.label.is_empty() {
                let _ = write!(
                    s,
                    r#"<text class="tick x" x="{:.1}" y="{:.1}" text-anchor="middle" stroke="none">{}</text>"#,
                    t.px,
                    p.y + p.h + 18.0,
                    esc(&t.label)
                );
            }
        }
        for t in &l.y_ticks {
            let len = if t.label.is_empty() { 3.0 } else { 5.0 };
            let _ = write!(
                s,
                r#"<line x1="{:.1}" x2="{:.1}" y1="{2:.1}" y2="{2:.1}"/>"#,
                p.x - len,
                p.x,
                t.px
            );
            if !t.label.is_empty() {
                let _ = write!(
                    s,
                    r#"<text class="tick y" x="{:.1}" y="{:.1}" text-anchor="end" stroke="none">{}</text>"#,
                    p.x - 8.0,
                    t.px + 4.0,
                    esc(&t.label)
                );
            }
        }
        s.push_str("</g>");
        let _ = write!(
            s,
            r##"<text class="label x" x="{:.1}" y="{:.1}" text-anchor="middle" font-size="{LABEL_PX}" fill="#1b1f24">{}</text>"##,
            p.x + 0.5 * p.w,
            p.y + p.h + 40.0,
            esc(&self.x_label)
        );
        let (ly, lx) = (p.y + 0.5 * p.h, 16.0);
        let _ = write!(
            s,
            r##"<text class="label y" x="{lx}" y="{ly:.1}" text-anchor="middle" font-size="{LABEL_PX}" fill="#1b1f24" transform="rotate(-90 {lx} {ly:.1})">{}</text>"##,
            esc(&self.y_label)
        );
        if let Some(note) = &self.note {
            let _ = write!(
                s,
                r##"<text class="note" x="{:.1}" y="{:.1}" font-size="11" fill="#5b6470">{}</text>"##,
                p.x,
                h - 8.0,
                esc(note)
            );
        }
        // Guides and data, clipped to the plot.
        s.push_str(r#"<g clip-path="url(#plot-area)">"#);
        for g in &self.guides {
            match g {
                Guide::VLine {
                    x, colour, dash, ..
                } => {
                    let (px, _) = l.to_px(self, (*x, l.y_range.0.max(f64::MIN_POSITIVE)));
                    let _ = write!(
                        s,
                        r#"<line class="guide" x1="{0:.1}" x2="{0:.1}" y1="{1:.1}" y2="{2:.1}" stroke="{colour}" stroke-width="1.5"{3}/>"#,
                        px,
                        p.y,
                        p.y + p.h,
                        dash_attr(Some(*dash))
                    );
                }
                Guide::HLine {
                    y, colour, dash, ..
                } => {
                    let (_, py) = l.to_px(self, (l.x_range.0.max(f64::MIN_POSITIVE), *y));
                    let _ = write!(
                        s,
                        r#"<line class="guide" x1="{:.1}" x2="{:.1}" y1="{2:.1}" y2="{2:.1}" stroke="{colour}" stroke-width="1.5"{3}/>"#,
                        p.x,
                        p.x + p.w,
                        py,
                        dash_attr(Some(*dash))
                    );
                }
                Guide::Ray {
                    slope,
                    colour,
                    dash,
                    ..
                } => {
                    let pts: Vec<String> = self
                        .ray_points(&l, *slope)
                        .into_iter()
                        .map(|q| {
                            let (a, b) = l.to_px(self, q);
                            format!("{a:.1},{b:.1}")
                        })
                        .collect();
                    let _ = write!(
                        s,
                        r#"<polyline class="guide" points="{}" fill="none" stroke="{colour}" stroke-width="1.5"{}/>"#,
                        pts.join(" "),
                        dash_attr(Some(*dash))
                    );
                }
                Guide::Circle { centre, radius, .. } => {
                    let (cx, cy) = l.to_px(self, *centre);
                    let (ex, _) = l.to_px(self, (centre.0 + radius, centre.1));
                    let _ = write!(
                        s,
                        r##"<circle class="guide" cx="{cx:.1}" cy="{cy:.1}" r="{:.1}" fill="none" stroke="#777777" stroke-width="1.5"{}/>"##,
                        (ex - cx).abs(),
                        dash_attr(Some(Dash::Dashed))
                    );
                }
            }
        }
        for c in &self.curves {
            let mut runs: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
            for &q in &c.points {
                if self.keep(q) {
                    runs.last_mut().expect("non-empty").push(l.to_px(self, q));
                } else if !runs.last().expect("non-empty").is_empty() {
                    runs.push(Vec::new());
                }
            }
            if let Some(d) = c.dash {
                for run in runs.iter().filter(|r| !r.is_empty()) {
                    let pts: Vec<String> =
                        run.iter().map(|(a, b)| format!("{a:.1},{b:.1}")).collect();
                    let _ = write!(
                        s,
                        r#"<polyline class="data" points="{}" fill="none" stroke="{}" stroke-width="{}" stroke-linejoin="round"{}/>"#,
                        pts.join(" "),
                        c.colour,
                        c.width,
                        dash_attr(Some(d))
                    );
                }
            }
            if let Some(m) = c.marker.or(if c.dash.is_none() {
                Some(Marker::Circle)
            } else {
                None
            }) {
                for &(a, b) in runs.iter().flatten() {
                    s.push_str(&marker_svg(m, a, b, &c.colour, 3.5));
                }
            }
        }
        s.push_str("</g>");
        // Legend.
        if let Some(r) = l.legend {
            let entries = self.legend_entries();
            let _ = write!(
                s,
                r##"<rect class="legend" x="{:.1}" y="{:.1}" width="{:.1}" height="{:.1}" fill="#ffffff" fill-opacity="0.92" stroke="#b8bec6"/>"##,
                r.x, r.y, r.w, r.h
            );
            let rows = ((r.h - 8.0) / LEGEND_ROW).floor().max(1.0) as usize;
            for (k, e) in entries.iter().enumerate().take(rows) {
                let y = r.y + 4.0 + LEGEND_ROW * (k as f64 + 0.5);
                let x0 = r.x + 8.0;
                if let Some(d) = e.dash {
                    let _ = write!(
                        s,
                        r#"<line x1="{x0:.1}" x2="{:.1}" y1="{y:.1}" y2="{y:.1}" stroke="{}" stroke-width="2"{}/>"#,
                        x0 + LEGEND_SAMPLE,
                        e.colour,
                        dash_attr(Some(d))
                    );
                }
                if let Some(m) = e.marker {
                    s.push_str(
                        &marker_svg(m, x0 + 0.5 * LEGEND_SAMPLE, y, &e.colour, 3.5)
                            .replace("class=\"marker\"", "class=\"key\""),
                    );
                }
                let _ = write!(
                    s,
                    r##"<text class="legend-entry" x="{:.1}" y="{:.1}" fill="#1b1f24">{}</text>"##,
                    x0 + LEGEND_SAMPLE + 6.0,
                    y + 4.0,
                    esc(&e.label)
                );
            }
            if entries.len() > rows {
                let _ = write!(
                    s,
                    r##"<text x="{:.1}" y="{:.1}" fill="#5b6470">+{} more</text>"##,
                    r.x + 8.0,
                    r.y + r.h + 14.0,
                    entries.len() - rows
                );
            }
        }
        s.push_str("</svg>\n");
        Ok(s)
    }
}

fn dash_attr(d: Option<Dash>) -> String {
    match d.and_then(Dash::array) {
        Some(a) => format!(r#" stroke-dasharray="{a}""#),
        None => String::new(),
    }
}

fn marker_svg(m: Marker, x: f64, y: f64, colour: &str, r: f64) -> String {
    match m {
        Marker::Circle => {
            format!(r#"<circle class="marker" cx="{x:.1}" cy="{y:.1}" r="{r}" fill="{colour}"/>"#)
        }
        Marker::Ring => format!(
            r##"<circle class="marker" cx="{x:.1}" cy="{y:.1}" r="{r}" fill="#ffffff" stroke="{colour}" stroke-width="1.5"/>"##
        ),
        Marker::Square => format!(
            r#"<path class="marker" d="M{:.1},{:.1}h{:.1}v{:.1}h{:.1}z" fill="{colour}"/>"#,
            x - r,
            y - r,
            2.0 * r,
            2.0 * r,
            -2.0 * r
        ),
        Marker::Triangle => {
            let q = 1.35 * r;
            format!(
                r##"<path class="marker" d="M{x:.1},{:.1}L{:.1},{:.1}L{:.1},{:.1}z" fill="{colour}" stroke="#000000" stroke-width="0.8"/>"##,
                y - q,
                x + q,
                y + 0.8 * q,
                x - q,
                y + 0.8 * q
            )
        }
    }
}

/// Writes a line plot of `series` to an SVG string (palette colours in order).
pub fn line_plot_svg(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series<'_>],
    x_scale: Scale,
    y_scale: Scale,
) -> Result<String, String> {
    simple(title, x_label, y_label, series, x_scale, y_scale, false).svg()
}

/// A linear plot with equal data units per pixel on both axes (orbits, trajectories).
pub fn line_plot_svg_equal_aspect(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series<'_>],
) -> Result<String, String> {
    simple(
        title,
        x_label,
        y_label,
        series,
        Scale::Linear,
        Scale::Linear,
        true,
    )
    .svg()
}

/// The [`Figure`] of [`line_plot_svg`]: markers at the points of curves with at most 40.
pub fn simple(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series<'_>],
    x_scale: Scale,
    y_scale: Scale,
    equal_aspect: bool,
) -> Figure {
    let mut f = Figure::new(title, x_label, y_label, x_scale, y_scale);
    f.equal_aspect = equal_aspect;
    if equal_aspect {
        f.size = (640.0, 600.0);
    }
    let single = series.len() == 1;
    for (k, s) in series.iter().enumerate() {
        let mut c = Curve::line(s.label, s.points.clone(), k);
        c.marker = (s.points.len() <= 40).then_some(Marker::Circle);
        // One unnamed curve needs no legend.
        c.legend = !(single && s.label.is_empty());
        f.curves.push(c);
    }
    f
}

/// A display unit: SI value × `scale` shown with `symbol`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Unit {
    /// Factor from the SI value.
    pub scale: f64,
    /// Symbol (empty: dimensionless).
    pub symbol: &'static str,
    /// The SI symbol of the stored value.
    pub si: &'static str,
}

const fn unit(scale: f64, symbol: &'static str, si: &'static str) -> Unit {
    Unit { scale, symbol, si }
}

/// Dimensionless.
pub const ONE: Unit = unit(1.0, "", "");

/// The display unit of a scene field named by an axis path (its last field name):
/// clearances, offsets and unbalance in µm, radii and lengths in mm, viscosity in mPa·s.
/// The web page's `unitOfPath` holds the same table.
pub fn unit_of_path(path: &str) -> Unit {
    let names: Vec<&str> = path
        .split('.')
        .map(|n| n.split('[').next().unwrap_or(n))
        .collect();
    let last = names.last().copied().unwrap_or("");
    match last {
        "clearance" | "offset" | "static_unbalance" | "threshold" | "g_radius" | "orbit"
        | "whirl" => unit(1e6, "µm", "m"),
        "radius" | "length" | "axial_position" => unit(1e3, "mm", "m"),
        "viscosity" => unit(1e3, "mPa·s", "Pa·s"),
        "mass" => unit(1.0, "kg", "kg"),
        "inertia" => unit(1.0, "kg·m²", "kg·m²"),
        "spin" | "speed" | "omega" => unit(1.0, "rad/s", "rad/s"),
        "couple_unbalance" | "angle" | "tilt" => unit(1e3, "mrad", "rad"),
        "gravity" => unit(1.0, "m/s²", "m/s²"),
        "velocity" => unit(1.0, "m/s", "m/s"),
        "t_end" | "sample_interval" | "fixed_step" | "max_step" | "duration" => unit(1.0, "s", "s"),
        "load" => unit(1.0, "N", "N"),
        _ => ONE,
    }
}

/// The display unit of a number in a variant's reductions, from its path's unit suffix
/// (`_m` µm, `_n` N, `_w` W, `_nm` N·m, `_rad_s` rad/s, `_1_s` 1/s, `_s` s).
pub fn unit_of_reduction(path: &str) -> Unit {
    let leaf = |p: &str| -> Unit {
        if p.ends_with("_rad_s") {
            unit(1.0, "rad/s", "rad/s")
        } else if p.ends_with("_1_s") {
            unit(1.0, "1/s", "1/s")
        } else if p.ends_with("_nm") {
            unit(1.0, "N·m", "N·m")
        } else if p.ends_with("_m") {
            unit(1e6, "µm", "m")
        } else if p.ends_with("_n") {
            unit(1.0, "N", "N")
        } else if p.ends_with("_w") {
            unit(1.0, "W", "W")
        } else if p.ends_with("_s") {
            unit(1.0, "s", "s")
        } else {
            ONE
        }
    };
    // The unit sits on the last field that carries one (`h_min.value_m`,
    // `bearings[0].force_peak_n.value`).
    path.split('.')
        .rev()
        .map(|n| n.split('[').next().unwrap_or(n))
        .map(leaf)
        .find(|u| !u.symbol.is_empty())
        .unwrap_or(ONE)
}

/// A readable name of an axis path: `bearings[*].viscosity` → `viscosity`,
/// `bearings[1].clearance` → `clearance (bearing 2)`, `initial.spin` → `spin`.
pub fn name_of_path(path: &str) -> String {
    let mut bearing = None;
    let mut names = Vec::new();
    for part in path.split('.') {
        let (name, idx) = match part.split_once('[') {
            Some((n, rest)) => (n, rest.trim_end_matches(']')),
            None => (part, ""),
        };
        if name == "bearings" {
            if let Ok(k) = idx.parse::<usize>() {
                bearing = Some(k);
            }
            continue;
        }
        if name == "initial" || name == "base" || name == "rotor" {
            continue;
        }
        names.push(name.to_string());
    }
    let mut s = names.join(".");
    if let Some(k) = bearing {
        s = format!("{s} (bearing {})", k + 1);
    }
    s
}

/// A readable name of a reduction path: `h_min.value_m` → `h_min`,
/// `bearings[0].friction_coefficient.mean` → `friction coefficient, mean (bearing 1)`.
pub fn name_of_reduction(path: &str) -> String {
    let mut bearing = None;
    let mut names: Vec<String> = Vec::new();
    for part in path.split('.') {
        let (name, idx) = match part.split_once('[') {
            Some((n, rest)) => (n, rest.trim_end_matches(']')),
            None => (part, ""),
        };
        if name == "bearings" {
            bearing = idx.parse::<usize>().ok();
            continue;
        }
        let mut n = name.to_string();
        for suffix in ["_rad_s", "_1_s", "_nm", "_m", "_n", "_w", "_s"] {
            if let Some(stem) = n.strip_suffix(suffix) {
                n = stem.to_string();
                break;
            }
        }
        if n == "value" || n.is_empty() {
            continue;
        }
        names.push(if n == "h_min" { n } else { n.replace('_', " ") });
    }
    let mut s = names.join(", ");
    if let Some(k) = bearing {
        s = format!("{s} (bearing {})", k + 1);
    }
    s
}

/// `name (unit)`, or `name` when dimensionless.
pub fn with_unit(name: &str, u: Unit) -> String {
    if u.symbol.is_empty() {
        name.to_string()
    } else {
        format!("{name} ({})", u.symbol)
    }
}

/// A user's axis label in display units: a trailing SI unit in `(…)` or `[…]` that is the
/// stored unit of the quantity is replaced by the display unit (`radial clearance (m)` →
/// `radial clearance (µm)`); a label without a unit gets the display unit appended.
pub fn label_in(label: &str, u: Unit) -> String {
    let t = label.trim_end();
    for (open, close) in [('(', ')'), ('[', ']')] {
        if t.ends_with(close) {
            if let Some(at) = t.rfind(open) {
                let inner = t[at + 1..t.len() - 1].trim();
                if !u.si.is_empty() && inner == u.si {
                    return with_unit(t[..at].trim_end(), u);
                }
                return t.to_string();
            }
        }
    }
    with_unit(t, u)
}

/// `value unit` with at most 4 significant digits (`5 mPa·s`, `143.1 µm`).
pub fn value_in(v: f64, u: Unit) -> String {
    let s = tick_label(v * u.scale);
    if u.symbol.is_empty() {
        s
    } else {
        format!("{s} {}", u.symbol)
    }
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
    fn linear_ticks_put_a_clean_zero() {
        // A range around zero from float noise: zero is `0`, never `-1.11e-16`.
        let t = linear_ticks(-0.3 + 1e-17, 0.7 - 2.2e-17, 5);
        assert!(t.iter().any(|(_, s)| s == "0"), "{t:?}");
        assert!(t.iter().all(|(_, s)| !s.contains("e-1")), "{t:?}");
        let t = linear_ticks(0.0, 2.5, 5);
        let labels: Vec<&str> = t.iter().map(|(_, s)| s.as_str()).collect();
        assert_eq!(labels, ["0", "0.5", "1.0", "1.5", "2.0", "2.5"]);
    }

    #[test]
    fn log_ticks_label_at_least_three_values() {
        for (lo, hi) in [
            (0.9, 1.1),
            (1.0, 2.0),
            (3.0, 20.0),
            (0.02, 0.09),
            (1e-5, 1e3),
            (1e-100, 1e100),
            (0.013, 0.2),
        ] {
            let t = log_ticks(lo, hi);
            let n = t.iter().filter(|(_, s)| !s.is_empty()).count();
            assert!(n >= 3, "[{lo}, {hi}]: {n} labels in {t:?}");
            assert!(
                t.iter()
                    .all(|(v, _)| (lo * (1.0 - 1e-9)..=hi * (1.0 + 1e-9)).contains(v)),
                "[{lo}, {hi}]: a tick outside: {t:?}"
            );
        }
    }

    #[test]
    fn labels_carry_display_units() {
        assert_eq!(
            value_in(0.005, unit_of_path("bearings[*].viscosity")),
            "5 mPa·s"
        );
        assert_eq!(
            label_in(
                "radial clearance (m)",
                unit_of_path("bearings[*].clearance")
            ),
            "radial clearance (µm)"
        );
        assert_eq!(
            label_in("h_min", unit_of_reduction("h_min.value_m")),
            "h_min (µm)"
        );
        assert_eq!(
            label_in("speed (rpm)", unit_of_path("initial.spin")),
            "speed (rpm)"
        );
        assert_eq!(
            name_of_reduction("bearings[0].friction_coefficient.mean"),
            "friction coefficient, mean (bearing 1)"
        );
        assert_eq!(name_of_path("bearings[*].viscosity"), "viscosity");
        assert_eq!(
            unit_of_reduction("bearings[0].force_peak_n.value").symbol,
            "N"
        );
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
