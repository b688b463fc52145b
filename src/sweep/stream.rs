//! Reductions as the run goes: a rotor variant whose evaluation window has a fixed length
//! (`{"revolutions": N}` or `{"seconds": T}`) keeps only the window's samples (a tail
//! compacted as it moves), the run's totals (sample count, angle, running extremes) and,
//! when the spec keeps series over the whole run, the samples those series will show.
//! Its memory follows what the spec keeps, not `t_end` or the memory budget; its
//! reductions are the numbers [`super::reduce::reduce`] gives on every sample (the tail
//! holds the whole window and the sample before it; `tests/sweep_stream.rs`).
//!
//! A window given as a fraction of the run grows with the run and is kept by the
//! decimating store instead ([`crate::rotor::SeriesStore`]).

use std::collections::BTreeSet;

use super::reduce::{
    angle_step, decimate_indices, kept_series_from, reduce_tail, BearingSignals, ReductionOptions,
    Reductions, RunTotals, SeriesGroup, Signals, Span, Window,
};
use crate::rotor::{Sample, SampleObserver, Scene};
use serde_json::Value;

/// Fewest samples the tail holds before it is compacted (compaction is amortised: the
/// tail is compacted when it reaches twice what the last compaction kept, at least this).
const MIN_COMPACT: usize = 64;

/// Samples kept for whole-run series of a run that ends before `t_end` (the exact
/// samples are known in advance only for a run that reaches it): every sample up to this
/// many, then every other one, and so on (at least `4 × points`).
pub const RUN_SERIES_FALLBACK: usize = 4096;

/// The running reductions of one rotor variant (see the module doc).
#[derive(Clone, Debug)]
pub struct RunReducer {
    window: Window,
    tail: Signals,
    totals: RunTotals,
    compact_at: usize,
    run_series: Option<RunSeries>,
    peak_stored: usize,
}

/// The samples of the whole-run series: those `decimate_indices` will pick for a run
/// that reaches `t_end`, and a decimating fallback for one that ends early.
#[derive(Clone, Debug)]
struct RunSeries {
    keep: BTreeSet<SeriesGroup>,
    /// Sample indices picked for a run of the full sample count, ascending.
    picks: Vec<usize>,
    next_pick: usize,
    picked: Signals,
    /// Every `stride`-th sample, at most `cap`.
    fallback: Signals,
    stride: usize,
    cap: usize,
    /// The latest sample (kept columns), appended at the end when off the stride.
    last: Signals,
}

/// Whether a variant reduced with `opts` can run with a [`RunReducer`]: its window has
/// a fixed length.
pub fn streams(opts: &ReductionOptions) -> bool {
    matches!(opts.window, Window::Revolutions(_) | Window::Seconds(_))
}

fn empty_signals(scene: &Scene) -> Signals {
    Signals {
        bearings: scene
            .bearings
            .iter()
            .map(|b| BearingSignals {
                clearance_m: b.clearance,
                ..BearingSignals::default()
            })
            .collect(),
        ..Signals::default()
    }
}

/// Appends sample `x` to `s`: every column, or only `t`, `spin` and the kept groups.
fn push(s: &mut Signals, x: &Sample<'_>, keep: Option<&BTreeSet<SeriesGroup>>) {
    let has = |g| keep.is_none_or(|k| k.contains(&g));
    s.t.push(x.t);
    s.spin.push(x.spin);
    if has(SeriesGroup::Orbit) {
        s.x_g.push(x.x_g);
        s.y_g.push(x.y_g);
    }
    for (b, v) in s.bearings.iter_mut().zip(x.bearings) {
        if has(SeriesGroup::Orbit) {
            b.xi.push(v.xi);
            b.yi.push(v.yi);
            b.xj.push(v.xj);
            b.yj.push(v.yj);
        }
        if has(SeriesGroup::Film) {
            b.h_min.push(v.h_min);
            b.eccentricity_max.push(v.eccentricity_max);
        }
        if has(SeriesGroup::Friction) {
            b.friction_coefficient.push(v.friction_coefficient);
            b.mz.push(v.mz);
        }
        if has(SeriesGroup::Forces) {
            b.wx.push(v.wx);
            b.wy.push(v.wy);
        }
    }
}

/// Applies `f` to every column of `s`.
fn each_column(s: &mut Signals, f: &mut dyn FnMut(&mut dyn Column)) {
    f(&mut s.t);
    f(&mut s.spin);
    f(&mut s.x_g);
    f(&mut s.y_g);
    for b in &mut s.bearings {
        for v in [
            &mut b.xi,
            &mut b.yi,
            &mut b.xj,
            &mut b.yj,
            &mut b.h_min,
            &mut b.eccentricity_max,
            &mut b.mz,
            &mut b.wx,
            &mut b.wy,
        ] {
            f(v);
        }
        f(&mut b.friction_coefficient);
    }
}

/// A column of [`Signals`], whatever its element.
trait Column {
    fn drain_front(&mut self, n: usize);
    fn keep_even(&mut self);
}

impl<T> Column for Vec<T> {
    fn drain_front(&mut self, n: usize) {
        self.drain(..n.min(self.len()));
    }
    fn keep_even(&mut self) {
        let mut k = 0usize;
        self.retain(|_| {
            k += 1;
            k % 2 == 1
        });
    }
}

fn len(s: &Signals) -> usize {
    s.t.len()
}

impl RunReducer {
    /// The reducer of a variant running `scene` under `opts` ([`streams`] must hold; a
    /// fraction window is treated as the whole run).
    pub fn new(scene: &Scene, opts: &ReductionOptions) -> Self {
        let run_series = (!opts.keep.is_empty() && opts.span == Span::Run).then(|| {
            let n = crate::integrate::sample_count(&crate::rotor::settings_of(scene));
            RunSeries {
                keep: opts.keep.clone(),
                picks: decimate_indices(0, n, opts.points),
                next_pick: 0,
                picked: empty_signals(scene),
                fallback: empty_signals(scene),
                stride: 1,
                cap: RUN_SERIES_FALLBACK.max(4 * opts.points),
                last: empty_signals(scene),
            }
        });
        RunReducer {
            window: opts.window,
            tail: empty_signals(scene),
            totals: RunTotals::default(),
            compact_at: MIN_COMPACT,
            run_series,
            peak_stored: 0,
        }
    }

    /// Most samples held at once (tail and whole-run series together).
    pub fn peak_stored_samples(&self) -> usize {
        self.peak_stored
    }

    /// Samples held now.
    fn stored(&self) -> usize {
        len(&self.tail)
            + self
                .run_series
                .as_ref()
                .map_or(0, |r| len(&r.picked) + len(&r.fallback) + len(&r.last))
    }

    /// First tail sample that a later end of the run can still need in its window (one
    /// before the window's start as it stands now: the window's start only moves on).
    fn needed_from(&self) -> usize {
        let t = &self.tail.t;
        let spin = &self.tail.spin;
        let n = t.len();
        if n < 3 {
            return 0;
        }
        let start = match self.window {
            Window::Seconds(s) => {
                let ts = t[n - 1] - s;
                t.iter().position(|&x| x >= ts).unwrap_or(0)
            }
            Window::Revolutions(r) => {
                let target = r * std::f64::consts::TAU;
                // The same test and backward sum as `window_start`: a run still shorter
                // than the window needs every sample.
                if self.totals.revolutions() * std::f64::consts::TAU < target {
                    return 0;
                }
                let mut acc = 0.0;
                let mut start = n - 1;
                for i in (0..n - 1).rev() {
                    acc += angle_step(t[i], spin[i], t[i + 1], spin[i + 1]);
                    if acc > target * (1.0 + 1e-12) {
                        break;
                    }
                    start = i;
                }
                start
            }
            Window::Fraction(_) => 0,
        };
        start.saturating_sub(1).min(n - 2)
    }

    fn compact(&mut self) {
        let from = self.needed_from();
        if from > 0 {
            each_column(&mut self.tail, &mut |c| c.drain_front(from));
        }
        self.compact_at = (2 * len(&self.tail)).max(MIN_COMPACT);
    }

    /// The variant's reductions and kept series, as [`super::reduce::reduce`] and
    /// [`super::reduce::kept_series`] give them on every sample.
    pub fn finish(&self, opts: &ReductionOptions) -> (Reductions, Option<Value>) {
        let reductions = reduce_tail(&self.tail, &self.totals, opts);
        let series = match &self.run_series {
            Some(r) if r.picks.len() == r.next_pick && self.totals.samples == r.full_count() => {
                kept_series_from(&r.picked, 0, opts)
            }
            Some(r) => {
                let mut s = r.fallback.clone();
                if self.totals.samples > 0 && !(self.totals.samples - 1).is_multiple_of(r.stride) {
                    append(&mut s, &mut r.last.clone());
                }
                kept_series_from(&s, 0, opts)
            }
            None => {
                let start = super::reduce::window_start_in(
                    &self.tail.t,
                    &self.tail.spin,
                    opts.window,
                    self.totals.t0,
                    || self.totals.revolutions(),
                )
                .0;
                kept_series_from(&self.tail, start, opts)
            }
        };
        (reductions, series)
    }
}

impl RunSeries {
    /// Samples of a run that reaches `t_end` (the last pick is its last sample).
    fn full_count(&self) -> usize {
        self.picks.last().map_or(0, |&i| i + 1)
    }

    fn observe(&mut self, index: usize, x: &Sample<'_>) {
        while self.picks.get(self.next_pick) == Some(&index) {
            push(&mut self.picked, x, Some(&self.keep));
            self.next_pick += 1;
        }
        if index.is_multiple_of(self.stride) {
            push(&mut self.fallback, x, Some(&self.keep));
            // Every sample while at most `cap`: exact for runs that short.
            if len(&self.fallback) > self.cap {
                each_column(&mut self.fallback, &mut |c| c.keep_even());
                self.stride *= 2;
            }
        }
        each_column(&mut self.last, &mut |c| c.drain_front(usize::MAX));
        push(&mut self.last, x, Some(&self.keep));
    }
}

/// Appends `b`'s samples to `a` (same shape).
fn append(a: &mut Signals, b: &mut Signals) {
    a.t.append(&mut b.t);
    a.spin.append(&mut b.spin);
    a.x_g.append(&mut b.x_g);
    a.y_g.append(&mut b.y_g);
    for (x, y) in a.bearings.iter_mut().zip(&mut b.bearings) {
        x.xi.append(&mut y.xi);
        x.yi.append(&mut y.yi);
        x.xj.append(&mut y.xj);
        x.yj.append(&mut y.yj);
        x.h_min.append(&mut y.h_min);
        x.eccentricity_max.append(&mut y.eccentricity_max);
        x.friction_coefficient.append(&mut y.friction_coefficient);
        x.mz.append(&mut y.mz);
        x.wx.append(&mut y.wx);
        x.wy.append(&mut y.wy);
    }
}

impl SampleObserver for RunReducer {
    fn observe(&mut self, x: &Sample<'_>) {
        let index = self.totals.samples;
        self.totals.observe(
            x.t,
            x.spin,
            x.bearings
                .iter()
                .map(|b| [b.h_min, b.eccentricity_max, b.wx, b.wy]),
        );
        push(&mut self.tail, x, None);
        if let Some(r) = &mut self.run_series {
            r.observe(index, x);
        }
        self.peak_stored = self.peak_stored.max(self.stored());
        if len(&self.tail) >= self.compact_at {
            self.compact();
        }
    }
}
