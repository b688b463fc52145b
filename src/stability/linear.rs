//! Linearisation of the scenes' rigid rotor (MODEL.md section 8) about its equilibrium:
//! `M q̈ + D q̇ + K q = 0` in `q = (s_x, s_y, tilt_x, tilt_y)`, `s` the shaft-axis point
//! level with `G` (m) and the tilts right-handed rotations of the shaft about global `x`
//! and `y` (rad), so that the journal centre at axial position `a` from `G` is
//! `(s_x + a tilt_y, s_y − a tilt_x)`.
//!
//! Frames:
//! - `fixed`: about the static equilibrium under gravity (unbalance ignored: it is a
//!   synchronous forcing, not part of the linearisation), or about the centred journal
//!   when nothing loads the rotor.
//! - `rotating`: an unbalanced rotor without gravity whirls synchronously on an orbit that
//!   is an equilibrium in the frame turning with the shaft at `Ω`; there the film is
//!   linearised about the whirling state (velocities `Ω ẑ × e`) and
//!   `m (q̈ + 2Ω J q̇ − Ω² q)`, `I_d θ̈ + (2 I_d − I_p) Ω J θ̇ + (I_p − I_d) Ω² θ` are the
//!   inertial terms (`J` the quarter turn `(x, y) → (−y, x)`).
//!
//! Spin is held at the analysed speed (a free spin adds a neutral, slowly drifting mode
//! driven by friction that does not couple to the lateral motion to first order).

use nalgebra::{Matrix4, Vector4};

use super::coefficients::{
    aligned_state, coefficients_batch, load_noise, perturb, pin_grid, BearingCoefficients,
    CoefficientJob, DiffOptions,
};
use super::equilibrium::closed_form_position;
use super::StabilityError;
use crate::bearing::{BearingParams, BearingState};
use crate::rotor::{ModelKind, Scene};

/// 4×4 matrix as nested arrays (row-major), for output.
pub type M4 = [[f64; 4]; 4];

/// In which frame the linearisation is made.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Frame {
    /// Fixed to the housings (static equilibrium).
    Fixed,
    /// Turning with the shaft (synchronous orbit of an unbalanced rotor).
    Rotating,
}

/// What the linear analysis needs of a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct RotorDescription {
    /// Mass, kg.
    pub mass: f64,
    /// Transverse moment of inertia about `G`, kg·m² (mean of the body's `xx`, `yy`).
    pub i_transverse: f64,
    /// Polar moment of inertia about the shaft axis, kg·m².
    pub i_polar: f64,
    /// Products of inertia `(I_xz, I_yz)` of the body (couple unbalance), kg·m².
    pub products: [f64; 2],
    /// Static unbalance (body frame), m.
    pub unbalance: [f64; 2],
    /// Gravity in the plane, m/s².
    pub gravity: [f64; 2],
    /// Bearings and the axial positions of their mid-planes from `G`, m.
    pub bearings: Vec<(BearingParams, f64)>,
    /// The scene's spin, rad/s (the operating speed).
    pub spin: f64,
    /// The linearisation frame.
    pub frame: Frame,
    /// What the linearisation leaves out for this rotor.
    pub notes: Vec<String>,
}

impl RotorDescription {
    /// From a (validated) scene. Errors name the scene field.
    pub fn from_scene(scene: &Scene) -> Result<Self, StabilityError> {
        scene
            .validate()
            .map_err(|e| StabilityError::input(e.path, e.reason))?;
        if scene.model != ModelKind::Bearing {
            return Err(StabilityError::input(
                "model",
                "ideal joints have no film to linearise (use \"bearing\")",
            ));
        }
        let r = &scene.rotor;
        // Body inertia with the couple unbalance: Rx(bx) Ry(by) diag(I) (Rx Ry)ᵀ.
        let (sx, cx) = r.couple_unbalance[0].sin_cos();
        let (sy, cy) = r.couple_unbalance[1].sin_cos();
        let rxm = nalgebra::Matrix3::new(1.0, 0.0, 0.0, 0.0, cx, -sx, 0.0, sx, cx);
        let rym = nalgebra::Matrix3::new(cy, 0.0, sy, 0.0, 1.0, 0.0, -sy, 0.0, cy);
        let rc = rxm * rym;
        let ib =
            rc * nalgebra::Matrix3::from_diagonal(&nalgebra::Vector3::new(
                r.inertia[0],
                r.inertia[1],
                r.inertia[2],
            )) * rc.transpose();
        let mut notes = Vec::new();
        let (ixx, iyy) = (ib[(0, 0)], ib[(1, 1)]);
        if (ixx - iyy).abs() > 1e-9 * (ixx + iyy) {
            notes.push(format!(
                "transverse inertias differ ({ixx} and {iyy} kg·m²): the fixed-frame equations are then periodic; linearised with their mean"
            ));
        }
        let gravity = [scene.gravity[0], scene.gravity[1]];
        let unbalanced = r.static_unbalance != [0.0, 0.0] || r.couple_unbalance != [0.0, 0.0];
        let frame = if gravity != [0.0, 0.0] {
            if unbalanced {
                notes.push("gravity and unbalance: linearised about the static equilibrium under gravity; the unbalance is a synchronous forcing, not part of the linear model".into());
            }
            Frame::Fixed
        } else if unbalanced {
            Frame::Rotating
        } else {
            Frame::Fixed
        };
        if scene.spin == crate::rotor::SpinMode::Free {
            notes.push("spin free in the scene: held constant in the linearisation (friction only drifts it slowly)".into());
        }
        Ok(RotorDescription {
            mass: r.mass,
            i_transverse: 0.5 * (ixx + iyy),
            i_polar: ib[(2, 2)],
            products: [ib[(0, 2)], ib[(1, 2)]],
            unbalance: r.static_unbalance,
            gravity,
            bearings: scene
                .bearings
                .iter()
                .map(|b| (b.params(), b.axial_position))
                .collect(),
            spin: scene.initial.spin,
            frame,
            notes,
        })
    }

    /// Whirl rate of the analysis frame at spin `speed`, rad/s.
    pub fn frame_rate(&self, speed: f64) -> f64 {
        match self.frame {
            Frame::Fixed => 0.0,
            Frame::Rotating => speed,
        }
    }

    /// External generalised load `f` and its stiffness-like part `E` (`r = Q_film + f + E q`).
    fn external(&self, speed: f64) -> ([f64; 4], [f64; 4]) {
        let m = self.mass;
        match self.frame {
            Frame::Fixed => (
                [m * self.gravity[0], m * self.gravity[1], 0.0, 0.0],
                [0.0; 4],
            ),
            Frame::Rotating => {
                let w2 = speed * speed;
                let tilt = -(self.i_polar - self.i_transverse) * w2;
                (
                    [
                        m * w2 * self.unbalance[0],
                        m * w2 * self.unbalance[1],
                        w2 * self.products[1],
                        -w2 * self.products[0],
                    ],
                    [m * w2, m * w2, tilt, tilt],
                )
            }
        }
    }
}

/// `T_b`: bearing mid-plane coordinates from rotor coordinates.
fn transfer(a: f64) -> Matrix4<f64> {
    Matrix4::new(
        1.0, 0.0, 0.0, a, //
        0.0, 1.0, -a, 0.0, //
        0.0, 0.0, 1.0, 0.0, //
        0.0, 0.0, 0.0, 1.0,
    )
}

/// Quarter turn on both pairs `(x, y)` and `(tilt_x, tilt_y)`.
fn quarter_turn() -> Matrix4<f64> {
    Matrix4::new(
        0.0, -1.0, 0.0, 0.0, //
        1.0, 0.0, 0.0, 0.0, //
        0.0, 0.0, 0.0, -1.0, //
        0.0, 0.0, 1.0, 0.0,
    )
}

fn to_m4(m: &Matrix4<f64>) -> M4 {
    let mut o = [[0.0; 4]; 4];
    for (i, row) in o.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = m[(i, j)];
        }
    }
    o
}

fn from_m4(m: &M4) -> Matrix4<f64> {
    Matrix4::from_fn(|i, j| m[i][j])
}

/// The state of bearing `(params, a)` when the rotor is at `q` spinning at `speed`, seen
/// from a frame whirling at `frame_rate` (the journals move at `frame_rate ẑ × e`).
pub fn bearing_state(
    q: &[f64; 4],
    params: &BearingParams,
    a: f64,
    speed: f64,
    frame_rate: f64,
) -> BearingState {
    let qb = transfer(a) * Vector4::from_column_slice(q);
    let mut s = perturb(
        &aligned_state(0.0, 0.0, speed),
        params.length,
        [qb[0], qb[1], qb[2], qb[3]],
        [0.0; 4],
    );
    s.vxi = -frame_rate * s.yi;
    s.vyi = frame_rate * s.xi;
    s.vxj = -frame_rate * s.yj;
    s.vyj = frame_rate * s.xj;
    s
}

/// One bearing at the rotor's equilibrium.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct BearingPoint {
    /// Journal state (bearing frame; velocities non-zero on a synchronous orbit).
    pub state: BearingState,
    /// Larger end eccentricity ratio.
    pub eccentricity_ratio: f64,
    /// The linearised film (4×4, about the bearing mid-plane).
    pub coefficients: BearingCoefficients,
    /// The effective-temperature balance at this equilibrium (bearings with a lubricant
    /// and a supply temperature; the coefficients are at its `μ(T_eff)`), else `None`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub thermal: Option<crate::bearing::Balance>,
}

/// The linear model at one speed.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct LinearRotor {
    /// Spin, rad/s.
    pub speed: f64,
    /// Frame of the linearisation.
    pub frame: Frame,
    /// Equilibrium `q` (m, m, rad, rad).
    pub equilibrium: [f64; 4],
    /// Newton iterations to reach it.
    pub newton_iterations: u32,
    /// Per bearing, in scene order.
    pub bearings: Vec<BearingPoint>,
    /// `M` (kg, kg·m²).
    pub mass: M4,
    /// `D`: film damping, gyroscopic and Coriolis terms.
    pub damping: M4,
    /// `K`: film stiffness (plus `Ω C J` in the rotating frame) and inertial terms.
    pub stiffness: M4,
}

/// Newton iterations at most for a rotor equilibrium.
const MAX_NEWTON: u32 = 40;
/// Step (relative to the smallest clearance) below which Newton has converged.
const NEWTON_TOL: f64 = 1e-12;

/// Closed-form start: the external load shared by the bearings as for a beam on supports
/// (force and moment balance, least-norm for more than two), each bearing aligned at its
/// short-bearing position, `q` fitted to the bearing positions.
fn initial_guess(rotor: &RotorDescription, speed: f64) -> [f64; 4] {
    let (f, _) = rotor.external(speed);
    if f == [0.0; 4] {
        return [0.0; 4];
    }
    let n = rotor.bearings.len() as f64;
    let (sa, saa) = rotor
        .bearings
        .iter()
        .fold((0.0, 0.0), |(s, ss), (_, a)| (s + a, ss + a * a));
    let det = n * saa - sa * sa;
    let solve = |total: f64, moment: f64| {
        if det.abs() <= 1e-300 * saa.max(1e-300) || rotor.bearings.len() == 1 {
            (total / n, 0.0)
        } else {
            (
                (saa * total - sa * moment) / det,
                (n * moment - sa * total) / det,
            )
        }
    };
    // Applied loads P_b = A + B a_b with Σ P_bx = f_x, Σ a P_bx = f_β, Σ P_by = f_y,
    // Σ a P_by = −f_α.
    let (ax, bx) = solve(f[0], f[3]);
    let (ay, by) = solve(f[1], -f[2]);
    let w_eff = speed - 2.0 * rotor.frame_rate(speed);
    let pos: Vec<(f64, [f64; 2])> = rotor
        .bearings
        .iter()
        .map(|(p, a)| {
            let load = [ax + bx * a, ay + by * a];
            // Start inside the bore even when the lever rule overloads a bearing.
            let e = closed_form_position(p, w_eff, load);
            let lim = 0.9 * p.clearance;
            let r = e[0].hypot(e[1]);
            let k = if r > lim { lim / r } else { 1.0 };
            (*a, [k * e[0], k * e[1]])
        })
        .collect();
    if det.abs() <= 1e-300 * saa.max(1e-300) || pos.len() == 1 {
        let (mx, my) = pos
            .iter()
            .fold((0.0, 0.0), |(x, y), (_, e)| (x + e[0] / n, y + e[1] / n));
        return [mx, my, 0.0, 0.0];
    }
    // x_b = s_x + a β, y_b = s_y − a α: least squares.
    let fit = |vals: Vec<f64>| {
        let sv: f64 = vals.iter().sum();
        let sav: f64 = pos.iter().zip(&vals).map(|((a, _), v)| a * v).sum();
        ((saa * sv - sa * sav) / det, (n * sav - sa * sv) / det)
    };
    let (sx, beta) = fit(pos.iter().map(|(_, e)| e[0]).collect());
    let (sy, malpha) = fit(pos.iter().map(|(_, e)| e[1]).collect());
    [sx, sy, -malpha, beta]
}

/// The rotor's static equilibrium (fixed frame) or synchronous orbit (rotating frame) at
/// each `(rotor, speed)`, in lockstep: every Newton iteration of every point is one
/// evaluator call (all bearings' perturbed states). Returns `q` and the Newton iterations.
pub fn equilibria_batch(
    evaluator: &mut crate::backend::LoadEvaluator,
    points: &[(&RotorDescription, f64)],
) -> Vec<Result<([f64; 4], u32), StabilityError>> {
    let n = points.len();
    let mut out: Vec<Option<StabilityError>> = vec![None; n];
    let mut q: Vec<[f64; 4]> = points.iter().map(|(r, w)| initial_guess(r, *w)).collect();
    let mut iters = vec![0u32; n];
    let mut converged = vec![false; n];
    // Finite film in accuracy mode: each bearing's grid is chosen at the first iterate
    // and held for the Newton iteration (see `bearing_equilibria`).
    let mut pinned: Vec<Vec<Option<[u32; 2]>>> = points
        .iter()
        .map(|(r, _)| vec![None; r.bearings.len()])
        .collect();
    for (k, (r, w)) in points.iter().enumerate() {
        if !w.is_finite() {
            out[k] = Some(StabilityError::input("speed", "must be finite"));
        } else if r.external(*w).0 == [0.0; 4] {
            // Nothing loads the rotor: the centred journal carries no film load.
            converged[k] = true;
        }
    }
    // Newton in lockstep.
    loop {
        let active: Vec<usize> = (0..n)
            .filter(|&k| out[k].is_none() && !converged[k])
            .collect();
        if active.is_empty() {
            break;
        }
        let mut jobs = Vec::new();
        for &k in &active {
            let (r, w) = points[k];
            let fr = r.frame_rate(w);
            for (b, (p, a)) in r.bearings.iter().enumerate() {
                jobs.push(CoefficientJob {
                    params: pin_grid(p, pinned[k][b]),
                    state: bearing_state(&q[k], p, *a, w, fr),
                });
            }
        }
        let mut coeffs = coefficients_batch(evaluator, &jobs, &DiffOptions::newton()).into_iter();
        for &k in &active {
            let (r, w) = points[k];
            let fr = r.frame_rate(w);
            let (f, e) = r.external(w);
            let mut res = Vector4::from_column_slice(&f)
                + Matrix4::from_diagonal(&Vector4::from_column_slice(&e))
                    * Vector4::from_column_slice(&q[k]);
            let mut jac = Matrix4::from_diagonal(&Vector4::from_column_slice(&e));
            let mut failed = None;
            for (b, (_, a)) in r.bearings.iter().enumerate() {
                match coeffs.next().expect("one result per job") {
                    Ok(c) => {
                        if pinned[k][b].is_none() {
                            pinned[k][b] = c.grid;
                        }
                        let t = transfer(*a);
                        res += t.transpose() * Vector4::from_column_slice(&c.mid_plane_loads);
                        let kb = from_m4(&c.stiffness) + fr * from_m4(&c.damping) * quarter_turn();
                        jac -= t.transpose() * kb * t;
                    }
                    Err(err) => {
                        failed.get_or_insert(match err {
                            StabilityError::Film { fault, .. } => StabilityError::Film {
                                bearing: b,
                                context: format!(
                                    "Newton iteration {} of the equilibrium at {w} rad/s",
                                    iters[k]
                                ),
                                fault,
                            },
                            other => other,
                        });
                    }
                }
            }
            if let Some(err) = failed {
                out[k] = Some(err);
                continue;
            }
            let Some(step) = jac.lu().solve(&res) else {
                out[k] = Some(StabilityError::NoEquilibrium {
                    speed_rad_s: w,
                    reason: "singular Jacobian (a degree of freedom without film stiffness)".into(),
                });
                continue;
            };
            let mut step = -step;
            // Keep every end face inside its bore: at most half its remaining gap.
            let mut scale: f64 = 1.0;
            for (p, a) in &r.bearings {
                let s0 = bearing_state(&q[k], p, *a, w, fr);
                let ds = bearing_state(&[step[0], step[1], step[2], step[3]], p, *a, w, 0.0);
                for (e, d) in [
                    ([s0.xi, s0.yi], [ds.xi, ds.yi]),
                    ([s0.xj, s0.yj], [ds.xj, ds.yj]),
                ] {
                    let gap = p.clearance - e[0].hypot(e[1]);
                    let len = d[0].hypot(d[1]);
                    if len > 0.5 * gap {
                        scale = scale.min(0.5 * gap / len);
                    }
                }
            }
            step *= scale;
            for c in 0..4 {
                q[k][c] += step[c];
            }
            iters[k] += 1;
            let dmin = r
                .bearings
                .iter()
                .map(|(p, _)| p.clearance)
                .fold(f64::INFINITY, f64::min);
            let reach = r
                .bearings
                .iter()
                .map(|(p, a)| a.abs() + 0.5 * p.length)
                .fold(0.0, f64::max);
            let size = step[0].hypot(step[1]) + reach * step[2].hypot(step[3]);
            // The films' noise floor (finite film: its iteration tolerance) bounds how
            // small a step can be resolved: stop at ten times it.
            let noise = r
                .bearings
                .iter()
                .map(|(p, _)| load_noise(p))
                .fold(0.0, f64::max);
            if size <= NEWTON_TOL.max(10.0 * noise) * dmin {
                converged[k] = true;
            } else if iters[k] >= MAX_NEWTON {
                out[k] = Some(StabilityError::NoEquilibrium {
                    speed_rad_s: w,
                    reason: format!(
                        "Newton did not converge in {MAX_NEWTON} iterations (last step {size:.2e} m)"
                    ),
                });
            }
        }
    }
    out.into_iter()
        .zip(q.into_iter().zip(iters))
        .map(|(e, qi)| match e {
            Some(e) => Err(e),
            None => Ok(qi),
        })
        .collect()
}

/// Linearises each `(rotor, speed)` about its equilibrium, in lockstep: every Newton
/// iteration of every point is one evaluator call (all bearings' perturbed states), and
/// one more call gives the final coefficients with their error estimates.
pub fn linearise_batch(
    evaluator: &mut crate::backend::LoadEvaluator,
    points: &[(&RotorDescription, f64)],
) -> Vec<Result<LinearRotor, StabilityError>> {
    let n = points.len();
    let mut out: Vec<Option<Result<LinearRotor, StabilityError>>> = vec![None; n];
    let mut q = vec![[0.0; 4]; n];
    let mut iters = vec![0u32; n];
    for (k, e) in equilibria_batch(evaluator, points).into_iter().enumerate() {
        match e {
            Ok((qk, ik)) => {
                q[k] = qk;
                iters[k] = ik;
            }
            Err(e) => out[k] = Some(Err(e)),
        }
    }
    // Final coefficients (Richardson) at every converged equilibrium, in one call.
    let done: Vec<usize> = (0..n).filter(|&k| out[k].is_none()).collect();
    let mut jobs = Vec::new();
    for &k in &done {
        let (r, w) = points[k];
        let fr = r.frame_rate(w);
        for (p, a) in &r.bearings {
            jobs.push(CoefficientJob {
                params: *p,
                state: bearing_state(&q[k], p, *a, w, fr),
            });
        }
    }
    let mut coeffs = coefficients_batch(evaluator, &jobs, &DiffOptions::default()).into_iter();
    let mut first_job = 0;
    for &k in &done {
        let (r, w) = points[k];
        let point_jobs = &jobs[first_job..first_job + r.bearings.len()];
        first_job += r.bearings.len();
        let fr = r.frame_rate(w);
        let mut kk = Matrix4::zeros();
        let mut dd = Matrix4::zeros();
        let mut bearings = Vec::new();
        let mut failed = None;
        for (b, ((p, a), job)) in r.bearings.iter().zip(point_jobs).enumerate() {
            match coeffs.next().expect("one result per job") {
                Ok(c) => {
                    let t = transfer(*a);
                    kk += t.transpose()
                        * (from_m4(&c.stiffness) + fr * from_m4(&c.damping) * quarter_turn())
                        * t;
                    dd += t.transpose() * from_m4(&c.damping) * t;
                    let (ei, ej) = job.state.eccentricity_ratios(p.clearance);
                    bearings.push(BearingPoint {
                        state: job.state,
                        eccentricity_ratio: ei.max(ej),
                        coefficients: c,
                        thermal: None,
                    });
                }
                Err(err) => {
                    failed.get_or_insert(match err {
                        StabilityError::Film { fault, .. } => StabilityError::Film {
                            bearing: b,
                            context: format!("coefficients at the equilibrium at {w} rad/s"),
                            fault,
                        },
                        other => other,
                    });
                }
            }
        }
        if let Some(err) = failed {
            out[k] = Some(Err(err));
            continue;
        }
        let (m, id, ip) = (r.mass, r.i_transverse, r.i_polar);
        let mut mass = Matrix4::zeros();
        mass[(0, 0)] = m;
        mass[(1, 1)] = m;
        mass[(2, 2)] = id;
        mass[(3, 3)] = id;
        let j = quarter_turn();
        // Gyroscopic and Coriolis terms (`J` on each pair) and the inertial stiffness.
        let gt = 2.0 * m * fr;
        let gr = 2.0 * id * fr - ip * w;
        let st = -m * fr * fr;
        let sr = ip * w * fr - id * fr * fr;
        for (i, (g, s)) in [(gt, st), (gt, st), (gr, sr), (gr, sr)].iter().enumerate() {
            for c in 0..4 {
                dd[(i, c)] += g * j[(i, c)];
            }
            kk[(i, i)] += s;
        }
        out[k] = Some(Ok(LinearRotor {
            speed: w,
            frame: r.frame,
            equilibrium: q[k],
            newton_iterations: iters[k],
            bearings,
            mass: to_m4(&mass),
            damping: to_m4(&dd),
            stiffness: to_m4(&kk),
        }));
    }
    out.into_iter()
        .map(|r| r.expect("every point ends"))
        .collect()
}
