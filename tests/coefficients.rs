//! Linearised bearing coefficients (issue 15) against closed forms, the textbook case and
//! invariances.
//!
//! # Short-bearing closed forms (derived from MODEL.md sections 2-3)
//! In the line-of-centres frame (`r` along the journal's displacement `e = ε δ`, `t` a
//! quarter turn ahead), with `U = ω − 2φ̇` and the film on `ψ ∈ (π, 2π)` (ψ from the line
//! of centres), `∫_0^B 3μ z(z−B) dz = −μB³/2` and the Sommerfeld integrals
//! `∫ sinψ cosψ/(1−ε cosψ)³ = −2ε/(1−ε²)²`, `∫ sin²ψ/(…)³ = π/(2(1−ε²)^{3/2})`,
//! `∫ cos²ψ/(…)³ = π(1+2ε²)/(2(1−ε²)^{5/2})` over that arc give, with `a = μ r0 B³/δ²`:
//!
//! ```text
//! W_r = −a [ U f_r(ε) + ε̇ g_r(ε) ],  f_r = ε²/(1−ε²)²,      g_r = π(1+2ε²)/(2(1−ε²)^{5/2})
//! W_t = +a [ U f_t(ε) + ε̇ g_t(ε) ],  f_t = πε/(4(1−ε²)^{3/2}), g_t = 2ε/(1−ε²)²
//! ```
//!
//! (at `ε̇ = φ̇ = 0` these are MODEL.md section 7). The loaded arc's ends move with the
//! state, but the pressure vanishes there, so (Leibniz) the derivatives are those of the
//! fixed arc. Differentiating (`δe_r = δ δε`, `δe_t = e δφ`; turning `φ` turns `W`):
//!
//! ```text
//! K_rr =  aω f_r'/δ     K_rt = aω f_t/(δε)      C_rr =  a g_r/δ     C_rt = −2a f_r/(δε)
//! K_tr = −aω f_t'/δ     K_tt = aω f_r/(δε)      C_tr = −a g_t/δ     C_tt =  2a f_t/(δε)
//! ```
//!
//! (`C_rt = C_tr`: `2 f_r/ε = g_t`), then turned into the bearing frame: `K = R K_rt Rᵀ`.
//!
//! # Tilt block (slice model, aligned base state)
//! Every slice has the same state, so the slice derivative is the aligned `K` (and `C`)
//! distributed along `z` with the weight `z(B−z) / (B³/6)`. A tilt `(α, β)` about the
//! mid-plane moves the slice at `ζ = z − B/2` by `ζ (β, −α)`. With `∫ ζ z(B−z) dz = 0` the
//! force-tilt and moment-displacement blocks vanish; with
//! `∫ ζ² z(B−z) dz = B⁵/120` and `M_x = −∫ ζ dW_y`, `M_y = ∫ ζ dW_x`:
//!
//! ```text
//! K_tilt = (B²/20) [[ K_yy, −K_yx], [−K_xy, K_xx]]     (same for C)
//! ```

use bearing_sweep::backend::{create_backend, BackendKind, LoadEvaluator};
use bearing_sweep::bearing::{Accuracy, BearingParams, ClearanceConvention};
use bearing_sweep::stability::{
    aligned_state, bearing_equilibria, coefficients_batch, BearingCoefficients, CoefficientJob,
    DiffOptions,
};

fn evaluator() -> LoadEvaluator {
    let (b, _) = create_backend(BackendKind::Cpu, Accuracy::new(1e-12).unwrap()).unwrap();
    LoadEvaluator::new(b)
}

fn bearing(radius: f64, length: f64, clearance: f64, viscosity: f64) -> BearingParams {
    BearingParams {
        radius,
        length,
        clearance,
        viscosity,
        clearance_convention: ClearanceConvention::Paper,
        ..BearingParams::paper_table2()
    }
}

/// Closed-form `(K, C)` 2×2 in the bearing frame for an aligned journal at `ε` along the
/// angle `phi`, spin `omega > 0` (formulas in the module comment).
fn closed_form(
    p: &BearingParams,
    eps: f64,
    phi: f64,
    omega: f64,
) -> ([[f64; 2]; 2], [[f64; 2]; 2]) {
    let pi = std::f64::consts::PI;
    let a = p.viscosity * p.radius * p.length.powi(3) / p.clearance.powi(2);
    let d = p.clearance;
    let q = 1.0 - eps * eps;
    let f_r = eps * eps / (q * q);
    let f_t = pi * eps / (4.0 * q.powf(1.5));
    let g_r = pi * (1.0 + 2.0 * eps * eps) / (2.0 * q.powf(2.5));
    let g_t = 2.0 * eps / (q * q);
    // f_r' = 2ε(1+ε²)/(1−ε²)³, f_t' = π(1+2ε²)/(4(1−ε²)^{5/2}).
    let df_r = 2.0 * eps * (1.0 + eps * eps) / (q * q * q);
    let df_t = pi * (1.0 + 2.0 * eps * eps) / (4.0 * q.powf(2.5));
    let k = [
        [a * omega * df_r / d, a * omega * f_t / (d * eps)],
        [-a * omega * df_t / d, a * omega * f_r / (d * eps)],
    ];
    let c = [
        [a * g_r / d, -2.0 * a * f_r / (d * eps)],
        [-a * g_t / d, 2.0 * a * f_t / (d * eps)],
    ];
    (rotate(&k, phi), rotate(&c, phi))
}

fn rotate(m: &[[f64; 2]; 2], phi: f64) -> [[f64; 2]; 2] {
    let (s, c) = phi.sin_cos();
    let r = [[c, -s], [s, c]];
    let mut rm = [[0.0; 2]; 2];
    let mut out = [[0.0; 2]; 2];
    for i in 0..2 {
        for j in 0..2 {
            rm[i][j] = (0..2).map(|k| r[i][k] * m[k][j]).sum();
        }
    }
    for i in 0..2 {
        for j in 0..2 {
            out[i][j] = (0..2).map(|k| rm[i][k] * r[j][k]).sum();
        }
    }
    out
}

fn coeffs_at(
    ev: &mut LoadEvaluator,
    p: BearingParams,
    x: f64,
    y: f64,
    omega: f64,
) -> BearingCoefficients {
    coefficients_batch(
        ev,
        &[CoefficientJob {
            params: p,
            state: aligned_state(x, y, omega),
        }],
        &DiffOptions::default(),
    )
    .remove(0)
    .expect("coefficients")
}

fn check(label: &str, actual: f64, expected: f64, tol: f64) {
    let err = (actual - expected).abs();
    assert!(
        err <= tol,
        "{label}: actual {actual:e}, expected {expected:e}, |diff| {err:e} > tolerance {tol:e}"
    );
}

#[test]
fn short_bearing_closed_forms_at_every_eccentricity() {
    let p = bearing(0.02, 0.02, 3e-4, 0.0242);
    let omega = 100.0;
    let mut ev = evaluator();
    let mut worst: f64 = 0.0;
    for &eps in &[0.05, 0.2, 0.4, 0.6, 0.8, 0.9, 0.95] {
        for &phi in &[0.0_f64, 0.7, -2.3] {
            let e = eps * p.clearance;
            let c = coeffs_at(&mut ev, p, e * phi.cos(), e * phi.sin(), omega);
            let (k2, c2) = closed_form(&p, eps, phi, omega);
            let kscale = k2.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
            let cscale = c2.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
            for i in 0..2 {
                for j in 0..2 {
                    let lk = format!("ε {eps} φ {phi}: K[{i}][{j}]");
                    let lc = format!("ε {eps} φ {phi}: C[{i}][{j}]");
                    check(&lk, c.stiffness[i][j], k2[i][j], 1e-7 * kscale);
                    check(&lc, c.damping[i][j], c2[i][j], 1e-7 * cscale);
                    // The error estimate bounds the actual error.
                    let ek = (c.stiffness[i][j] - k2[i][j]).abs();
                    let ec = (c.damping[i][j] - c2[i][j]).abs();
                    assert!(
                        ek <= c.stiffness_error[i][j].max(1e-12 * kscale),
                        "{lk}: error {ek:e} beyond its estimate {:e}",
                        c.stiffness_error[i][j]
                    );
                    assert!(
                        ec <= c.damping_error[i][j].max(1e-12 * cscale),
                        "{lc}: error {ec:e} beyond its estimate {:e}",
                        c.damping_error[i][j]
                    );
                    worst = worst.max(ek / kscale).max(ec / cscale);
                }
            }
            // Tilt block: (B²/20) [[K_yy, −K_yx], [−K_xy, K_xx]]; cross blocks zero.
            let b2 = p.length * p.length / 20.0;
            for (m, m2, name, scale) in [
                (&c.stiffness, &k2, "K", kscale),
                (&c.damping, &c2, "C", cscale),
            ] {
                let tilt = [[m2[1][1], -m2[1][0]], [-m2[0][1], m2[0][0]]];
                for i in 0..2 {
                    for j in 0..2 {
                        check(
                            &format!("ε {eps} φ {phi}: {name} tilt[{i}][{j}]"),
                            m[2 + i][2 + j],
                            b2 * tilt[i][j],
                            1e-7 * b2 * scale,
                        );
                        check(
                            &format!("ε {eps} φ {phi}: {name} force-tilt[{i}][{j}]"),
                            m[i][2 + j],
                            0.0,
                            1e-7 * scale * p.length,
                        );
                        check(
                            &format!("ε {eps} φ {phi}: {name} moment-displacement[{i}][{j}]"),
                            m[2 + i][j],
                            0.0,
                            1e-7 * scale * p.length,
                        );
                    }
                }
            }
        }
    }
    eprintln!("short-bearing closed forms: worst relative error {worst:.2e}");
}

#[test]
fn friswell_example_5_5_1() {
    // Friswell et al., Dynamics of Rotating Machines, Example 5.5.1: D = 0.1 m,
    // L = 0.03 m, radial clearance 1e-4 m (the δ of MODEL.md's h), μ = 0.1 Pa·s,
    // 157.1 rad/s, static load 525 N → ε = 0.2663,
    // K = [12.81 16.39; −25.06 8.815] MN/m, C = [232.9 −81.92; −81.92 294.9] kN·s/m.
    // The book's frame is ours with the static load along the y axis (either sign: a half
    // turn leaves K and C unchanged) and the spin from +x toward +y; with the load along x
    // the same numbers appear transposed-and-swapped (K_xx ↔ K_yy, K_xy ↔ −K_yx).
    let p = bearing(0.05, 0.03, 1e-4, 0.1);
    let mut ev = evaluator();
    for load in [[0.0, -525.0], [0.0, 525.0]] {
        let eq = bearing_equilibria(&mut ev, &[(p, 157.1, load)])
            .remove(0)
            .unwrap();
        check("ε", eq.eccentricity_ratio, 0.2663, 5e-5);
        let c = coeffs_at(&mut ev, p, eq.x, eq.y, 157.1);
        let k_book = [[12.81e6, 16.39e6], [-25.06e6, 8.815e6]];
        let c_book = [[232.9e3, -81.92e3], [-81.92e3, 294.9e3]];
        for i in 0..2 {
            for j in 0..2 {
                // Book values are printed to 4 significant digits.
                check(
                    &format!("load {load:?}: K[{i}][{j}]"),
                    c.stiffness[i][j],
                    k_book[i][j],
                    6e-4 * k_book[i][j].abs(),
                );
                check(
                    &format!("load {load:?}: C[{i}][{j}]"),
                    c.damping[i][j],
                    c_book[i][j],
                    6e-4 * c_book[i][j].abs(),
                );
            }
        }
        // Equilibrium: the film carries the load.
        check("W_x + P_x", eq.loads.wx + load[0], 0.0, 1e-9 * 525.0);
        check("W_y + P_y", eq.loads.wy + load[1], 0.0, 1e-9 * 525.0);
    }
}

#[test]
fn rotating_the_load_rotates_k_and_c() {
    // K(R P) = R K(P) Rᵀ for each 2×2 pair (x, y) and (tilt_x, tilt_y): the film is
    // invariant under turning the state about the bore axis (MODEL.md section 7).
    let p = bearing(0.02, 0.015, 2e-4, 0.03);
    let omega = 250.0;
    let mut ev = evaluator();
    let base = [40.0, -15.0];
    let eqs = bearing_equilibria(&mut ev, &[(p, omega, base)])
        .remove(0)
        .unwrap();
    let c0 = coeffs_at(&mut ev, p, eqs.x, eqs.y, omega);
    for &ang in &[0.3_f64, 1.9, -2.8] {
        let (s, c) = ang.sin_cos();
        let load = [c * base[0] - s * base[1], s * base[0] + c * base[1]];
        let eq = bearing_equilibria(&mut ev, &[(p, omega, load)])
            .remove(0)
            .unwrap();
        check(
            "ε invariant",
            eq.eccentricity_ratio,
            eqs.eccentricity_ratio,
            1e-10,
        );
        check(
            "attitude invariant",
            eq.attitude_angle,
            eqs.attitude_angle,
            1e-9,
        );
        let cr = coeffs_at(&mut ev, p, eq.x, eq.y, omega);
        let r4 = |m: &[[f64; 4]; 4]| {
            let mut r = [[0.0; 4]; 4];
            let rot = [
                [c, -s, 0.0, 0.0],
                [s, c, 0.0, 0.0],
                [0.0, 0.0, c, -s],
                [0.0, 0.0, s, c],
            ];
            let mut rm = [[0.0; 4]; 4];
            for i in 0..4 {
                for j in 0..4 {
                    rm[i][j] = (0..4).map(|k| rot[i][k] * m[k][j]).sum();
                }
            }
            for i in 0..4 {
                for j in 0..4 {
                    r[i][j] = (0..4).map(|k| rm[i][k] * rot[j][k]).sum();
                }
            }
            r
        };
        let (ke, ce) = (r4(&c0.stiffness), r4(&c0.damping));
        let ks = ke.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
        let cs = ce.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
        for i in 0..4 {
            for j in 0..4 {
                check(
                    &format!("angle {ang}: K[{i}][{j}]"),
                    cr.stiffness[i][j],
                    ke[i][j],
                    1e-8 * ks,
                );
                check(
                    &format!("angle {ang}: C[{i}][{j}]"),
                    cr.damping[i][j],
                    ce[i][j],
                    1e-8 * cs,
                );
            }
        }
    }
}

#[test]
fn centred_journal_is_a_damper_with_half_speed_cross_coupling() {
    // At ε = 0 the film is linear in the rate vector (docs/whirl.md): F = −c (ė − ω/2 J e)
    // with c = π a / (2 δ)·… ; here only the structure is checked against the coefficients
    // themselves: K = (ω/2) C J (skew), C isotropic, at a relative accuracy shown by the
    // error estimates (the centred film's second-order part is |t|·t-like).
    let p = bearing(0.02, 0.02, 3e-4, 0.1);
    let omega = 300.0;
    let mut ev = evaluator();
    let c = coeffs_at(&mut ev, p, 0.0, 0.0, omega);
    // Closed form: g_r(0) = π/2 ⇒ C_xx = C_yy = π a / (2δ); K_xy = −K_yx = ω/2 C_xx.
    let a = p.viscosity * p.radius * p.length.powi(3) / p.clearance.powi(2);
    let cc = std::f64::consts::PI * a / (2.0 * p.clearance);
    check("C_xx", c.damping[0][0], cc, 1e-6 * cc);
    check("C_yy", c.damping[1][1], cc, 1e-6 * cc);
    check("C_xy", c.damping[0][1], 0.0, 1e-6 * cc);
    check(
        "K_xy",
        c.stiffness[0][1],
        0.5 * omega * cc,
        1e-6 * omega * cc,
    );
    check(
        "K_yx",
        c.stiffness[1][0],
        -0.5 * omega * cc,
        1e-6 * omega * cc,
    );
    check("K_xx", c.stiffness[0][0], 0.0, 1e-6 * omega * cc);
    for i in 0..4 {
        for j in 0..4 {
            assert!(
                c.stiffness_error[i][j] < 1e-5 * omega * cc,
                "K error [{i}][{j}] {:e}",
                c.stiffness_error[i][j]
            );
        }
    }
}

mod cli_support;

/// Runs the binary: (success, stdout, stderr).
fn run_cli(args: &[&str], stdin: Option<&str>) -> (bool, String, String) {
    use std::io::Write;
    let mut cmd = cli_support::bin();
    cmd.args(args)
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped());
    let mut child = cmd.spawn().unwrap();
    if let Some(text) = stdin {
        child
            .stdin
            .take()
            .unwrap()
            .write_all(text.as_bytes())
            .unwrap();
    } else {
        drop(child.stdin.take());
    }
    let out = child.wait_with_output().unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

const FRISWELL: &str = r#"{"bearing": {"radius": 0.05, "length": 0.03, "clearance": 1e-4, "viscosity": 0.1},
                           "speed": 157.1, "load": [0, -525]}"#;

#[test]
fn cli_service_function_and_ross_rows_agree_with_the_library() {
    let (ok, out, err) = run_cli(&["coefficients", "-"], Some(FRISWELL));
    assert!(ok, "{err}");
    let cli: serde_json::Value = serde_json::from_str(&out).unwrap();
    // The service's one-line entry point gives the same document.
    let lib = bearing_sweep::app::coefficients_json(FRISWELL).unwrap();
    assert_eq!(cli["stiffness"], lib["stiffness"]);
    assert_eq!(cli["damping"], lib["damping"]);
    // ... and the same as the library's own pieces.
    let p = bearing(0.05, 0.03, 1e-4, 0.1);
    let mut ev = evaluator();
    let eq = bearing_equilibria(&mut ev, &[(p, 157.1, [0.0, -525.0])])
        .remove(0)
        .unwrap();
    let c = coeffs_at(&mut ev, p, eq.x, eq.y, 157.1);
    for i in 0..4 {
        for j in 0..4 {
            let k = cli["stiffness"][i][j].as_f64().unwrap();
            assert_eq!(
                k, c.stiffness[i][j],
                "K[{i}][{j}]: CLI {k} vs library {}",
                c.stiffness[i][j]
            );
        }
    }
    assert_eq!(
        cli["order"],
        serde_json::json!(["x", "y", "tilt_x", "tilt_y"])
    );
    let eps = cli["equilibrium"]["eccentricity_ratio"].as_f64().unwrap();
    check("CLI ε", eps, 0.2663, 5e-5);
    // ROSS rows: speed, kxx, kxy, kyx, kyy, cxx, cxy, cyx, cyy (the force block).
    let (ok, csv, err) = run_cli(
        &["coefficients", "--format", "ross-csv", "-"],
        Some(FRISWELL),
    );
    assert!(ok, "{err}");
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines[0], "speed,kxx,kxy,kyx,kyy,cxx,cxy,cyx,cyy");
    let row: Vec<f64> = lines[1].split(',').map(|v| v.parse().unwrap()).collect();
    let want = [
        157.1,
        c.stiffness[0][0],
        c.stiffness[0][1],
        c.stiffness[1][0],
        c.stiffness[1][1],
        c.damping[0][0],
        c.damping[0][1],
        c.damping[1][0],
        c.damping[1][1],
    ];
    for (k, (a, e)) in row.iter().zip(want).enumerate() {
        check(&format!("ROSS column {k}"), *a, e, 1e-12 * e.abs());
    }
    // A speed list: one row per speed, rising direct stiffness... and each row equal to
    // its single-speed run.
    let (ok, out, err) = run_cli(
        &["coefficients", "-"],
        Some(
            r#"{"bearing": {"radius": 0.05, "length": 0.03, "clearance": 1e-4, "viscosity": 0.1},
                 "speeds": [100, 157.1, 300], "load": [0, -525]}"#,
        ),
    );
    assert!(ok, "{err}");
    let many: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(many["points"].as_array().unwrap().len(), 3);
    assert_eq!(many["points"][1]["stiffness"], cli["stiffness"]);
}

#[test]
fn bad_coefficient_inputs_name_the_field() {
    let cases = [
        (
            r#"{"bearing": {"radius": 0.05, "length": 0.03, "clearance": -1e-4, "viscosity": 0.1}, "speed": 1, "load": [0, 1]}"#,
            "bearing.clearance",
        ),
        (
            r#"{"bearing": {"radius": 0.05, "length": 0.03, "clearance": 1e-4, "viscosity": 0.1}, "speed": 1}"#,
            "load",
        ),
        (
            r#"{"bearing": {"radius": 0.05, "length": 0.03, "clearance": 1e-4, "viscosity": 0.1}, "speed": "fast", "load": [0, 1]}"#,
            "speed",
        ),
        (
            r#"{"bearing": {"radius": 0.05, "length": 0.03, "clearance": 1e-4, "viscosity": 0.1}, "speeds": [1, null], "load": [0, 1]}"#,
            "speeds[1]",
        ),
        (
            r#"{"bearing": {"radius": 0.05, "length": 0.03, "clearance": 1e-4, "viscosity": 0.1}, "speed": 0, "load": [0, 1]}"#,
            "speed",
        ),
        (
            r#"{"bearing": {"radius": 0.05, "length": 0.03, "clearance": 1e-4, "viscosity": 0.1}, "speed": 1, "load": [0]}"#,
            "load",
        ),
        (
            r#"{"bearing": {"radius": 0.05, "length": 0.03, "clearance": 1e-4, "viscosity": 0.1}, "state": {"xi": 2e-4}}"#,
            "state",
        ),
        (
            r#"{"bearing": {"radius": 0.05, "length": 0.03, "clearance": 1e-4, "viscosity": 0.1}, "state": {"xi": 0}, "speed": 3}"#,
            "speed",
        ),
        (
            r#"{"bearing": {"radius": 0.05, "length": 0.03, "clearance": 1e-4, "viscosity": 0.1}, "speed": 1, "load": [0, 1], "lod": 2}"#,
            "lod",
        ),
    ];
    for (input, field) in cases {
        let (ok, out, err) = run_cli(&["coefficients", "-"], Some(input));
        assert!(!ok, "{input}: succeeded with {out}");
        assert!(
            err.starts_with(&format!("error: {field}")),
            "{input}: want an error at `{field}`, got {err}"
        );
        assert!(!err.contains("panicked"), "{err}");
    }
}

#[test]
fn gpu_backend_gives_the_cpu_coefficients_within_their_error() {
    // The perturbed states go through whatever backend the evaluator wraps: the f64 GPU
    // kernel must give the CPU's coefficients to within the differences' own error
    // estimate. Skips with a notice without an adapter, unless BEARING_SWEEP_REQUIRE_GPU=1.
    use bearing_sweep::backend::{GpuBackend, GpuOptions, Precision};
    let accuracy = Accuracy::new(1e-12).unwrap();
    let options = GpuOptions {
        precision: Some(Precision::F64),
        ..GpuOptions::default()
    };
    let gpu = match GpuBackend::new(accuracy, options) {
        Ok(g) => g,
        Err(e) if std::env::var("BEARING_SWEEP_REQUIRE_GPU").is_ok_and(|v| v == "1") => {
            panic!("BEARING_SWEEP_REQUIRE_GPU=1 but: {e}")
        }
        Err(e) => {
            eprintln!("notice: skipping the GPU case: {e}");
            return;
        }
    };
    let mut gev = LoadEvaluator::new(Box::new(gpu));
    let mut cev = evaluator();
    let p = bearing(0.02, 0.02, 3e-4, 0.0242);
    // An aligned loaded state, a tilted whirling one and the centred one, in one call each.
    let mut tilted = aligned_state(1.2e-4, -0.6e-4, 150.0);
    tilted.xj = 0.5e-4;
    tilted.vyi = 3e-3;
    let jobs: Vec<CoefficientJob> = [
        aligned_state(1.5e-4, 0.4e-4, 100.0),
        tilted,
        aligned_state(0.0, 0.0, 300.0),
    ]
    .iter()
    .map(|s| CoefficientJob {
        params: p,
        state: *s,
    })
    .collect();
    let g = coefficients_batch(&mut gev, &jobs, &DiffOptions::default());
    let c = coefficients_batch(&mut cev, &jobs, &DiffOptions::default());
    for (n, (g, c)) in g.iter().zip(&c).enumerate() {
        let (g, c) = (g.as_ref().unwrap(), c.as_ref().unwrap());
        let ks = c
            .stiffness
            .iter()
            .flatten()
            .fold(0.0f64, |m, v| m.max(v.abs()));
        let cs = c
            .damping
            .iter()
            .flatten()
            .fold(0.0f64, |m, v| m.max(v.abs()));
        for i in 0..4 {
            for j in 0..4 {
                let tk = 2.0 * c.stiffness_error[i][j] + 1e-9 * ks;
                let tc = 2.0 * c.damping_error[i][j] + 1e-9 * cs;
                check(
                    &format!("state {n}: GPU K[{i}][{j}]"),
                    g.stiffness[i][j],
                    c.stiffness[i][j],
                    tk,
                );
                check(
                    &format!("state {n}: GPU C[{i}][{j}]"),
                    g.damping[i][j],
                    c.damping[i][j],
                    tc,
                );
            }
        }
    }
}
