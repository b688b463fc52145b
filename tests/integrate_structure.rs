//! Radau5 with the structure a system declares (issue 28, eighth pass): kinematic pairs
//! (`f_i = y_j`, eliminated from the Newton systems in closed form), a scale-invariant
//! block (one Jacobian column derived by Euler's relation instead of evaluated) and a
//! quadrature (outside the LU). On a stiff toy with the rotor's layout the structured run
//! must reach the tolerance like the plain one (both against a tight dopri5 reference),
//! with fewer right-hand-side evaluations per Jacobian.

use bearing_sweep::integrate::{run_batch, BatchSystem, Method, Settings, Stats, Status};

/// `x' = v`, `v' = −c v − k x + a û_0`, `u' = ω (−u_1, u_0)`, `ω' = −(ω − 1)/10 + x û_1 / 100`,
/// `w' = v²` (`û = u / |u|`): components `x, v, u_0, u_1, ω, w`. Damping `c` per variant
/// (stiff: `c = 1e4` gives `h |λ| ≈ 10` at a 1 ms step).
struct Toy {
    structured: bool,
    damping: Vec<f64>,
    samples: Vec<Vec<(f64, Vec<f64>)>>,
    ended: Vec<Option<(Status<String>, Stats)>>,
}

const DIM: usize = 6;
const PAIRS: [(usize, usize); 1] = [(0, 1)];

impl BatchSystem for Toy {
    type Fault = String;
    fn dim(&self) -> usize {
        DIM
    }
    fn jacobian_dim(&self) -> usize {
        if self.structured {
            5
        } else {
            DIM
        }
    }
    fn kinematic_pairs(&self) -> &[(usize, usize)] {
        if self.structured {
            &PAIRS
        } else {
            &[]
        }
    }
    fn scale_invariant_block(&self) -> Option<(usize, usize)> {
        self.structured.then_some((2, 2))
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
            let y = &ys[k * DIM..(k + 1) * DIM];
            let dy = &mut dys[k * DIM..(k + 1) * DIM];
            let c = self.damping[id];
            let n = y[2].hypot(y[3]);
            let (u0, u1) = (y[2] / n, y[3] / n);
            dy[0] = y[1];
            dy[1] = -c * y[1] - 2.0e3 * y[0] + 50.0 * u0;
            dy[2] = -y[4] * y[3];
            dy[3] = y[4] * y[2];
            dy[4] = -(y[4] - 1.0) / 10.0 + y[0] * u1 / 100.0;
            dy[5] = y[1] * y[1];
        }
    }
    fn record(&mut self, ids: &[usize], ts: &[f64], ys: &[f64]) {
        for (k, &id) in ids.iter().enumerate() {
            self.samples[id].push((ts[k], ys[k * DIM..(k + 1) * DIM].to_vec()));
        }
    }
    fn finished(&mut self, id: usize, status: &Status<String>, stats: &Stats) {
        self.ended[id] = Some((status.clone(), *stats));
    }
}

fn run(method: Method, structured: bool, tol: f64) -> Toy {
    let damping = vec![1e4, 3e3, 300.0];
    let n = damping.len();
    let mut sys = Toy {
        structured,
        damping,
        samples: vec![Vec::new(); n],
        ended: vec![None; n],
    };
    let y0: Vec<f64> = (0..n)
        .flat_map(|k| [1e-3 * (k as f64 + 1.0), 0.0, 0.8, 0.6, 2.0, 0.0])
        .collect();
    let settings = vec![
        Settings {
            t_end: 2.0,
            sample_interval: 0.01,
            rtol: tol,
            atol: tol,
            ..Settings::default()
        };
        n
    ];
    run_batch(method, &mut sys, &y0, &settings);
    sys
}

#[test]
fn structured_radau5_meets_the_tolerance_like_the_plain_one_with_fewer_evaluations() {
    let reference = run(Method::Dopri5, false, 1e-11);
    let plain = run(Method::Radau5, false, 1e-6);
    let structured = run(Method::Radau5, true, 1e-6);
    let err = |s: &Toy| {
        let mut worst = 0.0f64;
        for (a, b) in s.samples.iter().zip(&reference.samples) {
            assert_eq!(a.len(), b.len(), "sample counts");
            for ((_, ya), (_, yb)) in a.iter().zip(b) {
                // x (scale 1e-3), the unit direction of u, ω and the work.
                let ua = ya[2].atan2(ya[3]);
                let ub = yb[2].atan2(yb[3]);
                for e in [
                    (ya[0] - yb[0]).abs() / 1e-3,
                    (ua - ub).abs(),
                    (ya[4] - yb[4]).abs(),
                    (ya[5] - yb[5]).abs() / (1.0 + yb[5].abs()),
                ] {
                    worst = worst.max(e);
                }
            }
        }
        worst
    };
    for s in [&plain, &structured] {
        for e in &s.ended {
            let (status, _) = e.as_ref().expect("every variant ends");
            assert!(matches!(status, Status::Finished), "{status:?}");
        }
    }
    let (ep, es) = (err(&plain), err(&structured));
    assert!(ep < 1e-4, "plain radau5 error {ep:.3e}");
    // The same solution up to the Newton iterates' rounding and the derived column's
    // finite-difference error: the error stays at the plain run's level.
    assert!(
        es < 1e-4 && es < 3.0 * ep + 1e-9,
        "structured radau5 error {es:.3e} against plain {ep:.3e}"
    );
    // Per Jacobian one column fewer (6 → 4: the quadrature's and a derived one), and the
    // Newton iterations about the same: fewer evaluations in all.
    let total = |s: &Toy, f: fn(&Stats) -> u64| -> u64 {
        s.ended.iter().map(|e| f(&e.as_ref().unwrap().1)).sum()
    };
    let (rp, rs) = (
        total(&plain, |s| s.rhs_evaluations),
        total(&structured, |s| s.rhs_evaluations),
    );
    let (jp, js) = (
        total(&plain, |s| s.jacobians),
        total(&structured, |s| s.jacobians),
    );
    assert!(jp > 0 && js > 0, "Jacobians {jp}, {js}");
    assert!(
        rs < rp,
        "structured {rs} evaluations ({js} Jacobians) against plain {rp} ({jp})"
    );
}
