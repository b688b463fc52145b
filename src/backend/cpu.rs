//! The CPU kernel: the reference implementation and the fallback, on a rayon pool.

use std::sync::Arc;

use rayon::prelude::*;

use super::{BackendError, BackendInfo, FilmBackend, Precision};
use crate::bearing::finite::{FiniteGrid, FiniteJob, SolveReport};
use crate::bearing::{Accuracy, FilmIntegrals, FilmRule, PackedState, RuleSettings};

/// States per parallel task: large enough to amortise scheduling (a state costs ~1 µs).
const CHUNK: usize = 256;

/// The default rule on the CPU.
pub struct CpuBackend {
    rule: FilmRule,
    pool: Option<Arc<rayon::ThreadPool>>,
    threads: usize,
}

impl CpuBackend {
    /// A CPU backend at `accuracy` on `threads` threads (`None`: all cores, rayon's
    /// global pool; `Some(1)`: the calling thread only).
    pub fn new(accuracy: Accuracy, threads: Option<usize>) -> Self {
        Self::with_settings(accuracy.settings(), threads)
    }

    /// A CPU backend running the rule with explicit `settings`.
    pub fn with_settings(settings: RuleSettings, threads: Option<usize>) -> Self {
        let (pool, threads) = match threads {
            Some(n) if n > 1 => (
                rayon::ThreadPoolBuilder::new()
                    .num_threads(n)
                    .build()
                    .ok()
                    .map(Arc::new),
                n,
            ),
            Some(_) => (None, 1),
            None => (None, rayon::current_num_threads()),
        };
        CpuBackend {
            rule: FilmRule::new(settings),
            pool,
            threads,
        }
    }

    /// The rule this backend runs.
    pub fn rule(&self) -> &FilmRule {
        &self.rule
    }
}

impl FilmBackend for CpuBackend {
    fn info(&self) -> BackendInfo {
        BackendInfo {
            name: "cpu".into(),
            device: format!("{} thread(s)", self.threads),
            precision: Precision::F64,
        }
    }

    fn settings(&self) -> RuleSettings {
        *self.rule.settings()
    }

    fn integrate(
        &mut self,
        states: &[PackedState],
        out: &mut Vec<FilmIntegrals>,
    ) -> Result<(), BackendError> {
        out.clear();
        out.resize(states.len(), [0.0; 4]);
        let rule = &self.rule;
        let run = |out: &mut [FilmIntegrals], states: &[PackedState]| {
            // Root searches of several states in SIMD lanes; the same bits as one state
            // at a time.
            rule.integrate_many(states, out);
        };
        if self.threads == 1 || states.len() <= CHUNK {
            run(out, states);
        } else {
            let mut par = || {
                out.par_chunks_mut(CHUNK)
                    .zip(states.par_chunks(CHUNK))
                    .for_each(|(o, s)| run(o, s))
            };
            match &self.pool {
                Some(pool) => pool.install(&mut par),
                None => par(),
            }
        }
        Ok(())
    }

    fn integrate_finite(
        &mut self,
        jobs: &[FiniteJob],
        grid: &FiniteGrid,
        fields: &mut [Vec<f64>],
        out: &mut Vec<FilmIntegrals>,
        reports: &mut Vec<SolveReport>,
    ) -> Result<(), BackendError> {
        let parallel = self.threads > 1;
        let mut run =
            || super::finite::cpu_integrate_finite(jobs, grid, fields, out, reports, parallel);
        match &self.pool {
            Some(pool) => pool.install(&mut run),
            None => run(),
        }
        Ok(())
    }
}
