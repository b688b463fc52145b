//! Jacobians of the implicit methods (radau5/radau9 and BDF): from the system's own
//! structure where it forms them ([`BatchSystem::jacobians`]), else by forward differences,
//! one batched call per state component, with the column of a scale-invariant block derived
//! by Euler's relation ([`BatchSystem::scale_invariant_block`]).

use std::time::Instant;

use super::common::{end_with_fault, Packed, Track};
use super::system::{BatchSystem, Status};

/// Finite-difference increment of Jacobian column entry `v` with component scale `scale`.
pub(crate) fn jacobian_delta(v: f64, scale: f64) -> f64 {
    f64::EPSILON.sqrt() * v.abs().max(scale)
}

/// Scratch buffers of [`Jacobians::form`], kept between rounds.
pub(crate) struct Jacobians<F> {
    /// Components `0..jd` get columns.
    jd: usize,
    /// A block whose scale `f` ignores, inside the Jacobian's columns.
    block: Option<(usize, usize)>,
    /// Per variant: the block column derived rather than evaluated this round.
    derived: Vec<Option<usize>>,
    retry: Vec<usize>,
    buf: Packed<F>,
    f0: Vec<f64>,
    jac: Vec<f64>,
    cost: Vec<Option<u64>>,
}

impl<F: Clone> Jacobians<F> {
    /// Scratch for `n` variants of `sys`.
    pub(crate) fn new<S: BatchSystem<Fault = F>>(sys: &S, n: usize) -> Self {
        let d = sys.dim();
        let jd = sys.jacobian_dim().min(d);
        Jacobians {
            jd,
            block: sys
                .scale_invariant_block()
                .filter(|&(b0, len)| len >= 2 && b0 + len <= jd),
            derived: vec![None; n],
            retry: Vec::new(),
            buf: Packed::new(),
            f0: Vec::new(),
            jac: Vec::new(),
            cost: Vec::new(),
        }
    }

    /// Forms `jac[id]` (row-major `d x d`, columns `0..jd`) for every variant in `work` at
    /// its track's time and state `y[id * d..]`, where `f0[id * d..]` is `f` (evaluated
    /// just before). A variant whose state faults both ways in a column ends there
    /// (`Status::Fault`, queued in `ended`). `work` is consumed.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn form<S: BatchSystem<Fault = F>>(
        &mut self,
        sys: &mut S,
        tracks: &mut [Track<F>],
        y: &[f64],
        f0: &[f64],
        scale: &[f64],
        jac: &mut [Vec<f64>],
        work: &mut Vec<usize>,
        ended: &mut Vec<usize>,
        start: Instant,
    ) {
        let d = sys.dim();
        let jd = self.jd;
        if sys.has_jacobians() && !work.is_empty() {
            self.buf.clear();
            self.f0.clear();
            for &id in work.iter() {
                self.buf
                    .push_from(id, tracks[id].t, y[id * d..(id + 1) * d].iter().copied());
                self.f0.extend_from_slice(&f0[id * d..(id + 1) * d]);
            }
            self.jac.clear();
            self.jac.resize(work.len() * d * d, 0.0);
            self.cost.clear();
            self.cost.resize(work.len(), None);
            sys.jacobians(
                &self.buf.ids,
                &self.buf.ts,
                &self.buf.ys,
                &self.f0,
                &mut self.jac,
                &mut self.cost,
            );
            for (k, &id) in self.buf.ids.iter().enumerate() {
                if let Some(c) = self.cost[k] {
                    tracks[id].stats.rhs_evaluations += c;
                    let src = &self.jac[k * d * d..(k + 1) * d * d];
                    for p in 0..d {
                        jac[id][p * d..p * d + jd].copy_from_slice(&src[p * d..p * d + jd]);
                    }
                }
            }
            let mut k = 0;
            work.retain(|_| {
                k += 1;
                self.cost[k - 1].is_none()
            });
        }
        // Each variant's column of the scale-invariant block derived from the others
        // (Euler's relation): the block's largest component, which is far from zero.
        for &id in work.iter() {
            self.derived[id] = self.block.and_then(|(b0, len)| {
                let yb = &y[id * d + b0..id * d + b0 + len];
                let (k, v) = yb
                    .iter()
                    .enumerate()
                    .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))?;
                (v.abs() > 0.0 && v.is_finite()).then_some(b0 + k)
            });
        }
        for col in 0..jd {
            self.buf.clear();
            for &id in work.iter() {
                if self.derived[id] == Some(col) {
                    continue;
                }
                let slot =
                    self.buf
                        .push_from(id, tracks[id].t, y[id * d..(id + 1) * d].iter().copied());
                slot[col] += jacobian_delta(slot[col], scale[id * d + col]);
            }
            self.buf.eval(sys, tracks);
            // A forward difference can leave the domain (a journal 1e-10 m off the wall
            // is pushed through it by the probe of a quaternion component, 1.5e-8 rad):
            // those columns are retried as backward differences, which move the other
            // way; only a state faulting both ways ends the variant.
            self.retry.clear();
            for e in 0..self.buf.len() {
                let id = self.buf.ids[e];
                if self.buf.faults[e].is_some() {
                    self.retry.push(id);
                    continue;
                }
                let del = self.buf.ys[e * d + col] - y[id * d + col];
                for p in 0..d {
                    jac[id][p * d + col] = (self.buf.dys[e * d + p] - f0[id * d + p]) / del;
                }
            }
            if self.retry.is_empty() {
                continue;
            }
            self.buf.clear();
            for &id in &self.retry {
                let slot =
                    self.buf
                        .push_from(id, tracks[id].t, y[id * d..(id + 1) * d].iter().copied());
                slot[col] -= jacobian_delta(slot[col], scale[id * d + col]);
            }
            self.buf.eval(sys, tracks);
            for e in 0..self.buf.len() {
                let id = self.buf.ids[e];
                if let Some(f) = &self.buf.faults[e] {
                    if matches!(tracks[id].status, Status::Running) {
                        end_with_fault(tracks, id, f, start, ended);
                    }
                    continue;
                }
                let del = self.buf.ys[e * d + col] - y[id * d + col];
                for p in 0..d {
                    jac[id][p * d + col] = (self.buf.dys[e * d + p] - f0[id * d + p]) / del;
                }
            }
        }
        // The derived columns: y_c* ∂f_r/∂y_c* = [r ∈ B] f_r − Σ_{c ∈ B, c ≠ c*} y_c ∂f_r/∂y_c.
        if let Some((b0, len)) = self.block {
            for &id in work.iter() {
                let Some(cs) = self.derived[id] else { continue };
                if !matches!(tracks[id].status, Status::Running) {
                    continue;
                }
                let yb = &y[id * d..(id + 1) * d];
                let jm = &mut jac[id];
                for p in 0..d {
                    let mut s = if (b0..b0 + len).contains(&p) {
                        f0[id * d + p]
                    } else {
                        0.0
                    };
                    for c in (b0..b0 + len).filter(|&c| c != cs) {
                        s -= yb[c] * jm[p * d + c];
                    }
                    jm[p * d + cs] = s / yb[cs];
                }
            }
        }
    }
}
