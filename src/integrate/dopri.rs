//! Dormand-Prince 5(4) in lockstep: six batched stage calls per round (first-same-as-last),
//! PI step-size control, the 4th-order continuous extension for samples.

use std::time::Instant;

use super::common::{
    end, err_norm, finite, h_floor, notify, plan_steps, start_explicit, status_after_accepted,
    Packed, Track,
};
use super::system::{BatchSystem, Settings, Stats, Status};

/// Nodes `c_s`.
const C: [f64; 7] = [0.0, 0.2, 0.3, 0.8, 8.0 / 9.0, 1.0, 1.0];

/// Runge-Kutta matrix rows `a_{s,0..s}` (row 6 is the 5th-order solution `b`).
const A: [&[f64]; 7] = [
    &[],
    &[0.2],
    &[3.0 / 40.0, 9.0 / 40.0],
    &[44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0],
    &[
        19372.0 / 6561.0,
        -25360.0 / 2187.0,
        64448.0 / 6561.0,
        -212.0 / 729.0,
    ],
    &[
        9017.0 / 3168.0,
        -355.0 / 33.0,
        46732.0 / 5247.0,
        49.0 / 176.0,
        -5103.0 / 18656.0,
    ],
    &[
        35.0 / 384.0,
        0.0,
        500.0 / 1113.0,
        125.0 / 192.0,
        -2187.0 / 6784.0,
        11.0 / 84.0,
    ],
];

/// Error weights `b - b*` (5th minus embedded 4th order).
const E: [f64; 7] = [
    71.0 / 57600.0,
    0.0,
    -71.0 / 16695.0,
    71.0 / 1920.0,
    -17253.0 / 339200.0,
    22.0 / 525.0,
    -1.0 / 40.0,
];

/// Dense-output weights of the continuous extension (Hairer, Norsett, Wanner, II.6).
const D: [f64; 7] = [
    -12715105075.0 / 11282082432.0,
    0.0,
    87487479700.0 / 32700410799.0,
    -10690763975.0 / 1880347072.0,
    701980252875.0 / 199316789632.0,
    -1453857185.0 / 822651844.0,
    69997945.0 / 29380423.0,
];

/// PI controller: exponents `alpha = 1/5 - 0.75 beta`, `beta = 0.04`, safety 0.9.
const ALPHA: f64 = 0.2 - 0.75 * BETA;
const BETA: f64 = 0.04;
const SAFETY: f64 = 0.9;
/// Step-size change bounds per step.
const FAC_MIN: f64 = 0.2;
const FAC_MAX: f64 = 10.0;
/// Step shrink after a right-hand-side fault in a stage.
const FAULT_SHRINK: f64 = 0.25;

/// Stiffness test after Hairer's DOPRI5 (Hairer-Wanner, Solving ODEs II, IV.2): `h |λ|`,
/// estimated per accepted step as `h ‖k7 − k6‖ / ‖y7 − y6‖` (two evaluations at `t + h`),
/// above this value means the steps are held by a fast mode. Hairer uses 3.25, the
/// method's stability boundary on the negative real axis (~3.3), which flags only
/// stability-limited variants; this used 2.5 (the clearance x viscosity sweep's δ = 1e-4 m,
/// μ = 0.1 Pa·s variant sits at h |λ| ≈ 3.0). But the film rotors' dopri5 steps follow a
/// film-damped fast mode (near the nutation `(I_p/I_t) Ω`) at h |λ| 0.8-2.1 throughout,
/// accuracy-limited, which L-stable radau5 steps over: 4.5x fewer steps at the same error
/// on issue 28's grid9 workload, 1.5-1.9x fewer instructions at equal error since radau5
/// reuses its Jacobians (BENCHMARKS.md "Issue 28, fourth pass"). So a variant whose steps
/// keep h |λ| above 0.7 (about 9 steps per period of an oscillating mode, coarser than
/// dopri5 follows a lightly damped oscillation at rtol 1e-5 and below:
/// tests/integrators.rs) is handed over. The price where the fast mode is an oscillation
/// that must be followed at a looser tolerance: radau5 resolves it too, at up to ~1.5x
/// dopri5's cost per step...
const STIFF_H_LAMBDA: f64 = 0.7;
/// ... for this many accepted steps without [`NONSTIFF_RESET`] steps below it in
/// between: the variant is stiff.
const STIFF_STEPS: u32 = 15;
/// Accepted steps below [`STIFF_H_LAMBDA`] that clear the count.
const NONSTIFF_RESET: u32 = 6;

/// Per-variant state of the stiffness test.
#[derive(Clone, Copy, Default)]
struct StiffCount {
    stiff: u32,
    nonstiff: u32,
}

impl StiffCount {
    /// Counts one accepted step with estimate `h_lambda`; true when the variant is stiff.
    fn observe(&mut self, h_lambda: f64) -> bool {
        if h_lambda > STIFF_H_LAMBDA {
            self.nonstiff = 0;
            self.stiff += 1;
            self.stiff >= STIFF_STEPS
        } else {
            self.nonstiff += 1;
            if self.nonstiff >= NONSTIFF_RESET {
                self.stiff = 0;
            }
            false
        }
    }
}

/// `h ‖k7 − k6‖ / ‖y7 − y6‖` in the norm weighted by the component scales (the
/// stiffness estimate of Hairer's DOPRI5); 0 where `y7 = y6`.
fn h_lambda(h: f64, k6: &[f64], k7: &[f64], y6: &[f64], y7: &[f64], scale: &[f64]) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for i in 0..k6.len() {
        let w = 1.0 / scale[i];
        num += ((k7[i] - k6[i]) * w).powi(2);
        den += ((y7[i] - y6[i]) * w).powi(2);
    }
    if den > 0.0 {
        h * (num / den).sqrt()
    } else {
        0.0
    }
}

/// The larger of the estimates in the natural scales and in the error weights' scales:
/// each is a Rayleigh-type lower bound of the stiffest rate, seeing best the modes its
/// weights emphasise.
#[allow(clippy::too_many_arguments)]
fn h_lambda_max(
    h: f64,
    k6: &[f64],
    k7: &[f64],
    y6: &[f64],
    y7: &[f64],
    natural: &[f64],
    error: &[f64],
) -> f64 {
    h_lambda(h, k6, k7, y6, y7, natural).max(h_lambda(h, k6, k7, y6, y7, error))
}

/// Integrates the batch with dopri5. With `switch` (method `auto`), a variant found stiff
/// by Hairer's test is taken out of the dopri5 batch after that step (its samples so far
/// recorded) and continued by radau5 ([`super::radau::continue_from`]), all handed-over
/// variants in one lockstep batch once the dopri5 batch has ended.
pub(crate) fn run<S: BatchSystem>(
    sys: &mut S,
    y0: &[f64],
    settings: &[Settings],
    start: Instant,
    switch: bool,
) -> Vec<(Status<S::Fault>, Stats)> {
    let n = settings.len();
    let d = sys.dim();
    let mut tracks: Vec<Track<S::Fault>> = settings.iter().map(Track::new).collect();
    let mut y = y0.to_vec();
    let mut ynew = vec![0.0; n * d];
    let mut k: [Vec<f64>; 7] = std::array::from_fn(|_| vec![0.0; n * d]);
    let mut scale = vec![1.0; n * d];
    for id in 0..n {
        sys.scales(id, &mut scale[id * d..(id + 1) * d]);
    }
    let mut err_old: Vec<f64> = vec![1e-4; n];
    let mut hs = vec![0.0; n];
    let mut stage_ok = vec![true; n];
    let mut errv = vec![0.0; d];
    let mut buf = Packed::new();
    let mut rec = Packed::new();
    let mut ended = Vec::new();
    let mut stiff_count = vec![StiffCount::default(); n];
    let mut handed: Vec<usize> = Vec::new();
    // Stage 6's input (the point of k6), for the stiffness test.
    let mut ysti = if switch { vec![0.0; n * d] } else { Vec::new() };
    let mut stiff_scale = if switch { vec![1.0; n * d] } else { Vec::new() };
    if switch {
        for id in 0..n {
            sys.stiffness_scales(id, &mut stiff_scale[id * d..(id + 1) * d]);
        }
    }

    let mut active = start_explicit(
        sys,
        &mut tracks,
        settings,
        &y,
        &scale,
        &mut k[0],
        &mut buf,
        &mut rec,
        &mut ended,
        start,
    );

    while !active.is_empty() {
        plan_steps(&active, &tracks, settings, &mut hs, &mut stage_ok);
        for st in 1..7 {
            buf.clear();
            for &id in &active {
                if !stage_ok[id] {
                    continue;
                }
                let h = hs[id];
                let slot = buf.push(id, tracks[id].t + C[st] * h, d);
                let base = id * d;
                for (i, out) in slot.iter_mut().enumerate() {
                    let mut acc = 0.0;
                    for (j, a) in A[st].iter().enumerate() {
                        acc += a * k[j][base + i];
                    }
                    *out = y[base + i] + h * acc;
                }
                if st == 6 {
                    ynew[base..base + d].copy_from_slice(slot);
                } else if st == 5 && switch {
                    ysti[base..base + d].copy_from_slice(slot);
                }
            }
            buf.eval(sys, &mut tracks);
            for e in 0..buf.len() {
                let id = buf.ids[e];
                match &buf.faults[e] {
                    Some(f) => {
                        stage_ok[id] = false;
                        tracks[id].fault = Some(f.clone());
                    }
                    None => {
                        k[st][id * d..(id + 1) * d].copy_from_slice(&buf.dys[e * d..(e + 1) * d])
                    }
                }
            }
        }
        for &id in &active {
            let s = &settings[id];
            let tr = &mut tracks[id];
            let h = hs[id];
            let t0 = tr.t;
            let r = id * d..(id + 1) * d;
            let fixed = s.fixed_step.is_some();
            if !stage_ok[id] {
                tr.stats.rejected += 1;
                tr.last_rejected = true;
                tr.h = h * FAULT_SHRINK;
                if fixed || tr.h < h_floor(t0, s.t_end) {
                    let fault = tr.fault.clone().expect("a stage fault was recorded");
                    end(tr, Status::Fault { time: t0, fault }, start);
                    ended.push(id);
                }
                continue;
            }
            for (i, ev) in errv.iter_mut().enumerate() {
                let mut acc = 0.0;
                for (j, e) in E.iter().enumerate() {
                    acc += e * k[j][id * d + i];
                }
                *ev = h * acc;
            }
            let norm = if fixed {
                0.0
            } else {
                err_norm(&errv, &y[r.clone()], &ynew[r.clone()], &scale[r.clone()], s)
            };
            if !norm.is_finite() || !finite(&ynew[r.clone()]) {
                tr.stats.rejected += 1;
                tr.last_rejected = true;
                tr.h = h * FAC_MIN;
                if fixed || tr.h < h_floor(t0, s.t_end) {
                    end(tr, Status::NonFinite { time: t0 }, start);
                    ended.push(id);
                }
                continue;
            }
            if norm <= 1.0 {
                {
                    let (ya, yb) = (&y[r.clone()], &ynew[r.clone()]);
                    let base = id * d;
                    let k = &k;
                    tr.emit(id, s, t0, h, d, &mut rec, |th, out| {
                        for (i, o) in out.iter_mut().enumerate() {
                            let rc2 = yb[i] - ya[i];
                            let rc3 = h * k[0][base + i] - rc2;
                            let rc4 = rc2 - h * k[6][base + i] - rc3;
                            let mut acc = 0.0;
                            for (j, dj) in D.iter().enumerate() {
                                acc += dj * k[j][base + i];
                            }
                            let rc5 = h * acc;
                            *o = ya[i]
                                + th * (rc2 + (1.0 - th) * (rc3 + th * (rc4 + (1.0 - th) * rc5)));
                        }
                    });
                }
                tr.t = if h == s.t_end - t0 { s.t_end } else { t0 + h };
                y[r.clone()].copy_from_slice(&ynew[r.clone()]);
                sys.project(id, &mut y[r.clone()]);
                let (k0, rest) = k.split_at_mut(1);
                k0[0][r.clone()].copy_from_slice(&rest[5][r.clone()]);
                tr.stats.steps += 1;
                let fac_max = if tr.last_rejected { 1.0 } else { FAC_MAX };
                let fac = if norm == 0.0 {
                    FAC_MAX
                } else {
                    SAFETY * norm.powf(-ALPHA) * err_old[id].powf(BETA)
                };
                tr.h = if fixed {
                    s.fixed_step.unwrap_or(h)
                } else {
                    h * fac.clamp(FAC_MIN, fac_max)
                };
                err_old[id] = norm.max(1e-4);
                tr.last_rejected = false;
                if let Some(status) = status_after_accepted(tr, s) {
                    end(tr, status, start);
                    ended.push(id);
                } else if switch && !fixed {
                    let hl = h_lambda_max(
                        h,
                        &k[5][r.clone()],
                        &k[6][r.clone()],
                        &ysti[r.clone()],
                        &ynew[r.clone()],
                        &stiff_scale[r.clone()],
                        &scale[r.clone()],
                    );
                    if stiff_count[id].observe(hl) {
                        tr.stats.stiff_switch_time = Some(tr.t);
                        handed.push(id);
                    }
                }
            } else {
                tr.stats.rejected += 1;
                tr.last_rejected = true;
                tr.h = h * (SAFETY * norm.powf(-0.2)).max(FAC_MIN);
                if tr.h < h_floor(t0, s.t_end) {
                    let step = tr.h;
                    end(tr, Status::StepSizeTooSmall { time: t0, step }, start);
                    ended.push(id);
                }
            }
        }
        active.retain(|&id| {
            matches!(tracks[id].status, Status::Running)
                && tracks[id].stats.stiff_switch_time.is_none()
        });
        rec.flush_records(sys);
        notify(sys, &tracks, &mut ended);
    }
    if !handed.is_empty() {
        super::radau::continue_from(
            sys,
            &mut y,
            settings,
            &mut tracks,
            handed,
            start,
            super::radau::Stages::Three,
        );
    }
    tracks.into_iter().map(|t| (t.status, t.stats)).collect()
}
