//! Bookkeeping shared by the methods: per-variant tracks, packed call buffers, error
//! norms, uniform sampling and ending variants.

use std::time::Instant;

use super::system::{BatchSystem, Settings, Stats, Status};

/// Relative step-size floor: a step below `H_FLOOR_REL * max(t_end, |t|)` cannot move `t`
/// meaningfully (about 4500 ulps of `t`), so the variant ends there.
const H_FLOOR_REL: f64 = 1e-12;

/// Samples within this fraction of a sample interval past a step's end still belong to
/// that step (round-off in `k * dt` against an accumulated `t`).
const SAMPLE_SLACK: f64 = 1e-9;

/// Smallest admissible step at time `t` of a run to `t_end`.
pub(crate) fn h_floor(t: f64, t_end: f64) -> f64 {
    H_FLOOR_REL * t_end.abs().max(t.abs())
}

/// Time left is negligible: the variant has reached `t_end`.
pub(crate) fn reached(t: f64, t_end: f64) -> bool {
    t_end - t <= 4.0 * f64::EPSILON * t_end.abs().max(1.0)
}

/// One variant's progress.
pub(crate) struct Track<F> {
    /// Current time.
    pub t: f64,
    /// Next step size to try.
    pub h: f64,
    /// Status; `Running` while active.
    pub status: Status<F>,
    /// Counters.
    pub stats: Stats,
    /// Index of the next sample to emit.
    pub next_sample: usize,
    /// Number of samples, `floor(t_end / dt) + 1`.
    pub n_samples: usize,
    /// Last fault seen by a rejected attempt (reported if the step size collapses).
    pub fault: Option<F>,
    /// The last step attempt was rejected.
    pub last_rejected: bool,
}

/// Output samples of a run that reaches `t_end`: `floor(t_end / dt) + 1` (times
/// `k * sample_interval`, with a relative slack of 1e-9 for rounding), 1 for settings
/// that cannot be sampled.
pub fn sample_count(s: &Settings) -> usize {
    if s.sample_interval > 0.0 && s.t_end >= 0.0 {
        (s.t_end / s.sample_interval * (1.0 + SAMPLE_SLACK)).floor() as usize + 1
    } else {
        1
    }
}

impl<F: Clone> Track<F> {
    pub(crate) fn new(s: &Settings) -> Self {
        let n = sample_count(s);
        Track {
            t: 0.0,
            h: 0.0,
            status: Status::Running,
            stats: Stats::default(),
            next_sample: 0,
            n_samples: n,
            fault: None,
            last_rejected: false,
        }
    }

    /// Settings that cannot be integrated end the variant at once.
    pub(crate) fn check_settings(&mut self, s: &Settings) -> bool {
        let ok = s.t_end.is_finite()
            && s.t_end >= 0.0
            && s.sample_interval.is_finite()
            && s.sample_interval > 0.0
            && s.rtol.is_finite()
            && s.rtol > 0.0
            && s.atol.is_finite()
            && s.atol > 0.0
            && s.fixed_step.is_none_or(|h| h.is_finite() && h > 0.0);
        if !ok {
            self.status = Status::StepSizeTooSmall {
                time: 0.0,
                step: 0.0,
            };
        }
        ok
    }

    /// Emits the samples in `(t0, t0 + h]` (and at `t0` for the first) into `rec`
    /// through `interp(theta, out)`, `theta` in `[0, 1]`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(crate) fn emit(
        &mut self,
        id: usize,
        s: &Settings,
        t0: f64,
        h: f64,
        dim: usize,
        rec: &mut Packed<F>,
        mut interp: impl FnMut(f64, &mut [f64]),
    ) {
        let t1 = t0 + h;
        while self.next_sample < self.n_samples {
            let tk = self.next_sample as f64 * s.sample_interval;
            if tk > t1 + SAMPLE_SLACK * s.sample_interval {
                break;
            }
            let theta = if h > 0.0 {
                ((tk - t0) / h).clamp(0.0, 1.0)
            } else {
                1.0
            };
            let out = rec.push(id, tk, dim);
            interp(theta, out);
            self.next_sample += 1;
        }
    }
}

/// Packed states of one call (or one round's samples).
pub(crate) struct Packed<F> {
    pub ids: Vec<usize>,
    pub ts: Vec<f64>,
    pub ys: Vec<f64>,
    pub dys: Vec<f64>,
    pub faults: Vec<Option<F>>,
}

impl<F: Clone> Packed<F> {
    pub(crate) fn new() -> Self {
        Packed {
            ids: Vec::new(),
            ts: Vec::new(),
            ys: Vec::new(),
            dys: Vec::new(),
            faults: Vec::new(),
        }
    }

    pub(crate) fn clear(&mut self) {
        self.ids.clear();
        self.ts.clear();
        self.ys.clear();
    }

    pub(crate) fn len(&self) -> usize {
        self.ids.len()
    }

    /// Appends an entry and returns its state slot (zeroed) to fill.
    pub(crate) fn push(&mut self, id: usize, t: f64, dim: usize) -> &mut [f64] {
        self.ids.push(id);
        self.ts.push(t);
        let n = self.ys.len();
        self.ys.resize(n + dim, 0.0);
        &mut self.ys[n..]
    }

    /// Appends an entry whose state is `state` (no zero fill before the copy) and returns
    /// its slot.
    pub(crate) fn push_from(
        &mut self,
        id: usize,
        t: f64,
        state: impl IntoIterator<Item = f64>,
    ) -> &mut [f64] {
        self.ids.push(id);
        self.ts.push(t);
        let n = self.ys.len();
        self.ys.extend(state);
        &mut self.ys[n..]
    }

    /// Evaluates all entries in one system call; `stats[id]` counts them.
    pub(crate) fn eval<S: BatchSystem<Fault = F>>(&mut self, sys: &mut S, tracks: &mut [Track<F>]) {
        let dim = sys.dim();
        self.dys.clear();
        self.dys.resize(self.ys.len(), 0.0);
        self.faults.clear();
        self.faults.resize(self.ids.len(), None);
        if self.ids.is_empty() {
            return;
        }
        for &id in &self.ids {
            tracks[id].stats.rhs_evaluations += 1;
        }
        sys.eval(
            &self.ids,
            &self.ts,
            &self.ys,
            &mut self.dys,
            &mut self.faults,
        );
        // A system that returns non-finite derivatives without a fault still never
        // propagates NaN silently: the error norm catches it.
        debug_assert_eq!(self.dys.len(), self.ids.len() * dim);
    }

    /// Hands the recorded samples to the system.
    pub(crate) fn flush_records<S: BatchSystem<Fault = F>>(&mut self, sys: &mut S) {
        if !self.ids.is_empty() {
            sys.record(&self.ids, &self.ts, &self.ys);
        }
        self.clear();
    }
}

/// Weighted RMS norm of `err` with weights `atol * scale + rtol * max(|a|, |b|)`.
pub(crate) fn err_norm(err: &[f64], a: &[f64], b: &[f64], scale: &[f64], s: &Settings) -> f64 {
    let mut sum = 0.0;
    for i in 0..err.len() {
        let w = s.atol * scale[i] + s.rtol * a[i].abs().max(b[i].abs());
        let r = err[i] / w;
        sum += r * r;
    }
    (sum / err.len().max(1) as f64).sqrt()
}

/// Initial step heuristic (Hairer-Norsett-Wanner, first half): `0.01 |y| / |f|` in the
/// weighted norm, capped by the time span; `1e-6 * t_end` when either norm is tiny.
pub(crate) fn initial_step(y: &[f64], f: &[f64], scale: &[f64], s: &Settings) -> f64 {
    if let Some(h) = s.initial_step {
        return h.min(s.t_end);
    }
    let mut d0 = 0.0;
    let mut d1 = 0.0;
    for i in 0..y.len() {
        let w = s.atol * scale[i] + s.rtol * y[i].abs();
        d0 += (y[i] / w).powi(2);
        d1 += (f[i] / w).powi(2);
    }
    let (d0, d1) = (d0.sqrt(), d1.sqrt());
    let h = if d0 < 1e-5 || d1 < 1e-5 || !(d0 / d1).is_finite() {
        1e-6 * s.t_end
    } else {
        0.01 * d0 / d1
    };
    h.min(s.t_end).min(s.max_step.unwrap_or(f64::INFINITY))
}

/// Ends variant `id` with `status` (wall time stamped); the caller calls
/// [`BatchSystem::finished`] after flushing the round's samples.
pub(crate) fn end<F>(track: &mut Track<F>, status: Status<F>, start: Instant) {
    track.status = status;
    track.stats.wall_time_s = start.elapsed().as_secs_f64();
}

/// Starts every variant at t = 0: one with unusable settings or a non-finite initial state
/// ends (`NonFinite`, queued in `ended`); the others emit their t = 0 sample into `rec` and
/// are returned as active, except those with `t_end = 0`, which finish at once.
pub(crate) fn admit<F: Clone>(
    tracks: &mut [Track<F>],
    settings: &[Settings],
    y: &[f64],
    d: usize,
    rec: &mut Packed<F>,
    ended: &mut Vec<usize>,
    start: Instant,
) -> Vec<usize> {
    let mut active = Vec::new();
    for (id, (tr, s)) in tracks.iter_mut().zip(settings).enumerate() {
        let y0 = &y[id * d..(id + 1) * d];
        if !tr.check_settings(s) || !finite(y0) {
            if matches!(tr.status, Status::Running) {
                end(tr, Status::NonFinite { time: 0.0 }, start);
            }
            ended.push(id);
            continue;
        }
        tr.emit(id, s, 0.0, 0.0, d, rec, |_, out| out.copy_from_slice(y0));
        if reached(0.0, s.t_end) {
            end(tr, Status::Finished, start);
            ended.push(id);
        } else {
            active.push(id);
        }
    }
    active
}

/// Starts an explicit Runge–Kutta batch at t = 0 (dopri5 and DOP853 share it): admits
/// the variants whose settings and initial state are usable (the others end `NonFinite`),
/// evaluates `f(0, y0)` for all of them in one call into `k0` (the first stage), picks each
/// one's first step (`fixed_step` or [`initial_step`]), emits the t = 0 sample and ends the
/// variants with `t_end = 0`; a variant whose first evaluation faults ends there without a
/// sample. Returns the variants still running, after flushing the samples and notifying
/// the system of those that ended.
#[allow(clippy::too_many_arguments)]
pub(crate) fn start_explicit<S: BatchSystem>(
    sys: &mut S,
    tracks: &mut [Track<S::Fault>],
    settings: &[Settings],
    y: &[f64],
    scale: &[f64],
    k0: &mut [f64],
    buf: &mut Packed<S::Fault>,
    rec: &mut Packed<S::Fault>,
    ended: &mut Vec<usize>,
    start: Instant,
) -> Vec<usize> {
    let d = sys.dim();
    let mut active = Vec::new();
    for id in 0..settings.len() {
        if tracks[id].check_settings(&settings[id]) && finite(&y[id * d..(id + 1) * d]) {
            active.push(id);
        } else {
            if matches!(tracks[id].status, Status::Running) {
                end(&mut tracks[id], Status::NonFinite { time: 0.0 }, start);
            }
            ended.push(id);
        }
    }
    // f(0, y0) for every variant in one call.
    buf.clear();
    for &id in &active {
        buf.push(id, 0.0, d)
            .copy_from_slice(&y[id * d..(id + 1) * d]);
    }
    buf.eval(sys, tracks);
    for e in 0..buf.len() {
        let id = buf.ids[e];
        let r = id * d..(id + 1) * d;
        let tr = &mut tracks[id];
        if let Some(f) = &buf.faults[e] {
            end(
                tr,
                Status::Fault {
                    time: 0.0,
                    fault: f.clone(),
                },
                start,
            );
            ended.push(id);
            continue;
        }
        k0[r.clone()].copy_from_slice(&buf.dys[e * d..(e + 1) * d]);
        let s = &settings[id];
        tr.h = s
            .fixed_step
            .unwrap_or_else(|| initial_step(&y[r.clone()], &k0[r.clone()], &scale[r.clone()], s));
        let y0v = &y[r];
        tr.emit(id, s, 0.0, 0.0, d, rec, |_, out| out.copy_from_slice(y0v));
        if reached(0.0, s.t_end) {
            end(tr, Status::Finished, start);
            ended.push(id);
        }
    }
    active.retain(|&id| matches!(tracks[id].status, Status::Running));
    rec.flush_records(sys);
    notify(sys, tracks, ended);
    active
}

/// The step each active variant tries this round, into `hs` (its controller's step, capped
/// by `max_step`, landing on `t_end` rather than leaving a sliver under 1 % of a step);
/// marks every variant's stages usable (`stage_ok`) for the round.
pub(crate) fn plan_steps<F>(
    active: &[usize],
    tracks: &[Track<F>],
    settings: &[Settings],
    hs: &mut [f64],
    stage_ok: &mut [bool],
) {
    for &id in active {
        let tr = &tracks[id];
        let s = &settings[id];
        hs[id] = step_to_try(tr, s);
        stage_ok[id] = true;
    }
}

/// The step a variant tries next: its controller's step, capped by `max_step`, landing
/// on `t_end` rather than leaving a sliver under 1 % of a step.
#[inline]
pub(crate) fn step_to_try<F>(tr: &Track<F>, s: &Settings) -> f64 {
    let left = s.t_end - tr.t;
    let h = tr.h.min(s.max_step.unwrap_or(f64::INFINITY));
    if h >= left || left - h < 0.01 * h {
        left
    } else {
        h
    }
}

/// Ends variant `id` with the fault `fault` at its track's time (queued in `ended`).
pub(crate) fn end_with_fault<F: Clone>(
    tracks: &mut [Track<F>],
    id: usize,
    fault: &F,
    start: Instant,
    ended: &mut Vec<usize>,
) {
    let time = tracks[id].t;
    end(
        &mut tracks[id],
        Status::Fault {
            time,
            fault: fault.clone(),
        },
        start,
    );
    ended.push(id);
}

/// After an accepted adaptive step: the status the variant ends with, if any — `t_end`
/// reached, accepted steps shrinking toward a singularity (Zeno), or the step budget spent.
pub(crate) fn status_after_accepted<F>(track: &Track<F>, s: &Settings) -> Option<Status<F>> {
    if reached(track.t, s.t_end) {
        Some(Status::Finished)
    } else if track.h < h_floor(track.t, s.t_end) {
        Some(Status::StepSizeTooSmall {
            time: track.t,
            step: track.h,
        })
    } else if track.stats.steps >= s.max_steps {
        Some(Status::MaxSteps {
            time: track.t,
            steps: track.stats.steps,
        })
    } else {
        None
    }
}

/// Calls `finished` for the variants in `ended` and clears the list.
pub(crate) fn notify<S: BatchSystem>(
    sys: &mut S,
    tracks: &[Track<S::Fault>],
    ended: &mut Vec<usize>,
) {
    for &id in ended.iter() {
        sys.finished(id, &tracks[id].status, &tracks[id].stats);
    }
    ended.clear();
}

/// All components finite.
pub(crate) fn finite(y: &[f64]) -> bool {
    y.iter().all(|v| v.is_finite())
}
