//! Batched simulation of scenes: the rotor batch as a lockstep [`BatchSystem`] (every
//! stage of every active variant's bearings in one [`LoadEvaluator::evaluate`] call),
//! statuses with physical context, sampled time series and counters.

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};

use serde::{Deserialize, Serialize};

use super::model::{add_contact_forces, EndKin, Kin, RotorModel, DIM, JAC_DIM, V3, WORK};
use super::scene::{ModelKind, Scene, SceneError};
use super::simplifications::{
    variant_report, SimplificationReport, SimplificationSpec, SimplificationTally,
};
use crate::backend::{BearingPlan, LoadEvaluator, LoadRequest, LoadResult};
use crate::bearing::{BearingParams, StateFault};
use crate::integrate::{run_batch, BatchSystem, Method, Settings, Stats, Status};

/// How a simulation ended. Serialised with a `kind` tag (`"finished"`, `"film_breakdown"`, ...).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, thiserror::Error)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum SimStatus {
    /// Reached `t_end`.
    #[error("finished")]
    Finished,
    /// The film in `bearing` became thinner than the scene's threshold.
    #[error("film breakdown in bearings[{bearing}] at t = {time} s: h_min = {h_min:e} m below the threshold")]
    FilmBreakdown {
        /// Time, s.
        time: f64,
        /// Index into the scene's bearings.
        bearing: usize,
        /// Minimum film thickness there, m.
        h_min: f64,
    },
    /// The journal reached the bore wall (eccentricity ratio >= 1) in `bearing`.
    #[error("journal through the wall of bearings[{bearing}] at t = {time} s (eccentricity ratio {eccentricity_ratio})")]
    ThroughWall {
        /// Time, s.
        time: f64,
        /// Index into the scene's bearings.
        bearing: usize,
        /// `|e| / δ` at the worse end face.
        eccentricity_ratio: f64,
    },
    /// Error control drove the step below `1e-12 t_end`.
    #[error("step size collapsed to {step:e} s at t = {time} s")]
    StepSizeTooSmall {
        /// Time, s.
        time: f64,
        /// Step, s.
        step: f64,
    },
    /// The state became NaN or infinite.
    #[error("non-finite state at t = {time} s")]
    NonFinite {
        /// Time, s.
        time: f64,
    },
    /// The step budget ran out.
    #[error("{steps} steps taken by t = {time} s (integrator.max_steps)")]
    MaxSteps {
        /// Time, s.
        time: f64,
        /// Steps.
        steps: u64,
    },
    /// The film loads could not be evaluated.
    #[error("film loads of bearings[{bearing}] failed at t = {time} s: {reason}")]
    LoadFailure {
        /// Time, s.
        time: f64,
        /// Index into the scene's bearings.
        bearing: usize,
        /// Why.
        reason: String,
    },
    /// The scene failed validation; nothing was simulated.
    #[error("invalid scene: {path}: {reason}")]
    InvalidScene {
        /// JSON path inside the scene.
        path: String,
        /// Why.
        reason: String,
    },
}

impl SimStatus {
    /// Reached `t_end`.
    pub fn is_finished(&self) -> bool {
        matches!(self, SimStatus::Finished)
    }
}

/// Why one right-hand-side evaluation has no derivative.
#[derive(Clone, Debug, PartialEq)]
pub enum RotorFault {
    /// Film below threshold.
    FilmBreakdown {
        /// Bearing index.
        bearing: usize,
        /// m.
        h_min: f64,
    },
    /// Eccentricity ratio >= 1.
    ThroughWall {
        /// Bearing index.
        bearing: usize,
        /// Ratio.
        ratio: f64,
    },
    /// Derivative not finite.
    NonFinite,
    /// Other load failure.
    Load {
        /// Bearing index.
        bearing: usize,
        /// Why.
        reason: String,
    },
}

/// A film falling below the threshold (seen at a sample).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FilmEvent {
    /// Sample time, s.
    pub time: f64,
    /// Bearing index.
    pub bearing: usize,
    /// Minimum film thickness there, m.
    pub h_min: f64,
}

/// Samples of one bearing, one entry per sample time.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BearingSeries {
    /// Journal centre at the first end face in the bearing frame, m (bearing 1's `xi,
    /// yi` is the paper's Fig. 10 orbit). Zero for ideal joints.
    pub xi: Vec<f64>,
    /// See `xi`, m.
    pub yi: Vec<f64>,
    /// Journal centre at the second end face, m.
    pub xj: Vec<f64>,
    /// See `xj`, m.
    pub yj: Vec<f64>,
    /// Minimum film thickness, m (the clearance for ideal joints).
    pub h_min: Vec<f64>,
    /// Larger end eccentricity ratio `max |e| / δ`.
    pub eccentricity_max: Vec<f64>,
    /// Film force (ideal joints: joint reaction) on the journal, x, N.
    pub wx: Vec<f64>,
    /// Same, y, N.
    pub wy: Vec<f64>,
    /// Friction torque about `+z`, N·m.
    pub mz: Vec<f64>,
    /// Friction coefficient (MODEL.md section 5); `null` where infinite or undefined.
    pub friction_coefficient: Vec<Option<f64>>,
    /// The lumped oil temperature and its heat flows (bearings with a lubricant only;
    /// absent otherwise, docs/thermal.md "Rotor scenes").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub thermal: Option<ThermalSeries>,
    /// The film's own friction and flows along the run: finite-film bearings with JFO
    /// cavitation only (whose film carries its history; absent otherwise, docs/jfo.md
    /// "Flow and power loss along a whirl orbit").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub film: Option<FilmSeries>,
}

/// A JFO film's own friction and flows (`Loads::film`, with the film fraction carried
/// through the run), one entry per sample.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FilmSeries {
    /// Friction torque of the film on the journal (Couette shear over the liquid share,
    /// plus the pressure term), N·m.
    pub friction_torque_nm: Vec<f64>,
    /// Power loss `|M ω|`, W.
    pub power_loss_w: Vec<f64>,
    /// Side flow out of both end faces, m³/s.
    pub side_flow_m3_per_s: Vec<f64>,
    /// Net flow out of the supply (held) nodes into the film, m³/s.
    pub inlet_flow_m3_per_s: Vec<f64>,
}

/// One JFO bearing's film friction and flows at one sample time (the columns of
/// [`FilmSeries`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FilmSample {
    /// Friction torque, N·m.
    pub friction_torque_nm: f64,
    /// Power loss, W.
    pub power_loss_w: f64,
    /// Side flow, m³/s.
    pub side_flow_m3_per_s: f64,
    /// Inlet flow, m³/s.
    pub inlet_flow_m3_per_s: f64,
}

/// The lumped oil temperature of one bearing and its heat flows, one entry per sample.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ThermalSeries {
    /// Effective film temperature (the state), °C.
    pub temperature_c: Vec<f64>,
    /// Film viscosity at that temperature, Pa·s.
    pub viscosity_pa_s: Vec<f64>,
    /// Heat generated: the film's own friction power (`film.power_loss_w`), W.
    pub power_w: Vec<f64>,
    /// Heat carried out by the side flow, `ρ c Q (T − T_supply) / k`, W.
    pub heat_to_flow_w: Vec<f64>,
    /// Heat through the housing, `H (T − T_supply)`, W.
    pub heat_to_housing_w: Vec<f64>,
}

/// One bearing's lumped oil temperature values at one sample time (the columns of
/// [`ThermalSeries`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ThermalSample {
    /// Effective film temperature, °C.
    pub temperature_c: f64,
    /// Film viscosity, Pa·s.
    pub viscosity_pa_s: f64,
    /// Film friction power, W.
    pub power_w: f64,
    /// Heat to the side flow, W.
    pub heat_to_flow_w: f64,
    /// Heat through the housing, W.
    pub heat_to_housing_w: f64,
}

/// Uniform samples of one simulation, decimated to a bounded count (docs/cli.md "Limits"):
/// a store holding `cap` samples drops every other one and doubles its stride, so the
/// kept samples are every `sample_stride`-th sample time, plus always the last one (the
/// end of the run or the failure) so windows end at the true end.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TimeSeries {
    /// Sample times `k * sample_stride * sample_interval` (and the last sample time), s.
    pub t: Vec<f64>,
    /// Kept every this many sample times (1: every sample kept). Film events and
    /// breakdown checks see every sample time whatever the stride.
    #[serde(default = "one")]
    pub sample_stride: u64,
    /// Centre of mass `G`, global x, m (Fig. 8).
    pub x_g: Vec<f64>,
    /// `G`, global y, m (Fig. 9).
    pub y_g: Vec<f64>,
    /// Global `z` component of the angular velocity, rad/s.
    pub spin: Vec<f64>,
    /// Kinetic energy, J.
    pub kinetic_energy: Vec<f64>,
    /// Work done on the rotor by all applied loads since `t = 0`, J.
    pub work: Vec<f64>,
    /// Per bearing, in scene order.
    pub bearings: Vec<BearingSeries>,
}

fn one() -> u64 {
    1
}

impl Default for TimeSeries {
    fn default() -> Self {
        TimeSeries {
            t: Vec::new(),
            sample_stride: 1,
            x_g: Vec::new(),
            y_g: Vec::new(),
            spin: Vec::new(),
            kinetic_energy: Vec::new(),
            work: Vec::new(),
            bearings: Vec::new(),
        }
    }
}

impl BearingSeries {
    /// The nine plain columns, in [`TimeSeries::columns`]' order.
    fn plain_columns(&mut self) -> [&mut Vec<f64>; 9] {
        [
            &mut self.xi,
            &mut self.yi,
            &mut self.xj,
            &mut self.yj,
            &mut self.h_min,
            &mut self.eccentricity_max,
            &mut self.wx,
            &mut self.wy,
            &mut self.mz,
        ]
    }
}

impl ThermalSeries {
    /// The five columns, in [`TimeSeries::columns`]' order.
    fn columns_mut(&mut self) -> [&mut Vec<f64>; 5] {
        [
            &mut self.temperature_c,
            &mut self.viscosity_pa_s,
            &mut self.power_w,
            &mut self.heat_to_flow_w,
            &mut self.heat_to_housing_w,
        ]
    }
}

impl FilmSeries {
    /// The four columns, in [`TimeSeries::columns`]' order.
    fn columns_mut(&mut self) -> [&mut Vec<f64>; 4] {
        [
            &mut self.friction_torque_nm,
            &mut self.power_loss_w,
            &mut self.side_flow_m3_per_s,
            &mut self.inlet_flow_m3_per_s,
        ]
    }
}

impl TimeSeries {
    /// The six columns before the bearings', in [`TimeSeries::columns`]' order.
    fn head_columns(&mut self) -> [&mut Vec<f64>; 6] {
        [
            &mut self.t,
            &mut self.x_g,
            &mut self.y_g,
            &mut self.spin,
            &mut self.kinetic_energy,
            &mut self.work,
        ]
    }

    /// Kept samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// No samples kept.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Applies `f` to every `f64` column and `g` to every optional one.
    fn columns(&mut self, f: impl Fn(&mut Vec<f64>), g: impl Fn(&mut Vec<Option<f64>>)) {
        self.head_columns().into_iter().for_each(&f);
        for b in &mut self.bearings {
            b.plain_columns().into_iter().for_each(&f);
            g(&mut b.friction_coefficient);
            if let Some(th) = &mut b.thermal {
                th.columns_mut().into_iter().for_each(&f);
            }
            if let Some(fl) = &mut b.film {
                fl.columns_mut().into_iter().for_each(&f);
            }
        }
    }

    /// Keeps samples 0, 2, 4, ... and the last one, and doubles the stride. Says whether
    /// the last one is now off the stride (an odd position).
    fn thin(&mut self) -> bool {
        let n = self.len();
        let odd_last = n.is_multiple_of(2) && n > 0;
        fn even<T>(v: &mut Vec<T>) {
            let n = v.len();
            let mut k = 0usize;
            v.retain(|_| {
                k += 1;
                k % 2 == 1 || k == n
            });
        }
        self.columns(even, even);
        self.sample_stride *= 2;
        odd_last
    }

    /// Drops the last sample.
    fn pop(&mut self) {
        self.columns(
            |v| {
                v.pop();
            },
            |v| {
                v.pop();
            },
        );
    }
}

/// What a [`Decimator`] thins: a store of samples that can drop its last one and keep
/// every other one.
trait Decimated {
    /// Samples kept.
    fn kept(&self) -> usize;
    /// Sample times between kept samples.
    fn stride(&self) -> u64;
    /// Drops the last sample.
    fn drop_last(&mut self);
    /// Keeps samples 0, 2, 4, ... and the last one, doubles the stride, and says whether
    /// the last one is now off the stride (see [`TimeSeries::thin`]).
    fn thin(&mut self) -> bool;
}

impl Decimated for TimeSeries {
    fn kept(&self) -> usize {
        self.len()
    }
    fn stride(&self) -> u64 {
        self.sample_stride
    }
    fn drop_last(&mut self) {
        self.pop();
    }
    fn thin(&mut self) -> bool {
        TimeSeries::thin(self)
    }
}

/// The decimating store's state of one simulation (see [`TimeSeries`]).
#[derive(Clone, Copy, Debug, Default)]
struct Decimator {
    /// Sample times seen so far.
    seen: u64,
    /// The last kept sample is off the stride (kept only as the latest), to be replaced.
    provisional: bool,
}

impl Decimator {
    /// Before sample time number `seen` is pushed to `s`: drops a provisional last
    /// sample and says whether the new one will be provisional.
    fn before_push(&mut self, s: &mut impl Decimated) {
        if self.provisional {
            s.drop_last();
        }
        self.provisional = !self.seen.is_multiple_of(s.stride());
        self.seen += 1;
    }

    /// After the push: a full store (`cap` samples on the stride) is thinned to `cap / 2`
    /// on the doubled stride plus the latest sample (provisional), so at most `cap`
    /// samples are ever kept.
    fn after_push(&mut self, s: &mut impl Decimated, cap: usize) {
        // Only when the samples on the stride fill it: a provisional one on top of
        // `cap - 1` is replaced by the next, not a reason to decimate.
        if !self.provisional && s.kept() >= cap {
            self.provisional = s.thin();
        }
    }
}

/// One bearing's values at one sample time (the columns of [`BearingSeries`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BearingSample {
    /// Journal centre at the first end face, bearing frame, m.
    pub xi: f64,
    /// See `xi`, m.
    pub yi: f64,
    /// Journal centre at the second end face, m.
    pub xj: f64,
    /// See `xj`, m.
    pub yj: f64,
    /// Minimum film thickness, m.
    pub h_min: f64,
    /// Larger end eccentricity ratio.
    pub eccentricity_max: f64,
    /// Film force (ideal joints: joint reaction) on the journal, x, N.
    pub wx: f64,
    /// Same, y, N.
    pub wy: f64,
    /// Friction torque about `+z`, N·m.
    pub mz: f64,
    /// Friction coefficient; `None` where infinite or undefined.
    pub friction_coefficient: Option<f64>,
    /// The lumped oil temperature (bearings with a lubricant only).
    pub thermal: Option<ThermalSample>,
    /// The film's own friction and flows (finite-film bearings with JFO cavitation only).
    pub film: Option<FilmSample>,
}

/// One output sample of a simulation (the columns of [`TimeSeries`]), handed to a
/// [`SampleObserver`] as it is taken.
#[derive(Clone, Copy, Debug)]
pub struct Sample<'a> {
    /// Sample time, s.
    pub t: f64,
    /// Centre of mass, global x, m.
    pub x_g: f64,
    /// Centre of mass, global y, m.
    pub y_g: f64,
    /// Global `z` component of the angular velocity, rad/s.
    pub spin: f64,
    /// Kinetic energy, J.
    pub kinetic_energy: f64,
    /// Work done on the rotor since `t = 0`, J.
    pub work: f64,
    /// Per bearing, in scene order.
    pub bearings: &'a [BearingSample],
}

/// Takes a simulation's samples as they are taken: the decimating store
/// ([`SeriesStore`], what [`simulate_batch`] returns), or a caller's running reductions
/// that keep only what they need ([`simulate_batch_observed`]).
pub trait SampleObserver: Send {
    /// Whether [`SampleObserver::take_series`] returns the samples (then the constant
    /// friction check reads them; otherwise it runs as the samples come).
    const STORES_SERIES: bool = false;
    /// One sample, in time order.
    fn observe(&mut self, sample: &Sample<'_>);
    /// The stored samples, taken (empty for an observer that stores none).
    fn take_series(&mut self) -> TimeSeries {
        TimeSeries::default()
    }
}

/// The decimating store of one simulation: at most `cap` samples (see [`TimeSeries`]).
#[derive(Clone, Debug)]
pub struct SeriesStore {
    kept: StagedSeries,
    decimator: Decimator,
    cap: usize,
    /// Samples the columns are sized for at the first sample (0: grown as they come).
    reserve: usize,
}

impl SeriesStore {
    /// A store keeping at most `cap` samples (rounded up to an even number, at least 2).
    pub fn new(cap: usize) -> Self {
        SeriesStore {
            kept: StagedSeries::default(),
            decimator: Decimator::default(),
            // Even, so a thinned store's last sample stays on the doubled stride.
            cap: (cap.max(2) + 1) & !1,
            reserve: 0,
        }
    }

    /// [`SeriesStore::new`] for a run of `samples` sample times
    /// ([`crate::integrate::sample_count`]): the columns are sized once, at the first
    /// sample, for all of them (at most the cap, plus the provisional latest sample a
    /// thinned store keeps beside it), instead of doubling and copying as they fill
    /// (with the samples' spin taken from the film pass, spin256 ~4 % faster; issue 28's
    /// fifteenth pass). The memory is the cap's, which the run's budget already allows.
    pub fn for_run(cap: usize, samples: usize) -> Self {
        let mut s = Self::new(cap);
        s.reserve = samples.min(s.cap + 1);
        s
    }
}

impl SampleObserver for SeriesStore {
    const STORES_SERIES: bool = true;

    fn observe(&mut self, x: &Sample<'_>) {
        if self.reserve > 0 {
            let n = std::mem::take(&mut self.reserve);
            let s = &mut self.kept.series;
            s.bearings = vec![BearingSeries::default(); x.bearings.len()];
            s.columns(|v| v.reserve_exact(n), |v| v.reserve_exact(n));
        }
        self.decimator.before_push(&mut self.kept);
        self.kept.stage(x);
        self.decimator.after_push(&mut self.kept, self.cap);
    }

    fn take_series(&mut self) -> TimeSeries {
        self.kept.flush();
        std::mem::take(&mut self.kept.series)
    }
}

/// Samples staged in rows before they go to [`TimeSeries`]' columns, this many at a time.
/// A lockstep batch takes one sample of each of its variants in turn, so a sample pushed
/// straight into its ~26 columns touched ~26 pages, each last touched a whole round of
/// variants earlier: with 256 variants, 7 680 pages in turn, far more than the TLB holds
/// (`benches/sample_store.rs`: 343 ns a sample at 256 variants against 152 at 32). Staged,
/// a sample is written to one short row and each column takes 16 samples at once (93 and
/// 74 ns; issue 28, sixteenth pass: spin256 ~5 % faster). The rows add `16 x 8 x`
/// [`numbers_per_sample`] bytes a variant: within the slack
/// [`crate::budget::BYTES_PER_SAMPLED_NUMBER`] allows over the 8 bytes a number, as the cap
/// is at least [`crate::budget::MIN_SAMPLE_CAP`].
const STAGE_ROWS: usize = 16;

/// A [`TimeSeries`] with up to [`STAGE_ROWS`] of its latest samples still in rows.
#[derive(Clone, Debug, Default)]
struct StagedSeries {
    series: TimeSeries,
    /// Staged samples, `width` numbers a row: `t, x_g, y_g, spin, kinetic_energy, work`,
    /// then per bearing `xi, yi, xj, yj, h_min, eccentricity_max, wx, wy, mz`, its five
    /// thermal values where `shape` has them and its four film values where it has them
    /// (the order of [`TimeSeries::columns`]).
    rows: Vec<f64>,
    /// Staged friction coefficients, one a bearing a row.
    friction: Vec<Option<f64>>,
    /// Per bearing of the staged rows: (a thermal sample, a film sample).
    shape: Vec<(bool, bool)>,
    /// Numbers a staged row.
    width: usize,
    /// Staged rows.
    staged: usize,
}

impl StagedSeries {
    /// Stages sample `x` after the staged ones (a sample of another shape first flushes
    /// them).
    fn stage(&mut self, x: &Sample<'_>) {
        let same = self.shape.len() == x.bearings.len()
            && self
                .shape
                .iter()
                .zip(x.bearings)
                .all(|(&(th, fl), b)| th == b.thermal.is_some() && fl == b.film.is_some());
        if !same {
            self.flush();
            self.shape.clear();
            self.shape.extend(
                x.bearings
                    .iter()
                    .map(|b| (b.thermal.is_some(), b.film.is_some())),
            );
            self.width = 6 + self
                .shape
                .iter()
                .map(|&(th, fl)| 9 + 5 * usize::from(th) + 4 * usize::from(fl))
                .sum::<usize>();
        }
        let r = &mut self.rows;
        r.extend_from_slice(&[x.t, x.x_g, x.y_g, x.spin, x.kinetic_energy, x.work]);
        for b in x.bearings {
            r.extend_from_slice(&[
                b.xi,
                b.yi,
                b.xj,
                b.yj,
                b.h_min,
                b.eccentricity_max,
                b.wx,
                b.wy,
                b.mz,
            ]);
            if let Some(t) = b.thermal {
                r.extend_from_slice(&[
                    t.temperature_c,
                    t.viscosity_pa_s,
                    t.power_w,
                    t.heat_to_flow_w,
                    t.heat_to_housing_w,
                ]);
            }
            if let Some(f) = b.film {
                r.extend_from_slice(&[
                    f.friction_torque_nm,
                    f.power_loss_w,
                    f.side_flow_m3_per_s,
                    f.inlet_flow_m3_per_s,
                ]);
            }
            self.friction.push(b.friction_coefficient);
        }
        self.staged += 1;
        if self.staged >= STAGE_ROWS {
            self.flush();
        }
    }

    /// Moves the staged samples into the columns, in order: the same columns as pushing
    /// each sample in turn.
    fn flush(&mut self) {
        if self.staged == 0 {
            return;
        }
        let (w, nb) = (self.width, self.shape.len());
        let rows = &self.rows[..self.staged * w];
        // Column `c` of the rows onto `v`, then the next column.
        let mut c = 0;
        let mut col = |v: &mut Vec<f64>| {
            v.extend(rows.chunks_exact(w).map(|r| r[c]));
            c += 1;
        };
        let s = &mut self.series;
        s.head_columns().into_iter().for_each(&mut col);
        if s.bearings.len() != nb {
            s.bearings = vec![BearingSeries::default(); nb];
        }
        for (b, bs) in s.bearings.iter_mut().enumerate() {
            bs.plain_columns().into_iter().for_each(&mut col);
            bs.friction_coefficient
                .extend(self.friction.chunks_exact(nb).map(|f| f[b]));
            let (th, fl) = self.shape[b];
            if th {
                let t = bs.thermal.get_or_insert_with(ThermalSeries::default);
                t.columns_mut().into_iter().for_each(&mut col);
            }
            if fl {
                let f = bs.film.get_or_insert_with(FilmSeries::default);
                f.columns_mut().into_iter().for_each(&mut col);
            }
        }
        debug_assert_eq!(c, w);
        self.rows.clear();
        self.friction.clear();
        self.staged = 0;
    }
}

impl Decimated for StagedSeries {
    fn kept(&self) -> usize {
        self.series.len() + self.staged
    }
    fn stride(&self) -> u64 {
        self.series.sample_stride
    }
    fn drop_last(&mut self) {
        if self.staged > 0 {
            self.staged -= 1;
            self.rows.truncate(self.staged * self.width);
            self.friction.truncate(self.staged * self.shape.len());
        } else {
            self.series.pop();
        }
    }
    fn thin(&mut self) -> bool {
        self.flush();
        self.series.thin()
    }
}

/// The constant-friction check run as the samples come (for observers that store
/// none): the same numbers as [`friction_deviation`] on every sample.
#[derive(Clone, Debug, Default)]
struct FrictionWatch {
    /// Each bearing's coefficient at the first sample at or after the settling time
    /// (`None` inside: undefined there, the bearing is skipped); `None` before it.
    start: Option<Vec<Option<f64>>>,
    /// Largest relative deviation so far.
    dev: Option<f64>,
}

impl FrictionWatch {
    fn observe(&mut self, settle: f64, x: &Sample<'_>) {
        if self.start.is_none() {
            if x.t < settle {
                return;
            }
            self.start = Some(x.bearings.iter().map(|b| b.friction_coefficient).collect());
        }
        let Some(start) = &self.start else { return };
        for (f0, b) in start.iter().zip(x.bearings) {
            let (Some(f0), Some(f)) = (*f0, b.friction_coefficient) else {
                continue;
            };
            let d = if f0 != 0.0 {
                ((f - f0) / f0).abs()
            } else {
                (f - f0).abs()
            };
            self.dev = Some(self.dev.map_or(d, |m: f64| m.max(d)));
        }
    }
}

/// Counters of one simulation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SimStats {
    /// Accepted steps.
    pub steps: u64,
    /// Rejected attempts.
    pub rejected: u64,
    /// Right-hand-side evaluations (stages, Jacobian columns).
    pub rhs_evaluations: u64,
    /// Film-load evaluations for integration (`rhs_evaluations × bearings`; 0 for ideal joints).
    pub load_evaluations: u64,
    /// Film-load evaluations for the output samples.
    pub sample_load_evaluations: u64,
    /// Jacobians formed (radau5).
    pub jacobians: u64,
    /// LU factorisations (radau5).
    pub factorizations: u64,
    /// Wall time from the start of the variant's batch to its end, s.
    pub wall_time_s: f64,
    /// Method `"auto"`: the time, s, at which dopri5's stiffness test handed this variant
    /// to radau5 (absent: dopri5 ran throughout, or another method was asked for).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stiff_switch_s: Option<f64>,
}

/// The lumped oil temperature of one bearing over a run (bearings with a lubricant, docs/thermal.md
/// "Rotor scenes"): taken from every sample time, whatever the decimation or observer.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct OilTemperature {
    /// Index into the scene's bearings.
    pub bearing: usize,
    /// Oil supply temperature (the state's start), °C.
    pub supply_temperature_c: f64,
    /// Effective film temperature at the last sample, °C.
    pub final_temperature_c: f64,
    /// Highest effective film temperature over the run's samples, °C.
    pub max_temperature_c: f64,
    /// Time of that maximum (the first of equals), s.
    pub max_at_s: f64,
    /// Film friction power at the last sample, W.
    pub final_power_w: f64,
}

/// One simulation's outcome.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SimResult {
    /// The scene's name.
    pub name: String,
    /// `"bearing"` or `"ideal"`.
    pub model: ModelKind,
    /// Integration method.
    pub method: Method,
    /// How it ended.
    pub status: SimStatus,
    /// Samples at which a film first fell below the threshold (runs with a contact
    /// model continue through them; one entry each time a bearing enters breakdown).
    pub film_events: Vec<FilmEvent>,
    /// Samples up to the end (or the failure).
    pub samples: TimeSeries,
    /// Counters.
    pub stats: SimStats,
    /// Model reductions applied and declined (docs/cli.md "Model reductions").
    #[serde(default)]
    pub model_reductions: SimplificationReport,
    /// Per bearing with a lumped oil temperature: final and highest temperature (absent
    /// without a lubricant).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub oil_temperature: Vec<OilTemperature>,
}

/// The rotor batch as a lockstep system.
struct RotorBatch<'a, 'p, O: SampleObserver> {
    models: Vec<RotorModel>,
    params: Vec<BearingParams>,
    /// State dimension of this batch: [`DIM`] plus the lumped oil temperatures (every
    /// variant of a batch has the same count).
    dim: usize,
    /// Thermal batches: the bearings of one call, each at the viscosity of its lumped
    /// temperature (`params`, then one extra entry per repeated variant of the call).
    stage_params: Vec<BearingParams>,
    /// Thermal batches: the call in which each of `params` was last set in `stage_params`.
    stamp: Vec<u64>,
    /// Calls of [`RotorBatch::film_pass`] so far.
    calls: u64,
    /// Each variant's lumped oil temperatures over its samples so far.
    oil: Vec<Vec<OilTemperature>>,
    /// `params` validated once for the whole run, and which bearings' loads carry the
    /// film friction and flow outputs: none, as nothing here reads them (skipping them
    /// saves ~21 % of a run's instructions; BENCHMARKS.md "Issue 28, third pass").
    plan: BearingPlan,
    /// The plan of output samples: as `plan`, with the film outputs of JFO finite-film
    /// bearings (their samples carry the film's own friction and flows, issue 27).
    sample_plan: BearingPlan,
    offsets: Vec<usize>,
    evaluator: &'a mut LoadEvaluator,
    requests: Vec<LoadRequest>,
    results: Vec<LoadResult>,
    ends: Vec<EndKin>,
    /// The kinematics of each bearing-model entry of the last film pass, in entry order
    /// (the derivative that follows reads them instead of computing them again).
    kins: Vec<Kin>,
    ideal_loads: Vec<[f64; 4]>,
    /// Each simulation's sample observer (the store, or running reductions).
    observers: Vec<O>,
    /// One sample's bearing values (reused).
    row: Vec<BearingSample>,
    /// The constant-friction check of observers that store no samples.
    friction: Vec<FrictionWatch>,
    sample_evals: Vec<u64>,
    events: Vec<Vec<FilmEvent>>,
    below: Vec<bool>,
    scenes: Vec<usize>,
    names: Vec<String>,
    reductions: Vec<SimplificationSpec>,
    tallies: Vec<SimplificationTally>,
    held: Vec<bool>,
    method: Method,
    out: &'a mut [Option<SimResult>],
    keep_samples: bool,
    progress: &'a mut (dyn FnMut(usize, &SimResult, &mut O) + 'p),
    /// Once set, every evaluation faults at once so the batch ends within a few cheap
    /// rounds (the caller discards those results).
    cancel: Option<&'a AtomicBool>,
    /// Variants with a step accepted since the last film pass: their JFO bearings'
    /// film fractions are committed before the next one (issue 27).
    accepted: std::cell::RefCell<Vec<usize>>,
    /// Time of each request of a film pass.
    times: Vec<f64>,
    /// Per variant: its Jacobians come from its bearings' own inputs
    /// ([`BatchSystem::jacobians`], `super::jacobian`): a bearing-model variant of a batch
    /// without lumped temperatures whose bearings are all short films (no grooves, no
    /// arcs) and whose states the squeeze drop does not change.
    jac_ok: Vec<bool>,
    /// Per variant, the state of its last right-hand side (`DIM` numbers a variant;
    /// `base_set` once there is one) and per bearing (as `offsets`) the loads there
    /// (`None` where they failed): a Jacobian at that state reuses them, whatever calls
    /// came between (the integrator's Newton iterate a Jacobian is formed at, issue 28's
    /// sixteenth pass).
    base_ys: Vec<f64>,
    base_set: Vec<bool>,
    base_loads: Vec<Option<[f64; 4]>>,
    /// The probes of one [`BatchSystem::jacobians`] call: requests, results, each
    /// bearing's probes and base loads (or the request that evaluates them), and each
    /// variant's `(entry, first bearing)` in them.
    jac_requests: Vec<LoadRequest>,
    jac_results: Vec<LoadResult>,
    jac_probes: Vec<super::jacobian::Probes>,
    jac_base: Vec<Result<[f64; 4], usize>>,
    jac_vars: Vec<(usize, usize)>,
    jac_film: Vec<[[f64; 8]; 4]>,
    jac_l0: Vec<[f64; 4]>,
}

impl<O: SampleObserver> RotorBatch<'_, '_, O> {
    /// Film loads of every bearing-model entry, in one evaluator call.
    /// `ts`: the entries' times; `stages`: integrator stages (JFO film fractions become
    /// commit candidates) or output samples.
    fn film_pass(&mut self, ids: &[usize], ts: &[f64], ys: &[f64], stages: bool) {
        // Accepted steps since the last pass: commit their bearings' film fractions (the
        // last stage evaluated, the step's end for dopri5).
        for id in self.accepted.get_mut().drain(..) {
            for b in 0..self.models[id].bearings.len() {
                self.evaluator
                    .commit_film_history((self.offsets[id] + b) as u32);
            }
        }
        self.requests.clear();
        self.ends.clear();
        self.kins.clear();
        let d = self.dim;
        let thermal = d > DIM;
        self.calls += 1;
        if thermal {
            self.stage_params.truncate(self.params.len());
        }
        self.times.clear();
        for (k, &id) in ids.iter().enumerate() {
            let m = &self.models[id];
            if m.kind != ModelKind::Bearing {
                continue;
            }
            let y = &ys[k * d..(k + 1) * d];
            // Kept for the derivative that follows and read from its place in `kins` (a
            // local pushed after the loop was copied once more: 0.8 M of grid9's
            // instructions, issue 28's thirteenth pass).
            self.kins.push(m.kin(y));
            let kin = self.kins.last().expect("just pushed");
            for (b, geom) in m.bearings.iter().enumerate() {
                let e = m.end_kin(kin, geom);
                let mut state = m.bearing_state(kin, &e);
                self.tallies[id].observe(&self.reductions[id], &geom.params, &mut state);
                let mut index = self.offsets[id] + b;
                if let (Some(j), Some(lub), Some(supply)) = (
                    geom.thermal,
                    geom.params.lubricant,
                    geom.params.supply_temperature,
                ) {
                    // The film at the viscosity of this entry's lumped temperature; a
                    // variant's first entry of the call keeps its own slot (stable
                    // warm-start keys of the finite film), repeats get extra ones.
                    let mu = lub.dynamic_viscosity(supply + y[DIM + j]);
                    if self.stamp[index] == self.calls {
                        let mut p = self.params[index];
                        p.viscosity = mu;
                        self.stage_params.push(p);
                        index = self.stage_params.len() - 1;
                    } else {
                        self.stamp[index] = self.calls;
                        self.stage_params[index].viscosity = mu;
                    }
                }
                self.requests.push(LoadRequest {
                    bearing: index as u32,
                    state,
                });
                self.times.push(ts[k]);
                self.ends.push(e);
            }
        }
        self.results.clear();
        if !self.requests.is_empty() {
            self.evaluator.set_times(&self.times, stages);
            if thermal {
                // Thermal batches: the viscosity follows each entry's lumped temperature
                // and the heat input is the film's own friction power, so these calls
                // validate their (changing) bearings and fill the film outputs.
                self.evaluator
                    .evaluate(&self.stage_params, &self.requests, &mut self.results);
            } else {
                let plan = if stages {
                    &self.plan
                } else {
                    &self.sample_plan
                };
                self.evaluator.evaluate_planned(
                    &self.params,
                    plan,
                    &self.requests,
                    &mut self.results,
                );
            }
        }
    }

    /// Keeps each bearing-model variant's state of this right-hand-side call and its
    /// bearings' loads (`results` of the film pass just made) as its Jacobian base.
    fn keep_bases(&mut self, ids: &[usize], ys: &[f64]) {
        if self.dim != DIM {
            // Lumped temperatures: no Jacobian from the bearings (`jacobians`).
            return;
        }
        let mut cursor = 0;
        for (k, &id) in ids.iter().enumerate() {
            let m = &self.models[id];
            if m.kind != ModelKind::Bearing {
                continue;
            }
            let nb = m.bearings.len();
            if self.jac_ok[id] {
                self.base_set[id] = true;
                // Sized copies (no `memcpy` call a variant).
                let dst: &mut [f64; DIM] = (&mut self.base_ys[id * DIM..(id + 1) * DIM])
                    .try_into()
                    .expect("DIM numbers a variant");
                *dst = ys[k * DIM..(k + 1) * DIM].try_into().expect("DIM numbers");
                for b in 0..nb {
                    self.base_loads[self.offsets[id] + b] = self.results[cursor + b]
                        .as_ref()
                        .ok()
                        .map(super::jacobian::load_vector);
                }
            }
            cursor += nb;
        }
    }

    /// The lumped temperature of thermal bearing `geom` in state `y` and its heat flows
    /// with film loads `l`: `(sample, dθ/dt)`. `None` for a bearing without one.
    fn thermal_of(
        geom: &super::model::BearingGeom,
        y: &[f64],
        l: &crate::bearing::Loads,
    ) -> Option<(ThermalSample, f64)> {
        let (j, lub, supply) = (
            geom.thermal?,
            geom.params.lubricant?,
            geom.params.supply_temperature?,
        );
        let th = &geom.params.thermal;
        let theta = y[DIM + j];
        let p = l.film.power_loss_w;
        let (to_flow, to_housing) = crate::bearing::thermal::lumped_heat_out(
            &lub,
            supply,
            th,
            theta,
            l.film.side_flow_m3_per_s,
        );
        Some((
            ThermalSample {
                temperature_c: supply + theta,
                viscosity_pa_s: lub.dynamic_viscosity(supply + theta),
                power_w: p,
                heat_to_flow_w: to_flow,
                heat_to_housing_w: to_housing,
            },
            (p - to_flow - to_housing) / th.thermal_capacity,
        ))
    }
}

/// A finite-film bearing with JFO cavitation: its samples carry the film's own friction
/// and flows ([`FilmSeries`]).
fn is_jfo(p: &BearingParams) -> bool {
    p.model == crate::bearing::FilmModel::Finite
        && p.finite.cavitation == crate::bearing::finite::Cavitation::Jfo
}

fn fault_of(bearing: usize, f: &StateFault) -> RotorFault {
    match f {
        StateFault::ThroughWall { ratio, .. } => RotorFault::ThroughWall {
            bearing,
            ratio: *ratio,
        },
        other => RotorFault::Load {
            bearing,
            reason: other.to_string(),
        },
    }
}

/// The rotor's positions whose rate is a state component: `(x, y)` of `G` and `v_G`.
const KINEMATIC: [(usize, usize); 2] = [
    (super::model::X, super::model::VX),
    (super::model::X + 1, super::model::VX + 1),
];

impl<O: SampleObserver> BatchSystem for RotorBatch<'_, '_, O> {
    type Fault = RotorFault;

    fn dim(&self) -> usize {
        self.dim
    }

    fn jacobian_dim(&self) -> usize {
        // Thermal batches keep the work quadrature at its place (component 11) with the
        // temperatures after it, so `f` depends on all components but that one: it gets
        // a Jacobian column (exactly zero) rather than a different layout.
        if self.dim > DIM {
            self.dim
        } else {
            JAC_DIM
        }
    }

    fn kinematic_pairs(&self) -> &[(usize, usize)] {
        // `Ġ = v_G` (both models: `rigid_derivative`, `ideal_derivative`).
        &KINEMATIC
    }

    fn scale_invariant_block(&self) -> Option<(usize, usize)> {
        // The attitude quaternion: loads, torques and the kinematics read it normalised
        // (`quat_matrix`), its rate `½ q ⊗ ω` is linear in it.
        Some((super::model::Q, 4))
    }

    fn has_jacobians(&self) -> bool {
        self.dim == DIM && self.jac_ok.iter().any(|&ok| ok)
    }

    fn jacobians(
        &mut self,
        ids: &[usize],
        _ts: &[f64],
        ys: &[f64],
        _f0s: &[f64],
        jac: &mut [f64],
        cost: &mut [Option<u64>],
    ) {
        use super::jacobian::{film_jacobian, load_vector, probes};
        if self.dim != DIM || self.cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
            return;
        }
        let d = DIM;
        self.jac_requests.clear();
        self.jac_probes.clear();
        self.jac_base.clear();
        self.jac_vars.clear();
        for (k, &id) in ids.iter().enumerate() {
            if !self.jac_ok[id] {
                continue;
            }
            let m = &self.models[id];
            let y = &ys[k * d..(k + 1) * d];
            let cached = self.base_set[id]
                && self.base_ys[id * d..(id + 1) * d]
                    .iter()
                    .zip(y)
                    .all(|(a, b)| a.to_bits() == b.to_bits());
            let kin = m.kin(y);
            let start = self.jac_probes.len();
            let req_start = self.jac_requests.len();
            let mut ok = true;
            for (b, geom) in m.bearings.iter().enumerate() {
                let e = m.end_kin(&kin, geom);
                let s0 = m.bearing_state(&kin, &e);
                let Some(pr) = probes(&s0, geom.params.clearance) else {
                    ok = false;
                    break;
                };
                let bearing = (self.offsets[id] + b) as u32;
                let base = match cached.then(|| self.base_loads[bearing as usize]) {
                    Some(Some(l)) => Ok(l),
                    _ => {
                        self.jac_requests.push(LoadRequest { bearing, state: s0 });
                        Err(self.jac_requests.len() - 1)
                    }
                };
                self.jac_base.push(base);
                for state in pr.states {
                    self.jac_requests.push(LoadRequest { bearing, state });
                }
                self.jac_probes.push(pr);
            }
            if ok {
                self.jac_vars.push((k, start));
            } else {
                // Leave this variant to radau5's columns; drop what it pushed.
                self.jac_probes.truncate(start);
                self.jac_base.truncate(start);
                self.jac_requests.truncate(req_start);
            }
        }
        if self.jac_requests.is_empty() {
            return;
        }
        self.evaluator.evaluate_planned(
            &self.params,
            &self.plan,
            &self.jac_requests,
            &mut self.jac_results,
        );
        let mut cursor = 0;
        let mut col = [0.0; DIM];
        let mut f_base = [0.0; DIM];
        for &(k, start) in &self.jac_vars {
            let id = ids[k];
            let m = &self.models[id];
            let nb = m.bearings.len();
            self.jac_film.clear();
            self.jac_l0.clear();
            let mut ok = true;
            let mut evaluated_base = false;
            for b in 0..nb {
                let l0 = match self.jac_base[start + b] {
                    Ok(l) => Some(l),
                    Err(_) => {
                        evaluated_base = true;
                        cursor += 1;
                        self.jac_results[cursor - 1].as_ref().ok().map(load_vector)
                    }
                };
                let mut lk = [[0.0; 4]; 6];
                for (n, v) in lk.iter_mut().enumerate() {
                    match &self.jac_results[cursor + n] {
                        Ok(l) => *v = load_vector(l),
                        Err(_) => ok = false,
                    }
                }
                cursor += 6;
                match l0 {
                    Some(l0) if ok => {
                        self.jac_film
                            .push(film_jacobian(&self.jac_probes[start + b], l0, &lk));
                        self.jac_l0.push(l0);
                    }
                    _ => ok = false,
                }
            }
            if !ok {
                continue;
            }
            let pr = &self.jac_probes[start..start + nb];
            let y = &ys[k * d..(k + 1) * d];
            linear_derivative(m, y, pr, &self.jac_film, &self.jac_l0, &mut f_base);
            let out = &mut jac[k * d * d..(k + 1) * d * d];
            let mut yc = [0.0; DIM];
            for c in 0..JAC_DIM {
                yc.copy_from_slice(y);
                // radau5's forward-difference increment.
                yc[c] += f64::EPSILON.sqrt() * yc[c].abs().max(m.scales[c]);
                let del = yc[c] - y[c];
                linear_derivative(m, &yc, pr, &self.jac_film, &self.jac_l0, &mut col);
                for p in 0..d {
                    out[p * d + c] = (col[p] - f_base[p]) / del;
                }
            }
            cost[k] = Some(6 + u64::from(evaluated_base));
        }
    }

    fn scales(&self, id: usize, out: &mut [f64]) {
        out[..DIM].copy_from_slice(&self.models[id].scales);
        // Lumped temperatures: unit 1 K (atol × 1 K absolute, rtol of the rise).
        out[DIM..].fill(1.0);
    }

    fn stiffness_scales(&self, id: usize, out: &mut [f64]) {
        out[..DIM].copy_from_slice(&self.models[id].natural_scales);
        out[DIM..].fill(1.0);
    }

    fn eval(
        &mut self,
        ids: &[usize],
        ts: &[f64],
        ys: &[f64],
        dys: &mut [f64],
        faults: &mut [Option<RotorFault>],
    ) {
        if self.cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
            dys.fill(0.0);
            faults.fill(Some(RotorFault::Load {
                bearing: 0,
                reason: "cancelled".into(),
            }));
            return;
        }
        self.film_pass(ids, ts, ys, true);
        if self.has_jacobians() {
            // A Jacobian at one of these states reuses their loads (`jacobians`).
            self.keep_bases(ids, ys);
        }
        let mut cursor = 0;
        // Index into `kins` (bearing-model entries only).
        let mut entry = 0;
        let d = self.dim;
        for (k, &id) in ids.iter().enumerate() {
            let m = &self.models[id];
            let y = &ys[k * d..(k + 1) * d];
            let dy = &mut dys[k * d..(k + 1) * d];
            if m.kind == ModelKind::Ideal {
                m.ideal_derivative(y, dy, &mut self.ideal_loads);
            } else {
                // The film pass's kinematics of this entry (the same state).
                let kin = &self.kins[entry];
                entry += 1;
                let mut f = [0.0; 2];
                let mut tau = V3::zeros();
                let mut power = 0.0;
                let mut fault = None;
                for (b, geom) in m.bearings.iter().enumerate() {
                    let e = &self.ends[cursor];
                    let res = &self.results[cursor];
                    cursor += 1;
                    let l = match res {
                        Ok(l) => l,
                        Err(sf) => {
                            fault.get_or_insert(fault_of(b, sf));
                            continue;
                        }
                    };
                    if let Some((x, rate)) = Self::thermal_of(geom, y, l) {
                        let rise = x.temperature_c - geom.params.supply_temperature.unwrap_or(0.0);
                        if rise.abs() > crate::bearing::thermal::MAX_LUMPED_RISE_K {
                            // Runaway: the viscosity law means nothing there.
                            fault.get_or_insert(RotorFault::Load {
                                bearing: b,
                                reason: format!(
                                    "lumped oil temperature {:.1} °C is more than {} K from the supply temperature (thermal runaway: more friction power than the side flow and housing remove)",
                                    x.temperature_c,
                                    crate::bearing::thermal::MAX_LUMPED_RISE_K
                                ),
                            });
                        }
                        dy[DIM + geom.thermal.unwrap_or(0)] = rate;
                    }
                    let (mut fi, mut fj) = l.end_forces(geom.params.length);
                    if l.h_min < m.threshold {
                        match m.contact {
                            None => {
                                fault.get_or_insert(RotorFault::FilmBreakdown {
                                    bearing: b,
                                    h_min: l.h_min,
                                });
                            }
                            Some(kc) => {
                                let st = &self.requests[cursor - 1].state;
                                let d = geom.params.clearance;
                                add_contact_forces(st, e, d, m.threshold, kc, &mut fi, &mut fj);
                            }
                        }
                    }
                    add_bearing_loads(
                        e,
                        fi,
                        fj,
                        l.mz,
                        kin.w_global[2],
                        &mut f,
                        &mut tau,
                        &mut power,
                    );
                }
                if let Some(fl) = fault {
                    faults[k] = Some(fl);
                    dy.fill(0.0);
                    continue;
                }
                m.rigid_derivative(y, kin, f, tau, power, &mut dy[..DIM]);
            }
            if !dy.iter().all(|v| v.is_finite()) {
                faults[k] = Some(RotorFault::NonFinite);
                dy.fill(0.0);
            }
        }
    }

    fn project(&self, id: usize, y: &mut [f64]) {
        // Called once per accepted step (issue 27: commits the JFO film history).
        self.accepted.borrow_mut().push(id);
        let q = &mut y[super::model::Q..super::model::Q + 4];
        let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
        if n > 0.0 && n.is_finite() {
            q.iter_mut().for_each(|v| *v /= n);
        }
    }

    fn record(&mut self, ids: &[usize], ts: &[f64], ys: &[f64]) {
        self.film_pass(ids, ts, ys, false);
        let mut cursor = 0;
        // The film pass's kinematics of each film-bearing variant, in order (the same
        // state's: not worked out again, ~1 % of a rotor run).
        let mut kin_at = 0;
        let mut scratch = [0.0; DIM];
        let d = self.dim;
        for (k, &id) in ids.iter().enumerate() {
            let m = &self.models[id];
            let y = &ys[k * d..(k + 1) * d];
            let g = m.g_position(y);
            let spin = if m.kind == ModelKind::Bearing {
                kin_at += 1;
                self.kins[kin_at - 1].w_global[2]
            } else {
                m.kin(y).w_global[2]
            };
            self.row.clear();
            if m.kind == ModelKind::Ideal {
                m.ideal_derivative(y, &mut scratch, &mut self.ideal_loads);
                for (b, geom) in m.bearings.iter().enumerate() {
                    let l = self.ideal_loads[b];
                    self.row.push(BearingSample {
                        h_min: geom.params.clearance,
                        wx: l[0],
                        wy: l[1],
                        mz: l[2],
                        friction_coefficient: l[3].is_finite().then_some(l[3]),
                        ..BearingSample::default()
                    });
                }
            } else {
                self.sample_evals[id] += m.bearings.len() as u64;
                for (b, geom) in m.bearings.iter().enumerate() {
                    let st = self.requests[cursor].state;
                    let res = &self.results[cursor];
                    cursor += 1;
                    let d = geom.params.clearance;
                    // The larger end offset once for both outputs (two libm `hypot`s a
                    // sample and bearing before, ~1.5 % of a rotor run; issue 28,
                    // fifteenth pass): `eccentricity_max` within 2 ulp of theirs.
                    let far = st.far_end_offset();
                    let h = d - far;
                    let below = h < m.threshold;
                    let flag = &mut self.below[self.offsets[id] + b];
                    if below && !*flag {
                        self.events[id].push(FilmEvent {
                            time: ts[k],
                            bearing: b,
                            h_min: h,
                        });
                    }
                    *flag = below;
                    let (wx, wy, mz, friction_coefficient) = match res {
                        Ok(l) => (l.wx, l.wy, l.mz, l.friction_coefficient),
                        // A sample between accepted steps outside the film's domain:
                        // no loads (never NaN), friction unknown.
                        Err(_) => (0.0, 0.0, 0.0, None),
                    };
                    // The lumped temperature; its heat flows zero where the film has
                    // no loads (as the loads above).
                    let thermal = match res {
                        Ok(l) => Self::thermal_of(geom, y, l).map(|(s, _)| s),
                        Err(_) => Self::thermal_of(geom, y, &zero_loads()).map(|(s, _)| s),
                    };
                    self.row.push(BearingSample {
                        xi: st.xi,
                        yi: st.yi,
                        xj: st.xj,
                        yj: st.yj,
                        h_min: h,
                        eccentricity_max: far / d,
                        wx,
                        wy,
                        mz,
                        friction_coefficient,
                        thermal,
                        film: match res {
                            Ok(l) if is_jfo(&geom.params) => Some(FilmSample {
                                friction_torque_nm: l.film.friction_torque_nm,
                                power_loss_w: l.film.power_loss_w,
                                side_flow_m3_per_s: l.film.side_flow_m3_per_s,
                                inlet_flow_m3_per_s: l.film.inlet_flow_m3_per_s,
                            }),
                            _ => None,
                        },
                    });
                    if let (Some(x), Some(j)) = (thermal, geom.thermal) {
                        let oil = &mut self.oil[id];
                        if oil.len() <= j {
                            oil.push(OilTemperature {
                                bearing: b,
                                supply_temperature_c: geom.params.supply_temperature.unwrap_or(0.0),
                                final_temperature_c: x.temperature_c,
                                max_temperature_c: x.temperature_c,
                                max_at_s: ts[k],
                                final_power_w: x.power_w,
                            });
                        }
                        let o = &mut oil[j];
                        o.final_temperature_c = x.temperature_c;
                        o.final_power_w = x.power_w;
                        if x.temperature_c > o.max_temperature_c {
                            o.max_temperature_c = x.temperature_c;
                            o.max_at_s = ts[k];
                        }
                    }
                }
            }
            let sample = Sample {
                t: ts[k],
                x_g: g[0],
                y_g: g[1],
                spin,
                kinetic_energy: m.kinetic_energy(y),
                work: y[WORK],
                bearings: &self.row,
            };
            let spec = &self.reductions[id];
            if !O::STORES_SERIES && spec.constant_friction.enabled && self.held[id] {
                self.friction[id].observe(spec.constant_friction.settle_time, &sample);
            }
            self.observers[id].observe(&sample);
        }
    }

    fn finished(&mut self, id: usize, status: &Status<RotorFault>, stats: &Stats) {
        let status = match status {
            Status::Running | Status::Finished => SimStatus::Finished,
            Status::Fault { time, fault } => match fault {
                RotorFault::FilmBreakdown { bearing, h_min } => SimStatus::FilmBreakdown {
                    time: *time,
                    bearing: *bearing,
                    h_min: *h_min,
                },
                RotorFault::ThroughWall { bearing, ratio } => SimStatus::ThroughWall {
                    time: *time,
                    bearing: *bearing,
                    eccentricity_ratio: *ratio,
                },
                RotorFault::NonFinite => SimStatus::NonFinite { time: *time },
                RotorFault::Load { bearing, reason } => SimStatus::LoadFailure {
                    time: *time,
                    bearing: *bearing,
                    reason: reason.clone(),
                },
            },
            Status::StepSizeTooSmall { time, step } => SimStatus::StepSizeTooSmall {
                time: *time,
                step: *step,
            },
            Status::NonFinite { time } => SimStatus::NonFinite { time: *time },
            Status::MaxSteps { time, steps } => SimStatus::MaxSteps {
                time: *time,
                steps: *steps,
            },
        };
        let m = &self.models[id];
        let loads_per_rhs = if m.kind == ModelKind::Bearing {
            m.bearings.len() as u64
        } else {
            0
        };
        let spec = &self.reductions[id];
        let samples = self.observers[id].take_series();
        let friction_dev = if !(spec.constant_friction.enabled && self.held[id]) {
            None
        } else if O::STORES_SERIES {
            friction_deviation(&samples, spec.constant_friction.settle_time)
        } else {
            self.friction[id].dev
        };
        let model_reductions = variant_report(
            spec,
            spec.is_full(),
            &self.tallies[id],
            self.held[id],
            friction_dev,
        );
        let result = SimResult {
            oil_temperature: std::mem::take(&mut self.oil[id]),
            name: self.names[id].clone(),
            model: m.kind,
            method: self.method,
            status,
            model_reductions,
            film_events: std::mem::take(&mut self.events[id]),
            samples,
            stats: SimStats {
                steps: stats.steps,
                rejected: stats.rejected,
                rhs_evaluations: stats.rhs_evaluations,
                load_evaluations: stats.rhs_evaluations * loads_per_rhs,
                sample_load_evaluations: self.sample_evals[id],
                jacobians: stats.jacobians,
                factorizations: stats.factorizations,
                wall_time_s: stats.wall_time_s,
                stiff_switch_s: stats.stiff_switch_time,
            },
        };
        (self.progress)(self.scenes[id], &result, &mut self.observers[id]);
        let slot = &mut self.out[self.scenes[id]];
        *slot = Some(if self.keep_samples {
            result
        } else {
            SimResult {
                samples: TimeSeries::default(),
                ..result
            }
        });
    }
}

/// Loads of no film (a sample outside the film's domain): zero power and flow.
fn zero_loads() -> crate::bearing::Loads {
    crate::bearing::Loads {
        wx: 0.0,
        wy: 0.0,
        mx: 0.0,
        my: 0.0,
        mz: 0.0,
        friction_coefficient: None,
        sommerfeld: None,
        h_min: 0.0,
        power_loss: 0.0,
        friction_model: Default::default(),
        film: Default::default(),
    }
}

/// Largest relative deviation of any bearing's friction coefficient from its value at
/// the first sample at or after `settle` s (what a coefficient frozen there would cost);
/// `None` without such samples.
fn friction_deviation(series: &TimeSeries, settle: f64) -> Option<f64> {
    let start = series.t.iter().position(|&t| t >= settle)?;
    let mut dev: Option<f64> = None;
    for b in &series.bearings {
        let Some(Some(f0)) = b.friction_coefficient.get(start).copied() else {
            continue;
        };
        for f in b.friction_coefficient[start..].iter().flatten() {
            let d = if f0 != 0.0 {
                ((f - f0) / f0).abs()
            } else {
                (f - f0).abs()
            };
            dev = Some(dev.map_or(d, |m: f64| m.max(d)));
        }
    }
    dev
}

/// Integrator settings of a scene.
pub fn settings_of(scene: &Scene) -> Settings {
    let g = &scene.integrator;
    Settings {
        t_end: g.t_end,
        sample_interval: g.sample_interval,
        rtol: g.rtol,
        atol: g.atol,
        fixed_step: g.fixed_step,
        initial_step: None,
        max_step: g.max_step,
        max_steps: g.max_steps,
    }
}

/// Simulates every scene. Scenes sharing an integration method advance in one lockstep
/// batch whose stages each make one `evaluator.evaluate` call for all active variants'
/// bearings; a variant that fails (film breakdown, journal through the wall, step-size
/// collapse, ...) ends with its status and samples up to that time while the others go
/// on. `progress(scene_index, &result)` is called as each variant ends (invalid scenes
/// at once), so results can be streamed. Returns one result per scene, in input order.
pub fn simulate_batch(
    scenes: &[Scene],
    evaluator: &mut LoadEvaluator,
    progress: &mut dyn FnMut(usize, &SimResult),
) -> Vec<SimResult> {
    let budget = crate::budget::MemoryBudget::default();
    let cap = sample_cap(scenes, budget);
    stored(scenes, evaluator, progress, true, None, cap, budget)
}

/// Numbers kept per sample of `scene` (t, x_g, y_g, spin, energy, work; ten per bearing,
/// five more per bearing with a lumped oil temperature, four more per JFO finite-film
/// bearing: its film friction and flows).
pub fn numbers_per_sample(scene: &Scene) -> usize {
    let jfo = if scene.model == ModelKind::Bearing {
        scene
            .bearings
            .iter()
            .filter(|b| {
                b.model == crate::bearing::FilmModel::Finite
                    && b.finite.cavitation == crate::bearing::finite::Cavitation::Jfo
            })
            .count()
    } else {
        0
    };
    6 + 10 * scene.bearings.len() + 5 * thermal_bearings(scene) + 4 * jfo
}

/// Bearings of `scene` with a lumped oil temperature state (a lubricant, bearing model):
/// the count [`RotorModel::thermal_count`] gives once compiled.
fn thermal_bearings(scene: &Scene) -> usize {
    if scene.model != ModelKind::Bearing {
        return 0;
    }
    scene
        .bearings
        .iter()
        .filter(|b| b.lubricant.is_some() && b.supply_temperature.is_some())
        .count()
}

/// The per-simulation sample cap when all of `scenes` are in flight at once, from the
/// memory budget `budget` ([`crate::budget::MemoryBudget::sample_cap`]).
pub fn sample_cap(scenes: &[Scene], budget: crate::budget::MemoryBudget) -> usize {
    let numbers = scenes.iter().map(numbers_per_sample).max().unwrap_or(6);
    budget.sample_cap(scenes.len(), numbers)
}

/// [`simulate_batch`] keeping at most `cap` samples per simulation (rounded up to an
/// even number, at least 2): the decimating store of [`TimeSeries`]. Each scene is
/// validated within the run's memory budget `budget` (the one `cap` comes from).
pub fn simulate_batch_capped(
    scenes: &[Scene],
    evaluator: &mut LoadEvaluator,
    progress: &mut dyn FnMut(usize, &SimResult),
    cap: usize,
    budget: crate::budget::MemoryBudget,
) -> Vec<SimResult> {
    stored(scenes, evaluator, progress, true, None, cap, budget)
}

/// [`simulate_batch`] for large sweeps: each result's samples go to `progress` only and
/// are dropped after it returns, so memory holds the running variants' series alone. The
/// returned results carry status, events and counters with empty `samples`.
pub fn simulate_batch_streaming(
    scenes: &[Scene],
    evaluator: &mut LoadEvaluator,
    progress: &mut dyn FnMut(usize, &SimResult),
) -> Vec<SimResult> {
    let budget = crate::budget::MemoryBudget::default();
    let cap = sample_cap(scenes, budget);
    stored(scenes, evaluator, progress, false, None, cap, budget)
}

/// [`simulate_batch_streaming`] that stops once `cancel` is set: the variants still
/// running end at once with a `cancelled` load failure (to be discarded by the caller).
/// At most `cap` samples are kept per simulation (the caller knows how many variants are
/// in flight across threads: [`crate::budget::MemoryBudget::sample_cap`]); each scene is
/// validated within the run's memory budget `budget`.
pub fn simulate_batch_streaming_cancellable(
    scenes: &[Scene],
    evaluator: &mut LoadEvaluator,
    progress: &mut dyn FnMut(usize, &SimResult),
    cancel: &AtomicBool,
    cap: usize,
    budget: crate::budget::MemoryBudget,
) -> Vec<SimResult> {
    stored(
        scenes,
        evaluator,
        progress,
        false,
        Some(cancel),
        cap,
        budget,
    )
}

/// Simulates every scene like [`simulate_batch_streaming_cancellable`], handing each
/// sample to the scene's observer (`observers[i]` for `scenes[i]`) instead of storing
/// it: memory holds what the observers keep. `progress(i, &result, &mut observer)` is
/// called as each variant ends, its `samples` empty. Each scene is validated within the
/// run's memory budget `budget`.
pub fn simulate_batch_observed<O: SampleObserver>(
    scenes: &[Scene],
    evaluator: &mut LoadEvaluator,
    observers: Vec<O>,
    progress: &mut dyn FnMut(usize, &SimResult, &mut O),
    cancel: Option<&AtomicBool>,
    budget: crate::budget::MemoryBudget,
) {
    simulate(
        scenes, evaluator, observers, progress, false, cancel, budget,
    );
}

/// The decimating store behind every [`SimResult`] with samples.
fn stored(
    scenes: &[Scene],
    evaluator: &mut LoadEvaluator,
    progress: &mut dyn FnMut(usize, &SimResult),
    keep_samples: bool,
    cancel: Option<&AtomicBool>,
    cap: usize,
    budget: crate::budget::MemoryBudget,
) -> Vec<SimResult> {
    let observers = scenes
        .iter()
        .map(|s| SeriesStore::for_run(cap, crate::integrate::sample_count(&settings_of(s))))
        .collect();
    simulate(
        scenes,
        evaluator,
        observers,
        &mut |i, r, _| progress(i, r),
        keep_samples,
        cancel,
        budget,
    )
}

/// Whether scene `scene` in a batch with `n_thermal` lumped temperatures gets its
/// Jacobians from its bearings' own inputs (`super::jacobian`): the bearing model,
/// short films without grooves or arcs (their loads homogeneous in the rates and
/// invariant under rotation about the bore axis), no lumped temperatures and no squeeze
/// drop (which changes the states the film sees).
fn jacobian_from_bearings(scene: &Scene, n_thermal: usize) -> bool {
    scene.model == ModelKind::Bearing
        && n_thermal == 0
        && !scene.reductions.squeeze_drop.enabled
        && scene.bearings.iter().all(|b| {
            let p = b.params();
            p.model == crate::bearing::FilmModel::Short
                && p.grooves.is_empty()
                && p.arcs.is_empty()
                && p.lubricant.is_none()
        })
}

/// Adds one bearing's end-point forces `fi`, `fj` (N) and friction torque `mz` (N·m) at
/// the end centres `e` to the rotor's total force `f`, torque about `G` `tau` and load
/// power `power` (`w_z`: the global spin rate).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn add_bearing_loads(
    e: &EndKin,
    fi: [f64; 2],
    fj: [f64; 2],
    mz: f64,
    w_z: f64,
    f: &mut [f64; 2],
    tau: &mut V3,
    power: &mut f64,
) {
    f[0] += fi[0] + fj[0];
    f[1] += fi[1] + fj[1];
    // Exact torque about G: end-point forces at the journal end centres.
    let ti = e.r_i.cross(&V3::new(fi[0], fi[1], 0.0));
    let tj = e.r_j.cross(&V3::new(fj[0], fj[1], 0.0));
    *tau += ti + tj;
    tau.z += mz;
    *power += fi[0] * e.v_i[0] + fi[1] * e.v_i[1] + fj[0] * e.v_j[0] + fj[1] * e.v_j[1] + mz * w_z;
}

/// The rigid-body derivative of model `m` in state `y` with each bearing's film loads
/// from the linear model about its probes' base (`pr`, `jf`, `l0`: `super::jacobian`);
/// kinematics, end forces, friction torque and contact exact.
fn linear_derivative(
    m: &RotorModel,
    y: &[f64],
    pr: &[super::jacobian::Probes],
    jf: &[[[f64; 8]; 4]],
    l0: &[[f64; 4]],
    dy: &mut [f64],
) {
    let kin = m.kin(y);
    let mut f = [0.0; 2];
    let mut tau = V3::zeros();
    let mut power = 0.0;
    for (b, geom) in m.bearings.iter().enumerate() {
        let e = m.end_kin(&kin, geom);
        let st = m.bearing_state(&kin, &e);
        let p = &geom.params;
        let l = super::jacobian::linear_loads(&pr[b], &jf[b], l0[b], &st, p.clearance);
        let (wx, wy, mx, my) = (l[0], l[1], l[2], l[3]);
        let fj0 = [my / p.length, -mx / p.length];
        let (mut fi, mut fj) = ([wx - fj0[0], wy - fj0[1]], fj0);
        let mz = crate::bearing::friction(p, crate::bearing::planar_length(wx, wy), st.omega).mz;
        if let Some(kc) = m.contact {
            if st.h_min(p.clearance) < m.threshold {
                add_contact_forces(&st, &e, p.clearance, m.threshold, kc, &mut fi, &mut fj);
            }
        }
        add_bearing_loads(
            &e,
            fi,
            fj,
            mz,
            kin.w_global[2],
            &mut f,
            &mut tau,
            &mut power,
        );
    }
    m.rigid_derivative(y, &kin, f, tau, power, &mut dy[..DIM]);
}

fn simulate<O: SampleObserver>(
    scenes: &[Scene],
    evaluator: &mut LoadEvaluator,
    observers: Vec<O>,
    progress: &mut dyn FnMut(usize, &SimResult, &mut O),
    keep_samples: bool,
    cancel: Option<&AtomicBool>,
    budget: crate::budget::MemoryBudget,
) -> Vec<SimResult> {
    let mut observers: Vec<Option<O>> = observers.into_iter().map(Some).collect();
    let mut out: Vec<Option<SimResult>> = vec![None; scenes.len()];
    // One lockstep batch per method and state dimension (the lumped oil temperatures of
    // thermal scenes add components; scenes without them keep the 12 of the rigid rotor).
    let mut groups: BTreeMap<(&'static str, usize), (Method, Vec<usize>)> = BTreeMap::new();
    for (i, s) in scenes.iter().enumerate() {
        // At the run's budget: a scene admitted under `--max-memory` is not failed here.
        match s.validate_within(budget) {
            Ok(()) => groups
                .entry((s.integrator.method.name(), thermal_bearings(s)))
                .or_insert((s.integrator.method, Vec::new()))
                .1
                .push(i),
            Err(SceneError { path, reason }) => {
                let r = SimResult {
                    name: s.name.clone(),
                    model: s.model,
                    method: s.integrator.method,
                    status: SimStatus::InvalidScene { path, reason },
                    film_events: Vec::new(),
                    samples: TimeSeries::default(),
                    stats: SimStats::default(),
                    model_reductions: SimplificationReport::default(),
                    oil_temperature: Vec::new(),
                };
                if let Some(o) = observers[i].as_mut() {
                    progress(i, &r, o);
                }
                out[i] = Some(r);
            }
        }
    }
    for ((_, n_thermal), (method, idx)) in groups {
        let models: Vec<RotorModel> = idx.iter().map(|&i| RotorModel::new(&scenes[i])).collect();
        let mut params = Vec::new();
        let mut offsets = Vec::new();
        let dim = DIM + n_thermal;
        let mut y0 = Vec::with_capacity(idx.len() * dim);
        for (m, &i) in models.iter().zip(&idx) {
            offsets.push(params.len());
            params.extend(m.bearings.iter().map(|b| b.params));
            y0.extend_from_slice(&m.initial_state(&scenes[i]));
            // The oil starts at its supply temperature (a rise of 0 K).
            y0.extend(std::iter::repeat_n(0.0, n_thermal));
        }
        let settings: Vec<Settings> = idx.iter().map(|&i| settings_of(&scenes[i])).collect();
        let n = idx.len();
        let n_bearings = params.len();
        let mut batch = RotorBatch {
            models,
            dim,
            stage_params: if n_thermal > 0 {
                params.clone()
            } else {
                Vec::new()
            },
            stamp: vec![0; params.len()],
            calls: 0,
            oil: vec![Vec::new(); n],
            plan: BearingPlan::new(&params, false),
            sample_plan: {
                let mut p = BearingPlan::new(&params, false);
                p.film_outputs = params.iter().map(is_jfo).collect();
                p
            },
            params,
            offsets,
            evaluator: &mut *evaluator,
            requests: Vec::new(),
            results: Vec::new(),
            ends: Vec::new(),
            kins: Vec::new(),
            ideal_loads: Vec::new(),
            observers: idx
                .iter()
                .map(|&i| observers[i].take().expect("one observer per scene"))
                .collect(),
            row: Vec::new(),
            friction: vec![FrictionWatch::default(); n],
            sample_evals: vec![0; n],
            events: vec![Vec::new(); n],
            below: Vec::new(),
            scenes: idx.clone(),
            names: idx.iter().map(|&i| scenes[i].name.clone()).collect(),
            reductions: idx.iter().map(|&i| scenes[i].reductions).collect(),
            tallies: vec![SimplificationTally::default(); n],
            held: idx
                .iter()
                .map(|&i| scenes[i].spin == super::scene::SpinMode::Held)
                .collect(),
            method,
            out: &mut out,
            keep_samples,
            progress: &mut *progress,
            cancel,
            accepted: Default::default(),
            times: Vec::new(),
            jac_ok: idx
                .iter()
                .map(|&i| jacobian_from_bearings(&scenes[i], n_thermal))
                .collect(),
            base_ys: vec![0.0; n * DIM],
            base_set: vec![false; n],
            base_loads: vec![None; n_bearings],
            jac_requests: Vec::new(),
            jac_results: Vec::new(),
            jac_probes: Vec::new(),
            jac_base: Vec::new(),
            jac_vars: Vec::new(),
            jac_film: Vec::new(),
            jac_l0: Vec::new(),
        };
        batch.below = vec![false; n_bearings];
        // Bearing indices restart per batch: no JFO film history carries over.
        batch.evaluator.clear_film_history();
        run_batch(method, &mut batch, &y0, &settings);
    }
    out.into_iter()
        .map(|r| r.expect("every scene ends with a result"))
        .collect()
}

#[cfg(test)]
mod decimation_tests {
    use super::*;

    /// Pushes `n` samples `t = k dt`, `x_g = k` through a store of `cap`.
    fn store(n: u64, cap: usize) -> TimeSeries {
        let mut s = TimeSeries::default();
        let mut d = Decimator::default();
        for k in 0..n {
            d.before_push(&mut s);
            s.t.push(k as f64 * 0.5);
            s.x_g.push(k as f64);
            d.after_push(&mut s, cap);
            assert!(s.len() <= cap, "n {n}: {} kept over cap {cap}", s.len());
        }
        s
    }

    /// Sample `k` of a two-bearing run whose second bearing has a lumped temperature
    /// and (from sample 7 on) a JFO film, every value distinct.
    fn bearings_of(k: u64) -> [BearingSample; 2] {
        let v = |c: u64| (k * 40 + c) as f64;
        let plain = |o: u64| BearingSample {
            xi: v(o),
            yi: v(o + 1),
            xj: v(o + 2),
            yj: v(o + 3),
            h_min: v(o + 4),
            eccentricity_max: v(o + 5),
            wx: v(o + 6),
            wy: v(o + 7),
            mz: v(o + 8),
            friction_coefficient: (!k.is_multiple_of(3)).then(|| v(o + 9)),
            thermal: None,
            film: None,
        };
        let mut second = plain(20);
        second.thermal = Some(ThermalSample {
            temperature_c: v(30),
            viscosity_pa_s: v(31),
            power_w: v(32),
            heat_to_flow_w: v(33),
            heat_to_housing_w: v(34),
        });
        second.film = (k >= 7).then(|| FilmSample {
            friction_torque_nm: v(35),
            power_loss_w: v(36),
            side_flow_m3_per_s: v(37),
            inlet_flow_m3_per_s: v(38),
        });
        [plain(10), second]
    }

    /// The same samples pushed one at a time straight into the columns (the store before
    /// it staged rows), as the reference.
    fn straight(n: u64, cap: usize) -> TimeSeries {
        let cap = (cap.max(2) + 1) & !1;
        let mut s = TimeSeries::default();
        let mut d = Decimator::default();
        for k in 0..n {
            d.before_push(&mut s);
            let (t, b) = (k as f64 * 0.5, bearings_of(k));
            s.t.push(t);
            s.x_g.push(t + 1.0);
            s.y_g.push(t + 2.0);
            s.spin.push(t + 3.0);
            s.kinetic_energy.push(t + 4.0);
            s.work.push(t + 5.0);
            if s.bearings.len() != b.len() {
                s.bearings = vec![BearingSeries::default(); b.len()];
            }
            for (bs, b) in s.bearings.iter_mut().zip(&b) {
                for (col, x) in [
                    (&mut bs.xi, b.xi),
                    (&mut bs.yi, b.yi),
                    (&mut bs.xj, b.xj),
                    (&mut bs.yj, b.yj),
                    (&mut bs.h_min, b.h_min),
                    (&mut bs.eccentricity_max, b.eccentricity_max),
                    (&mut bs.wx, b.wx),
                    (&mut bs.wy, b.wy),
                    (&mut bs.mz, b.mz),
                ] {
                    col.push(x);
                }
                bs.friction_coefficient.push(b.friction_coefficient);
                if let Some(x) = b.thermal {
                    let th = bs.thermal.get_or_insert_with(ThermalSeries::default);
                    th.temperature_c.push(x.temperature_c);
                    th.viscosity_pa_s.push(x.viscosity_pa_s);
                    th.power_w.push(x.power_w);
                    th.heat_to_flow_w.push(x.heat_to_flow_w);
                    th.heat_to_housing_w.push(x.heat_to_housing_w);
                }
                if let Some(x) = b.film {
                    let fl = bs.film.get_or_insert_with(FilmSeries::default);
                    fl.friction_torque_nm.push(x.friction_torque_nm);
                    fl.power_loss_w.push(x.power_loss_w);
                    fl.side_flow_m3_per_s.push(x.side_flow_m3_per_s);
                    fl.inlet_flow_m3_per_s.push(x.inlet_flow_m3_per_s);
                }
            }
            d.after_push(&mut s, cap);
        }
        s
    }

    #[test]
    fn staged_store_equals_pushing_each_sample_into_the_columns() {
        // Caps below, at and above the staging block, counts across several blocks and
        // several thinnings (provisional samples dropped from the rows and the columns).
        for cap in [2usize, 3, 8, 15, 16, 17, 40, 1000] {
            for (n, sized) in (0..100u64)
                .chain([255, 256, 257, 700])
                .flat_map(|n| [(n, false), (n, true)])
            {
                let mut store = if sized {
                    SeriesStore::for_run(cap, n as usize)
                } else {
                    SeriesStore::new(cap)
                };
                for k in 0..n {
                    let t = k as f64 * 0.5;
                    let b = bearings_of(k);
                    store.observe(&Sample {
                        t,
                        x_g: t + 1.0,
                        y_g: t + 2.0,
                        spin: t + 3.0,
                        kinetic_energy: t + 4.0,
                        work: t + 5.0,
                        bearings: &b,
                    });
                }
                let got = store.take_series();
                let want = straight(n, cap);
                assert_eq!(
                    got, want,
                    "cap {cap}, {n} samples (sized {sized}): staged store differs from the column pushes"
                );
                assert!(
                    got.len() <= cap.max(2) + 1,
                    "cap {cap}, {n}: {} kept",
                    got.len()
                );
            }
        }
    }

    #[test]
    fn a_store_sized_for_its_run_keeps_the_same_samples() {
        let b = [BearingSample {
            friction_coefficient: Some(0.5),
            ..BearingSample::default()
        }; 2];
        for cap in [2usize, 8, 64, 1000] {
            for n in [1usize, 7, 64, 65, 300] {
                let (mut plain, mut sized) = (SeriesStore::new(cap), SeriesStore::for_run(cap, n));
                for k in 0..n {
                    let x = Sample {
                        t: k as f64,
                        x_g: k as f64 * 2.0,
                        y_g: 0.0,
                        spin: 1.0,
                        kinetic_energy: 0.0,
                        work: 0.0,
                        bearings: &b,
                    };
                    plain.observe(&x);
                    sized.observe(&x);
                }
                let (a, z) = (plain.take_series(), sized.take_series());
                assert_eq!(a, z, "cap {cap}, {n} samples");
                // Sized once: no column grew past what the run (or the cap) needs.
                let need = n.min(cap.max(2) + 2);
                assert!(z.t.capacity() <= need, "cap {cap}, {n}: {}", z.t.capacity());
            }
        }
    }

    #[test]
    fn store_is_bounded_uniform_and_keeps_the_last_sample() {
        for cap in [2usize, 4, 8, 64] {
            for n in 1..600u64 {
                let s = store(n, cap);
                let stride = s.sample_stride;
                assert!(stride.is_power_of_two(), "n {n} cap {cap} stride {stride}");
                assert_eq!(s.t.len(), s.x_g.len());
                // First and last sample times always kept.
                assert_eq!(s.x_g[0], 0.0);
                assert_eq!(*s.x_g.last().unwrap(), (n - 1) as f64, "n {n} cap {cap}");
                // Every sample but the last on the stride, uniform in time.
                for (p, &x) in s.x_g[..s.len() - 1].iter().enumerate() {
                    assert_eq!(x, (p as u64 * stride) as f64, "n {n} cap {cap}");
                    assert_eq!(s.t[p], x * 0.5);
                }
                // No needless decimation: a stride > 1 only once the store fills, and
                // then at least half the cap is kept.
                if (n as usize) < cap {
                    assert_eq!((stride, s.len()), (1, n as usize));
                } else {
                    assert!(s.len() >= cap / 2, "n {n} cap {cap}: {}", s.len());
                }
            }
        }
    }
}

#[cfg(test)]
mod jacobian_tests {
    use super::super::jacobian::{film_jacobian, load_vector, probes};
    use super::*;
    use crate::bearing::{film_loads, Accuracy, FilmRule};

    /// The rigid derivative with every bearing's exact film loads (the rule at `rule`'s
    /// level), assembled as [`linear_derivative`] does.
    fn exact_derivative(m: &RotorModel, rule: &FilmRule, y: &[f64], dy: &mut [f64]) {
        let kin = m.kin(y);
        let (mut f, mut tau, mut power) = ([0.0; 2], V3::zeros(), 0.0);
        for geom in &m.bearings {
            let e = m.end_kin(&kin, geom);
            let st = m.bearing_state(&kin, &e);
            let l = film_loads(&geom.params, &st, rule).expect("a valid state");
            let (fi, fj) = l.end_forces(geom.params.length);
            add_bearing_loads(
                &e,
                fi,
                fj,
                l.mz,
                kin.w_global[2],
                &mut f,
                &mut tau,
                &mut power,
            );
        }
        m.rigid_derivative(y, &kin, f, tau, power, &mut dy[..DIM]);
    }

    /// The rotor's Jacobian from its bearings' inputs (six film probes a bearing, two
    /// film columns derived) against central differences of the exact right-hand side,
    /// on tilted, whirling states of the paper rotor: every entry within 1e-5 of its
    /// row's largest, at the 1e-12 rule level where differences are clean.
    #[test]
    fn the_bearing_jacobian_matches_differences_of_the_right_hand_side() {
        let scene = super::super::load_scene(
            r#"{"name": "j", "rotor": {"mass": 1.0, "inertia": [0.01, 0.01, 0.3],
                "static_unbalance": [0.001, 0.0]},
              "bearings": [
                {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242, "axial_position": 0.2},
                {"radius": 0.02, "length": 0.02, "clearance": 0.0003, "viscosity": 0.0242, "axial_position": -0.1}],
              "gravity": [0.0, -9.81, 0.0], "spin": "free", "initial": {"spin": 100.0},
              "integrator": {"method": "radau5", "rtol": 1e-6, "atol": 1e-6, "t_end": 0.1,
                "sample_interval": 1e-3},
              "film": {"threshold": 1e-6}}"#,
        )
        .expect("a scene")
        .remove(0);
        assert!(jacobian_from_bearings(&scene, 0));
        let m = RotorModel::new(&scene);
        let rule = FilmRule::new(Accuracy::new(1e-12).unwrap().settings());
        let d = 3e-4;
        let tilt = |a: f64| (0.5 * a).sin();
        let states: [[f64; DIM]; 2] = [
            [
                0.3 * d,
                -0.2 * d,
                0.02,
                -0.01,
                1.0,
                0.2 * tilt(1e-3),
                -0.1 * tilt(1e-3),
                0.05,
                0.4,
                -0.3,
                100.0,
                0.0,
            ],
            [
                -0.5 * d,
                0.1 * d,
                -0.03,
                0.04,
                0.9,
                -0.4 * tilt(1e-3),
                0.3 * tilt(1e-3),
                -0.3,
                -0.2,
                0.5,
                120.0,
                0.0,
            ],
        ];
        for y0 in &states {
            // G where the journal axis is offset by the state's (x, y) from the bore's:
            // the body's shaft axis is at −u from G (static unbalance u = 1 mm).
            let mut y = *y0;
            let ru = super::super::model::quat_matrix(&y[4..8]) * V3::new(1e-3, 0.0, 0.0);
            y[0] += ru[0];
            y[1] += ru[1];
            let y = &y;
            let kin = m.kin(y);
            let mut pr = Vec::new();
            let mut jf = Vec::new();
            let mut l0 = Vec::new();
            for geom in &m.bearings {
                let e = m.end_kin(&kin, geom);
                let s0 = m.bearing_state(&kin, &e);
                let p = probes(&s0, geom.params.clearance).expect("probes");
                let base = load_vector(&film_loads(&geom.params, &s0, &rule).unwrap());
                let lk: [[f64; 4]; 6] = std::array::from_fn(|n| {
                    load_vector(&film_loads(&geom.params, &p.states[n], &rule).unwrap())
                });
                jf.push(film_jacobian(&p, base, &lk));
                l0.push(base);
                pr.push(p);
            }
            let mut f0 = [0.0; DIM];
            let mut lin0 = [0.0; DIM];
            exact_derivative(&m, &rule, y, &mut f0);
            linear_derivative(&m, y, &pr, &jf, &l0, &mut lin0);
            for p in 0..DIM {
                assert!(
                    (f0[p] - lin0[p]).abs() <= 1e-12 * f0[p].abs().max(1e-300),
                    "base derivative {p}: {} against {}",
                    lin0[p],
                    f0[p]
                );
            }
            // Columns: the structured one (forward, as `jacobians`) and central
            // differences of the exact right-hand side with 1e-5 of each scale.
            let mut jac_s = [[0.0; JAC_DIM]; DIM];
            let mut jac_c = [[0.0; JAC_DIM]; DIM];
            for c in 0..JAC_DIM {
                let mut yc = *y;
                yc[c] += f64::EPSILON.sqrt() * yc[c].abs().max(m.scales[c]);
                let del = yc[c] - y[c];
                let mut fc = [0.0; DIM];
                linear_derivative(&m, &yc, &pr, &jf, &l0, &mut fc);
                let h = 1e-5 * m.scales[c];
                let (mut yp, mut ym) = (*y, *y);
                yp[c] += h;
                ym[c] -= h;
                let (mut fp, mut fm) = ([0.0; DIM], [0.0; DIM]);
                exact_derivative(&m, &rule, &yp, &mut fp);
                exact_derivative(&m, &rule, &ym, &mut fm);
                for p in 0..DIM {
                    jac_s[p][c] = (fc[p] - lin0[p]) / del;
                    jac_c[p][c] = (fp[p] - fm[p]) / (yp[c] - ym[c]);
                }
            }
            for p in 0..DIM {
                // Entries in the error norm's units: column c times its scale.
                let row = |j: &[[f64; JAC_DIM]; DIM], c: usize| j[p][c] * m.scales[c];
                let big = (0..JAC_DIM).fold(0.0_f64, |a, c| a.max(row(&jac_c, c).abs()));
                for c in 0..JAC_DIM {
                    let err = (row(&jac_s, c) - row(&jac_c, c)).abs();
                    assert!(
                        err <= 1e-5 * big,
                        "J[{p}][{c}] = {} against {} (row scale {big:.3e})",
                        jac_s[p][c],
                        jac_c[p][c]
                    );
                }
            }
        }
    }
}
