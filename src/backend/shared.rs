//! One film backend shared by several host threads: each thread's evaluator holds a
//! [`SharedBackend`] handle, and the requests that wait while a dispatch is in flight are
//! merged into the next one (group commit), so that the device evaluates one merged
//! request while the other threads do their host work.
//!
//! A request is served alone when a dispatch slot is free; otherwise it joins the batch
//! being filled, and the first of that batch's requesters to find a slot free dispatches it
//! for all of them. A backend that offers siblings ([`FilmBackend::sibling`]: the GPU
//! backend on a hardware device) gets [`FilmBackend::dispatch_slots`] slots, each with its
//! own buffers on the same device, so that one merged batch is uploaded and read back while
//! another runs. Every state's integrals are computed alone by the kernel, so a state's
//! result does not depend on which requests it was merged with nor on the slot.

use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use super::{BackendChoice, BackendError, BackendInfo, FilmBackend};
use crate::bearing::finite::{FiniteGrid, FiniteJob, JfoHistory, SolveReport};
use crate::bearing::{FilmIntegrals, PackedState, RuleSettings};

/// Under a merge policy, a handle counts as active while its last request is at most this
/// many lingers old.
const ACTIVE_WINDOW: u32 = 10;

/// Counters of a [`Dispatcher`] over its lifetime (or since [`Dispatcher::reset_stats`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct DispatchStats {
    /// `integrate` requests served (one per evaluator call that reached the backend).
    pub requests: u64,
    /// Backend calls made for them (merged requests count once).
    pub dispatches: u64,
    /// States sent to the backend.
    pub states: u64,
    /// Seconds in which at least one dispatch (upload, kernel, read-back) was in flight.
    pub device_busy_s: f64,
    /// Seconds the requesting threads spent inside `integrate` (waiting for their
    /// results, or dispatching them), summed over requests.
    pub request_wait_s: f64,
    /// Seconds from the first request to the end of the last dispatch.
    pub span_s: f64,
    /// Dispatch slots (dispatches that may be in flight at once).
    pub slots: usize,
    /// Most dispatches that were in flight at once.
    pub max_in_flight: usize,
    /// Dispatches that waited for more requests to join ([`FilmBackend::merge_policy`]).
    pub lingered: u64,
}

impl DispatchStats {
    /// Fraction of [`DispatchStats::span_s`] in which no dispatch was in flight (the
    /// device waited for the host); 0 without requests.
    pub fn device_idle_fraction(&self) -> f64 {
        if self.span_s > 0.0 {
            (1.0 - self.device_busy_s / self.span_s).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }
}

/// The merge queue (under [`Dispatcher::queue`]).
struct Queue {
    /// States of the batch being filled (the next dispatch), in arrival order.
    filling: Vec<PackedState>,
    /// Number of the batch being filled; dispatched batches have smaller numbers.
    generation: u64,
    /// Requests in the batch being filled.
    joined: usize,
    /// Dispatches in flight.
    in_flight: usize,
    /// Slots not in flight (indices into [`Dispatcher::backends`]).
    free: Vec<usize>,
    /// Since when at least one dispatch has been in flight.
    busy_since: Option<Instant>,
    /// When the batch being filled found a slot free (the merge policy's linger start).
    free_since: Option<Instant>,
    /// Each handle's last request (the merge policy counts the handles active within
    /// [`ACTIVE_WINDOW`] lingers).
    last_seen: Vec<Option<Instant>>,
    /// Results of dispatched batches that some requesters have not collected yet:
    /// (batch number, result, requesters still to collect).
    done: Vec<(u64, Result<Vec<FilmIntegrals>, BackendError>, usize)>,
    /// Buffers of finished batches kept for reuse (states, results), at most one per slot.
    spare_states: Vec<Vec<PackedState>>,
    spare_results: Vec<Vec<FilmIntegrals>>,
    stats: DispatchStats,
    first_request: Option<Instant>,
}

/// One backend behind a merge queue; create handles with [`Dispatcher::handle`].
pub struct Dispatcher {
    /// The dispatch slots: the backend first, then its siblings.
    backends: Vec<Mutex<Box<dyn FilmBackend>>>,
    /// Requests to wait for, and for how long at most, before a dispatch.
    merge: Option<(usize, Duration)>,
    info: BackendInfo,
    settings: RuleSettings,
    choice: Option<BackendChoice>,
    queue: Mutex<Queue>,
    ready: Condvar,
}

impl Dispatcher {
    /// Puts `backend` behind a merge queue, with [`FilmBackend::dispatch_slots`] slots
    /// (as many as it gives siblings for).
    pub fn new(backend: Box<dyn FilmBackend>) -> Arc<Self> {
        let wanted = backend.dispatch_slots().max(1);
        let mut backends = Vec::with_capacity(wanted);
        while backends.len() + 1 < wanted {
            match backend.sibling() {
                Some(b) => backends.push(Mutex::new(b)),
                None => break,
            }
        }
        let info = backend.info();
        let settings = backend.settings();
        let choice = backend.choice();
        let merge = backend.merge_policy();
        backends.insert(0, Mutex::new(backend));
        let slots = backends.len();
        Arc::new(Dispatcher {
            info,
            settings,
            choice,
            backends,
            merge,
            queue: Mutex::new(Queue {
                filling: Vec::new(),
                generation: 0,
                joined: 0,
                in_flight: 0,
                // Popped from the back: slot 0 first.
                free: (0..slots).rev().collect(),
                busy_since: None,
                free_since: None,
                last_seen: Vec::new(),
                done: Vec::new(),
                spare_states: Vec::new(),
                spare_results: Vec::new(),
                stats: DispatchStats {
                    slots,
                    ..DispatchStats::default()
                },
                first_request: None,
            }),
            ready: Condvar::new(),
        })
    }

    /// A backend handle whose `integrate` goes through the queue.
    pub fn handle(self: &Arc<Self>) -> Box<dyn FilmBackend> {
        let id = {
            let mut q = self.lock_queue();
            q.last_seen.push(None);
            q.last_seen.len() - 1
        };
        Box::new(SharedBackend {
            dispatcher: self.clone(),
            id,
        })
    }

    /// Counters so far.
    pub fn stats(&self) -> DispatchStats {
        self.lock_queue().stats
    }

    /// Zeroes the counters (the next request starts a new span).
    pub fn reset_stats(&self) {
        let mut q = self.lock_queue();
        q.stats = DispatchStats {
            slots: self.backends.len(),
            ..DispatchStats::default()
        };
        q.first_request = None;
    }

    /// Dispatch slots.
    pub fn slots(&self) -> usize {
        self.backends.len()
    }

    fn lock_queue(&self) -> MutexGuard<'_, Queue> {
        // A panic while holding the lock leaves plain data behind: keep going.
        self.queue.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn lock_backend(&self, slot: usize) -> MutexGuard<'_, Box<dyn FilmBackend>> {
        self.backends[slot]
            .lock()
            .unwrap_or_else(|p| p.into_inner())
    }

    /// Marks a dispatch from `slot` finished (under the queue lock).
    fn release(&self, q: &mut Queue, slot: usize) {
        q.in_flight -= 1;
        q.free.push(slot);
        if q.in_flight == 0 {
            if let Some(t) = q.busy_since.take() {
                q.stats.device_busy_s += t.elapsed().as_secs_f64();
            }
        }
    }

    /// Integrals of `states` into `out`, merged with whatever other threads request
    /// meanwhile.
    fn integrate(
        &self,
        id: usize,
        states: &[PackedState],
        out: &mut Vec<FilmIntegrals>,
    ) -> Result<(), BackendError> {
        out.clear();
        let start = Instant::now();
        let mut q = self.lock_queue();
        q.first_request.get_or_insert(start);
        q.stats.requests += 1;
        let offset = q.filling.len();
        q.filling.extend_from_slice(states);
        q.joined += 1;
        if let Some(t) = q.last_seen.get_mut(id) {
            *t = Some(start);
        }
        let mine = q.generation;
        if self.merge.is_some() {
            // A requester may be lingering for this batch to fill.
            self.ready.notify_all();
        }
        loop {
            if let Some(pos) = q.done.iter().position(|d| d.0 == mine) {
                let entry = &mut q.done[pos];
                let result = match &entry.1 {
                    Ok(all) => {
                        out.extend_from_slice(&all[offset..offset + states.len()]);
                        Ok(())
                    }
                    Err(e) => Err(e.clone()),
                };
                entry.2 -= 1;
                if entry.2 == 0 {
                    let (_, r, _) = q.done.swap_remove(pos);
                    if let Ok(mut v) = r {
                        if q.spare_results.len() < self.backends.len() {
                            v.clear();
                            q.spare_results.push(v);
                        }
                    }
                }
                q.stats.request_wait_s += start.elapsed().as_secs_f64();
                return result;
            }
            if q.in_flight < self.backends.len() && q.generation == mine {
                // This request's batch is next and a slot is free: dispatch it for
                // everyone in it (under a merge policy, once enough requests joined or
                // the linger ran out).
                if let Some((m, linger)) = self.merge {
                    let now = Instant::now();
                    let deadline = *q.free_since.get_or_insert(now) + linger;
                    // Wait for at most the handles that requested recently (threads
                    // that ran out of work stop counting after a few lingers).
                    let window = linger * ACTIVE_WINDOW;
                    let active = q
                        .last_seen
                        .iter()
                        .flatten()
                        .filter(|t| now.saturating_duration_since(**t) <= window)
                        .count();
                    let target = m.min(active.max(1));
                    if q.joined < target && now < deadline {
                        q = self
                            .ready
                            .wait_timeout(q, deadline - now)
                            .unwrap_or_else(|p| p.into_inner())
                            .0;
                        continue;
                    }
                    if q.free_since.take().is_some_and(|t| t < now) {
                        q.stats.lingered += 1;
                    }
                }
                let slot = q.free.pop().expect("a free slot when fewer are in flight");
                let spare = q.spare_states.pop().unwrap_or_default();
                let mut batch = std::mem::replace(&mut q.filling, spare);
                let mut results = q.spare_results.pop().unwrap_or_default();
                let joined = std::mem::take(&mut q.joined);
                q.generation += 1;
                q.in_flight += 1;
                q.stats.max_in_flight = q.stats.max_in_flight.max(q.in_flight);
                if q.in_flight == 1 {
                    q.busy_since = Some(Instant::now());
                }
                drop(q);
                // Should the backend panic, the batch's other requesters get an error
                // instead of waiting for ever.
                let guard = PanicGuard {
                    dispatcher: self,
                    generation: mine,
                    joined,
                    slot,
                };
                let r = self.lock_backend(slot).integrate(&batch, &mut results);
                std::mem::forget(guard);
                q = self.lock_queue();
                self.release(&mut q, slot);
                q.stats.dispatches += 1;
                q.stats.states += batch.len() as u64;
                if let Some(f) = q.first_request {
                    q.stats.span_s = f.elapsed().as_secs_f64();
                }
                // A backend that returned too few results leaves NaN in their place,
                // which the evaluator recomputes on the CPU.
                let r = r.map(|()| {
                    results.resize(batch.len(), [f64::NAN; 4]);
                    results
                });
                batch.clear();
                if q.spare_states.len() < self.backends.len() {
                    q.spare_states.push(batch);
                }
                q.done.push((mine, r, joined));
                self.ready.notify_all();
                continue;
            }
            q = self.ready.wait(q).unwrap_or_else(|p| p.into_inner());
        }
    }
}

/// Armed while a dispatch runs: dropped only when the backend panicked, it frees the
/// queue and answers the batch with an error.
struct PanicGuard<'a> {
    dispatcher: &'a Dispatcher,
    generation: u64,
    joined: usize,
    slot: usize,
}

impl Drop for PanicGuard<'_> {
    fn drop(&mut self) {
        let mut q = self.dispatcher.lock_queue();
        self.dispatcher.release(&mut q, self.slot);
        // The panicking requester never collects its share.
        let others = self.joined.saturating_sub(1);
        if others > 0 {
            q.done.push((
                self.generation,
                Err(BackendError::Device("the backend panicked".into())),
                others,
            ));
        }
        self.dispatcher.ready.notify_all();
    }
}

/// A handle on a [`Dispatcher`]: a [`FilmBackend`] to give each thread's evaluator.
pub struct SharedBackend {
    dispatcher: Arc<Dispatcher>,
    /// Index of this handle's last request time in the queue.
    id: usize,
}

impl FilmBackend for SharedBackend {
    fn info(&self) -> BackendInfo {
        self.dispatcher.info.clone()
    }

    fn settings(&self) -> RuleSettings {
        self.dispatcher.settings
    }

    fn integrate(
        &mut self,
        states: &[PackedState],
        out: &mut Vec<FilmIntegrals>,
    ) -> Result<(), BackendError> {
        self.dispatcher.integrate(self.id, states, out)
    }

    /// Finite-film calls are not merged: they take the first slot's backend in turn.
    fn integrate_finite(
        &mut self,
        jobs: &[FiniteJob],
        grid: &FiniteGrid,
        fields: &mut [Vec<f64>],
        out: &mut Vec<FilmIntegrals>,
        reports: &mut Vec<SolveReport>,
    ) -> Result<(), BackendError> {
        self.dispatcher
            .lock_backend(0)
            .integrate_finite(jobs, grid, fields, out, reports)
    }

    fn integrate_finite_with(
        &mut self,
        jobs: &[FiniteJob],
        grid: &FiniteGrid,
        fields: &mut [Vec<f64>],
        fields_wanted: bool,
        out: &mut Vec<FilmIntegrals>,
        reports: &mut Vec<SolveReport>,
    ) -> Result<(), BackendError> {
        self.dispatcher.lock_backend(0).integrate_finite_with(
            jobs,
            grid,
            fields,
            fields_wanted,
            out,
            reports,
        )
    }

    fn integrate_finite_jfo(
        &mut self,
        jobs: &[FiniteJob],
        grid: &FiniteGrid,
        fields: &mut [Vec<f64>],
        histories: &[Option<JfoHistory>],
        out: &mut Vec<FilmIntegrals>,
        reports: &mut Vec<SolveReport>,
    ) -> Result<(), BackendError> {
        self.dispatcher
            .lock_backend(0)
            .integrate_finite_jfo(jobs, grid, fields, histories, out, reports)
    }

    fn choice(&self) -> Option<BackendChoice> {
        self.dispatcher.choice.clone()
    }
}
