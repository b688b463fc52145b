//! One film backend shared by several host threads: each thread's evaluator holds a
//! [`SharedBackend`] handle, and the requests that wait while a dispatch is in flight are
//! merged into the next one (group commit), so that the device evaluates one merged
//! request while the other threads do their host work.
//!
//! A request is served alone when the device is free; otherwise it joins the batch being
//! filled, and the first of that batch's requesters to find the device free dispatches it
//! for all of them. Every state's integrals are computed alone by the kernel, so a state's
//! result does not depend on which requests it was merged with.

use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::Instant;

use super::{BackendChoice, BackendError, BackendInfo, FilmBackend};
use crate::bearing::finite::{FiniteGrid, FiniteJob, SolveReport};
use crate::bearing::{FilmIntegrals, PackedState, RuleSettings};

/// Counters of a [`Dispatcher`] over its lifetime (or since [`Dispatcher::reset_stats`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct DispatchStats {
    /// `integrate` requests served (one per evaluator call that reached the backend).
    pub requests: u64,
    /// Backend calls made for them (merged requests count once).
    pub dispatches: u64,
    /// States sent to the backend.
    pub states: u64,
    /// Seconds the backend was busy with dispatches (upload, kernel, read-back), summed.
    pub device_busy_s: f64,
    /// Seconds the requesting threads spent inside `integrate` (waiting for their
    /// results, or dispatching them), summed over requests.
    pub request_wait_s: f64,
    /// Seconds from the first request to the end of the last dispatch.
    pub span_s: f64,
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
    /// Whether a dispatch is in flight.
    busy: bool,
    /// Results of dispatched batches that some requesters have not collected yet:
    /// (batch number, result, requesters still to collect).
    done: Vec<(u64, Result<Vec<FilmIntegrals>, BackendError>, usize)>,
    /// Buffers of finished batches kept for reuse (states, results).
    spare_states: Vec<PackedState>,
    spare_results: Vec<FilmIntegrals>,
    stats: DispatchStats,
    first_request: Option<Instant>,
}

/// One backend behind a merge queue; create handles with [`Dispatcher::handle`].
pub struct Dispatcher {
    backend: Mutex<Box<dyn FilmBackend>>,
    info: BackendInfo,
    settings: RuleSettings,
    choice: Option<BackendChoice>,
    queue: Mutex<Queue>,
    ready: Condvar,
}

impl Dispatcher {
    /// Puts `backend` behind a merge queue.
    pub fn new(backend: Box<dyn FilmBackend>) -> Arc<Self> {
        Arc::new(Dispatcher {
            info: backend.info(),
            settings: backend.settings(),
            choice: backend.choice(),
            backend: Mutex::new(backend),
            queue: Mutex::new(Queue {
                filling: Vec::new(),
                generation: 0,
                joined: 0,
                busy: false,
                done: Vec::new(),
                spare_states: Vec::new(),
                spare_results: Vec::new(),
                stats: DispatchStats::default(),
                first_request: None,
            }),
            ready: Condvar::new(),
        })
    }

    /// A backend handle whose `integrate` goes through the queue.
    pub fn handle(self: &Arc<Self>) -> Box<dyn FilmBackend> {
        Box::new(SharedBackend {
            dispatcher: self.clone(),
        })
    }

    /// Counters so far.
    pub fn stats(&self) -> DispatchStats {
        self.lock_queue().stats
    }

    /// Zeroes the counters (the next request starts a new span).
    pub fn reset_stats(&self) {
        let mut q = self.lock_queue();
        q.stats = DispatchStats::default();
        q.first_request = None;
    }

    fn lock_queue(&self) -> MutexGuard<'_, Queue> {
        // A panic while holding the lock leaves plain data behind: keep going.
        self.queue.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn lock_backend(&self) -> MutexGuard<'_, Box<dyn FilmBackend>> {
        self.backend.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Integrals of `states` into `out`, merged with whatever other threads request
    /// meanwhile.
    fn integrate(
        &self,
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
        let mine = q.generation;
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
                        if v.capacity() > q.spare_results.capacity() {
                            v.clear();
                            q.spare_results = v;
                        }
                    }
                }
                q.stats.request_wait_s += start.elapsed().as_secs_f64();
                return result;
            }
            if !q.busy && q.generation == mine {
                // This request's batch is next and the device is free: dispatch it for
                // everyone in it.
                let spare = std::mem::take(&mut q.spare_states);
                let mut batch = std::mem::replace(&mut q.filling, spare);
                let mut results = std::mem::take(&mut q.spare_results);
                let joined = std::mem::take(&mut q.joined);
                q.generation += 1;
                q.busy = true;
                drop(q);
                let t = Instant::now();
                // Should the backend panic, the batch's other requesters get an error
                // instead of waiting for ever.
                let guard = PanicGuard {
                    dispatcher: self,
                    generation: mine,
                    joined,
                };
                let r = self.lock_backend().integrate(&batch, &mut results);
                std::mem::forget(guard);
                let busy = t.elapsed().as_secs_f64();
                q = self.lock_queue();
                q.busy = false;
                q.stats.dispatches += 1;
                q.stats.states += batch.len() as u64;
                q.stats.device_busy_s += busy;
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
                if batch.capacity() > q.spare_states.capacity() {
                    q.spare_states = batch;
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
}

impl Drop for PanicGuard<'_> {
    fn drop(&mut self) {
        let mut q = self.dispatcher.lock_queue();
        q.busy = false;
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
        self.dispatcher.integrate(states, out)
    }

    /// Finite-film calls are not merged: they take the backend in turn.
    fn integrate_finite(
        &mut self,
        jobs: &[FiniteJob],
        grid: &FiniteGrid,
        fields: &mut [Vec<f64>],
        out: &mut Vec<FilmIntegrals>,
        reports: &mut Vec<SolveReport>,
    ) -> Result<(), BackendError> {
        self.dispatcher
            .lock_backend()
            .integrate_finite(jobs, grid, fields, out, reports)
    }

    fn choice(&self) -> Option<BackendChoice> {
        self.dispatcher.choice.clone()
    }
}
