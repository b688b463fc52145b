//! Reductions as the run goes: every rotor variant of a sweep keeps only its evaluation
//! window's samples, the run's totals (sample count, angle, running extremes) and, when
//! the spec keeps series over the whole run, the samples those series will show.
//!
//! - A window of fixed length (`{"revolutions": N}` or `{"seconds": T}`) is a tail
//!   compacted as it moves; its reductions are the numbers [`super::reduce::reduce`]
//!   gives on every sample (the tail holds the whole window and the sample before it).
//! - A window given as a fraction of the run (`{"fraction": f}`, the default) starts at
//!   `t_last − f (t_last − t0)`, known in advance for a run that reaches `t_end`
//!   (`t_last` its last sample time): the tail keeps the samples from there on (every
//!   one up to [`WINDOW_SAMPLES`], or the batch's sample cap where lower, then every
//!   other, ...), so a run that reaches `t_end` gets the reductions of every sample
//!   whenever its window has at most that many. A run that ends early (step limit,
//!   failure, stop event) has a window not known in advance: it is reduced from a
//!   decimating record of the whole run ([`EARLY_END_RECORD`] samples at most); its
//!   `window.record_samples` and `window.sample_stride` say so when that record was
//!   decimated.
//! - Beside them a fraction window keeps its last [`WHIRL_TAIL`] samples at the full rate
//!   (time, spin, journal centres): when the window's kept samples are so coarse that
//!   the whirl search would stop below `max_ratio` (aliasing), each bearing's whirl is
//!   taken from that tail instead ([`super::reduce::whirl_from_tail`]).
//!
//! Memory follows what the spec keeps and these constants, not `t_end` or the memory
//! budget (the budget's sample cap only lowers them; `tests/sweep_stream.rs`).

use std::collections::{BTreeSet, VecDeque};

use super::reduce::whirl_from_tail;
use super::reduce::{
    angle_step, decimate_indices, kept_series_from, reduce_tail, BearingSignals, ReductionOptions,
    Reductions, RunTotals, SeriesGroup, Signals, Span, WhirlSamples, Window,
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

/// Most samples of the whole-run record from which a run that ends before `t_end` is
/// reduced over a fraction window (every sample up to this many, then every other one,
/// and so on; never more than the batch's sample cap, [`crate::budget::MemoryBudget::sample_cap`]).
/// 16 384 samples: 3.1 MB for a two-bearing variant (24 numbers of 8 B each), the
/// budget's cap for a 256-variant CPU batch at 2 GiB; a half-run window then keeps 4 096
/// to 8 192 samples, the decimating store's floor ([`crate::budget::MIN_SAMPLE_CAP`]).
pub const EARLY_END_RECORD: usize = 1 << 14;

/// Most samples a fraction window's tail holds per variant: every sample of the window
/// up to this many, then every other one, and so on (lower where the batch's sample cap
/// is, [`crate::budget::MemoryBudget::sample_cap`]). 2^16 samples: 12.6 MB for a
/// two-bearing variant (24 numbers of 8 B); a window of up to 6.5 s at the example
/// sweeps' 1e-4 s sample interval is kept whole, a longer one keeps 32 768 to 65 536
/// samples (stride 2, 4, ...), whose means and min/max differ from every sample's by
/// 7e-7 and 2.2e-6 (relative) at stride 4, 5e-5 and 1.2e-4 at stride 128 against 16
/// (BENCHMARKS.md "Issue 21"). So a variant's memory depends on the spec and this
/// constant, not on `t_end` or `--max-memory`.
pub const WINDOW_SAMPLES: usize = 1 << 16;

/// Samples of a fraction window's end kept at the full sample rate for the whirl
/// spectrum (a ring buffer of time, spin and each bearing's journal centre), used when
/// the window's kept samples are decimated beyond the search's Nyquist limit (lower
/// where the batch's sample cap is). 2^14 samples: 1.6 s, 26 revolutions at the example
/// sweeps' 1e-4 s and 100 rad/s (docs/outputs.md asks 10+ revolutions of a whirl
/// study), 0.8 MB for a two-bearing variant (6 numbers of 8 B).
pub const WHIRL_TAIL: usize = 1 << 14;

/// The running reductions of one rotor variant (see the module doc).
#[derive(Clone, Debug)]
pub struct RunReducer {
    window: Window,
    tail: Signals,
    totals: RunTotals,
    compact_at: usize,
    run_series: Option<RunSeries>,
    peak_stored: usize,
    /// A fraction window's tail and record (then `tail` stays empty).
    fraction: Option<FractionWindow>,
}

/// A fraction window kept as the run goes (see the module doc).
#[derive(Clone, Debug)]
struct FractionWindow {
    /// The window's fraction of the run.
    f: f64,
    /// Last sample time of a run that reaches `t_end`, s.
    t_last: f64,
    /// Sample interval, s.
    dt: f64,
    /// Samples before this time are left out of `tail` (set at the first sample).
    keep_from: f64,
    /// Samples left out of `tail`.
    skipped: usize,
    /// The samples from `keep_from` on, decimated beyond the batch's sample cap.
    tail: Decimating,
    /// The whole run, decimated beyond [`EARLY_END_RECORD`].
    record: Decimating,
    /// The last [`WHIRL_TAIL`] samples at the full rate, for the whirl.
    ring: WhirlRing,
}

/// The latest samples (at most `cap`) of what the whirl spectrum reads, every one.
#[derive(Clone, Debug)]
struct WhirlRing {
    cap: usize,
    t: VecDeque<f64>,
    spin: VecDeque<f64>,
    /// Per bearing, the journal centre at `z = 0`.
    centres: Vec<(VecDeque<f64>, VecDeque<f64>)>,
}

impl WhirlRing {
    fn new(scene: &Scene, cap: usize) -> Self {
        WhirlRing {
            cap: cap.max(1),
            t: VecDeque::new(),
            spin: VecDeque::new(),
            centres: vec![(VecDeque::new(), VecDeque::new()); scene.bearings.len()],
        }
    }

    fn observe(&mut self, x: &Sample<'_>) {
        let full = self.t.len() >= self.cap;
        let put = |v: &mut VecDeque<f64>, a: f64| {
            if full {
                v.pop_front();
            }
            v.push_back(a);
        };
        put(&mut self.t, x.t);
        put(&mut self.spin, x.spin);
        for ((cx, cy), b) in self.centres.iter_mut().zip(x.bearings) {
            put(cx, b.xi);
            put(cy, b.yi);
        }
    }

    fn samples(&self) -> WhirlSamples {
        let v = |d: &VecDeque<f64>| d.iter().copied().collect::<Vec<_>>();
        WhirlSamples {
            t: v(&self.t),
            spin: v(&self.spin),
            centres: self.centres.iter().map(|(x, y)| (v(x), v(y))).collect(),
        }
    }
}

/// Samples kept every `stride`-th (counted from the first one it saw) at most `cap`
/// (then every other one is dropped and the stride doubles), plus the latest one.
#[derive(Clone, Debug)]
struct Decimating {
    keep: Option<BTreeSet<SeriesGroup>>,
    kept: Signals,
    stride: usize,
    cap: usize,
    seen: usize,
    /// The latest sample, appended when off the stride.
    last: Signals,
}

impl Decimating {
    fn new(scene: &Scene, cap: usize, keep: Option<BTreeSet<SeriesGroup>>) -> Self {
        Decimating {
            keep,
            kept: empty_signals(scene),
            stride: 1,
            cap: cap.max(2),
            seen: 0,
            last: empty_signals(scene),
        }
    }

    fn observe(&mut self, x: &Sample<'_>) {
        if self.seen.is_multiple_of(self.stride) {
            if len(&self.kept) == self.cap {
                // The one sample over the cap, without doubling the columns' capacity.
                each_column(&mut self.kept, &mut |c| c.reserve_one());
            }
            push(&mut self.kept, x, self.keep.as_ref());
            // Every sample while at most `cap`: exact for runs that short.
            if len(&self.kept) > self.cap {
                each_column(&mut self.kept, &mut |c| c.keep_even());
                self.stride *= 2;
            }
        }
        self.seen += 1;
        each_column(&mut self.last, &mut |c| c.drain_front(usize::MAX));
        push(&mut self.last, x, self.keep.as_ref());
    }

    /// The kept samples and the latest one (when off the stride).
    fn samples(&self) -> Signals {
        let mut s = self.kept.clone();
        if self.seen > 0 && !(self.seen - 1).is_multiple_of(self.stride) {
            append(&mut s, &mut self.last.clone());
        }
        s
    }

    fn stored(&self) -> usize {
        len(&self.kept) + len(&self.last)
    }
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
    /// The whole run decimated (for a run that ends early).
    fallback: Decimating,
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
        // The film's own friction and flows: read by the reductions only (no kept group).
        if let (None, Some(f)) = (keep, v.film) {
            b.film.friction_torque_nm.push(f.friction_torque_nm);
            b.film.power_loss_w.push(f.power_loss_w);
            b.film.side_flow_m3_per_s.push(f.side_flow_m3_per_s);
            b.film.inlet_flow_m3_per_s.push(f.inlet_flow_m3_per_s);
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
            &mut b.film.friction_torque_nm,
            &mut b.film.power_loss_w,
            &mut b.film.side_flow_m3_per_s,
            &mut b.film.inlet_flow_m3_per_s,
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
    /// Room for one more element, exactly, when full.
    fn reserve_one(&mut self);
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
    fn reserve_one(&mut self) {
        if !self.is_empty() && self.len() == self.capacity() {
            self.reserve_exact(1);
        }
    }
}

fn len(s: &Signals) -> usize {
    s.t.len()
}

impl RunReducer {
    /// The reducer of a variant running `scene` under `opts`; `cap`: the batch's sample
    /// cap ([`crate::rotor::sample_cap`]), a ceiling on what a fraction window holds
    /// (its tail [`WINDOW_SAMPLES`], record [`EARLY_END_RECORD`] and full-rate end
    /// [`WHIRL_TAIL`], each lowered to `cap`).
    pub fn new(scene: &Scene, opts: &ReductionOptions, cap: usize) -> Self {
        let settings = crate::rotor::settings_of(scene);
        let n = crate::integrate::sample_count(&settings);
        let run_series = (!opts.keep.is_empty() && opts.span == Span::Run).then(|| RunSeries {
            keep: opts.keep.clone(),
            picks: decimate_indices(0, n, opts.points),
            next_pick: 0,
            picked: empty_signals(scene),
            fallback: Decimating::new(
                scene,
                RUN_SERIES_FALLBACK.max(4 * opts.points),
                Some(opts.keep.clone()),
            ),
        });
        let fraction = match opts.window {
            Window::Fraction(f) => Some(FractionWindow {
                f,
                // Sample times are `k · sample_interval`, k < n (integrate::sample_count).
                t_last: n.saturating_sub(1) as f64 * settings.sample_interval,
                dt: settings.sample_interval,
                keep_from: f64::NEG_INFINITY,
                skipped: 0,
                tail: Decimating::new(scene, WINDOW_SAMPLES.min(cap), None),
                record: Decimating::new(scene, EARLY_END_RECORD.min(cap), None),
                ring: WhirlRing::new(scene, WHIRL_TAIL.min(cap)),
            }),
            _ => None,
        };
        RunReducer {
            window: opts.window,
            tail: empty_signals(scene),
            totals: RunTotals::default(),
            compact_at: MIN_COMPACT,
            run_series,
            peak_stored: 0,
            fraction,
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
                .map_or(0, |r| len(&r.picked) + r.fallback.stored())
            + self
                .fraction
                .as_ref()
                .map_or(0, |w| w.tail.stored() + w.record.stored() + w.ring.t.len())
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
    /// [`super::reduce::kept_series`] give them on every sample (a fraction window: on
    /// its kept samples, see the module doc).
    pub fn finish(&self, opts: &ReductionOptions) -> (Reductions, Option<Value>) {
        let fraction = self.fraction.as_ref().map(|w| w.window(&self.totals));
        let (window, stride, record) = match &fraction {
            Some((s, stride, record)) => (s, *stride, *record),
            None => (&self.tail, 1, None),
        };
        let mut reductions = reduce_tail(window, &self.totals, opts);
        if let Some(w) = &mut reductions.window {
            // Only when decimated, so the reductions of every sample are unchanged.
            w.sample_stride = (stride > 1).then_some(stride);
            w.record_samples = record;
        }
        if let (Some(f), true) = (&self.fraction, stride > 1) {
            // Decimated: a whirl search stopped short by the kept samples' Nyquist limit
            // is redone on the window's end at the full rate.
            let clearances: Vec<f64> = window.bearings.iter().map(|b| b.clearance_m).collect();
            whirl_from_tail(&mut reductions, &f.ring.samples(), &clearances, opts);
        }
        let series = match &self.run_series {
            Some(r) if r.picks.len() == r.next_pick && self.totals.samples == r.full_count() => {
                kept_series_from(&r.picked, 0, opts)
            }
            Some(r) => kept_series_from(&r.fallback.samples(), 0, opts),
            None => {
                let start = super::reduce::window_start_in(
                    &window.t,
                    &window.spin,
                    opts.window,
                    self.totals.t0,
                    || self.totals.revolutions(),
                )
                .0;
                kept_series_from(window, start, opts)
            }
        };
        (reductions, series)
    }
}

impl FractionWindow {
    fn observe(&mut self, first: bool, x: &Sample<'_>) {
        if first {
            // The window's start for a run that reaches `t_end` (as `window_start_in`
            // computes it), less two sample intervals: the sample before the start is
            // kept, and a rounding difference in `t_last` does not lose the start.
            self.keep_from = self.t_last - self.f * (self.t_last - x.t) - 2.0 * self.dt;
        }
        if x.t >= self.keep_from {
            self.tail.observe(x);
        } else {
            self.skipped += 1;
        }
        self.record.observe(x);
        self.ring.observe(x);
    }

    /// The samples the window is reduced from, their stride, and the record's sample
    /// count when the run ended before the tail's start and the record was decimated.
    fn window(&self, totals: &RunTotals) -> (Signals, usize, Option<usize>) {
        let tail = self.tail.samples();
        let covers = match (tail.t.first(), tail.t.last()) {
            // The window's start, as `window_start_in` computes it.
            (Some(&first), Some(&t1)) => {
                self.skipped == 0 || first <= t1 - self.f * (t1 - totals.t0)
            }
            _ => self.skipped == 0,
        };
        if covers {
            return (tail, self.tail.stride, None);
        }
        let record = self.record.samples();
        let stride = self.record.stride;
        let n = len(&record);
        (record, stride, (stride > 1).then_some(n))
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
        self.fallback.observe(x);
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
        let (f, g) = (&mut x.film, &mut y.film);
        f.friction_torque_nm.append(&mut g.friction_torque_nm);
        f.power_loss_w.append(&mut g.power_loss_w);
        f.side_flow_m3_per_s.append(&mut g.side_flow_m3_per_s);
        f.inlet_flow_m3_per_s.append(&mut g.inlet_flow_m3_per_s);
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
        match &mut self.fraction {
            Some(w) => w.observe(index == 0, x),
            None => push(&mut self.tail, x, None),
        }
        if let Some(r) = &mut self.run_series {
            r.observe(index, x);
        }
        self.peak_stored = self.peak_stored.max(self.stored());
        if self.fraction.is_none() && len(&self.tail) >= self.compact_at {
            self.compact();
        }
    }
}
