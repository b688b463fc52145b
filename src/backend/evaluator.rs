//! The batched front end every caller uses: validate and pack on the host, one backend
//! call for all good states, CPU recomputation of anything non-finite, loads out.

use rayon::prelude::*;

use super::{effective_model, BackendInfo, CpuBackend, FilmBackend};
use crate::bearing::finite::{FiniteGrid, FiniteJob, SolveReport};
use crate::bearing::{
    finish_loads_using, finish_loads_with, pack_state, BearingParams, BearingState, FilmIntegrals,
    FilmModel, LoadConstants, Loads, Packed, PackedState, StateFault,
};

/// Calls of at least this many states pack and finish their states on rayon's pool
/// (results are the same: each state is packed and finished alone). Below it, the
/// fork-join costs more than it saves; the rotor sweeps' per-thread CPU evaluators
/// carry a few hundred states per call and stay serial. On the H100 host (16 cores) the
/// serial host path cost ~0.5 µs per state, 25 times the GPU kernel's 0.02 µs at 10^6
/// states (BENCHMARKS.md "GPU backend", H100).
pub const PARALLEL_HOST_STATES: usize = 4096;

/// A request packed for the kernel, with whether it needs the finite-length film.
type Prepared = Result<(Packed, bool), StateFault>;

/// One state to evaluate and the bearing (index into the call's bearing list) it is in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoadRequest {
    /// Index into the `bearings` slice passed with the request.
    pub bearing: u32,
    /// The journal's kinematics in that bearing's frame.
    pub state: BearingState,
}

/// Loads, or why a state has none.
pub type LoadResult = Result<Loads, StateFault>;

/// What a caller with a fixed bearing list settles once instead of on every call
/// ([`LoadEvaluator::evaluate_planned`]): each bearing's validation and whether its loads
/// carry the film friction and flow outputs. Entries are indexed as the bearing list the
/// plan was made from, which every planned call must pass unchanged.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BearingPlan {
    /// [`BearingParams::validate`] of each bearing, as the fault a state in it gets.
    pub valid: Vec<Result<(), StateFault>>,
    /// Whether loads of states in that bearing fill [`Loads::film`] (the film friction and
    /// flow); `false` leaves it at [`crate::bearing::FilmFlow::default`] and changes no
    /// other output. One flag per bearing, so that a scene whose bearing needs its film
    /// power (a thermal balance) can keep it while the others skip it.
    pub film_outputs: Vec<bool>,
    /// [`LoadConstants::of`] each bearing: its loads are finished without working out
    /// the bearing's force scale and friction constants again for every state (the same
    /// numbers, so the same loads; BENCHMARKS.md "Issue 28, thirteenth pass"). A plan
    /// without them (shorter than the list) finishes as an unplanned call does.
    pub constants: Vec<LoadConstants>,
}

impl BearingPlan {
    /// Validates every bearing once; `film_outputs` for all of them.
    pub fn new(bearings: &[BearingParams], film_outputs: bool) -> Self {
        BearingPlan {
            valid: bearings.iter().map(validity).collect(),
            film_outputs: vec![film_outputs; bearings.len()],
            constants: bearings.iter().map(LoadConstants::of).collect(),
        }
    }
}

/// A bearing's validation as the fault its states get.
fn validity(b: &BearingParams) -> Result<(), StateFault> {
    b.validate().map_err(|e| StateFault::InvalidBearing {
        field: e.field,
        reason: e.reason,
    })
}

/// Counters over the evaluator's lifetime.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct EvalStats {
    /// Backend calls made (calls of [`LoadEvaluator::evaluate`]).
    pub calls: u64,
    /// States evaluated (including rejected ones).
    pub states: u64,
    /// States recomputed on the CPU after a backend failure or a non-finite result.
    pub cpu_recomputed: u64,
    /// States whose packed kernel input equalled an earlier state's in the same call
    /// (identical bearings in identical states, e.g. identical variants): integrated once,
    /// the integrals shared. Exact.
    pub deduplicated: u64,
    /// Kernel integrations actually run (states sent to the backend or the CPU).
    pub integrated: u64,
    /// Calls whose kernel work was small enough to run on the CPU fallback instead of a
    /// GPU round trip (see [`EvaluatorOptions::cpu_below`]). Exact: the same rule.
    pub small_batch_cpu_calls: u64,
    /// States integrated in those calls.
    pub small_batch_cpu_states: u64,
    /// States solved by the finite-length film (`"model": "finite"`, or `"auto"` where
    /// the short model's mapped error exceeded the tolerance).
    pub finite_states: u64,
    /// Projected-SOR sweeps over all finite solves.
    pub finite_sweeps: u64,
    /// Finite solves started from the previous field of the same bearing slot.
    pub finite_warm_starts: u64,
    /// Finite solves that hit the sweep limit before the tolerance (loads still returned).
    pub finite_unconverged: u64,
}

/// Largest number of f64 kept for warm starts (256 MB); beyond it fields are dropped and
/// solves start cold.
const WARM_BUDGET_F64: usize = 32 << 20;

/// Angle of the journal's mid-plane eccentricity, rad (0 for a centred journal).
fn mid_angle(job: &FiniteJob) -> f64 {
    let e = &job.state.ecc;
    (e[1] + e[3]).atan2(e[0] + e[2])
}

/// Turns a warm-start field by `d` rad in θ (periodic linear interpolation per row): the
/// film pattern follows the line of centres, which in a rotor orbit turns by `ω Δt` per
/// step, about a tenth of a grid cell at the paper's 100 rad/s; turned, the previous field
/// is a much closer start (BENCHMARKS.md "Finite-length film").
fn rotate_field(f: &mut [f64], grid: &FiniteGrid, d: f64) {
    let nt = grid.n_theta;
    let shift = d / (2.0 * std::f64::consts::PI / nt as f64);
    if !shift.is_finite() || shift.abs() < 1e-3 {
        return;
    }
    let k0 = shift.floor();
    let w = shift - k0;
    let k0 = (k0 as i64).rem_euclid(nt as i64) as usize;
    let mut row = vec![0.0; nt];
    for r in f.chunks_mut(nt) {
        row.copy_from_slice(r);
        for (i, v) in r.iter_mut().enumerate() {
            // New value at θ_i is the old one at θ_i − d.
            let a = (i + nt - k0) % nt;
            let b = (a + nt - 1) % nt;
            *v = (1.0 - w) * row[a] + w * row[b];
        }
    }
}

/// One finite-film state of a call: request index, rate scale, job, grid, warm-start key.
struct FiniteSlot {
    request: usize,
    rate_scale: f64,
    job: FiniteJob,
    grid: FiniteGrid,
    key: (u32, u32),
}

/// Exact reductions of the evaluator.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct EvaluatorOptions {
    /// Integrate identical packed states once per call. Default true.
    pub dedupe: bool,
    /// With a GPU backend, a call with fewer distinct states than this runs on the CPU
    /// fallback (a GPU round trip costs ~0.1-0.2 ms whatever the size). 0 turns it off.
    pub cpu_below: usize,
}

/// Default crossover for [`EvaluatorOptions::cpu_below`], states per call: below it the
/// CPU backend beats a GPU round trip (BENCHMARKS.md "GPU backend": lavapipe's round trip
/// is 0.09-0.16 ms, the CPU backend's 2-3 µs per state on 2 threads, so the CPU wins up to
/// ~50-100 states; and "Model reductions" for the end-to-end check). A hardware GPU's
/// round trip is of the same order (submit, wait, read back), so the default holds there.
pub const DEFAULT_CPU_BELOW: usize = 64;

impl Default for EvaluatorOptions {
    fn default() -> Self {
        EvaluatorOptions {
            dedupe: true,
            cpu_below: DEFAULT_CPU_BELOW,
        }
    }
}

impl EvaluatorOptions {
    /// Every reduction off: each state integrated by the backend itself.
    pub fn full() -> Self {
        EvaluatorOptions {
            dedupe: false,
            cpu_below: 0,
        }
    }
}

/// FxHash's odd multiplier (a 64-bit approximation of 2^64 / golden ratio).
const FX_MULTIPLIER: u64 = 0x51_7c_c1_b7_27_22_0a_95;

/// Hasher of the deduplication keys (bit patterns of packed states): a multiply-rotate
/// mix of each 8-byte word (the FxHash scheme), several times cheaper than the default
/// SipHash on 64-byte keys. Keys are our own kernel inputs, not adversarial, so no
/// resistance to chosen collisions is needed; equal keys still compare in full.
#[derive(Default)]
struct KeyHasher(u64);

impl std::hash::Hasher for KeyHasher {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut w = [0u8; 8];
            w[..chunk.len()].copy_from_slice(chunk);
            self.write_u64(u64::from_le_bytes(w));
        }
    }

    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0.rotate_left(5) ^ v).wrapping_mul(FX_MULTIPLIER);
    }

    fn write_usize(&mut self, v: usize) {
        self.write_u64(v as u64);
    }
}

/// The deduplication table of calls below [`PARALLEL_HOST_STATES`]: each distinct packed
/// state of the call once, found by its key ([`key_of`]). Open addressing with linear
/// probing over a power-of-two array of slots (`0` empty, else the state's index in the
/// call's packed list plus one) sized to at least twice the call's requests, so a probe
/// ends within a few slots. The same verdicts as a map from key to index (equal keys
/// only), without the general map's entry machinery (~80 instructions a state on the
/// rotor's calls, BENCHMARKS.md "Issue 28, ninth pass").
#[derive(Default)]
struct DedupeTable {
    slots: Vec<u32>,
    /// `64 − log2(slots.len())`: the hash's top bits index the table.
    shift: u32,
}

impl DedupeTable {
    /// Empties the table for a call of `requests` requests.
    fn reset(&mut self, requests: usize) {
        // Load factor at most 1/2; at least 16 slots.
        let len = (2 * requests).next_power_of_two().max(16);
        self.slots.clear();
        self.slots.resize(len, 0);
        self.shift = 64 - len.trailing_zeros();
    }

    /// The index in `packed` of the state with `state`'s key, pushing `state` first if
    /// there is none: `(index, pushed)`.
    fn find_or_push(
        &mut self,
        packed: &mut Vec<PackedState>,
        state: &PackedState,
    ) -> (usize, bool) {
        let key = key_of(state);
        let mask = self.slots.len() - 1;
        // Pairs of words mixed apart and summed: four independent multiplies instead of
        // FxHash's chain of eight dependent ones (a state's hash waited on that chain;
        // issue 28, fifteenth pass). Any mix serves: equal keys still compare in full.
        let mix = |a: u64, b: u64| (a ^ b.rotate_left(32)).wrapping_mul(FX_MULTIPLIER);
        let h = mix(key[0], key[1])
            .wrapping_add(mix(key[2], key[3]).rotate_left(16))
            .wrapping_add(mix(key[4], key[5]).rotate_left(32))
            .wrapping_add(mix(key[6], key[7]).rotate_left(48))
            .wrapping_mul(FX_MULTIPLIER);
        let mut i = (h >> self.shift) as usize;
        loop {
            let v = self.slots[i];
            if v == 0 {
                let n = packed.len();
                packed.push(*state);
                // The table holds fewer than 2^32 states (calls below PARALLEL_HOST_STATES).
                self.slots[i] = (n + 1) as u32;
                return (n, true);
            }
            let n = (v - 1) as usize;
            // Word by word, folded without a branch: `==` on the arrays was a call to
            // `memcmp` at every occupied slot probed (~1 % of a rotor run; issue 28,
            // sixteenth pass).
            let other = key_of(&packed[n]);
            if other.iter().zip(&key).fold(0, |acc, (a, b)| acc | (a ^ b)) == 0 {
                return (n, false);
            }
            i = (i + 1) & mask;
        }
    }
}

/// Bit pattern of a packed state: the key of identical kernel inputs.
fn key_of(p: &PackedState) -> [u64; 8] {
    // +0 and -0 give identical integrals; one key for both: `v + 0` is `v` for every
    // other value (packed states are finite) and +0 for both zeros, the key of a `v == 0`
    // test without its branch per component (~50 instructions a state with it, issue
    // 28's thirteenth pass).
    let mut k = [0u64; 8];
    for (n, v) in p.ecc.iter().chain(p.rate.iter()).enumerate() {
        k[n] = (*v + 0.0).to_bits();
    }
    k
}

/// FxHash of a key (as [`KeyHasher`] hashes it in a map).
fn key_hash(k: &[u64; 8]) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = KeyHasher::default();
    k.hash(&mut h);
    h.finish()
}

/// For a large call: `first[k]` = the first request whose film state has the same key as
/// request k's (k itself when none before it; every request without a film state maps to
/// itself). The same answer as inserting the keys into a map in request order, found in
/// parallel: keys hashed on rayon's pool, (hash, index) pairs sorted, runs of equal hashes
/// compared in full (a hash collision of different keys stays apart).
fn first_occurrences(prepared: &[Prepared], first: &mut Vec<usize>, order: &mut Vec<(u64, usize)>) {
    let film = |p: &Prepared| -> Option<[u64; 8]> {
        match p {
            Ok((p, false)) if p.rate_scale > 0.0 => Some(key_of(&p.state)),
            _ => None,
        }
    };
    order.clear();
    order.par_extend(
        prepared
            .par_iter()
            .enumerate()
            .filter_map(|(k, p)| film(p).map(|key| (key_hash(&key), k))),
    );
    // Ties in the hash sort by index: each run lists its requests in request order.
    order.par_sort_unstable();
    first.clear();
    first.extend(0..prepared.len());
    let key = |k: usize| film(&prepared[k]).expect("film state");
    let mut start = 0;
    while start < order.len() {
        let mut end = start + 1;
        while end < order.len() && order[end].0 == order[start].0 {
            end += 1;
        }
        // Within a run (almost always of one key), each request maps to the earliest
        // request of the run with an equal key.
        for j in start + 1..end {
            let kj = key(order[j].1);
            if let Some(i) = (start..j).find(|&i| key(order[i].1) == kj) {
                first[order[j].1] = first[order[i].1];
            }
        }
        start = end;
    }
}

/// Batched load evaluation over any backend, with its scratch buffers kept between calls.
pub struct LoadEvaluator {
    backend: Box<dyn FilmBackend>,
    fallback: Option<CpuBackend>,
    options: EvaluatorOptions,
    packed: Vec<PackedState>,
    /// Per film state (in request order): its request, rate scale and packed index.
    slots: Vec<(usize, f64, usize)>,
    bearing_ok: Vec<Result<(), StateFault>>,
    /// Per bearing of the current call: referred to by a request.
    bearing_used: Vec<bool>,
    prepared: Vec<Prepared>,
    seen: DedupeTable,
    /// Large calls' deduplication ([`first_occurrences`]): first equal request, the
    /// sorted (hash, request) pairs, and each first occurrence's packed index.
    first: Vec<usize>,
    order: Vec<(u64, usize)>,
    packed_at: Vec<usize>,
    integrals: Vec<FilmIntegrals>,
    bad: Vec<bool>,
    notices: Vec<String>,
    stats: EvalStats,
    finite: Vec<FiniteSlot>,
    /// Last field per warm-start key, with the angle of the journal's mid-plane
    /// eccentricity it was computed at.
    warm: std::collections::HashMap<(u32, u32), (Vec<f64>, f64)>,
    warm_start: bool,
    /// Reasons the backend declined finite-film work, each reported once.
    finite_fallbacks: std::collections::HashSet<String>,
    /// JFO film fractions carried through a time-stepped run (issue 27).
    film_history: super::finite::FilmHistory,
}

impl LoadEvaluator {
    /// Wraps `backend`; a non-CPU backend gets a CPU fallback at the same rule settings.
    /// Deduplication on, small-batch CPU routing off (so a GPU backend sees every call;
    /// the commands use [`LoadEvaluator::with_options`]).
    pub fn new(backend: Box<dyn FilmBackend>) -> Self {
        Self::with_options(
            backend,
            EvaluatorOptions {
                cpu_below: 0,
                ..EvaluatorOptions::default()
            },
        )
    }

    /// Wraps `backend` with explicit reductions.
    pub fn with_options(backend: Box<dyn FilmBackend>, options: EvaluatorOptions) -> Self {
        let info = backend.info();
        let fallback =
            (info.name != "cpu").then(|| CpuBackend::with_settings(backend.settings(), None));
        LoadEvaluator {
            backend,
            fallback,
            options,
            packed: Vec::new(),
            slots: Vec::new(),
            bearing_ok: Vec::new(),
            bearing_used: Vec::new(),
            prepared: Vec::new(),
            seen: DedupeTable::default(),
            first: Vec::new(),
            order: Vec::new(),
            packed_at: Vec::new(),
            integrals: Vec::new(),
            bad: Vec::new(),
            notices: Vec::new(),
            stats: EvalStats::default(),
            finite: Vec::new(),
            warm: std::collections::HashMap::new(),
            warm_start: true,
            finite_fallbacks: std::collections::HashSet::new(),
            film_history: Default::default(),
        }
    }

    /// Times of the next [`LoadEvaluator::evaluate`] call's requests (one per request, s)
    /// and whether they are integrator stages (`true`) or output samples: JFO bearings on
    /// an explicit grid are then solved as a time step from the film fraction committed
    /// for their bearing index (issue 27; docs/jfo.md). Applies to the next call only;
    /// without it JFO films are steady. No effect on other films.
    pub fn set_times(&mut self, times: &[f64], stages: bool) {
        self.film_history.set_times(times, stages);
    }

    /// An accepted step: the latest stage film fraction of JFO bearing `bearing` becomes
    /// its committed history (no-op for other bearings).
    pub fn commit_film_history(&mut self, bearing: u32) {
        self.film_history.commit(bearing);
    }

    /// Forgets the committed JFO film fractions (a new run whose bearing indices
    /// restart).
    pub fn clear_film_history(&mut self) {
        self.film_history.clear();
    }

    /// Finite-film warm start on or off (default on): a finite solve starts from the
    /// field last computed for the same bearing index and the same occurrence of it in a
    /// call, i.e. in a rotor batch the same variant's bearing at the previous stage or step.
    /// The result agrees with a cold start to the solver tolerance.
    pub fn set_warm_start(&mut self, on: bool) {
        self.warm_start = on;
        if !on {
            self.warm.clear();
        }
    }

    /// Forgets the finite-film fields kept for warm starts, so the next call answers as
    /// a new evaluator would (an evaluator reused across unrelated requests).
    pub fn forget_fields(&mut self) {
        self.warm.clear();
        self.film_history.clear();
    }

    /// The reductions in force.
    pub fn options(&self) -> EvaluatorOptions {
        self.options
    }

    /// The backend's description.
    pub fn info(&self) -> BackendInfo {
        self.backend.info()
    }

    /// Why the backend runs, when [`super::choose_backend`] created it.
    pub fn choice(&self) -> Option<super::BackendChoice> {
        self.backend.choice()
    }

    /// The backend itself.
    pub fn backend(&self) -> &dyn FilmBackend {
        self.backend.as_ref()
    }

    /// The backend, giving up the evaluator (its scratch buffers, counters and warm
    /// starts are dropped).
    pub fn into_backend(self) -> Box<dyn FilmBackend> {
        self.backend
    }

    /// Notices raised so far (fallbacks), oldest first; draining them clears the list.
    pub fn take_notices(&mut self) -> Vec<String> {
        std::mem::take(&mut self.notices)
    }

    /// Counters.
    pub fn stats(&self) -> EvalStats {
        self.stats
    }

    /// Evaluates every request in one backend call; `out` receives one result per
    /// request, in order.
    pub fn evaluate(
        &mut self,
        bearings: &[BearingParams],
        requests: &[LoadRequest],
        out: &mut Vec<LoadResult>,
    ) {
        self.evaluate_planned_or_not(bearings, None, requests, out);
    }

    /// [`LoadEvaluator::evaluate`] for a caller that made `plan` from this same
    /// `bearings` list ([`BearingPlan::new`]): the bearings are not validated again (states
    /// still are), and loads carry the film outputs only where the plan asks. Every other
    /// output is bit for bit that of `evaluate`.
    pub fn evaluate_planned(
        &mut self,
        bearings: &[BearingParams],
        plan: &BearingPlan,
        requests: &[LoadRequest],
        out: &mut Vec<LoadResult>,
    ) {
        debug_assert_eq!(plan.valid.len(), bearings.len(), "plan of another list");
        self.evaluate_planned_or_not(bearings, Some(plan), requests, out);
    }

    fn evaluate_planned_or_not(
        &mut self,
        bearings: &[BearingParams],
        plan: Option<&BearingPlan>,
        requests: &[LoadRequest],
        out: &mut Vec<LoadResult>,
    ) {
        // One placeholder per request, replaced below by its loads or fault (written in
        // place: pushing each result moved ~230 bytes through `memcpy`, BENCHMARKS.md
        // "Issue 28, ninth pass").
        out.clear();
        out.resize(requests.len(), Err(StateFault::BackendNonFinite));
        self.packed.clear();
        self.slots.clear();
        self.finite.clear();
        let mut occurrence: std::collections::HashMap<u32, u32> = Default::default();
        self.stats.calls += 1;
        self.stats.states += requests.len() as u64;
        // Validate only the bearings this call's requests refer to: a rotor batch passes
        // every variant's bearings on every call, and once most variants have ended
        // (a sweep's slowest variant alone) validating all of them cost more than the
        // loads (5 % of `sweeps/clearance-viscosity.json`; BENCHMARKS.md "Issue 28").
        // A planned call's bearings were validated once, when its plan was made.
        let bearing_ok: &[Result<(), StateFault>] = match plan {
            Some(p) => &p.valid,
            None => {
                self.bearing_used.clear();
                self.bearing_used.resize(bearings.len(), false);
                for req in requests {
                    if let Some(u) = self.bearing_used.get_mut(req.bearing as usize) {
                        *u = true;
                    }
                }
                self.bearing_ok.clear();
                self.bearing_ok
                    .extend(bearings.iter().zip(&self.bearing_used).map(|(b, &used)| {
                        if used {
                            validity(b)
                        } else {
                            Ok(())
                        }
                    }));
                &self.bearing_ok
            }
        };
        // Film friction and flow wanted for this bearing (every one without a plan).
        let film_flags = plan.map(|p| p.film_outputs.as_slice());
        let film_of = move |bearing: u32| -> bool {
            film_flags.is_none_or(|f| f.get(bearing as usize).copied().unwrap_or(true))
        };
        let prepare = |req: &LoadRequest| -> Prepared {
            let ok = bearing_ok.get(req.bearing as usize).copied().unwrap_or(Err(
                StateFault::InvalidBearing {
                    field: "bearing",
                    reason: "index out of range",
                },
            ));
            ok?;
            let b = &bearings[req.bearing as usize];
            let p = pack_state(b, &req.state)?;
            let finite = p.rate_scale > 0.0 && effective_model(b, &req.state) == FilmModel::Finite;
            Ok((p, finite))
        };
        // The bearing's finishing constants: the plan's, else worked out for the state.
        let planned_constants = plan.map(|p| p.constants.as_slice());
        let constants_of = move |bearing: u32| -> LoadConstants {
            match planned_constants.and_then(|c| c.get(bearing as usize)) {
                Some(c) => *c,
                None => LoadConstants::of(&bearings[bearing as usize]),
            }
        };
        // Large calls prepare every request on rayon's pool first; the others prepare
        // each request in the loop below (one pass: no list of prepared requests
        // written and read back).
        let serial = requests.len() < PARALLEL_HOST_STATES;
        self.prepared.clear();
        if !serial {
            requests
                .par_iter()
                .map(prepare)
                .collect_into_vec(&mut self.prepared);
        }
        // Large calls find their duplicates in parallel (the map below is serial).
        let parallel_dedupe = self.options.dedupe && requests.len() >= PARALLEL_HOST_STATES;
        if self.options.dedupe && !parallel_dedupe {
            self.seen.reset(requests.len());
        }
        if parallel_dedupe {
            first_occurrences(&self.prepared, &mut self.first, &mut self.order);
            self.packed_at.clear();
            self.packed_at.resize(requests.len(), 0);
        }
        for (k, req) in requests.iter().enumerate() {
            let prepared = if serial {
                prepare(req)
            } else {
                self.prepared[k]
            };
            match prepared {
                Ok((p, true)) => {
                    // The placeholder stays until `evaluate_finite` writes the loads.
                    let b = &bearings[req.bearing as usize];
                    let n = occurrence.entry(req.bearing).or_insert(0);
                    self.finite.push(FiniteSlot {
                        request: k,
                        rate_scale: p.rate_scale,
                        job: FiniteJob::of_state(b, &p, req.state.omega),
                        grid: FiniteGrid {
                            // Accuracy mode: the field to the tolerance where its film
                            // friction and flow are wanted (issue 20).
                            polish: film_of(req.bearing),
                            ..FiniteGrid::for_bearing(b)
                        },
                        key: (req.bearing, *n),
                    });
                    *n += 1;
                }
                Ok((p, _)) if p.rate_scale > 0.0 => {
                    // The placeholder stays until the integrals are in (below).
                    let n = if parallel_dedupe {
                        let f = self.first[k];
                        if f == k {
                            self.packed_at[k] = self.packed.len();
                            self.packed.push(p.state);
                        } else {
                            self.stats.deduplicated += 1;
                        }
                        self.packed_at[f]
                    } else if self.options.dedupe {
                        let (n, pushed) = self.seen.find_or_push(&mut self.packed, &p.state);
                        if !pushed {
                            self.stats.deduplicated += 1;
                        }
                        n
                    } else {
                        self.packed.push(p.state);
                        self.packed.len() - 1
                    };
                    self.slots.push((k, p.rate_scale, n));
                }
                // A film without pressure: its final loads.
                Ok((_, _)) => {
                    out[k] = finish_loads_with(
                        &bearings[req.bearing as usize],
                        &req.state,
                        &[0.0; 4],
                        0.0,
                        film_of(req.bearing),
                    )
                    .finite_or_fault()
                }
                Err(fault) => out[k] = Err(fault),
            }
        }
        if !self.finite.is_empty() {
            self.evaluate_finite(bearings, requests, out, film_of);
        }
        self.film_history.end_call();
        if self.packed.is_empty() {
            return;
        }
        self.stats.integrated += self.packed.len() as u64;
        let small = self.packed.len() < self.options.cpu_below;
        let done = match self.fallback.as_mut() {
            Some(cpu) if small => {
                self.stats.small_batch_cpu_calls += 1;
                self.stats.small_batch_cpu_states += self.packed.len() as u64;
                // The CPU kernel cannot fail.
                let _ = cpu.integrate(&self.packed, &mut self.integrals);
                Ok(())
            }
            _ => self.backend.integrate(&self.packed, &mut self.integrals),
        };
        if let Err(e) = done {
            match self.fallback.as_mut() {
                Some(cpu) => {
                    self.notices.push(format!(
                        "notice: {e}; batch of {} states recomputed on the CPU",
                        self.packed.len()
                    ));
                    self.stats.cpu_recomputed += self.packed.len() as u64;
                    // The CPU kernel cannot fail.
                    let _ = cpu.integrate(&self.packed, &mut self.integrals);
                }
                None => {
                    for &(k, _, _) in &self.slots {
                        out[k] = Err(StateFault::BackendNonFinite);
                    }
                    return;
                }
            }
        }
        self.integrals.resize(self.packed.len(), [f64::NAN; 4]);
        self.bad.clear();
        // Non-finite exactly when `Σ 0 · v` is not 0 (`0 · x` is ±0 for a finite `x`, NaN
        // for ±∞ or NaN): the verdict of testing each integral, without a branch per
        // integral (issue 28's thirteenth pass).
        self.bad.extend(
            self.integrals
                .iter()
                .map(|v| 0.0 * v[0] + 0.0 * v[1] + 0.0 * v[2] + 0.0 * v[3] != 0.0),
        );
        let n_bad = self.bad.iter().filter(|&&b| b).count();
        if n_bad > 0 {
            if let Some(cpu) = self.fallback.as_mut() {
                let states: Vec<PackedState> = (0..self.packed.len())
                    .filter(|&n| self.bad[n])
                    .map(|n| self.packed[n])
                    .collect();
                let mut fixed = Vec::new();
                let _ = cpu.integrate(&states, &mut fixed);
                let bad_idx: Vec<usize> = (0..self.packed.len()).filter(|&n| self.bad[n]).collect();
                for (&n, v) in bad_idx.iter().zip(fixed) {
                    self.integrals[n] = v;
                    self.bad[n] = !v.iter().all(|x| x.is_finite());
                }
                self.stats.cpu_recomputed += n_bad as u64;
                self.notices.push(format!(
                    "notice: {n_bad} non-finite results recomputed on the CPU"
                ));
            }
        }
        let (bad, integrals) = (&self.bad, &self.integrals);
        let finish = |&(k, scale, n): &(usize, f64, usize)| -> LoadResult {
            if bad[n] {
                return Err(StateFault::BackendNonFinite);
            }
            let req = &requests[k];
            finish_loads_using(
                &bearings[req.bearing as usize],
                &constants_of(req.bearing),
                &req.state,
                &integrals[n],
                scale,
                film_of(req.bearing),
            )
            .finite_or_fault()
        };
        if self.slots.len() >= PARALLEL_HOST_STATES {
            let done: Vec<LoadResult> = self.slots.par_iter().map(finish).collect();
            for (&(k, _, _), r) in self.slots.iter().zip(done) {
                out[k] = r;
            }
        } else {
            // Each state's loads written in their place and checked there (the same
            // results as `finish`, without moving the loads twice).
            for &(k, scale, n) in &self.slots {
                let o = &mut out[k];
                if bad[n] {
                    *o = Err(StateFault::BackendNonFinite);
                    continue;
                }
                let req = &requests[k];
                *o = Ok(finish_loads_using(
                    &bearings[req.bearing as usize],
                    &constants_of(req.bearing),
                    &req.state,
                    &integrals[n],
                    scale,
                    film_of(req.bearing),
                ));
                if let Some(fault) = o.as_ref().ok().and_then(Loads::fault) {
                    *o = Err(fault);
                }
            }
        }
    }

    /// The finite-film states of the current call, one backend call per distinct grid.
    fn evaluate_finite(
        &mut self,
        bearings: &[BearingParams],
        requests: &[LoadRequest],
        out: &mut [LoadResult],
        film_of: impl Fn(u32) -> bool,
    ) {
        let slots = std::mem::take(&mut self.finite);
        let mut grids: Vec<FiniteGrid> = Vec::new();
        for s in &slots {
            if !grids.contains(&s.grid) {
                grids.push(s.grid);
            }
        }
        let mut ints = Vec::new();
        let mut reports: Vec<SolveReport> = Vec::new();
        for grid in grids {
            let group: Vec<&FiniteSlot> = slots.iter().filter(|s| s.grid == grid).collect();
            let jobs: Vec<FiniteJob> = group.iter().map(|s| s.job).collect();
            let mut fields: Vec<Vec<f64>> = group
                .iter()
                .map(|s| {
                    let f = if self.warm_start {
                        match self.warm.remove(&s.key) {
                            // Not on a held ladder grid (accuracy mode, n_theta > 0):
                            // its solve starts from the ladder, not from a field.
                            Some((mut f, angle))
                                if f.len() == grid.field_len() && grid.accuracy.is_none() =>
                            {
                                rotate_field(&mut f, &grid, mid_angle(&s.job) - angle);
                                f
                            }
                            _ => Vec::new(),
                        }
                    } else {
                        Vec::new()
                    };
                    if f.len() == grid.field_len() {
                        self.stats.finite_warm_starts += 1;
                    }
                    f
                })
                .collect();
            self.stats.finite_states += jobs.len() as u64;
            self.stats.integrated += jobs.len() as u64;
            // The fields come back only where something uses them (a device backend's
            // read-back can cost more than its kernel): the next call's warm start
            // (explicit grids; accuracy mode starts from its ladder, never from a kept
            // field), film friction and flow, JFO films.
            let fields_wanted = (self.warm_start && grid.accuracy.is_none())
                || grid.cavitation == crate::bearing::finite::Cavitation::Jfo
                || group.iter().any(|s| film_of(requests[s.request].bearing));
            let timed: Vec<(u32, usize, f64)> = group
                .iter()
                .map(|s| (s.key.0, s.request, s.rate_scale))
                .collect();
            if let Some(status) = self.film_history.solve_group(
                &timed,
                &jobs,
                &grid,
                &mut fields,
                &mut ints,
                &mut reports,
                self.backend.as_mut(),
            ) {
                // JFO with its film history (issue 27): the backend's JFO solve, the CPU's
                // after a backend failure.
                if let Err(e) = status {
                    let why = e.to_string();
                    if self.finite_fallbacks.insert(why.clone()) {
                        self.notices.push(format!(
                            "notice: {why}; JFO film-history states recomputed on the CPU \
                             (this call: {}; further calls for the same reason silently)",
                            jobs.len()
                        ));
                    }
                    self.stats.cpu_recomputed += jobs.len() as u64;
                }
            } else if let Err(e) = self.backend.integrate_finite_with(
                &jobs,
                &grid,
                &mut fields,
                fields_wanted,
                &mut ints,
                &mut reports,
            ) {
                // Once per distinct reason: a rotor run makes thousands of calls.
                let why = e.to_string();
                if self.finite_fallbacks.insert(why.clone()) {
                    self.notices.push(format!(
                        "notice: {why}; finite-film states recomputed on the CPU (this call: \
                         {}; further calls for the same reason silently)",
                        jobs.len()
                    ));
                }
                self.stats.cpu_recomputed += jobs.len() as u64;
                for f in fields.iter_mut() {
                    f.clear();
                }
                super::finite::cpu_integrate_finite(
                    &jobs,
                    &grid,
                    &mut fields,
                    &mut ints,
                    &mut reports,
                    true,
                );
            }
            ints.resize(jobs.len(), [f64::NAN; 4]);
            reports.resize(jobs.len(), SolveReport::default());
            let mut recomputed = 0;
            for (n, slot) in group.iter().enumerate() {
                if !ints[n].iter().all(|x| x.is_finite()) {
                    // A backend's non-finite result: the CPU solver from a cold start.
                    let mut f = Vec::new();
                    let (v, r) =
                        crate::bearing::finite::FiniteSolver::new().solve(&slot.job, &grid, &mut f);
                    ints[n] = v;
                    reports[n] = r;
                    fields[n] = f;
                    recomputed += 1;
                }
                self.stats.finite_sweeps += reports[n].sweeps as u64;
                self.stats.finite_unconverged += u64::from(!reports[n].converged);
                let req = &requests[slot.request];
                out[slot.request] = if ints[n].iter().all(|x| x.is_finite()) {
                    let params = &bearings[req.bearing as usize];
                    let film = film_of(req.bearing);
                    finish_loads_with(params, &req.state, &ints[n], slot.rate_scale, film)
                        .finite_or_fault()
                        .map(|mut l| {
                            // Film friction and flow from the returned field (issue 24).
                            if !film {
                                return l;
                            }
                            self.film_history.apply_flow(
                                n,
                                &mut l,
                                params,
                                &req.state,
                                slot.rate_scale,
                                &slot.job,
                                &grid,
                                &reports[n],
                                &fields[n],
                            );
                            l
                        })
                } else {
                    Err(StateFault::BackendNonFinite)
                };
            }
            if recomputed > 0 {
                self.stats.cpu_recomputed += recomputed;
                self.notices.push(format!(
                    "notice: {recomputed} non-finite finite-film results recomputed on the CPU"
                ));
            }
            if self.warm_start && fields_wanted {
                let kept: usize = self.warm.values().map(|(f, _)| f.len()).sum();
                if kept + fields.len() * grid.field_len() <= WARM_BUDGET_F64 {
                    for (slot, f) in group.iter().zip(fields) {
                        self.warm.insert(slot.key, (f, mid_angle(&slot.job)));
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A call large enough to pack and finish on rayon's pool gives, state for state,
    /// the loads of the serial path (calls below [`PARALLEL_HOST_STATES`]), faults and
    /// duplicates included.
    #[test]
    fn the_parallel_host_path_matches_the_serial_one() {
        let n = PARALLEL_HOST_STATES + 977;
        let (bearing, mut requests) = crate::backend::bench_states(n, 0.95, 7);
        // Faults and duplicates among them: a journal through the wall, a NaN, an
        // unknown bearing index, and a repeat of state 0.
        requests[5].state.xi = 2.0 * bearing.clearance;
        requests[17].state.vxi = f64::NAN;
        requests[29].bearing = 3;
        requests[41] = requests[0];
        let bearings = [bearing];
        let mut big = LoadEvaluator::new(Box::new(CpuBackend::new(
            crate::bearing::Accuracy::new(1e-6).unwrap(),
            Some(2),
        )));
        let mut small = LoadEvaluator::new(Box::new(CpuBackend::new(
            crate::bearing::Accuracy::new(1e-6).unwrap(),
            Some(1),
        )));
        let mut all = Vec::new();
        big.evaluate(&bearings, &requests, &mut all);
        assert_eq!(all.len(), n);
        let mut one = Vec::new();
        for (k, chunk) in requests.chunks(PARALLEL_HOST_STATES / 2).enumerate() {
            small.evaluate(&bearings, chunk, &mut one);
            for (i, (got, want)) in all[k * PARALLEL_HOST_STATES / 2..]
                .iter()
                .zip(&one)
                .enumerate()
            {
                let idx = k * PARALLEL_HOST_STATES / 2 + i;
                match (got, want) {
                    (Ok(a), Ok(b)) => assert_eq!(a, b, "state {idx}: parallel vs serial"),
                    (Err(a), Err(b)) => assert_eq!(a, b, "state {idx}: faults differ"),
                    _ => panic!("state {idx}: parallel {got:?}, serial {want:?}"),
                }
            }
        }
        assert!(all[5].is_err() && all[17].is_err() && all[29].is_err());
        assert_eq!(all[41], all[0]);
    }
}
