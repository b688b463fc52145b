//! The batched front end every caller uses: validate and pack on the host, one backend
//! call for all good states, CPU recomputation of anything non-finite, loads out.

use super::{BackendInfo, CpuBackend, FilmBackend};
use crate::bearing::{
    finish_loads, pack_state, BearingParams, BearingState, FilmIntegrals, Loads, PackedState,
    StateFault,
};

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

/// Counters over the evaluator's lifetime.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct EvalStats {
    /// Backend calls made.
    pub calls: u64,
    /// States evaluated (including rejected ones).
    pub states: u64,
    /// States recomputed on the CPU after a backend failure or a non-finite result.
    pub cpu_recomputed: u64,
}

/// Batched load evaluation over any backend, with its scratch buffers kept between calls.
pub struct LoadEvaluator {
    backend: Box<dyn FilmBackend>,
    fallback: Option<CpuBackend>,
    packed: Vec<PackedState>,
    scales: Vec<f64>,
    slots: Vec<usize>,
    integrals: Vec<FilmIntegrals>,
    notices: Vec<String>,
    stats: EvalStats,
}

impl LoadEvaluator {
    /// Wraps `backend`; a non-CPU backend gets a CPU fallback at the same rule settings.
    pub fn new(backend: Box<dyn FilmBackend>) -> Self {
        let info = backend.info();
        let fallback =
            (info.name != "cpu").then(|| CpuBackend::with_settings(backend.settings(), None));
        LoadEvaluator {
            backend,
            fallback,
            packed: Vec::new(),
            scales: Vec::new(),
            slots: Vec::new(),
            integrals: Vec::new(),
            notices: Vec::new(),
            stats: EvalStats::default(),
        }
    }

    /// The backend's description.
    pub fn info(&self) -> BackendInfo {
        self.backend.info()
    }

    /// The backend itself.
    pub fn backend(&self) -> &dyn FilmBackend {
        self.backend.as_ref()
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
        out.clear();
        self.packed.clear();
        self.scales.clear();
        self.slots.clear();
        self.stats.calls += 1;
        self.stats.states += requests.len() as u64;
        let bearing_ok: Vec<Result<(), StateFault>> = bearings
            .iter()
            .map(|b| {
                b.validate().map_err(|e| StateFault::InvalidBearing {
                    field: e.field,
                    reason: e.reason,
                })
            })
            .collect();
        for (k, req) in requests.iter().enumerate() {
            let result = match bearings.get(req.bearing as usize) {
                None => Err(StateFault::InvalidBearing {
                    field: "bearing",
                    reason: "index out of range",
                }),
                Some(params) => {
                    bearing_ok[req.bearing as usize].and_then(|_| pack_state(params, &req.state))
                }
            };
            match result {
                Ok(p) => {
                    // Final loads of a film without pressure; a placeholder otherwise,
                    // overwritten below.
                    out.push(
                        finish_loads(&bearings[req.bearing as usize], &req.state, &[0.0; 4], 0.0)
                            .finite_or_fault(),
                    );
                    if p.rate_scale > 0.0 {
                        self.packed.push(p.state);
                        self.scales.push(p.rate_scale);
                        self.slots.push(k);
                    }
                }
                Err(fault) => out.push(Err(fault)),
            }
        }
        if self.packed.is_empty() {
            return;
        }
        if let Err(e) = self.backend.integrate(&self.packed, &mut self.integrals) {
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
                    for &k in &self.slots {
                        out[k] = Err(StateFault::BackendNonFinite);
                    }
                    return;
                }
            }
        }
        let mut bad: Vec<usize> = (0..self.packed.len())
            .filter(|&n| {
                self.integrals
                    .get(n)
                    .is_none_or(|v| !v.iter().all(|x| x.is_finite()))
            })
            .collect();
        if !bad.is_empty() {
            if let Some(cpu) = self.fallback.as_mut() {
                let states: Vec<PackedState> = bad.iter().map(|&n| self.packed[n]).collect();
                let mut fixed = Vec::new();
                let _ = cpu.integrate(&states, &mut fixed);
                self.integrals.resize(self.packed.len(), [f64::NAN; 4]);
                for (&n, v) in bad.iter().zip(fixed) {
                    self.integrals[n] = v;
                }
                self.stats.cpu_recomputed += bad.len() as u64;
                self.notices.push(format!(
                    "notice: {} non-finite results recomputed on the CPU",
                    bad.len()
                ));
                bad.retain(|&n| !self.integrals[n].iter().all(|x| x.is_finite()));
            }
        }
        for (n, &k) in self.slots.iter().enumerate() {
            if bad.contains(&n) {
                out[k] = Err(StateFault::BackendNonFinite);
                continue;
            }
            let req = &requests[k];
            out[k] = finish_loads(
                &bearings[req.bearing as usize],
                &req.state,
                &self.integrals[n],
                self.scales[n],
            )
            .finite_or_fault();
        }
    }
}
