//! One suite, run on every backend: the CPU backend on two threads, the GPU backend at the
//! adapter's best precision, and the GPU backend forced to f32. Each must reproduce the
//! single-threaded CPU kernel (the reference) through the same `LoadEvaluator` front end:
//! same statuses for bad states, loads within the backend's tolerance, order kept, any
//! batch size.
//!
//! GPU cases skip with a printed notice when no adapter exists, unless
//! `BEARING_SWEEP_REQUIRE_GPU=1` (set by `.ci/run`, which installs lavapipe), where a
//! missing adapter fails the test.

use std::time::Duration;

use bearing_sweep::backend::{
    CpuBackend, FilmBackend, GpuBackend, GpuOptions, LoadEvaluator, LoadRequest, LoadResult,
    Precision,
};
use bearing_sweep::bearing::{Accuracy, BearingParams, BearingState};

/// Relative agreement of the load vector `(W_x, W_y, M_x/B, M_y/B)` with the CPU kernel
/// promised for end eccentricity ratios up to 0.95 (issue 3): f64 and f32.
const TOL_F64: f64 = 1e-9;
const TOL_F32: f64 = 1e-5;
/// The same between 0.95 and 0.98, where `1/(1 − ε)` amplifies the rounding of the
/// inputs (measured worst cases on lavapipe, 3000 states: f64 3.4e-13, f32 5.0e-6).
const TOL_F64_NEAR_WALL: f64 = 1e-9;
const TOL_F32_NEAR_WALL: f64 = 3e-5;

/// Tiny deterministic generator (64-bit LCG, top 53 bits).
struct Rng(u64);
impl Rng {
    fn uniform(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.uniform()
    }
}

fn bearing() -> BearingParams {
    BearingParams::paper_table2()
}

/// Random states of every kind the suite covers, with their larger end eccentricity
/// ratio: tilted and aligned, squeeze only (zero spin), negative spin, end ratios up to
/// `max_ratio`.
fn random_states(n: usize, max_ratio: f64, seed: u64) -> Vec<(BearingState, f64)> {
    let b = bearing();
    let d = b.clearance;
    let mut rng = Rng(seed);
    (0..n)
        .map(|k| {
            let ei = max_ratio * rng.uniform().sqrt();
            let ej = match k % 5 {
                0 => ei, // aligned or parallel offset
                _ => max_ratio * rng.uniform().sqrt(),
            };
            let ai = rng.range(0.0, std::f64::consts::TAU);
            let aj = if k % 5 == 0 {
                ai
            } else {
                rng.range(0.0, std::f64::consts::TAU)
            };
            let omega = match k % 4 {
                0 => 0.0,                      // squeeze only
                1 => -rng.range(10.0, 1000.0), // negative spin
                _ => rng.range(10.0, 1000.0),
            };
            // Velocities up to ~clearance × 300 1/s, comparable with the spin term.
            let v = |rng: &mut Rng| {
                if k % 7 == 3 {
                    0.0
                } else {
                    rng.range(-1.0, 1.0) * d * 300.0
                }
            };
            let (vxi, vyi, vxj, vyj) = (v(&mut rng), v(&mut rng), v(&mut rng), v(&mut rng));
            let state = BearingState {
                xi: ei * d * ai.cos(),
                yi: ei * d * ai.sin(),
                xj: ej * d * aj.cos(),
                yj: ej * d * aj.sin(),
                vxi,
                vyi,
                vxj: if k % 5 == 0 { vxi } else { vxj },
                vyj: if k % 5 == 0 { vyi } else { vyj },
                omega,
            };
            (state, ei.max(ej))
        })
        .collect()
}

fn zero_state() -> BearingState {
    BearingState {
        xi: 0.0,
        yi: 0.0,
        xj: 0.0,
        yj: 0.0,
        vxi: 0.0,
        vyi: 0.0,
        vxj: 0.0,
        vyj: 0.0,
        omega: 0.0,
    }
}

/// Hand-picked states at the rule's edges, with their larger end ratio: a rate-vector
/// kink inside the bearing (squeeze reversing along z), conical whirl, one end at 0.98
/// and the other centred, spin dominating squeeze by 1e6, a tilted journal at rest
/// except for spin about a centred end.
fn edge_states() -> Vec<(BearingState, f64)> {
    let d = bearing().clearance;
    let z = zero_state();
    vec![
        (
            BearingState {
                xi: 0.3 * d,
                xj: 0.3 * d,
                vxi: 0.01,
                vxj: -0.01,
                ..z
            },
            0.3,
        ),
        (
            BearingState {
                xi: 0.6 * d,
                xj: -0.6 * d,
                vyi: 0.02,
                vyj: -0.02,
                omega: 50.0,
                ..z
            },
            0.6,
        ),
        (
            BearingState {
                xi: 0.98 * d,
                omega: 300.0,
                ..z
            },
            0.98,
        ),
        (
            BearingState {
                yj: 0.98 * d,
                vxi: 1e-3,
                omega: -300.0,
                ..z
            },
            0.98,
        ),
        (
            BearingState {
                xi: 0.5 * d,
                yj: 0.9 * d,
                vxi: 1e-9,
                omega: 1e3,
                ..z
            },
            0.9,
        ),
        (
            BearingState {
                xj: 0.95 * d,
                yj: 0.1 * d,
                omega: 1e5,
                ..z
            },
            0.95_f64.hypot(0.1),
        ),
    ]
}

/// States every backend must reject with the CPU's status.
fn bad_states() -> Vec<BearingState> {
    let d = bearing().clearance;
    let z = zero_state();
    vec![
        BearingState { xi: d, ..z }, // touching the wall at i
        BearingState {
            xj: 0.8 * d,
            yj: 0.8 * d,
            ..z
        }, // through the wall at j
        BearingState {
            omega: f64::NAN,
            ..z
        }, // NaN spin
        BearingState {
            vyj: f64::INFINITY,
            ..z
        }, // infinite velocity
        BearingState {
            xi: 0.5 * d,
            omega: 1e308,
            vxi: 1e308,
            ..z
        }, // overflows the rate
    ]
}

/// A named backend of the suite and its tolerances (≤ 0.95, 0.95..0.98).
struct Case {
    name: &'static str,
    backend: Box<dyn FilmBackend>,
    tol: f64,
    tol_near_wall: f64,
}

fn gpu_required() -> bool {
    std::env::var("BEARING_SWEEP_REQUIRE_GPU").is_ok_and(|v| v == "1")
}

/// The GPU backend with `precision` (`None`: the adapter's best), or `None` with a
/// printed notice when no adapter exists (a failure under BEARING_SWEEP_REQUIRE_GPU=1).
fn gpu(precision: Option<Precision>, accuracy: Accuracy, max_chunk: usize) -> Option<GpuBackend> {
    let options = GpuOptions {
        precision,
        max_chunk: Some(max_chunk),
        ..GpuOptions::default()
    };
    match GpuBackend::new(accuracy, options) {
        Ok(b) => Some(b),
        Err(e) if gpu_required() => panic!("BEARING_SWEEP_REQUIRE_GPU=1 but: {e}"),
        Err(e) => {
            eprintln!("notice: skipping the GPU cases: {e}");
            None
        }
    }
}

fn tolerances(p: Precision) -> (f64, f64) {
    match p {
        Precision::F64 => (TOL_F64, TOL_F64_NEAR_WALL),
        Precision::F32 => (TOL_F32, TOL_F32_NEAR_WALL),
    }
}

/// Every backend of the suite at `accuracy`; GPU dispatches split at `max_chunk` states.
fn cases(accuracy: Accuracy, max_chunk: usize) -> Vec<Case> {
    let mut v = vec![Case {
        name: "cpu (2 threads)",
        backend: Box::new(CpuBackend::new(accuracy, Some(2))),
        // The same kernel per state: bitwise equal.
        tol: 0.0,
        tol_near_wall: 0.0,
    }];
    if let Some(g) = gpu(None, accuracy, max_chunk) {
        let (tol, tol_near_wall) = tolerances(g.precision());
        v.push(Case {
            name: if g.precision() == Precision::F64 {
                "gpu (f64)"
            } else {
                "gpu (f32, no SHADER_F64)"
            },
            backend: Box::new(g),
            tol,
            tol_near_wall,
        });
    }
    if let Some(g) = gpu(Some(Precision::F32), accuracy, max_chunk) {
        v.push(Case {
            name: "gpu (f32 forced)",
            backend: Box::new(g),
            tol: TOL_F32,
            tol_near_wall: TOL_F32_NEAR_WALL,
        });
    }
    v
}

fn evaluate(
    backend: Box<dyn FilmBackend>,
    states: &[BearingState],
) -> (Vec<LoadResult>, LoadEvaluator) {
    let requests: Vec<LoadRequest> = states
        .iter()
        .map(|&state| LoadRequest { bearing: 0, state })
        .collect();
    let mut ev = LoadEvaluator::new(backend);
    let mut out = Vec::new();
    ev.evaluate(&[bearing()], &requests, &mut out);
    (out, ev)
}

fn reference(accuracy: Accuracy, states: &[BearingState]) -> Vec<LoadResult> {
    evaluate(Box::new(CpuBackend::new(accuracy, Some(1))), states).0
}

/// Relative difference of the load vectors (Euclidean).
fn load_error(got: &LoadResult, want: &LoadResult) -> f64 {
    let l = bearing().length;
    match (got, want) {
        (Ok(g), Ok(w)) => {
            let (g, w) = (g.load_vector(l), w.load_vector(l));
            let d: f64 = g.iter().zip(&w).map(|(a, b)| (a - b) * (a - b)).sum();
            let n: f64 = w.iter().map(|a| a * a).sum();
            if n == 0.0 {
                d.sqrt()
            } else {
                (d / n).sqrt()
            }
        }
        _ => f64::NAN,
    }
}

/// Compares results with the reference state by state; returns the worst errors for
/// end ratios ≤ 0.95 and above.
fn compare(
    case: &str,
    got: &[LoadResult],
    want: &[LoadResult],
    ratios: &[f64],
    tol: f64,
    tol_near_wall: f64,
) -> (f64, f64) {
    assert_eq!(got.len(), want.len(), "{case}: result count");
    let (mut worst, mut worst_near) = (0.0_f64, 0.0_f64);
    for (k, (g, w)) in got.iter().zip(want).enumerate() {
        match (g, w) {
            (Err(a), Err(b)) => assert_eq!(
                a.code(),
                b.code(),
                "{case}: state {k}: status {} but the CPU says {}",
                a.code(),
                b.code()
            ),
            (Ok(_), Ok(_)) => {
                let err = load_error(g, w);
                let near = ratios[k] > 0.95;
                let t = if near { tol_near_wall } else { tol };
                assert!(
                    err <= t,
                    "{case}: state {k} (end ratio {:.4}): load vector {:?} vs CPU {:?}: \
                     relative error {err:.3e} > tolerance {t:.0e}",
                    ratios[k],
                    g.as_ref().map(|l| l.load_vector(bearing().length)),
                    w.as_ref().map(|l| l.load_vector(bearing().length)),
                );
                if near {
                    worst_near = worst_near.max(err);
                } else {
                    worst = worst.max(err);
                }
                let (g, w) = (g.as_ref().unwrap(), w.as_ref().unwrap());
                // Host-side fields use the same code on every backend.
                assert_eq!(g.h_min, w.h_min, "{case}: state {k}: h_min");
                assert_eq!(
                    g.sommerfeld.is_some(),
                    w.sommerfeld.is_some(),
                    "{case}: state {k}"
                );
            }
            _ => panic!(
                "{case}: state {k}: {} but the CPU says {}",
                g.as_ref().map_or_else(|e| e.code(), |_| "ok"),
                w.as_ref().map_or_else(|e| e.code(), |_| "ok"),
            ),
        }
    }
    (worst, worst_near)
}

#[test]
fn random_states_match_the_cpu_kernel_on_every_backend() {
    let accuracy = Accuracy::default();
    let mut states = random_states(3000, 0.98, 0x5eed);
    states.extend(edge_states());
    states.push((zero_state(), 0.0));
    for s in bad_states() {
        states.push((s, 0.0));
    }
    let (st, ratios): (Vec<BearingState>, Vec<f64>) = states.into_iter().unzip();
    let want = reference(accuracy, &st);
    assert!(want.iter().filter(|r| r.is_err()).count() == bad_states().len());
    for case in cases(accuracy, 1024) {
        let (got, mut ev) = evaluate(case.backend, &st);
        let (w, wn) = compare(
            case.name,
            &got,
            &want,
            &ratios,
            case.tol,
            case.tol_near_wall,
        );
        eprintln!(
            "{}: worst relative load error vs CPU: {w:.2e} (end ratio <= 0.95), \
             {wn:.2e} (0.95..0.98); {} states",
            case.name,
            st.len()
        );
        assert!(
            ev.take_notices().is_empty(),
            "{}: unexpected fallback",
            case.name
        );
        assert_eq!(ev.stats().cpu_recomputed, 0, "{}", case.name);
    }
}

#[test]
fn tightest_accuracy_level_matches_too() {
    // 12 nodes per panel and a finer kink floor: a different table and panel march.
    let accuracy = Accuracy::new(1e-12).expect("calibrated level");
    let states = random_states(400, 0.95, 77);
    let (st, ratios): (Vec<BearingState>, Vec<f64>) = states.into_iter().unzip();
    let want = reference(accuracy, &st);
    for case in cases(accuracy, 1024) {
        let (got, _) = evaluate(case.backend, &st);
        let (w, _) = compare(
            case.name,
            &got,
            &want,
            &ratios,
            case.tol,
            case.tol_near_wall,
        );
        eprintln!(
            "{} at accuracy 1e-12: worst relative error {w:.2e}",
            case.name
        );
    }
}

#[test]
fn large_batch_is_chunked_and_kept_in_order() {
    // 100 000 states, dispatched in chunks of 8192 on the GPU; a sample of 1 in 97
    // checked against the CPU kernel state by state.
    let accuracy = Accuracy::default();
    let states = random_states(100_000, 0.95, 12345);
    let (st, ratios): (Vec<BearingState>, Vec<f64>) = states.into_iter().unzip();
    let sample: Vec<usize> = (0..st.len()).step_by(97).chain([st.len() - 1]).collect();
    let sample_states: Vec<BearingState> = sample.iter().map(|&k| st[k]).collect();
    let sample_ratios: Vec<f64> = sample.iter().map(|&k| ratios[k]).collect();
    let want = reference(accuracy, &sample_states);
    for case in cases(accuracy, 8192).into_iter().skip(1) {
        let (got, _) = evaluate(case.backend, &st);
        assert_eq!(got.len(), st.len());
        let got_sample: Vec<LoadResult> = sample.iter().map(|&k| got[k]).collect();
        compare(
            case.name,
            &got_sample,
            &want,
            &sample_ratios,
            case.tol,
            case.tol_near_wall,
        );
    }
}

#[test]
fn batch_of_one_and_reversed_batch_give_the_same_loads() {
    let accuracy = Accuracy::default();
    let states = random_states(64, 0.95, 9);
    let st: Vec<BearingState> = states.into_iter().map(|(s, _)| s).collect();
    let reversed: Vec<BearingState> = st.iter().rev().copied().collect();
    for case in cases(accuracy, 1024) {
        let name = case.name;
        let requests: Vec<LoadRequest> = st
            .iter()
            .map(|&state| LoadRequest { bearing: 0, state })
            .collect();
        let rev_requests: Vec<LoadRequest> = requests.iter().rev().copied().collect();
        let mut ev = LoadEvaluator::new(case.backend);
        let (mut all, mut rev, mut one) = (Vec::new(), Vec::new(), Vec::new());
        ev.evaluate(&[bearing()], &requests, &mut all);
        ev.evaluate(&[bearing()], &rev_requests, &mut rev);
        for (k, r) in requests.iter().enumerate() {
            ev.evaluate(&[bearing()], std::slice::from_ref(r), &mut one);
            assert_eq!(one.len(), 1);
            // One state's kernel does not depend on its neighbours: bitwise equal.
            assert_eq!(one[0], all[k], "{name}: state {k} alone vs in the batch");
            assert_eq!(rev[st.len() - 1 - k], all[k], "{name}: state {k} reversed");
        }
        assert_eq!(reversed.len(), st.len());
        // An empty batch is fine too.
        ev.evaluate(&[bearing()], &[], &mut one);
        assert!(one.is_empty(), "{name}: empty batch");
    }
}

/// States the evaluator hands to a backend: all but those without any film pressure
/// (no spin and no motion).
fn sent_to_backend(states: &[BearingState]) -> u64 {
    states
        .iter()
        .filter(|s| {
            [s.omega, s.vxi, s.vyi, s.vxj, s.vyj]
                .iter()
                .any(|&v| v != 0.0)
        })
        .count() as u64
}

#[test]
fn lost_device_falls_back_to_the_cpu() {
    let accuracy = Accuracy::default();
    let Some(mut g) = gpu(None, accuracy, 1024) else {
        return;
    };
    g.simulate_device_loss();
    let states = random_states(500, 0.95, 4);
    let (st, ratios): (Vec<BearingState>, Vec<f64>) = states.into_iter().unzip();
    let want = reference(accuracy, &st);
    let (got, mut ev) = evaluate(Box::new(g), &st);
    // Recomputed by the CPU kernel: exact.
    compare("lost device", &got, &want, &ratios, 0.0, 0.0);
    let notices = ev.take_notices();
    assert_eq!(notices.len(), 1, "one notice per failed batch: {notices:?}");
    assert!(
        notices[0].contains("GPU device failure") && notices[0].contains("recomputed on the CPU"),
        "notice: {}",
        notices[0]
    );
    assert_eq!(ev.stats().cpu_recomputed, sent_to_backend(&st));
}

#[test]
fn timed_out_batch_falls_back_to_the_cpu() {
    let accuracy = Accuracy::default();
    let Some(mut g) = gpu(None, accuracy, 1 << 20) else {
        return;
    };
    // A zero wait: the first poll does not see 20 000 states finished on lavapipe (CI).
    // A device fast enough to finish before the poll takes the normal path, which must
    // then agree within tolerance.
    g.set_timeout(Duration::ZERO);
    let (tol, tol_near_wall) = tolerances(g.precision());
    let states = random_states(20_000, 0.95, 5);
    let (st, ratios): (Vec<BearingState>, Vec<f64>) = states.into_iter().unzip();
    let want = reference(accuracy, &st);
    let (got, mut ev) = evaluate(Box::new(g), &st);
    let notices = ev.take_notices();
    if notices.is_empty() {
        eprintln!("notice: the device finished 20 000 states within a zero timeout");
        compare("no timeout", &got, &want, &ratios, tol, tol_near_wall);
        return;
    }
    // Recomputed by the CPU kernel: exact.
    compare("timeout", &got, &want, &ratios, 0.0, 0.0);
    assert_eq!(notices.len(), 1, "{notices:?}");
    assert!(notices[0].contains("timeout"), "notice: {}", notices[0]);
    assert_eq!(ev.stats().cpu_recomputed, sent_to_backend(&st));
}

#[test]
fn rate_kinks_meet_the_accuracy_promise_on_every_backend() {
    // The rate vector vanishes on the real axis (a kink), inside the bearing or at an
    // end: the arc-end quartic has a double root there. Before the rule merged those
    // roots into the kink, the first state crawled toward a root 5e-18 off the axis,
    // ran out of panels and was 4.7e-2 off.
    let accuracy = Accuracy::default();
    let d = bearing().clearance;
    let z = zero_state();
    let kinks = [
        BearingState {
            yj: 0.98 * d,
            vxi: 1e-3,
            omega: -300.0,
            ..z
        },
        BearingState {
            xi: 0.98 * d,
            omega: 300.0,
            ..z
        },
        BearingState {
            xj: 0.95 * d,
            yj: 0.1 * d,
            omega: 1e5,
            ..z
        },
        BearingState {
            xi: 0.3 * d,
            xj: 0.3 * d,
            vxi: 0.01,
            vxj: -0.01,
            ..z
        },
        BearingState {
            yi: -0.5 * d,
            yj: 0.9 * d,
            vxi: 2e-3,
            vxj: -5e-3,
            omega: 40.0,
            ..z
        },
    ];
    let l = bearing().length;
    // Promise at end ratio 0.98 (`Accuracy::promise_near_wall`).
    let tol = accuracy.promise_near_wall();
    for case in cases(accuracy, 1024) {
        let (got, _) = evaluate(case.backend, &kinks);
        for (k, (g, s)) in got.iter().zip(&kinks).enumerate() {
            let want = bearing_sweep::bearing::reference::reference_loads(&bearing(), s, 1e-12)
                .expect("valid state");
            let want = [want[0], want[1], want[2] / l, want[3] / l];
            let g = g.as_ref().expect("valid state").load_vector(l);
            let err = bearing_sweep::backend::relative_difference(&g, &want);
            let t = tol.max(case.tol);
            assert!(
                err <= t,
                "{}: kink state {k}: load vector {g:?} vs reference {want:?}: relative \
                 error {err:.3e} > tolerance {t:.0e}",
                case.name
            );
        }
    }
}
