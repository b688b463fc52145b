//! The lockstep DOP853 (issue 28) on closed-form problems: order 8 at the step ends and
//! order 7 through its dense output under step halving, an adaptive batch against the
//! closed form at every sample, fewer right-hand-side evaluations than dopri5 at a tight
//! tolerance, and a batch equal to single runs.

#![allow(clippy::needless_range_loop)]

use bearing_sweep::integrate::{run_batch, BatchSystem, Method, Settings, Stats, Status};

/// Damped oscillators `x'' + 2 ζ w x' + w² x = 0` (`ζ = 0.1`), `w` per variant.
struct Springs {
    w: Vec<f64>,
    samples: Vec<Vec<(f64, [f64; 2])>>,
    evals: u64,
}

impl Springs {
    fn new(w: Vec<f64>) -> Self {
        let n = w.len();
        Springs {
            w,
            samples: vec![Vec::new(); n],
            evals: 0,
        }
    }
}

impl BatchSystem for Springs {
    type Fault = String;
    fn dim(&self) -> usize {
        2
    }
    fn eval(
        &mut self,
        ids: &[usize],
        _ts: &[f64],
        ys: &[f64],
        dys: &mut [f64],
        _faults: &mut [Option<String>],
    ) {
        for (k, &id) in ids.iter().enumerate() {
            let w = self.w[id];
            self.evals += 1;
            dys[2 * k] = ys[2 * k + 1];
            dys[2 * k + 1] = -2.0 * 0.1 * w * ys[2 * k + 1] - w * w * ys[2 * k];
        }
    }
    fn record(&mut self, ids: &[usize], ts: &[f64], ys: &[f64]) {
        for (k, &id) in ids.iter().enumerate() {
            self.samples[id].push((ts[k], [ys[2 * k], ys[2 * k + 1]]));
        }
    }
    fn finished(&mut self, _id: usize, _status: &Status<String>, _stats: &Stats) {}
}

/// Closed form from `x = 1, v = 0`.
fn exact(t: f64, w: f64) -> [f64; 2] {
    let z: f64 = 0.1;
    let wd = w * (1.0 - z * z).sqrt();
    let e = (-z * w * t).exp();
    let (s, c) = (wd * t).sin_cos();
    let x = e * (c + z * w / wd * s);
    let v = e * (-wd * s + z * w * c) - z * w * x;
    [x, v]
}

/// Max error of x over the samples and at the last sample, at fixed step `h`.
fn fixed_step_errors(h: f64, dt: f64) -> (f64, f64) {
    let w = 2.0 * std::f64::consts::PI;
    let mut sys = Springs::new(vec![w]);
    let set = [Settings {
        t_end: 1.0,
        sample_interval: dt,
        rtol: 1e-14,
        atol: 1e-14,
        fixed_step: Some(h),
        ..Settings::default()
    }];
    let out = run_batch(Method::Dop853, &mut sys, &[1.0, 0.0], &set);
    assert_eq!(out[0].0, Status::Finished, "h={h}");
    let (mut max, mut last) = (0.0f64, 0.0);
    for (t, y) in &sys.samples[0] {
        let e = (y[0] - exact(*t, w)[0]).abs();
        max = max.max(e);
        last = e;
    }
    (max, last)
}

#[test]
fn dop853_converges_at_order_8_at_step_ends_and_7_through_dense_output() {
    let hs = [1.0 / 10.0, 1.0 / 20.0, 1.0 / 40.0];
    let ends: Vec<f64> = hs.iter().map(|&h| fixed_step_errors(h, 0.1).1).collect();
    let dense: Vec<f64> = hs.iter().map(|&h| fixed_step_errors(h, 0.0137).0).collect();
    eprintln!("dop853: step-end errors {ends:?}, dense {dense:?}");
    for k in 0..2 {
        let order = (ends[k] / ends[k + 1]).log2();
        assert!(
            (order - 8.0).abs() < 0.5,
            "step-end order between h={} and h={}: {order:.3} ({:.3e}, {:.3e})",
            hs[k],
            hs[k + 1],
            ends[k],
            ends[k + 1]
        );
        let order = (dense[k] / dense[k + 1]).log2();
        assert!(
            order > 7.0 - 0.5,
            "dense-output order between h={} and h={}: {order:.3} ({:.3e}, {:.3e})",
            hs[k],
            hs[k + 1],
            dense[k],
            dense[k + 1]
        );
    }
}

fn adaptive(method: Method, ws: &[f64], tol: f64) -> (Springs, Vec<(Status<String>, Stats)>) {
    let mut sys = Springs::new(ws.to_vec());
    let y0: Vec<f64> = ws.iter().flat_map(|_| [1.0, 0.0]).collect();
    let set: Vec<Settings> = ws
        .iter()
        .map(|_| Settings {
            t_end: 2.0,
            sample_interval: 0.013,
            rtol: tol,
            atol: tol,
            ..Settings::default()
        })
        .collect();
    let out = run_batch(method, &mut sys, &y0, &set);
    (sys, out)
}

#[test]
fn adaptive_dop853_matches_the_closed_form_with_fewer_evaluations_than_dopri5() {
    let ws = [2.0 * std::f64::consts::PI, 3.0, 7.5];
    let (sys, out) = adaptive(Method::Dop853, &ws, 1e-10);
    for (id, &w) in ws.iter().enumerate() {
        assert_eq!(out[id].0, Status::Finished);
        let samples = &sys.samples[id];
        assert_eq!(samples.len(), 154, "samples at k * 0.013 <= 2");
        for (k, (t, y)) in samples.iter().enumerate() {
            assert!((t - k as f64 * 0.013).abs() < 1e-15, "sample time {t}");
            let ex = exact(*t, w);
            for c in 0..2 {
                let err = (y[c] - ex[c]).abs() / w.powi(c as i32);
                assert!(err < 2e-8, "w={w} sample {k} t={t} comp {c}: error {err:e}");
            }
        }
    }
    let (dsys, _) = adaptive(Method::Dopri5, &ws, 1e-10);
    eprintln!(
        "rhs evaluations at tol 1e-10: dop853 {}, dopri5 {}",
        sys.evals, dsys.evals
    );
    assert!(
        2 * sys.evals < dsys.evals,
        "dop853 {} evaluations, dopri5 {}",
        sys.evals,
        dsys.evals
    );
}

#[test]
fn a_dop853_batch_equals_single_runs() {
    let ws = [2.0 * std::f64::consts::PI, 3.0, 7.5];
    let (batch, _) = adaptive(Method::Dop853, &ws, 1e-8);
    for (id, &w) in ws.iter().enumerate() {
        let (single, _) = adaptive(Method::Dop853, &[w], 1e-8);
        assert_eq!(batch.samples[id], single.samples[0], "variant {id}");
    }
}
