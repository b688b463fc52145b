//! The lockstep integrators on problems with closed-form solutions: a damped linear
//! oscillator and a torque-free symmetric gyroscope through every method, each method's
//! convergence order at the step ends and through its dense output, lockstep batches
//! equal single runs, and one failing variant ending alone.

#![allow(clippy::needless_range_loop)]

use bearing_sweep::integrate::{run_batch, BatchSystem, Method, Settings, Stats, Status};

/// A batch of identical-form ODEs `y' = f(t, y, p)` with a per-variant parameter `p`.
struct Ode<F: FnMut(f64, &[f64], f64, &mut [f64]) -> Result<(), String>> {
    dim: usize,
    f: F,
    params: Vec<f64>,
    samples: Vec<Vec<(f64, Vec<f64>)>>,
    statuses: Vec<Option<Status<String>>>,
    calls: usize,
}

impl<F: FnMut(f64, &[f64], f64, &mut [f64]) -> Result<(), String>> Ode<F> {
    fn new(dim: usize, params: Vec<f64>, f: F) -> Self {
        let n = params.len();
        Ode {
            dim,
            f,
            params,
            samples: vec![Vec::new(); n],
            statuses: vec![None; n],
            calls: 0,
        }
    }
}

impl<F: FnMut(f64, &[f64], f64, &mut [f64]) -> Result<(), String>> BatchSystem for Ode<F> {
    type Fault = String;
    fn dim(&self) -> usize {
        self.dim
    }
    fn eval(
        &mut self,
        ids: &[usize],
        ts: &[f64],
        ys: &[f64],
        dys: &mut [f64],
        faults: &mut [Option<String>],
    ) {
        self.calls += 1;
        let d = self.dim;
        for (k, &id) in ids.iter().enumerate() {
            if let Err(e) = (self.f)(
                ts[k],
                &ys[k * d..(k + 1) * d],
                self.params[id],
                &mut dys[k * d..(k + 1) * d],
            ) {
                faults[k] = Some(e);
            }
        }
    }
    fn project(&self, _id: usize, y: &mut [f64]) {
        if self.dim == 7 {
            let n = (y[0] * y[0] + y[1] * y[1] + y[2] * y[2] + y[3] * y[3]).sqrt();
            y[..4].iter_mut().for_each(|v| *v /= n);
        }
    }
    fn record(&mut self, ids: &[usize], ts: &[f64], ys: &[f64]) {
        let d = self.dim;
        for (k, &id) in ids.iter().enumerate() {
            self.samples[id].push((ts[k], ys[k * d..(k + 1) * d].to_vec()));
        }
    }
    fn finished(&mut self, id: usize, status: &Status<String>, _stats: &Stats) {
        assert!(self.statuses[id].is_none(), "variant {id} finished twice");
        self.statuses[id] = Some(status.clone());
    }
}

const METHODS: [Method; 3] = [Method::Dopri5, Method::Radau5, Method::Rk4];

/// Damped oscillator `x'' + 2 zeta w x' + w^2 x = 0`, `w = p`, `zeta = 0.1`.
fn spring(_t: f64, y: &[f64], w: f64, dy: &mut [f64]) -> Result<(), String> {
    dy[0] = y[1];
    dy[1] = -2.0 * 0.1 * w * y[1] - w * w * y[0];
    Ok(())
}

/// Closed form of [`spring`] from `x = 1, v = 0`: `(x, v)`.
fn spring_exact(t: f64, w: f64) -> [f64; 2] {
    let z: f64 = 0.1;
    let wd = w * (1.0 - z * z).sqrt();
    let e = (-z * w * t).exp();
    let (s, c) = (wd * t).sin_cos();
    let x = e * (c + z * w / wd * s);
    let v = e * (-wd * s + z * w * c) - z * w * x;
    [x, v]
}

fn settings(method: Method, t_end: f64, dt: f64, tol: f64, fixed: Option<f64>) -> Settings {
    Settings {
        t_end,
        sample_interval: dt,
        rtol: tol,
        atol: tol,
        fixed_step: if method == Method::Rk4 {
            Some(fixed.unwrap_or(1e-3))
        } else {
            fixed
        },
        ..Settings::default()
    }
}

#[test]
fn damped_oscillator_matches_its_closed_form_through_every_method() {
    for method in METHODS {
        let ws = vec![2.0 * std::f64::consts::PI, 3.0, 7.5];
        let mut sys = Ode::new(2, ws.clone(), spring);
        let y0: Vec<f64> = ws.iter().flat_map(|_| [1.0, 0.0]).collect();
        let set: Vec<Settings> = ws
            .iter()
            .map(|_| settings(method, 2.0, 0.013, 1e-10, None))
            .collect();
        let out = run_batch(method, &mut sys, &y0, &set);
        let tol = 2e-8;
        for (id, &w) in ws.iter().enumerate() {
            assert_eq!(out[id].0, Status::Finished, "{method:?} variant {id}");
            let samples = &sys.samples[id];
            assert_eq!(samples.len(), 154, "{method:?}: samples at k * 0.013 <= 2");
            for (k, (t, y)) in samples.iter().enumerate() {
                assert!((t - k as f64 * 0.013).abs() < 1e-15, "sample time {t}");
                let ex = spring_exact(*t, w);
                for c in 0..2 {
                    let err = (y[c] - ex[c]).abs() / w.powi(c as i32);
                    assert!(
                        err < tol,
                        "{method:?} w={w} sample {k} t={t} comp {c}: got {}, want {}, tol {tol}",
                        y[c],
                        ex[c]
                    );
                }
            }
        }
    }
}

/// Torque-free body with `I = diag(1, 1, 2)`: state `(q0..q3, w1, w2, w3)`.
fn gyro(_t: f64, y: &[f64], _p: f64, dy: &mut [f64]) -> Result<(), String> {
    let (w0, x, yq, z) = (y[0], y[1], y[2], y[3]);
    let (a, b, c) = (y[4], y[5], y[6]);
    dy[0] = -0.5 * (x * a + yq * b + z * c);
    dy[1] = 0.5 * (w0 * a + yq * c - z * b);
    dy[2] = 0.5 * (w0 * b + z * a - x * c);
    dy[3] = 0.5 * (w0 * c + x * b - yq * a);
    let (i1, i3) = (1.0, 2.0);
    dy[4] = (i1 - i3) / i1 * b * c;
    dy[5] = (i3 - i1) / i1 * c * a;
    dy[6] = 0.0;
    Ok(())
}

type M3 = [[f64; 3]; 3];

fn quat_matrix(q: &[f64]) -> M3 {
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    let (w, x, y, z) = (q[0] / n, q[1] / n, q[2] / n, q[3] / n);
    [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ],
        [
            2.0 * (x * y + w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - w * x),
        ],
        [
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ]
}

fn axis_angle(u: [f64; 3], a: f64) -> M3 {
    let (s, c) = a.sin_cos();
    let t = 1.0 - c;
    let [x, y, z] = u;
    [
        [c + x * x * t, x * y * t - z * s, x * z * t + y * s],
        [y * x * t + z * s, c + y * y * t, y * z * t - x * s],
        [z * x * t - y * s, z * y * t + x * s, c + z * z * t],
    ]
}

fn mul(a: &M3, b: &M3) -> M3 {
    let mut r = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            r[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    r
}

/// Closed form: body rates turn about the symmetry axis at `lambda = (I3 - I1)/I1 w3`;
/// the attitude is a precession about the fixed angular momentum `L` at `|L| / I1`
/// composed with a body rotation about `z` at `-lambda`: `R = Rot(L, |L|t/I1) R0 Rot(z, -lambda t)`.
fn gyro_exact(t: f64, w0: [f64; 3]) -> ([f64; 3], M3) {
    let (i1, i3) = (1.0, 2.0);
    let lam = (i3 - i1) / i1 * w0[2];
    let (s, c) = (lam * t).sin_cos();
    let w = [w0[0] * c - w0[1] * s, w0[0] * s + w0[1] * c, w0[2]];
    let l = [i1 * w0[0], i1 * w0[1], i3 * w0[2]]; // R0 = I: L = I w0
    let ln = (l[0] * l[0] + l[1] * l[1] + l[2] * l[2]).sqrt();
    let r = mul(
        &axis_angle([l[0] / ln, l[1] / ln, l[2] / ln], ln * t / i1),
        &axis_angle([0.0, 0.0, 1.0], -lam * t),
    );
    (w, r)
}

#[test]
fn torque_free_symmetric_gyroscope_matches_its_closed_form_through_every_method() {
    let w0 = [0.6, -0.3, 2.0];
    for method in METHODS {
        let mut sys = Ode::new(7, vec![0.0], gyro);
        let y0 = [1.0, 0.0, 0.0, 0.0, w0[0], w0[1], w0[2]];
        let set = [settings(method, 3.0, 0.05, 1e-10, Some(5e-4)).with_adaptive(method)];
        let out = run_batch(method, &mut sys, &y0, &set);
        assert_eq!(out[0].0, Status::Finished, "{method:?}");
        let tol = 1e-7;
        for (t, y) in &sys.samples[0] {
            let (w, r) = gyro_exact(*t, w0);
            let rq = quat_matrix(y);
            for i in 0..3 {
                let e = (y[4 + i] - w[i]).abs();
                assert!(
                    e < tol,
                    "{method:?} t={t} w[{i}]: got {}, want {}, tol {tol}",
                    y[4 + i],
                    w[i]
                );
                for j in 0..3 {
                    let e = (rq[i][j] - r[i][j]).abs();
                    assert!(
                        e < tol,
                        "{method:?} t={t} R[{i}][{j}]: got {}, want {}, tol {tol}",
                        rq[i][j],
                        r[i][j]
                    );
                }
            }
        }
    }
}

trait Adaptive {
    fn with_adaptive(self, m: Method) -> Self;
}
impl Adaptive for Settings {
    /// Adaptive methods run adaptively; only RK4 keeps the fixed step.
    fn with_adaptive(mut self, m: Method) -> Self {
        if m != Method::Rk4 {
            self.fixed_step = None;
        }
        self
    }
}

/// Max error of the oscillator over the samples and at the end, at fixed step `h`.
fn fixed_step_errors(method: Method, h: f64, dt: f64) -> (f64, f64) {
    let w = 2.0 * std::f64::consts::PI;
    let mut sys = Ode::new(2, vec![w], spring);
    let set = [Settings {
        t_end: 1.0,
        sample_interval: dt,
        rtol: 1e-14,
        atol: 1e-14,
        fixed_step: Some(h),
        ..Settings::default()
    }];
    let out = run_batch(method, &mut sys, &[1.0, 0.0], &set);
    assert_eq!(out[0].0, Status::Finished, "{method:?} h={h}");
    let mut max = 0.0f64;
    let mut last = 0.0;
    for (t, y) in &sys.samples[0] {
        let e = (y[0] - spring_exact(*t, w)[0]).abs();
        max = max.max(e);
        last = e;
    }
    (max, last)
}

#[test]
fn each_method_converges_at_its_order_at_step_ends_and_through_dense_output() {
    // (method, order at step ends, order of the sampled (dense) output)
    let cases = [
        (Method::Rk4, 4.0, 4.0),
        (Method::Dopri5, 5.0, 5.0),
        (Method::Radau5, 5.0, 4.0),
    ];
    for (method, p, p_dense) in cases {
        let hs = [1.0 / 60.0, 1.0 / 120.0, 1.0 / 240.0];
        // Samples at the step ends (dt = 1/60) and between them (dt = 0.0137).
        let ends: Vec<f64> = hs
            .iter()
            .map(|&h| fixed_step_errors(method, h, 1.0 / 60.0).1)
            .collect();
        let dense: Vec<f64> = hs
            .iter()
            .map(|&h| fixed_step_errors(method, h, 0.0137).0)
            .collect();
        eprintln!("{method:?}: step-end errors {ends:?}, dense {dense:?}");
        for k in 0..2 {
            let order = (ends[k] / ends[k + 1]).log2();
            assert!(
                (order - p).abs() < 0.35,
                "{method:?} step-end order between h={} and h={}: {order:.3} (errors {:.3e}, {:.3e}), want {p} +- 0.35",
                hs[k], hs[k + 1], ends[k], ends[k + 1]
            );
            let order = (dense[k] / dense[k + 1]).log2();
            assert!(
                order > p_dense - 0.35,
                "{method:?} dense-output order between h={} and h={}: {order:.3} (errors {:.3e}, {:.3e}), want >= {p_dense} - 0.35",
                hs[k], hs[k + 1], dense[k], dense[k + 1]
            );
        }
    }
}

#[test]
fn a_batch_equals_single_runs_and_a_failing_variant_ends_alone() {
    // Variant 1 faults whenever x < -0.5 (reached near t = 0.5): it must end with the
    // fault at that time while the others finish exactly as they would alone.
    let f = |t: f64, y: &[f64], p: f64, dy: &mut [f64]| {
        if p < 0.0 && y[0] < -0.5 {
            return Err(format!("x below -0.5 at t = {t}"));
        }
        spring(t, y, p.abs(), dy)
    };
    for method in METHODS {
        let ws = vec![6.0, -6.0, 6.0, 9.0];
        let y0: Vec<f64> = ws.iter().flat_map(|_| [1.0, 0.0]).collect();
        let set: Vec<Settings> = ws
            .iter()
            .map(|_| settings(method, 1.5, 0.01, 1e-8, None))
            .collect();
        let mut batch = Ode::new(2, ws.clone(), f);
        let out = run_batch(method, &mut batch, &y0, &set);
        match &out[1].0 {
            Status::Fault { time, fault } => {
                assert!(
                    *time > 0.2 && *time < 0.6,
                    "{method:?}: fault at {time}: {fault}"
                );
            }
            other => panic!("{method:?}: variant 1 should fault, got {other:?}"),
        }
        assert!(batch.samples[1]
            .iter()
            .all(|(_, y)| y.iter().all(|v| v.is_finite())));
        for id in [0, 2, 3] {
            assert_eq!(out[id].0, Status::Finished, "{method:?} variant {id}");
            let mut single = Ode::new(2, vec![ws[id]], f);
            let one = run_batch(method, &mut single, &[1.0, 0.0], &set[id..id + 1]);
            assert_eq!(
                one[0].1.steps, out[id].1.steps,
                "{method:?} variant {id} steps"
            );
            assert_eq!(
                single.samples[0], batch.samples[id],
                "{method:?} variant {id} samples differ"
            );
        }
        assert_eq!(
            batch.samples[0], batch.samples[2],
            "{method:?}: identical variants differ"
        );
    }
}

#[test]
fn a_blow_up_ends_with_a_status_at_its_time_and_no_nan_in_the_samples() {
    // y' = y^2, y(0) = 1 blows up at t = 1: every method must stop there with a status
    // (step-size collapse or non-finite state), never return NaN samples, and the
    // healthy variant in the same batch must finish.
    let f = |_t: f64, y: &[f64], p: f64, dy: &mut [f64]| {
        dy[0] = if p > 0.0 { y[0] * y[0] } else { -y[0] };
        Ok(())
    };
    for method in METHODS {
        let mut sys = Ode::new(1, vec![1.0, -1.0], f);
        let set = [
            settings(method, 2.0, 0.01, 1e-8, None),
            settings(method, 2.0, 0.01, 1e-8, None),
        ];
        let out = run_batch(method, &mut sys, &[1.0, 1.0], &set);
        let time = match &out[0].0 {
            Status::StepSizeTooSmall { time, .. } | Status::NonFinite { time } => *time,
            other => panic!("{method:?}: blow-up should end with a status, got {other:?}"),
        };
        // Fixed-step RK4 (h = 1e-3) may take a few steps past the singularity.
        assert!(
            (0.9..=1.01).contains(&time),
            "{method:?}: ended at {time}, blow-up at 1"
        );
        eprintln!("{method:?}: {:?}", out[0].0);
        assert!(
            sys.samples[0].iter().all(|(_, y)| y[0].is_finite()),
            "{method:?}: NaN in samples"
        );
        assert_eq!(
            out[1].0,
            Status::Finished,
            "{method:?}: the healthy variant"
        );
        let (t, y) = sys.samples[1].last().unwrap();
        assert!(
            (y[0] - (-t).exp()).abs() < 1e-6,
            "{method:?}: healthy variant wrong at {t}"
        );
    }
}

#[test]
fn the_step_budget_ends_a_variant_with_max_steps() {
    for method in METHODS {
        let mut sys = Ode::new(2, vec![6.0], spring);
        let mut set = settings(method, 10.0, 0.1, 1e-8, None);
        set.max_steps = 25;
        let out = run_batch(method, &mut sys, &[1.0, 0.0], &[set]);
        match &out[0].0 {
            Status::MaxSteps { time, steps } => {
                assert_eq!(*steps, 25, "{method:?}");
                assert!(*time > 0.0 && *time < 10.0, "{method:?}: time {time}");
                let last = sys.samples[0].last().unwrap().0;
                assert!(
                    last <= *time + 1e-12,
                    "{method:?}: samples past the end {last} > {time}"
                );
            }
            other => panic!("{method:?}: expected max_steps, got {other:?}"),
        }
    }
}

/// Prothero-Robinson `y' = -p (y - cos t) - sin t`, exact `y = cos t` from `y(0) = 1`;
/// stiff for large `p` (eigenvalue `-p`).
fn prothero(t: f64, y: &[f64], p: f64, dy: &mut [f64]) -> Result<(), String> {
    dy[0] = -p * (y[0] - t.cos()) - t.sin();
    Ok(())
}

#[test]
fn auto_switches_the_stiff_variant_to_radau5_and_leaves_the_others_dopri5() {
    // Variant 0 is mild (p = 1), variant 1 stiff (p = 1e5: dopri5 would need
    // ~2 * 1e5 / 3.3 = 60 000 stability-limited steps over 2 s).
    let ps = vec![1.0, 1e5];
    let set: Vec<Settings> = ps
        .iter()
        .map(|_| settings(Method::Auto, 2.0, 0.01, 1e-6, None))
        .collect();
    let mut auto = Ode::new(1, ps.clone(), prothero);
    let out = run_batch(Method::Auto, &mut auto, &[1.0, 1.0], &set);
    let mut plain = Ode::new(1, ps.clone(), prothero);
    let set_d: Vec<Settings> = ps
        .iter()
        .map(|_| settings(Method::Dopri5, 2.0, 0.01, 1e-6, None))
        .collect();
    let out_d = run_batch(Method::Dopri5, &mut plain, &[1.0, 1.0], &set_d);
    // Radau5 alone on the same batch: the error the stiff variant may have after the
    // hand-over. It is far above rtol at the samples (7.9e-4 measured): radau5's steps grow
    // to ~0.1 s on the smooth solution and its samples come from the cubic collocation
    // polynomial, whose interpolation error between step ends is O(h^4). A broken
    // hand-over (wrong state, time or samples) gives errors of order one.
    let mut radau = Ode::new(1, ps.clone(), prothero);
    let set_r: Vec<Settings> = ps
        .iter()
        .map(|_| settings(Method::Radau5, 2.0, 0.01, 1e-6, None))
        .collect();
    run_batch(Method::Radau5, &mut radau, &[1.0, 1.0], &set_r);
    let max_err = |samples: &[(f64, Vec<f64>)]| {
        samples
            .iter()
            .map(|(t, y)| (y[0] - t.cos()).abs())
            .fold(0.0, f64::max)
    };
    for id in 0..2 {
        assert_eq!(out[id].0, Status::Finished, "auto variant {id}");
        assert_eq!(out_d[id].0, Status::Finished, "dopri5 variant {id}");
        assert_eq!(
            auto.samples[id].len(),
            201,
            "variant {id}: samples k * 0.01 <= 2"
        );
        // rtol = atol = 1e-6 per step; globally a few times that, or radau5's own error.
        let tol = 1e-5f64.max(3.0 * max_err(&radau.samples[id]));
        for (k, (t, y)) in auto.samples[id].iter().enumerate() {
            let err = (y[0] - t.cos()).abs();
            assert!(
                err < tol,
                "auto variant {id} sample {k} t={t}: got {}, want {}, tol {tol:e}",
                y[0],
                t.cos()
            );
        }
        eprintln!(
            "variant {id}: auto max error {:.2e}, radau5 alone {:.2e}, dopri5 alone {:.2e}",
            max_err(&auto.samples[id]),
            max_err(&radau.samples[id]),
            max_err(&plain.samples[id])
        );
    }
    // The mild variant never switched and ran exactly as under dopri5.
    assert_eq!(out[0].1.stiff_switch_time, None);
    assert_eq!(
        auto.samples[0], plain.samples[0],
        "mild variant: auto != dopri5"
    );
    assert_eq!(out[0].1.rhs_evaluations, out_d[0].1.rhs_evaluations);
    // The stiff one switched early (15 stability-limited steps of ~3e-5) and then cost
    // far fewer evaluations than dopri5's stability-limited march.
    let t_switch = out[1]
        .1
        .stiff_switch_time
        .expect("the stiff variant switched");
    assert!(t_switch > 0.0 && t_switch < 0.01, "switched at {t_switch}");
    let (ea, ed) = (out[1].1.rhs_evaluations, out_d[1].1.rhs_evaluations);
    assert!(
        ed > 200_000 && ea * 20 < ed,
        "stiff variant: auto {ea} evaluations, dopri5 {ed}"
    );
    // Samples continue without gap or repeat across the hand-over.
    for (k, (t, _)) in auto.samples[1].iter().enumerate() {
        assert!((t - k as f64 * 0.01).abs() < 1e-12, "sample {k} at {t}");
    }
}

#[test]
fn auto_on_a_non_stiff_batch_is_dopri5_step_for_step() {
    let ws = vec![2.0 * std::f64::consts::PI, 3.0, 7.5];
    let y0: Vec<f64> = ws.iter().flat_map(|_| [1.0, 0.0]).collect();
    let mut runs = Vec::new();
    for method in [Method::Dopri5, Method::Auto] {
        let mut sys = Ode::new(2, ws.clone(), spring);
        let set: Vec<Settings> = ws
            .iter()
            .map(|_| settings(method, 2.0, 0.013, 1e-8, None))
            .collect();
        let out = run_batch(method, &mut sys, &y0, &set);
        runs.push((out, sys.samples));
    }
    for id in 0..ws.len() {
        assert_eq!(runs[1].0[id].1.stiff_switch_time, None, "variant {id}");
        assert_eq!(runs[0].0[id].1.steps, runs[1].0[id].1.steps, "variant {id}");
        assert_eq!(runs[0].1[id], runs[1].1[id], "variant {id}: samples differ");
    }
}

#[test]
fn auto_hands_over_a_mildly_stiff_variant_and_keeps_oscillators_on_dopri5() {
    // Prothero-Robinson with p = 20: dopri5 at rtol 1e-6 follows cos t with steps of
    // h |λ| = 20 h ≈ 1 (accuracy-limited, not stability-limited: Hairer's 3.25 would never
    // flag it), the film rotors' situation. auto hands it to radau5 after 15 such steps,
    // and the samples stay within the tolerance's reach of cos t.
    let ps = vec![20.0];
    let set: Vec<Settings> = ps
        .iter()
        .map(|_| settings(Method::Auto, 2.0, 0.01, 1e-6, None))
        .collect();
    let mut auto = Ode::new(1, ps.clone(), prothero);
    let out = run_batch(Method::Auto, &mut auto, &[1.0], &set);
    assert_eq!(out[0].0, Status::Finished);
    let t_switch = out[0]
        .1
        .stiff_switch_time
        .expect("the mildly stiff variant switched");
    assert!(t_switch > 0.0 && t_switch < 1.0, "switched at {t_switch}");
    let err = auto.samples[0]
        .iter()
        .map(|(t, y)| (y[0] - t.cos()).abs())
        .fold(0.0, f64::max);
    assert!(
        err < 1e-5,
        "auto max error {err:.2e} against cos t, tolerance 1e-5"
    );
    // Lightly damped oscillators ([`spring`]: ζ = 0.1, ω = 2π and 7.5, 2 and 2.4 periods
    // over 2 s, amplitudes still above e^-1.5) at rtol 1e-5 and 1e-6: dopri5 follows them
    // with h |λ| below the threshold, so auto is dopri5 step for step.
    let ws = vec![2.0 * std::f64::consts::PI, 7.5];
    let y0: Vec<f64> = ws.iter().flat_map(|_| [1.0, 0.0]).collect();
    for tol in [1e-5, 1e-6] {
        let mut runs = Vec::new();
        for method in [Method::Dopri5, Method::Auto] {
            let mut sys = Ode::new(2, ws.clone(), spring);
            let set: Vec<Settings> = ws
                .iter()
                .map(|_| settings(method, 2.0, 0.013, tol, None))
                .collect();
            let out = run_batch(method, &mut sys, &y0, &set);
            runs.push((out, sys.samples));
        }
        for id in 0..ws.len() {
            assert_eq!(
                runs[1].0[id].1.stiff_switch_time, None,
                "rtol {tol:e}, ω = {}: an oscillator that must be followed was handed over",
                ws[id]
            );
            assert_eq!(runs[0].0[id].1.steps, runs[1].0[id].1.steps, "variant {id}");
            assert_eq!(runs[0].1[id], runs[1].1[id], "variant {id}: samples differ");
        }
    }
}
