//! Per-variant reductions of simulated signals (time series in SI units) to the numbers a
//! design sweep compares, and decimated series. Pure functions on slices: no I/O.
//!
//! Definitions (docs/cli.md "Sweeps" section repeats them):
//! - **Evaluation window**: the last `N` revolutions (revolutions counted from the
//!   integral of `|spin|`), the last fraction of the run, or the last seconds. Windowed
//!   quantities describe the steady state; run extremes (`h_min`, `eccentricity_max`,
//!   `force_peak_n`) cover the whole run, start-up included.
//! - **Mean** of a signal: time average by the trapezoidal rule over the window; `min` and
//!   `max` over its samples.
//! - **Orbit** (journal centre at the bearing's first end face `z = 0`, in the bearing
//!   frame; or `G`): centre = midpoint of the bounding box over the window; `radius_m` =
//!   largest distance of a sample from that centre; `half_pp_x_m`, `half_pp_y_m` = half
//!   peak-to-peak in x and y. A circle of radius `r` gives `r` exactly.
//! - **Whirl**: amplitude spectrum `A(ω) = |Σ w_n (z_n − z̄) e^{−iωt_n}| / Σ w_n` of the complex
//!   journal-centre signal `z = x + iy` over the window, with `w_n` = Hann window × the
//!   trapezoidal weight of `t_n` (nonuniform samples are fine) and `z̄` the weighted mean.
//!   A whirl `A e^{iωt}` gives `A(ω) = A`. The ratio is `ω / spin̄` (signed: positive =
//!   forward whirl, in the spin's direction), searched over `|ratio| <= max_ratio` (and
//!   below the Nyquist limit of the coarsest sample step) on a grid of spacing
//!   `1 / (4 revolutions)`, then refined by bisection on the slope of `|Z|²` (to
//!   rounding; golden-section search on `A` where the peak is on a band end). The
//!   dominant ratio is the largest peak; the sub-synchronous peak is the largest in
//!   `band` (default 0.3..0.6, oil whirl sits near 0.45); `oil_whirl` is true when it is
//!   a true peak (not the flank of a peak outside the band), is the dominant peak or lies
//!   farther than `2 / revolutions` from it (resolved), and reaches `relative_threshold`
//!   × the dominant amplitude and `min_amplitude_ratio` × the radial clearance.
//!   Resolving two peaks needs them about `2 / revolutions` apart (the Hann main-lobe
//!   half-width); a window shorter than one revolution gives no whirl (`null`).
//! - **Power loss**: time mean of `|M_z · spin|` per bearing, W; `power_loss_w` sums them.
//! - **Friction torque**: `|M_z|`, N·m; friction coefficient `f` of eq. 11 (samples where
//!   it is undefined are skipped). **Force**: `|W| = hypot(W_x, W_y)`, N.

use serde::Serialize;
use serde_json::{json, Map, Value};

// The option documents and the whirl spectrum live in their own files; re-exported here.
pub use super::reduction_options::{
    BandDoc, ReductionOptions, ReductionsDoc, SeriesGroup, Span, WhirlDoc, WhirlOptions, Window,
    WindowDoc,
};
pub use super::whirl::whirl;

/// Time series of one bearing, sampled at the variant's `t`. SI units.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BearingSignals {
    /// Radial clearance `δ`, m (scales the oil-whirl amplitude floor).
    pub clearance_m: f64,
    /// Journal centre at the end face `z = 0`, bearing frame, m.
    pub xi: Vec<f64>,
    /// y of the same, m.
    pub yi: Vec<f64>,
    /// Journal centre at the end face `z = B`, m.
    pub xj: Vec<f64>,
    /// y of the same, m.
    pub yj: Vec<f64>,
    /// Minimum film thickness, m.
    pub h_min: Vec<f64>,
    /// Larger end eccentricity ratio, dimensionless.
    pub eccentricity_max: Vec<f64>,
    /// Friction coefficient; `None` where undefined.
    pub friction_coefficient: Vec<Option<f64>>,
    /// Friction torque about `+z`, N·m.
    pub mz: Vec<f64>,
    /// Film force on the journal, N.
    pub wx: Vec<f64>,
    /// Film force on the journal, N.
    pub wy: Vec<f64>,
    /// The film's own friction and flows (JFO finite-film bearings, whose samples carry
    /// them; empty otherwise).
    pub film: FilmSignals,
}

/// A film's own friction and flows, sampled at the variant's `t` (the rotor samples'
/// `film` series, docs/jfo.md). SI units.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FilmSignals {
    /// Friction torque of the film on the journal, N·m.
    pub friction_torque_nm: Vec<f64>,
    /// Power loss `|M ω|`, W.
    pub power_loss_w: Vec<f64>,
    /// Side flow out of both end faces, m³/s.
    pub side_flow_m3_per_s: Vec<f64>,
    /// Net flow from the supply into the film, m³/s.
    pub inlet_flow_m3_per_s: Vec<f64>,
}

/// Time series of one variant. SI units.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Signals {
    /// Sample times, s, increasing.
    pub t: Vec<f64>,
    /// Rotor spin about `+z` (the journals' relative spin; housings fixed), rad/s.
    pub spin: Vec<f64>,
    /// Centre of mass, global x, m.
    pub x_g: Vec<f64>,
    /// Centre of mass, global y, m.
    pub y_g: Vec<f64>,
    /// Per bearing.
    pub bearings: Vec<BearingSignals>,
}

/// `Some(x)` when finite: results never hold NaN or infinities.
pub(crate) fn fin(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}

/// Mean (time average), min and max of a signal over the window.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct WindowStats {
    /// Trapezoidal time average.
    pub mean: f64,
    /// Smallest sample.
    pub min: f64,
    /// Largest sample.
    pub max: f64,
}

/// An extreme value and when it occurred.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Extreme {
    /// The value.
    pub value: f64,
    /// Its time, s.
    pub t_s: f64,
}

/// The thinnest film of a variant.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct FilmMin {
    /// Minimum film thickness, m.
    pub value_m: f64,
    /// Bearing index (spec order).
    pub bearing: usize,
    /// Time, s.
    pub t_s: f64,
}

/// Steady orbit over the window.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Orbit {
    /// Bounding-box centre, m.
    pub centre_x_m: f64,
    /// Bounding-box centre, m.
    pub centre_y_m: f64,
    /// Largest distance from the centre, m.
    pub radius_m: f64,
    /// Half peak-to-peak in x, m.
    pub half_pp_x_m: f64,
    /// Half peak-to-peak in y, m.
    pub half_pp_y_m: f64,
}

/// Whirl of one journal centre over the window.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Whirl {
    /// Dominant whirl frequency / mean spin (signed, forward positive).
    pub ratio: f64,
    /// Its amplitude, m.
    pub amplitude_m: f64,
    /// Strongest ratio in the sub-synchronous band.
    pub subsync_ratio: f64,
    /// Its amplitude, m.
    pub subsync_amplitude_m: f64,
    /// Sub-synchronous whirl detected (see the module doc).
    pub oil_whirl: bool,
    /// Largest `|ratio|` searched, present only when below `max_ratio`: the kept sample
    /// rate (decimated samples, docs/cli.md "Limits") would alias higher ratios, so they were
    /// not searched rather than reported wrong.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub searched_up_to_ratio: Option<f64>,
    /// Present when the window's kept samples were decimated so far that its search
    /// would stop below `max_ratio`: the whirl was then taken from the window's last
    /// samples at the full sample rate (`super::stream::WHIRL_TAIL` at most), this many.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub samples: Option<usize>,
    /// With `samples`: the first of those full-rate samples, s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub t_start_s: Option<f64>,
}

/// The window actually used.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct WindowInfo {
    /// Start, s.
    pub t_start_s: f64,
    /// End, s.
    pub t_end_s: f64,
    /// Revolutions of the rotor inside it.
    pub revolutions: f64,
    /// Samples inside it.
    pub samples: usize,
    /// The run was shorter than the requested window: the whole run is used.
    pub truncated: bool,
    /// Present when the window's samples were decimated: every this many samples were
    /// kept (a fraction window longer than the batch's sample cap, or one taken from a
    /// decimated record).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sample_stride: Option<usize>,
    /// Present when the run ended before `t_end` and its fraction window was taken from
    /// a decimated record of the whole run: the record's samples
    /// (`super::stream::EARLY_END_RECORD` at most).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub record_samples: Option<usize>,
}

/// A film's own friction and flows over the window (JFO finite-film bearings).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct FilmReduction {
    /// The film's friction torque on the journal (as sampled, signed), N·m.
    pub friction_torque_nm: Option<WindowStats>,
    /// The film's power loss `|M ω|`, W.
    pub power_loss_w: Option<WindowStats>,
    /// Side flow out of both end faces, m³/s.
    pub side_flow_m3_per_s: Option<WindowStats>,
    /// Net flow from the supply into the film, m³/s.
    pub inlet_flow_m3_per_s: Option<WindowStats>,
}

/// Reductions of one bearing.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BearingReduction {
    /// Friction coefficient over the window.
    pub friction_coefficient: Option<WindowStats>,
    /// `|M_z|` over the window, N·m.
    pub friction_torque_nm: Option<WindowStats>,
    /// Mean `|M_z · spin|` over the window, W.
    pub power_loss_w: Option<f64>,
    /// `|W|` over the window, N.
    pub force_n: Option<WindowStats>,
    /// Peak `|W|` over the run, N (the transmitted bearing force).
    pub force_peak_n: Option<Extreme>,
    /// Minimum film thickness over the run, m.
    pub h_min_m: Option<Extreme>,
    /// Maximum eccentricity ratio over the run.
    pub eccentricity_max: Option<Extreme>,
    /// Journal-centre orbit (end face `z = 0`) over the window.
    pub orbit: Option<Orbit>,
    /// Journal-centre whirl over the window.
    pub whirl: Option<Whirl>,
    /// The film's own friction and flows over the window (present for JFO finite-film
    /// bearings only, whose samples carry them).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub film: Option<FilmReduction>,
}

/// Reductions of one variant.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Reductions {
    /// The evaluation window.
    pub window: Option<WindowInfo>,
    /// Thinnest film over all bearings and the run.
    pub h_min: Option<FilmMin>,
    /// Total friction power loss over the window, W.
    pub power_loss_w: Option<f64>,
    /// Orbit of the centre of mass over the window.
    pub g_orbit: Option<Orbit>,
    /// Dominant whirl ratio of the bearing with the largest whirl amplitude.
    pub whirl_ratio: Option<f64>,
    /// Any bearing shows oil whirl.
    pub oil_whirl: bool,
    /// Per bearing.
    pub bearings: Vec<BearingReduction>,
}

impl Reductions {
    /// Every field present (zeros), one bearing: the shape a variant's `reductions`
    /// can take, to check paths into it (a plot's `y`) before running.
    pub fn schema() -> Value {
        let stats = Some(WindowStats {
            mean: 0.0,
            min: 0.0,
            max: 0.0,
        });
        let extreme = Some(Extreme {
            value: 0.0,
            t_s: 0.0,
        });
        let orbit = Some(Orbit {
            centre_x_m: 0.0,
            centre_y_m: 0.0,
            radius_m: 0.0,
            half_pp_x_m: 0.0,
            half_pp_y_m: 0.0,
        });
        let r = Reductions {
            window: Some(WindowInfo {
                t_start_s: 0.0,
                t_end_s: 0.0,
                revolutions: 0.0,
                samples: 0,
                truncated: false,
                sample_stride: Some(1),
                record_samples: Some(0),
            }),
            h_min: Some(FilmMin {
                value_m: 0.0,
                bearing: 0,
                t_s: 0.0,
            }),
            power_loss_w: Some(0.0),
            g_orbit: orbit,
            whirl_ratio: Some(0.0),
            oil_whirl: false,
            bearings: vec![BearingReduction {
                friction_coefficient: stats,
                friction_torque_nm: stats,
                power_loss_w: Some(0.0),
                force_n: stats,
                force_peak_n: extreme,
                h_min_m: extreme,
                eccentricity_max: extreme,
                orbit,
                whirl: Some(Whirl {
                    ratio: 0.0,
                    amplitude_m: 0.0,
                    subsync_ratio: 0.0,
                    subsync_amplitude_m: 0.0,
                    oil_whirl: false,
                    searched_up_to_ratio: Some(2.5),
                    samples: Some(0),
                    t_start_s: Some(0.0),
                }),
                film: Some(FilmReduction {
                    friction_torque_nm: stats,
                    power_loss_w: stats,
                    side_flow_m3_per_s: stats,
                    inlet_flow_m3_per_s: stats,
                }),
            }],
        };
        serde_json::to_value(r).unwrap_or(Value::Null)
    }
}

/// Index of the first sample of the window, and whether the run was too short.
pub fn window_start(t: &[f64], spin: &[f64], window: Window) -> (usize, bool) {
    let Some(&t0) = t.first() else {
        return (0, false);
    };
    window_start_in(t, spin, window, t0, || revolutions_from(t, spin, 0))
}

/// [`window_start`] over the last samples of a run (`t`, `spin`: the run's tail, at
/// least every sample of the window and the one before it), given the run's first
/// sample time `t0` and its revolutions `run_revolutions()` (both over the whole run).
pub fn window_start_in(
    t: &[f64],
    spin: &[f64],
    window: Window,
    t0: f64,
    run_revolutions: impl FnOnce() -> f64,
) -> (usize, bool) {
    let n = t.len();
    if n < 2 {
        return (0, n == 1);
    }
    let t1 = t[n - 1];
    let (start, truncated) = match window {
        Window::Fraction(f) => {
            let ts = t1 - f * (t1 - t0);
            (t.iter().position(|&x| x >= ts).unwrap_or(0), false)
        }
        Window::Seconds(s) => {
            let ts = t1 - s;
            (t.iter().position(|&x| x >= ts).unwrap_or(0), ts < t0)
        }
        Window::Revolutions(r) => {
            let angle = run_revolutions() * std::f64::consts::TAU;
            let target = r * std::f64::consts::TAU;
            if angle < target {
                (0, true)
            } else {
                // Angle from sample i to the end, accumulated backwards.
                let mut acc = 0.0;
                let mut start = n - 1;
                for i in (0..n - 1).rev() {
                    acc += 0.5 * (spin[i].abs() + spin[i + 1].abs()) * (t[i + 1] - t[i]);
                    if acc > target * (1.0 + 1e-12) {
                        break;
                    }
                    start = i;
                }
                (start, false)
            }
        }
    };
    // At least two samples.
    (start.min(n - 2), truncated)
}

/// Revolutions (integral of `|spin|` / 2π) from sample `start` to the end.
pub fn revolutions_from(t: &[f64], spin: &[f64], start: usize) -> f64 {
    let mut acc = 0.0;
    for i in start..t.len().saturating_sub(1) {
        acc += angle_step(t[i], spin[i], t[i + 1], spin[i + 1]);
    }
    acc / std::f64::consts::TAU
}

/// Angle turned between two samples (trapezoidal rule on `|spin|`), rad.
pub(crate) fn angle_step(t0: f64, spin0: f64, t1: f64, spin1: f64) -> f64 {
    0.5 * (spin0.abs() + spin1.abs()) * (t1 - t0)
}

/// What the reductions read from a whole run, kept as the run goes: its sample count,
/// first time, angle turned, and each bearing's extremes (film minimum, eccentricity and
/// force peaks). [`RunTotals::of`] gives the same numbers from stored signals.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunTotals {
    /// Samples seen.
    pub samples: usize,
    /// First sample time, s.
    pub t0: f64,
    /// Angle turned from the first sample (trapezoidal on `|spin|`, summed in time
    /// order), rad.
    pub angle_rad: f64,
    /// The latest sample's time (s) and spin (rad/s).
    last: Option<(f64, f64)>,
    /// Per bearing.
    pub bearings: Vec<BearingTotals>,
}

/// A bearing's extremes over a run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BearingTotals {
    /// Thinnest film and its time (the first of equals).
    pub h_min: Option<Extreme>,
    /// Largest eccentricity ratio and its time.
    pub eccentricity_max: Option<Extreme>,
    /// Largest `|W|` and its time.
    pub force_peak: Option<Extreme>,
}

/// `best` updated with sample `(t, x)`: smallest (`sign = 1`) or largest (`sign = −1`),
/// finite values only, the first of equals.
fn keep_extreme(best: &mut Option<Extreme>, t: f64, x: f64, sign: f64) {
    if x.is_finite() && best.is_none_or(|b| sign * x < sign * b.value) {
        *best = Some(Extreme { value: x, t_s: t });
    }
}

impl RunTotals {
    /// Adds one sample: time `t`, spin, and per bearing `(h_min, eccentricity_max, wx, wy)`.
    pub fn observe(&mut self, t: f64, spin: f64, bearings: impl Iterator<Item = [f64; 4]>) {
        match self.last {
            None => self.t0 = t,
            Some((tp, sp)) => self.angle_rad += angle_step(tp, sp, t, spin),
        }
        self.last = Some((t, spin));
        self.samples += 1;
        for (k, [h, e, wx, wy]) in bearings.enumerate() {
            if self.bearings.len() <= k {
                self.bearings.push(BearingTotals::default());
            }
            let b = &mut self.bearings[k];
            keep_extreme(&mut b.h_min, t, h, 1.0);
            keep_extreme(&mut b.eccentricity_max, t, e, -1.0);
            keep_extreme(&mut b.force_peak, t, wx.hypot(wy), -1.0);
        }
    }

    /// The totals of stored signals.
    pub fn of(s: &Signals) -> Self {
        let mut r = RunTotals::default();
        for i in 0..s.t.len() {
            r.observe(
                s.t[i],
                s.spin[i],
                s.bearings
                    .iter()
                    .map(|b| [b.h_min[i], b.eccentricity_max[i], b.wx[i], b.wy[i]]),
            );
        }
        r
    }

    /// Revolutions turned over the run.
    pub fn revolutions(&self) -> f64 {
        self.angle_rad / std::f64::consts::TAU
    }
}

/// Trapezoidal weights of the samples `t` (sum = `t_last − t_first`).
pub(crate) fn trapezoid_weights(t: &[f64]) -> Vec<f64> {
    let n = t.len();
    let mut w = vec![0.0; n];
    for i in 0..n.saturating_sub(1) {
        let h = 0.5 * (t[i + 1] - t[i]);
        w[i] += h;
        w[i + 1] += h;
    }
    w
}

/// Time average, min and max of `v` over samples `t` (skipping `None`s); `None` when
/// nothing is defined or a result is non-finite.
pub fn stats_opt(t: &[f64], v: impl Fn(usize) -> Option<f64>) -> Option<WindowStats> {
    let mut min = f64::INFINITY;
    let mut max = f64::NEG_INFINITY;
    let mut area = 0.0;
    let mut span = 0.0;
    let mut prev: Option<(f64, f64)> = None;
    let mut count = 0usize;
    let mut only = 0.0;
    for (i, &ti) in t.iter().enumerate() {
        match v(i) {
            Some(x) => {
                min = min.min(x);
                max = max.max(x);
                count += 1;
                only = x;
                if let Some((tp, xp)) = prev {
                    area += 0.5 * (x + xp) * (ti - tp);
                    span += ti - tp;
                }
                prev = Some((ti, x));
            }
            None => prev = None,
        }
    }
    if count == 0 {
        return None;
    }
    let mean = if span > 0.0 { area / span } else { only };
    Some(WindowStats {
        mean: fin(mean)?,
        min: fin(min)?,
        max: fin(max)?,
    })
}

/// [`stats_opt`] of a plain signal.
pub fn stats(t: &[f64], v: &[f64]) -> Option<WindowStats> {
    stats_opt(t, |i| Some(v[i]))
}

/// Steady orbit of `(x, y)` (see the module doc).
pub fn orbit(x: &[f64], y: &[f64]) -> Option<Orbit> {
    if x.is_empty() {
        return None;
    }
    let range = |v: &[f64]| {
        v.iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &a| {
                (lo.min(a), hi.max(a))
            })
    };
    let (x0, x1) = range(x);
    let (y0, y1) = range(y);
    let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    let r = x
        .iter()
        .zip(y)
        .map(|(a, b)| (a - cx).hypot(b - cy))
        .fold(0.0, f64::max);
    Some(Orbit {
        centre_x_m: fin(cx)?,
        centre_y_m: fin(cy)?,
        radius_m: fin(r)?,
        half_pp_x_m: fin(0.5 * (x1 - x0))?,
        half_pp_y_m: fin(0.5 * (y1 - y0))?,
    })
}

/// Indices of at most `points` samples spread evenly over `start..n`, both ends kept.
pub fn decimate_indices(start: usize, n: usize, points: usize) -> Vec<usize> {
    let len = n.saturating_sub(start);
    if len <= points {
        return (start..n).collect();
    }
    let m = points.max(2);
    (0..m)
        .map(|k| start + ((k as f64) * (len - 1) as f64 / (m - 1) as f64).round() as usize)
        .collect()
}

fn pick(v: &[f64], idx: &[usize]) -> Value {
    Value::Array(
        idx.iter()
            .map(|&i| serde_json::Number::from_f64(v[i]).map_or(Value::Null, Value::Number))
            .collect(),
    )
}

/// Reduces one variant's signals. Every output number is finite or `null`.
pub fn reduce(s: &Signals, opts: &ReductionOptions) -> Reductions {
    reduce_tail(s, &RunTotals::of(s), opts)
}

/// [`reduce`] of a run kept as it went: `s` its last samples (at least the evaluation
/// window and the sample before it, [`super::stream::RunReducer`]), `run` its totals.
/// The same numbers as [`reduce`] on every sample.
pub fn reduce_tail(s: &Signals, run: &RunTotals, opts: &ReductionOptions) -> Reductions {
    let n = s.t.len();
    if n == 0 || run.samples == 0 {
        return Reductions {
            window: None,
            h_min: None,
            power_loss_w: None,
            g_orbit: None,
            whirl_ratio: None,
            oil_whirl: false,
            bearings: Vec::new(),
        };
    }
    let (w0, truncated) = window_start_in(&s.t, &s.spin, opts.window, run.t0, || run.revolutions());
    let tw = &s.t[w0..];
    let spin_mean = stats(tw, &s.spin[w0..]).map(|st| st.mean);
    let window = WindowInfo {
        t_start_s: s.t[w0],
        t_end_s: s.t[n - 1],
        revolutions: revolutions_from(&s.t, &s.spin, w0),
        samples: n - w0,
        truncated,
        sample_stride: None,
        record_samples: None,
    };
    let mut h_min: Option<FilmMin> = None;
    let mut total_power = Some(0.0);
    let mut best_whirl: Option<(f64, f64)> = None;
    let mut oil = false;
    let bearings = s
        .bearings
        .iter()
        .enumerate()
        .map(|(k, b)| {
            let force: Vec<f64> = b.wx[w0..]
                .iter()
                .zip(&b.wy[w0..])
                .map(|(x, y)| x.hypot(*y))
                .collect();
            let power: Vec<f64> = b.mz[w0..]
                .iter()
                .zip(&s.spin[w0..])
                .map(|(m, w)| (m * w).abs())
                .collect();
            let torque: Vec<f64> = b.mz[w0..].iter().map(|m| m.abs()).collect();
            let totals = run.bearings.get(k).copied().unwrap_or_default();
            let hm = totals.h_min;
            if let Some(e) = hm {
                if h_min.is_none_or(|h| e.value < h.value_m) {
                    h_min = Some(FilmMin {
                        value_m: e.value,
                        bearing: k,
                        t_s: e.t_s,
                    });
                }
            }
            let power_mean = stats(tw, &power).map(|st| st.mean);
            total_power = match (total_power, power_mean) {
                (Some(a), Some(p)) => Some(a + p),
                _ => None,
            };
            let wh = spin_mean
                .and_then(|sm| whirl(tw, &b.xi[w0..], &b.yi[w0..], sm, b.clearance_m, &opts.whirl));
            if let Some(w) = wh {
                oil |= w.oil_whirl;
                if best_whirl.is_none_or(|(_, a)| w.amplitude_m > a) {
                    best_whirl = Some((w.ratio, w.amplitude_m));
                }
            }
            BearingReduction {
                friction_coefficient: stats_opt(tw, |i| b.friction_coefficient[w0 + i]),
                friction_torque_nm: stats(tw, &torque),
                power_loss_w: power_mean,
                force_n: stats(tw, &force),
                force_peak_n: totals.force_peak,
                h_min_m: hm,
                eccentricity_max: totals.eccentricity_max,
                orbit: orbit(&b.xi[w0..], &b.yi[w0..]),
                whirl: wh,
                film: film_reduction(tw, &b.film, w0, n),
            }
        })
        .collect();
    Reductions {
        window: Some(window),
        h_min,
        power_loss_w: total_power.and_then(fin),
        g_orbit: orbit(&s.x_g[w0..], &s.y_g[w0..]),
        whirl_ratio: best_whirl.map(|(r, _)| r),
        oil_whirl: oil,
        bearings,
    }
}

/// The end of a window at the full sample rate: its times, spin and each bearing's
/// journal centre at the end face `z = 0` (what the whirl spectrum reads). SI units.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WhirlSamples {
    /// Sample times, s, increasing.
    pub t: Vec<f64>,
    /// Spin, rad/s.
    pub spin: Vec<f64>,
    /// Per bearing `(x, y)` of the journal centre, m.
    pub centres: Vec<(Vec<f64>, Vec<f64>)>,
}

/// Replaces the whirl of each bearing whose search over the window's decimated samples
/// stopped below `max_ratio` (`searched_up_to_ratio` present) by the whirl of `tail`,
/// the window's last samples at the full rate, from the window's start on (`ratio`
/// then over the tail's own mean spin; `samples` and `t_start_s` say so), when the tail
/// is at least a revolution long. `whirl_ratio` and `oil_whirl` are recomputed as
/// [`reduce_tail`] computes them. `clearances_m`: per bearing, m.
pub fn whirl_from_tail(
    r: &mut Reductions,
    tail: &WhirlSamples,
    clearances_m: &[f64],
    opts: &ReductionOptions,
) {
    let Some(window) = r.window else {
        return;
    };
    let from = tail.t.partition_point(|&t| t < window.t_start_s);
    let t = &tail.t[from..];
    let Some(spin_mean) = stats(t, &tail.spin[from..]).map(|st| st.mean) else {
        return;
    };
    let mut changed = false;
    for (k, b) in r.bearings.iter_mut().enumerate() {
        let limited = b.whirl.is_some_and(|w| w.searched_up_to_ratio.is_some());
        let (Some((x, y)), Some(&clearance)) = (tail.centres.get(k), clearances_m.get(k)) else {
            continue;
        };
        if !limited {
            continue;
        }
        let full = whirl(t, &x[from..], &y[from..], spin_mean, clearance, &opts.whirl);
        if let Some(mut w) = full {
            w.samples = Some(t.len());
            w.t_start_s = t.first().copied();
            b.whirl = Some(w);
            changed = true;
        }
    }
    if changed {
        // As `reduce_tail`: the ratio of the largest amplitude (the first of equals).
        let mut best: Option<(f64, f64)> = None;
        r.oil_whirl = false;
        for w in r.bearings.iter().filter_map(|b| b.whirl) {
            r.oil_whirl |= w.oil_whirl;
            if best.is_none_or(|(_, a)| w.amplitude_m > a) {
                best = Some((w.ratio, w.amplitude_m));
            }
        }
        r.whirl_ratio = best.map(|(ratio, _)| ratio);
    }
}

/// A film's friction and flows over the window (samples `w0..n`): `None` when the
/// bearing's samples do not carry them.
fn film_reduction(tw: &[f64], f: &FilmSignals, w0: usize, n: usize) -> Option<FilmReduction> {
    let columns = [
        &f.friction_torque_nm,
        &f.power_loss_w,
        &f.side_flow_m3_per_s,
        &f.inlet_flow_m3_per_s,
    ];
    if columns.iter().any(|c| c.len() != n) {
        return None;
    }
    Some(FilmReduction {
        friction_torque_nm: stats(tw, &f.friction_torque_nm[w0..]),
        power_loss_w: stats(tw, &f.power_loss_w[w0..]),
        side_flow_m3_per_s: stats(tw, &f.side_flow_m3_per_s[w0..]),
        inlet_flow_m3_per_s: stats(tw, &f.inlet_flow_m3_per_s[w0..]),
    })
}

/// The kept series, decimated (`None` when nothing is kept).
pub fn kept_series(s: &Signals, opts: &ReductionOptions) -> Option<Value> {
    let start = match opts.span {
        Span::Run => 0,
        Span::Window => window_start(&s.t, &s.spin, opts.window).0,
    };
    kept_series_from(s, start, opts)
}

/// [`kept_series`] of samples `start..` of `s` (every column of a kept group present).
pub fn kept_series_from(s: &Signals, start: usize, opts: &ReductionOptions) -> Option<Value> {
    if opts.keep.is_empty() || s.t.is_empty() {
        return None;
    }
    let idx = decimate_indices(start, s.t.len(), opts.points);
    let mut m = Map::new();
    m.insert("t".into(), pick(&s.t, &idx));
    let keep = |g| opts.keep.contains(&g);
    if keep(SeriesGroup::Orbit) {
        m.insert("x_g".into(), pick(&s.x_g, &idx));
        m.insert("y_g".into(), pick(&s.y_g, &idx));
    }
    if keep(SeriesGroup::Spin) {
        m.insert("spin".into(), pick(&s.spin, &idx));
    }
    let bearings: Vec<Value> = s
        .bearings
        .iter()
        .map(|b| {
            let mut bm = Map::new();
            if keep(SeriesGroup::Orbit) {
                bm.insert("xi".into(), pick(&b.xi, &idx));
                bm.insert("yi".into(), pick(&b.yi, &idx));
                bm.insert("xj".into(), pick(&b.xj, &idx));
                bm.insert("yj".into(), pick(&b.yj, &idx));
            }
            if keep(SeriesGroup::Film) {
                bm.insert("h_min".into(), pick(&b.h_min, &idx));
                bm.insert("eccentricity_max".into(), pick(&b.eccentricity_max, &idx));
            }
            if keep(SeriesGroup::Friction) {
                bm.insert(
                    "friction_coefficient".into(),
                    Value::Array(
                        idx.iter()
                            .map(|&i| {
                                b.friction_coefficient[i]
                                    .and_then(serde_json::Number::from_f64)
                                    .map_or(Value::Null, Value::Number)
                            })
                            .collect(),
                    ),
                );
                bm.insert("mz".into(), pick(&b.mz, &idx));
            }
            if keep(SeriesGroup::Forces) {
                bm.insert("wx".into(), pick(&b.wx, &idx));
                bm.insert("wy".into(), pick(&b.wy, &idx));
            }
            Value::Object(bm)
        })
        .collect();
    if bearings
        .iter()
        .any(|b| b.as_object().is_some_and(|o| !o.is_empty()))
    {
        m.insert("bearings".into(), Value::Array(bearings));
    }
    Some(Value::Object(m))
}

/// Units of every reduction, written once into each result file.
pub fn units() -> Value {
    json!({
        "t_s, t_start_s, t_end_s": "s",
        "*_m, value_m, radius_m, amplitude_m": "m",
        "friction_torque_nm": "N·m (magnitude)",
        "force_n, force_peak_n": "N (magnitude of the film force)",
        "power_loss_w": "W",
        "ratio, whirl_ratio, subsync_ratio": "whirl frequency / mean spin (signed, forward > 0)",
        "friction_coefficient, eccentricity_max": "dimensionless",
        "series": "SI: t s, positions m, spin rad/s, mz N·m, wx wy N"
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep::SweepError;
    use std::f64::consts::TAU;

    fn close(name: &str, got: f64, expected: f64, tol: f64) {
        assert!(
            (got - expected).abs() <= tol,
            "{name}: got {got}, expected {expected}, tolerance {tol}"
        );
    }

    fn uniform(t_end: f64, n: usize) -> Vec<f64> {
        (0..n).map(|i| t_end * i as f64 / (n - 1) as f64).collect()
    }

    #[test]
    fn window_by_revolutions_fraction_and_seconds() {
        // 100 rad/s for 1 s: 15.915 revolutions.
        let t = uniform(1.0, 1001);
        let spin = vec![100.0; t.len()];
        let (s, tr) = window_start(&t, &spin, Window::Revolutions(5.0));
        // 5 revolutions = 0.314159 s: the window starts at the first sample with at most
        // that much left, t = 0.686.
        assert!(!tr);
        close("start time (revolutions)", t[s], 0.686, 1e-12);
        close(
            "revolutions in window",
            revolutions_from(&t, &spin, s),
            0.314 * 100.0 / TAU,
            1e-9,
        );
        let (s, _) = window_start(&t, &spin, Window::Fraction(0.25));
        close("start time (fraction)", t[s], 0.75, 1e-12);
        let (s, tr) = window_start(&t, &spin, Window::Seconds(0.1));
        close("start time (seconds)", t[s], 0.9, 1e-12);
        assert!(!tr);
        let (s, tr) = window_start(&t, &spin, Window::Revolutions(100.0));
        assert_eq!((s, tr), (0, true));
    }

    #[test]
    fn stats_of_a_ramp_and_of_gappy_samples() {
        let t = uniform(2.0, 21);
        let v: Vec<f64> = t.iter().map(|x| 3.0 * x + 1.0).collect();
        let st = stats(&t, &v).unwrap();
        // Mean of 3t + 1 over [0, 2] = 4 (trapezoid exact for a line).
        close("mean", st.mean, 4.0, 1e-12);
        close("min", st.min, 1.0, 0.0);
        close("max", st.max, 7.0, 0.0);
        let st = stats_opt(&t, |i| (i % 5 != 0).then_some(2.0)).unwrap();
        close("mean with gaps", st.mean, 2.0, 1e-15);
        assert!(stats_opt(&t, |_| None).is_none());
    }

    #[test]
    fn circle_orbit_has_its_radius_for_any_number_of_turns() {
        for turns in [1.0, 2.37] {
            let n = 4001;
            let (x, y): (Vec<f64>, Vec<f64>) = (0..n)
                .map(|i| {
                    let a = TAU * turns * i as f64 / (n - 1) as f64;
                    (2e-5 + 7e-6 * a.cos(), -1e-5 + 7e-6 * a.sin())
                })
                .unzip();
            let o = orbit(&x, &y).unwrap();
            // Sampling error of the extremes: r (1 − cos(π turns / n)) < 1e-11 m.
            close("radius", o.radius_m, 7e-6, 1e-11);
            close("centre x", o.centre_x_m, 2e-5, 1e-11);
            close("centre y", o.centre_y_m, -1e-5, 1e-11);
            close("half pp x", o.half_pp_x_m, 7e-6, 1e-11);
        }
    }

    fn tone(t: &[f64], parts: &[(f64, f64)], omega: f64) -> (Vec<f64>, Vec<f64>) {
        t.iter()
            .map(|&ti| {
                parts.iter().fold((0.0, 0.0), |(x, y), &(amp, ratio)| {
                    let a = ratio * omega * ti + 0.3;
                    (x + amp * a.cos(), y + amp * a.sin())
                })
            })
            .unzip()
    }

    #[test]
    fn coarse_samples_limit_the_whirl_search_and_say_so() {
        let omega = 100.0;
        // 40 revolutions at 3 samples per revolution (decimated samples): the kept rate
        // resolves |ratio| < 0.9 * 3 / 2 = 1.35 only.
        let t = uniform(40.0 * TAU / omega, 121);
        let (x, y) = tone(&t, &[(4e-6, 1.0)], omega);
        let w = whirl(&t, &x, &y, omega, 3e-4, &WhirlOptions::default()).unwrap();
        let limit = w.searched_up_to_ratio.expect("limit reported");
        close("searched limit", limit, 1.35, 1e-9);
        close("synchronous ratio still found", w.ratio, 1.0, 1e-6);
        // Fine samples search the whole max_ratio and report no limit.
        let t = uniform(40.0 * TAU / omega, 4001);
        let (x, y) = tone(&t, &[(4e-6, 1.0)], omega);
        let w = whirl(&t, &x, &y, omega, 3e-4, &WhirlOptions::default()).unwrap();
        assert_eq!(w.searched_up_to_ratio, None);
    }

    #[test]
    fn whirl_of_a_pure_tone_is_exact() {
        let omega = 100.0;
        // 20 revolutions, uniform samples: the tone completes 0.47·20 = 9.4 cycles, not
        // an integer; a single complex exponential still peaks exactly at its frequency
        // except for the tiny bias of the removed (windowed) mean.
        let t: Vec<f64> = uniform(20.0 * TAU / omega, 2001)
            .iter()
            .map(|x| x + 0.7)
            .collect();
        for ratio in [0.47, 1.0, -0.8, 2.0] {
            let (x, y) = tone(&t, &[(4e-6, ratio)], omega);
            let w = whirl(&t, &x, &y, omega, 3e-4, &WhirlOptions::default()).unwrap();
            close(&format!("ratio {ratio}"), w.ratio, ratio, 1e-6);
            close(
                &format!("amplitude at {ratio}"),
                w.amplitude_m,
                4e-6,
                4e-6 * 1e-4,
            );
            assert_eq!(
                w.oil_whirl,
                ratio == 0.47,
                "oil whirl flag for ratio {ratio}"
            );
        }
        // Integer cycles (20 revolutions at 0.45 = 9 cycles): the windowed mean is zero and the ratio is exact to the golden-section tolerance.
        let (x, y) = tone(&t, &[(4e-6, 0.45)], omega);
        let w = whirl(&t, &x, &y, omega, 3e-4, &WhirlOptions::default()).unwrap();
        close("ratio 0.45 (integer cycles)", w.ratio, 0.45, 1e-9);
        close("amplitude 0.45", w.amplitude_m, 4e-6, 1e-15);
        // Negative spin: a whirl in the spin's direction is still a positive ratio.
        let (x, y) = tone(&t, &[(4e-6, 0.45)], omega);
        let (xm, ym): (Vec<f64>, Vec<f64>) = (x, y.iter().map(|v| -v).collect());
        let w = whirl(&t, &xm, &ym, -omega, 3e-4, &WhirlOptions::default()).unwrap();
        close("ratio 0.45 (mirrored, negative spin)", w.ratio, 0.45, 1e-9);
    }

    #[test]
    fn synchronous_orbit_with_sub_synchronous_whirl() {
        let omega = 150.0;
        let t = uniform(40.0 * TAU / omega, 4001);
        let opts = WhirlOptions::default();
        // Dominant unbalance response at 1x, whirl at 0.45x with 40 % of its amplitude:
        // oil whirl flagged, dominant ratio 1.
        let (x, y) = tone(&t, &[(1e-5, 1.0), (4e-6, 0.45)], omega);
        let w = whirl(&t, &x, &y, omega, 3e-4, &opts).unwrap();
        close("dominant ratio", w.ratio, 1.0, 1e-4);
        close("dominant amplitude", w.amplitude_m, 1e-5, 1e-8);
        close("sub-synchronous ratio", w.subsync_ratio, 0.45, 1e-4);
        close(
            "sub-synchronous amplitude",
            w.subsync_amplitude_m,
            4e-6,
            1e-8,
        );
        assert!(w.oil_whirl);
        // A 5 % whirl is below the relative threshold: no oil whirl.
        let (x, y) = tone(&t, &[(1e-5, 1.0), (5e-7, 0.45)], omega);
        let w = whirl(&t, &x, &y, omega, 3e-4, &opts).unwrap();
        assert!(!w.oil_whirl, "5 % whirl flagged: {w:?}");
        // A strong but tiny (below 1 % of the clearance) whirl is not flagged either.
        let (x, y) = tone(&t, &[(1e-6, 0.45)], omega);
        let w = whirl(&t, &x, &y, omega, 3e-4, &opts).unwrap();
        close("tiny whirl ratio", w.ratio, 0.45, 1e-6);
        assert!(
            !w.oil_whirl,
            "whirl of 1e-6 m in a 3e-4 m clearance flagged"
        );
    }

    #[test]
    fn leakage_of_a_synchronous_orbit_in_a_short_window_is_not_oil_whirl() {
        // 3 revolutions: the 1x main lobe reaches down to 0.33x, so the band maximum
        // (at its upper end, 0.6) is large but only leakage.
        let omega = 100.0;
        let t = uniform(3.0 * TAU / omega, 301);
        let (x, y) = tone(&t, &[(1.7e-4, 1.0)], omega);
        let w = whirl(&t, &x, &y, omega, 3e-4, &WhirlOptions::default()).unwrap();
        assert!(w.subsync_amplitude_m > 0.2 * w.amplitude_m, "{w:?}");
        assert!(!w.oil_whirl, "leakage flagged as oil whirl: {w:?}");
    }

    #[test]
    fn nonuniform_samples_give_the_same_whirl() {
        let omega = 100.0;
        let t_end = 20.0 * TAU / omega;
        // Sample times bunched by a smooth warp.
        let t: Vec<f64> = uniform(1.0, 3001)
            .iter()
            .map(|u| t_end * (u + 0.1 * (TAU * u).sin() / TAU))
            .collect();
        assert!(t.windows(2).all(|p| p[1] > p[0]));
        let (x, y) = tone(&t, &[(3e-6, 0.45)], omega);
        let w = whirl(&t, &x, &y, omega, 3e-4, &WhirlOptions::default()).unwrap();
        close("ratio (nonuniform)", w.ratio, 0.45, 1e-6);
        close("amplitude (nonuniform)", w.amplitude_m, 3e-6, 3e-6 * 1e-4);
    }

    #[test]
    fn decimation_keeps_ends_and_counts() {
        assert_eq!(decimate_indices(0, 5, 10), vec![0, 1, 2, 3, 4]);
        assert_eq!(decimate_indices(0, 11, 3), vec![0, 5, 10]);
        assert_eq!(decimate_indices(10, 110, 5), vec![10, 35, 60, 84, 109]);
        assert_eq!(decimate_indices(0, 1000, 200).len(), 200);
    }

    fn signals(n: usize) -> Signals {
        // Rotor at 100 rad/s for 1 s; G on a circle of 1 mm at 1x; one bearing with the
        // journal on a 5 µm circle at 1x around (1e-4, 0); |W| = 10 + 2 sin(ωt) N;
        // Mz = −0.01 N·m; f = 0.02 + 0.01 t; h_min = δ − |e|; dip at t = 0.2.
        let omega = 100.0;
        let t = uniform(1.0, n);
        let mut s = Signals {
            t: t.clone(),
            spin: vec![omega; n],
            ..Default::default()
        };
        let mut b = BearingSignals {
            clearance_m: 3e-4,
            ..Default::default()
        };
        for &ti in &t {
            let a = omega * ti;
            s.x_g.push(1e-3 * a.cos());
            s.y_g.push(1e-3 * a.sin());
            let (xi, yi) = (1e-4 + 5e-6 * a.cos(), 5e-6 * a.sin());
            b.xi.push(xi);
            b.yi.push(yi);
            b.xj.push(xi);
            b.yj.push(yi);
            let e = xi.hypot(yi);
            let dip = if (ti - 0.2).abs() < 1e-9 { 1e-5 } else { 0.0 };
            b.h_min.push(3e-4 - e - dip);
            b.eccentricity_max.push(e / 3e-4);
            b.friction_coefficient.push(Some(0.02 + 0.01 * ti));
            b.mz.push(-0.01);
            let w = 10.0 + 2.0 * a.sin();
            b.wx.push(w);
            b.wy.push(0.0);
        }
        s.bearings.push(b);
        s
    }

    #[test]
    fn reductions_of_known_signals() {
        let s = signals(2001);
        let r = reduce(&s, &ReductionOptions::default());
        let w = r.window.unwrap();
        close("window start", w.t_start_s, 0.5, 1e-12);
        close("window revolutions", w.revolutions, 50.0 / TAU, 1e-9);
        let b = &r.bearings[0];
        let f = b.friction_coefficient.unwrap();
        close(
            "f mean (0.02 + 0.01 t over [0.5, 1])",
            f.mean,
            0.0275,
            1e-12,
        );
        close("f min", f.min, 0.025, 1e-12);
        close("f max", f.max, 0.03, 1e-12);
        close(
            "torque mean",
            b.friction_torque_nm.unwrap().mean,
            0.01,
            1e-15,
        );
        close("power loss", b.power_loss_w.unwrap(), 1.0, 1e-12);
        close("total power loss", r.power_loss_w.unwrap(), 1.0, 1e-12);
        // Samples are 0.05 rad of spin apart: extremes are missed by at most
        // 1 − cos(0.025) = 3.1e-4 of an amplitude.
        let fp = b.force_peak_n.unwrap();
        close("peak force", fp.value, 12.0, 2.0 * 3.2e-4);
        // Mean of 10 + 2 sin(100 t) over [0.5, 1]: 10 + 2 (cos 50 − cos 100)/50.
        let expected_mean = 10.0 + 2.0 * ((50f64).cos() - (100f64).cos()) / 50.0;
        close("force mean", b.force_n.unwrap().mean, expected_mean, 1e-5);
        let hm = r.h_min.unwrap();
        assert_eq!(hm.bearing, 0);
        close("h_min time", hm.t_s, 0.2, 1e-12);
        let e_at = ((1e-4 + 5e-6 * (20f64).cos()).powi(2) + (5e-6 * (20f64).sin()).powi(2)).sqrt();
        close("h_min value", hm.value_m, 3e-4 - e_at - 1e-5, 1e-15);
        close(
            "eccentricity max",
            b.eccentricity_max.unwrap().value,
            1.05e-4 / 3e-4,
            5e-6 * 3.2e-4 / 3e-4,
        );
        close(
            "journal orbit radius",
            b.orbit.unwrap().radius_m,
            5e-6,
            5e-6 * 4e-4,
        );
        close(
            "G orbit radius",
            r.g_orbit.unwrap().radius_m,
            1e-3,
            1e-3 * 4e-4,
        );
        let wh = b.whirl.unwrap();
        close("whirl ratio", wh.ratio, 1.0, 1e-6);
        close("whirl amplitude", wh.amplitude_m, 5e-6, 5e-10);
        assert!(!wh.oil_whirl);
        assert_eq!(r.whirl_ratio, Some(wh.ratio));
        let json = serde_json::to_string(&r).unwrap();
        assert!(!json.contains("NaN") && !json.contains("inf"), "{json}");
    }

    #[test]
    fn kept_series_are_decimated_and_grouped() {
        let s = signals(2001);
        let mut o = ReductionOptions::default();
        assert!(kept_series(&s, &o).is_none());
        o.keep.insert(SeriesGroup::Orbit);
        o.points = 11;
        let v = kept_series(&s, &o).unwrap();
        assert_eq!(v["t"].as_array().unwrap().len(), 11);
        assert_eq!(v["t"][10].as_f64(), Some(1.0));
        assert_eq!(v["bearings"][0]["xi"].as_array().unwrap().len(), 11);
        assert!(v["bearings"][0].get("h_min").is_none());
        assert!(v.get("spin").is_none());
        o.span = Span::Window;
        let v = kept_series(&s, &o).unwrap();
        assert_eq!(v["t"][0].as_f64(), Some(0.5));
    }

    #[test]
    fn empty_signals_reduce_to_nulls() {
        let r = reduce(&Signals::default(), &ReductionOptions::default());
        assert!(r.window.is_none() && r.h_min.is_none() && r.bearings.is_empty());
    }

    #[test]
    fn option_errors_name_paths() {
        let cases = [
            (
                serde_json::json!({"keep": ["orbits"]}),
                "r.keep[0]",
                "unknown series group",
            ),
            (
                serde_json::json!({"window": {"fraction": 2}}),
                "r.window.fraction",
                "at most 1",
            ),
            (
                serde_json::json!({"window": {"turns": 2}}),
                "r.window.turns",
                "unknown field",
            ),
            (serde_json::json!({"points": 1}), "r.points", "at least 2"),
            (serde_json::json!({"span": "all"}), "r.span", "expected"),
            (
                serde_json::json!({"whirl": {"band": [0.6, 0.3]}}),
                "r.whirl.band",
                "low < high",
            ),
            (
                serde_json::json!({"whirl": {"band": [0.3, 3.0]}}),
                "r.whirl.band",
                "max_ratio",
            ),
            // Short numbers, not 301 digits.
            (
                serde_json::json!({"whirl": {"band": [1e300, 1e299], "max_ratio": 1e301}}),
                "r.whirl.band",
                "got [1e300, 1e299]",
            ),
            (
                serde_json::json!({"whirl": {"max_ratio": "big"}}),
                "r.whirl.max_ratio",
                "expected a number, got a string",
            ),
            (
                serde_json::json!({"window": {"seconds": 1, "fraction": 0.5}}),
                "r.window",
                "expected one of",
            ),
        ];
        for (k, (v, path, reason)) in cases.iter().enumerate() {
            match ReductionOptions::parse(Some(v), "r") {
                Err(SweepError::Spec { path: p, reason: r }) => assert!(
                    p == *path && r.contains(reason),
                    "case {k}: got `{p}: {r}`, expected `{path}` with `{reason}`"
                ),
                other => panic!("case {k}: expected an error, got {other:?}"),
            }
        }
    }
}
