//! `LoadEvaluator::evaluate_planned` (the rotor's stage evaluations, issue 28 third pass):
//! bearings validated once in a `BearingPlan`, film friction and flow outputs only where
//! the plan asks. Every other output must be bit for bit that of `evaluate`, faults
//! included, for the short, finite and auto films and for pressure-free states; with the
//! flag off `film` is the default (zeros) and with it on it equals `evaluate`'s.

use bearing_sweep::backend::{BearingPlan, CpuBackend, LoadEvaluator, LoadRequest, LoadResult};
use bearing_sweep::bearing::{
    Accuracy, BearingParams, BearingState, FilmFlow, FilmModel, FiniteSettings, Loads,
};

fn evaluator() -> LoadEvaluator {
    LoadEvaluator::new(Box::new(CpuBackend::new(Accuracy::default(), Some(1))))
}

/// The bearing list: paper short film, a coarse finite film, auto with a low threshold
/// (so that eccentric states go finite), and an invalid one (negative viscosity).
fn bearings() -> Vec<BearingParams> {
    let paper = BearingParams::paper_table2();
    let coarse = FiniteSettings {
        n_theta: Some(32),
        n_z: Some(8),
        ..FiniteSettings::default()
    };
    let finite = BearingParams {
        model: FilmModel::Finite,
        finite: coarse,
        ..paper
    };
    let auto = BearingParams {
        model: FilmModel::Auto,
        finite: FiniteSettings {
            auto_tolerance: 0.05,
            ..coarse
        },
        ..paper
    };
    let bad = BearingParams {
        viscosity: -1.0,
        ..paper
    };
    vec![paper, finite, auto, bad]
}

/// Deterministic tilted, whirling states across eccentricities (a small LCG), plus the
/// edge cases: a pressure-free state, one through the wall, one non-finite, and an index
/// past the bearing list.
fn requests(bearings: &[BearingParams]) -> Vec<LoadRequest> {
    let mut seed = 0x2545_f491_4f6c_dd1d_u64;
    let mut u = move || {
        seed = seed
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let mut out = Vec::new();
    for (b, p) in bearings.iter().enumerate() {
        let d = p.clearance;
        // Finite solves cost milliseconds: fewer states there.
        let n = if p.model == FilmModel::Short { 40 } else { 6 };
        for _ in 0..n {
            // End eccentricity ratios in [0.05, 0.85] at any angle (|u| <= 0.5).
            let mut end = || {
                let (e, a) = (0.45 + 0.8 * u(), 2.0 * std::f64::consts::PI * u());
                (e * a.cos() * d, e * a.sin() * d)
            };
            let ((xi, yi), (xj, yj)) = (end(), end());
            let state = BearingState {
                xi,
                yi,
                xj,
                yj,
                vxi: 20.0 * u() * d,
                vyi: 20.0 * u() * d,
                vxj: 20.0 * u() * d,
                vyj: 20.0 * u() * d,
                omega: 100.0 + 50.0 * u(),
            };
            out.push(LoadRequest {
                bearing: b as u32,
                state,
            });
        }
        out.push(LoadRequest {
            bearing: b as u32,
            state: BearingState::default(),
        });
        out.push(LoadRequest {
            bearing: b as u32,
            state: BearingState {
                xi: 1.5 * d,
                omega: 10.0,
                ..BearingState::default()
            },
        });
        out.push(LoadRequest {
            bearing: b as u32,
            state: BearingState {
                vxj: f64::NAN,
                ..BearingState::default()
            },
        });
    }
    out.push(LoadRequest {
        bearing: bearings.len() as u32,
        state: BearingState::default(),
    });
    out
}

/// Bit patterns of every output but `film`.
fn bits(l: &Loads) -> Vec<u64> {
    let opt = |v: Option<f64>| v.map_or(u64::MAX, f64::to_bits);
    vec![
        l.wx.to_bits(),
        l.wy.to_bits(),
        l.mx.to_bits(),
        l.my.to_bits(),
        l.mz.to_bits(),
        opt(l.friction_coefficient),
        opt(l.sommerfeld),
        l.h_min.to_bits(),
        l.power_loss.to_bits(),
        l.friction_model as u64,
    ]
}

fn film_bits(f: &FilmFlow) -> Vec<u64> {
    let opt = |v: Option<f64>| v.map_or(u64::MAX, f64::to_bits);
    vec![
        f.friction_torque_nm.to_bits(),
        f.power_loss_w.to_bits(),
        opt(f.friction_coefficient),
        opt(f.friction_variable),
        f.side_flow_i_m3_per_s.to_bits(),
        f.side_flow_j_m3_per_s.to_bits(),
        f.side_flow_m3_per_s.to_bits(),
        f.inlet_flow_m3_per_s.to_bits(),
    ]
}

fn run(plan: Option<&BearingPlan>) -> Vec<LoadResult> {
    let b = bearings();
    let r = requests(&b);
    let mut out = Vec::new();
    let mut ev = evaluator();
    match plan {
        Some(p) => ev.evaluate_planned(&b, p, &r, &mut out),
        None => ev.evaluate(&b, &r, &mut out),
    }
    assert_eq!(out.len(), r.len());
    out
}

#[test]
fn a_plan_without_film_outputs_changes_only_the_film_outputs() {
    let b = bearings();
    let r = requests(&b);
    let want = run(None);
    // Mixed flags: film outputs for the finite bearing only.
    let mut plan = BearingPlan::new(&b, false);
    plan.film_outputs[1] = true;
    let got = run(Some(&plan));
    let (mut ok, mut faults, mut film_nonzero, mut finite_kept) = (0, 0, 0, 0);
    for (k, (w, g)) in want.iter().zip(&got).enumerate() {
        match (w, g) {
            (Ok(w), Ok(g)) => {
                assert_eq!(
                    bits(w),
                    bits(g),
                    "state {k}: outputs other than film differ"
                );
                let wanted = plan.film_outputs[r[k].bearing as usize];
                if wanted {
                    assert_eq!(film_bits(&w.film), film_bits(&g.film), "state {k}");
                    finite_kept += usize::from(w.film.friction_torque_nm != 0.0);
                } else {
                    assert_eq!(
                        film_bits(&g.film),
                        film_bits(&FilmFlow::default()),
                        "state {k}: film outputs computed though not asked for"
                    );
                    film_nonzero += usize::from(w.film.friction_torque_nm != 0.0);
                }
                ok += 1;
            }
            (Err(w), Err(g)) => {
                assert_eq!(w, g, "state {k}: faults differ");
                faults += 1;
            }
            _ => panic!("state {k}: {w:?} against {g:?}"),
        }
    }
    // The comparison has teeth: loads with film outputs skipped, finite loads with them
    // kept, and faults of every kind (through the wall, non-finite, invalid bearing,
    // index out of range).
    assert!(
        film_nonzero >= 40,
        "{film_nonzero} loads had film outputs to skip"
    );
    assert!(finite_kept >= 6, "{finite_kept} finite loads kept theirs");
    assert!(ok >= 50 && faults >= 49, "{ok} loads, {faults} faults");
}

#[test]
fn a_plan_with_film_outputs_is_evaluate_bit_for_bit() {
    let b = bearings();
    let want = run(None);
    let got = run(Some(&BearingPlan::new(&b, true)));
    for (k, (w, g)) in want.iter().zip(&got).enumerate() {
        match (w, g) {
            (Ok(w), Ok(g)) => {
                assert_eq!(bits(w), bits(g), "state {k}");
                assert_eq!(film_bits(&w.film), film_bits(&g.film), "state {k}");
            }
            (Err(w), Err(g)) => assert_eq!(w, g, "state {k}"),
            _ => panic!("state {k}: {w:?} against {g:?}"),
        }
    }
}

#[test]
fn a_plan_names_the_invalid_bearing_field_like_evaluate() {
    let b = bearings();
    let plan = BearingPlan::new(&b, false);
    assert!(plan.valid[..3].iter().all(Result::is_ok));
    let fault = plan.valid[3].unwrap_err();
    assert!(
        fault.to_string().contains("viscosity"),
        "fault names the field: {fault}"
    );
}
