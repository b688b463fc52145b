//! A published JFO benchmark: the oscillatory squeeze film of Ausas, Jai and Buscaglia,
//! "A mass-conserving algorithm for dynamical lubrication problems with cavitation",
//! ASME J. Tribol. 131 (2009) 031702, section 3 (docs/jfo.md "Published benchmark").
//!
//! The case (the paper's units): two parallel plates, no sliding, the gap uniform in x and
//! `h(t) = 0.125 cos(4πt) + 0.375`, the film on `x ∈ [0, 1]` fed at both ends at
//! `p0 = 0.025`, full at `t = 0`, the equation `∂x(h³ ∂x p) = 2 ∂t(θ h)`. The film
//! ruptures at the mid-plane at `t_rup = 0.250079` (where `h'/h³ = 4 p0`) and during the
//! rupture phase (up to `t = 0.31483`, the maximum of `h'/h³`) the cavity's right edge
//! is `Σ(t) = 1 − √(p0 h³/h')` (the paper's closed form; numbers taken from its public
//! re-implementations, the paper itself was not reachable here, and re-derived in
//! docs/jfo.md). Both the time and the curve are checked below.
//!
//! How the journal solver takes it: a bearing with `B/r0 = 1e-5` (`λ = 1e-10`: the
//! columns of the grid decouple to 1e-13) and no spin is a set of 1-D squeeze films along
//! ζ, one per column, of gap `H = 1 − ε_x cos θ`. With `ε_x(τ) = 1 − h(τ)` the column
//! `θ = 0` has the paper's gap exactly. A centred circumferential groove of half the
//! length held at `P0` makes `ζ ∈ [0, L]`, `L = ¼`, a film fed at its groove edge `ζ = L`
//! and closed at the bearing end `ζ = 0` (ambient, which is the cavity pressure). In our
//! scaling (`∂ζ(H³ ∂ζP) = 12 ∂τ(φH)`) the rupture phase's full-film zone is
//! `[L − ℓ, L]` with `P = (k/2)(ζ − L + ℓ)²`, `k = 12 H'/H³`, `ℓ = √(P0 H³/(6 H'))`,
//! the paper's half-film `[½, 1]` stretched by `2L`: with `P0 = 24 L² p0` the film
//! ruptures at the same `t_rup` (at the end face, where the end's `P = 0` plays the role
//! of the paper's symmetry plane once cavitated) and `ℓ/L = 2 (1 − Σ)`.
//!
//! Beyond the paper's curve, the film fraction of the cavity is a closed form of the
//! mass-conserving model only (Swift–Stieber has none): a point cavitated at `τ_r(ζ)`
//! (the inverse of the rupture front) keeps its liquid `h(τ_r)` (no flow in the cavity),
//! so `φ(ζ, τ) = h(τ_r(ζ))/h(τ)`.

use bearing_sweep::bearing::finite::{
    jfo_balance, Cavitation, FiniteGrid, FiniteJob, FiniteSettings, FiniteSolver, JfoBalance,
    JfoHistory, JfoSolver, SolveReport,
};
use bearing_sweep::bearing::{BearingParams, FilmModel, Groove, PackedState};
use std::f64::consts::PI;

/// The paper's supply pressure (its scaling).
const P0_PAPER: f64 = 0.025;
/// Distance from the end face to the groove edge (the half-film), fraction of the length.
const L: f64 = 0.25;
/// The paper's rupture time (its eq. for `h'/h³ = 4 p0`), as its re-implementations
/// print it.
const T_RUP_PAPER: f64 = 0.250079;
/// End of the rupture phase: the maximum of `h'/h³`.
const T_RUPTURE_PHASE_END: f64 = 0.31483;

fn h(t: f64) -> f64 {
    0.125 * (4.0 * PI * t).cos() + 0.375
}

fn h_dot(t: f64) -> f64 {
    -0.5 * PI * (4.0 * PI * t).sin()
}

/// Our held supply: the paper's `p0` in our scaling (module docs).
fn p0() -> f64 {
    24.0 * L * L * P0_PAPER
}

/// Closed form: width of the full-film zone next to the groove in the rupture phase.
fn ell(t: f64) -> f64 {
    (p0() * h(t).powi(3) / (6.0 * h_dot(t))).sqrt()
}

/// The paper's cavity edge `Σ(t) = 1 − √(p0 h³/h')`.
fn sigma_paper(t: f64) -> f64 {
    1.0 - (P0_PAPER * h(t).powi(3) / h_dot(t)).sqrt()
}

/// End of the rupture phase to full precision: the maximum of `h'/h³`, where
/// `h'' h = 3 h'²` (bisection; [`T_RUPTURE_PHASE_END`] is it rounded).
fn t_m() -> f64 {
    let h_ddot = |t: f64| -2.0 * PI * PI * (4.0 * PI * t).cos();
    let (mut lo, mut hi) = (0.30, 0.33);
    for _ in 0..60 {
        let m = 0.5 * (lo + hi);
        if h_ddot(m) * h(m) - 3.0 * h_dot(m).powi(2) > 0.0 {
            lo = m;
        } else {
            hi = m;
        }
    }
    0.5 * (lo + hi)
}

/// Closed form: the time the rupture front passed `zeta` (bisection on the increasing
/// front `L − ℓ(τ)` over the rupture phase).
fn rupture_time(zeta: f64) -> f64 {
    let (mut lo, mut hi) = (T_RUP_PAPER, t_m());
    for _ in 0..80 {
        let m = 0.5 * (lo + hi);
        if L - ell(m) < zeta {
            lo = m;
        } else {
            hi = m;
        }
    }
    0.5 * (lo + hi)
}

/// The bearing: groove at 0° (60° wide, so only the column θ = 0 of a 4-column grid is
/// held), half the length, supply 1 Pa (the job's `supply` scales it to `P0`), JFO
/// iteration tolerance `tol`.
fn setup(nz: usize, tol: f64) -> FiniteGrid {
    let p = BearingParams {
        radius: 1e5,
        length: 1.0,
        clearance: 1e-3,
        viscosity: 1.0,
        model: FilmModel::Finite,
        finite: FiniteSettings {
            n_theta: Some(4),
            n_z: Some(nz as u32),
            tolerance: tol,
            cavitation: Cavitation::Jfo,
            ..FiniteSettings::default()
        },
        grooves: bearing_sweep::bearing::Grooves::new(&[Groove {
            angle: 0.0,
            width: 60.0,
            supply_pressure: 1.0,
            length: Some(2.0 * (0.5 - L)),
        }])
        .unwrap(),
        ..BearingParams::paper_table2()
    };
    FiniteGrid::for_bearing(&p)
}

/// The job at time `t`: `ε_x = 1 − h(t)`, no spin, the rate vector of `ε̇_x` (the packed
/// rate is `(−2 ε̇_y, 2 ε̇_x)` at zero spin).
fn job(t: f64) -> FiniteJob {
    let ex = 1.0 - h(t);
    let b = -2.0 * h_dot(t);
    FiniteJob {
        state: PackedState {
            ecc: [ex, 0.0, ex, 0.0],
            rate: [0.0, b, 0.0, b],
        },
        aspect: 1e-5,
        supply: p0(),
        spin: Some(0.0),
    }
}

/// What a march measured on the column θ = 0.
struct March {
    /// First time step with a cavitated node in `(0, L)`.
    t_rup: f64,
    /// Largest `|ℓ_num − ℓ|/L` over the rupture-phase checkpoints.
    ell_err: f64,
    /// Largest `|φ_num − φ|` over the cavity at the last checkpoint (nodes at least
    /// two steps from the front).
    phi_err: f64,
    /// Largest deviation from the pre-rupture closed form `P = P0 ζ/L + (k/2) ζ (ζ − L)`
    /// over the full-film steps, relative to `P0`.
    pre_err: f64,
}

/// Start of every march: the film is full (the plates approach until `t = 0.25`).
const T0: f64 = 0.24;

/// The column film marched in backward-Euler steps on `4 × nz` from the full film at
/// `T0` (the conservative time step, [`JfoHistory::prev_ecc`]).
struct Stepper {
    g: FiniteGrid,
    nz: usize,
    reynolds: FiniteSolver,
    jfo: JfoSolver,
    /// Pressure then film fraction of the latest step.
    field: Vec<f64>,
    /// Film fraction of the step before (the history of the latest step).
    phi_old: Vec<f64>,
    /// Steps taken and the step length.
    steps: usize,
    dt: f64,
    /// The conservative time step (`prev_ecc` given), else the product-rule form.
    conservative: bool,
}

impl Stepper {
    fn new(nz: usize, dt: f64, tol: f64) -> Self {
        let g = setup(nz, tol);
        let n = NT * (nz + 1);
        // The paper's start: the film full (φ = 1; the pressure only warm-starts the first
        // step). Not a steady solve: a column without supply whose gap opens (θ = 180°
        // here) would start empty, and an empty node whose gap opens clips φ at 0 (its
        // void's backward-Euler update differs from the gap's change by the rectangle
        // rule), which puts that difference into the balance residual.
        let field: Vec<f64> = (0..2 * n).map(|k| if k < n { 0.0 } else { 1.0 }).collect();
        Stepper {
            g,
            nz,
            reynolds: FiniteSolver::new(),
            jfo: JfoSolver::new(),
            phi_old: field[n..].to_vec(),
            field,
            steps: 0,
            dt,
            conservative: true,
        }
    }

    fn n(&self) -> usize {
        NT * (self.nz + 1)
    }

    /// Time of the latest step.
    fn t(&self) -> f64 {
        T0 + self.steps as f64 * self.dt
    }

    fn history(&self) -> JfoHistory<'_> {
        JfoHistory {
            phi: &self.phi_old,
            dtau: self.dt,
            prev_ecc: Some(job(self.t() - self.dt).state.ecc).filter(|_| self.conservative),
        }
    }

    /// One step; returns its report.
    fn step(&mut self) -> SolveReport {
        let n = self.n();
        self.phi_old.clear();
        self.phi_old.extend_from_slice(&self.field[n..]);
        self.steps += 1;
        let t = self.t();
        let hist = JfoHistory {
            phi: &self.phi_old,
            dtau: self.dt,
            prev_ecc: Some(job(t - self.dt).state.ecc).filter(|_| self.conservative),
        };
        let (_, rep) = self.jfo.solve(
            &mut self.reynolds,
            &job(t),
            &self.g,
            &mut self.field,
            Some(&hist),
        );
        assert!(rep.converged, "step {} at t = {t}: {rep:?}", self.steps);
        rep
    }

    /// Pressure and film fraction of node `j` of the column θ = 0.
    fn p(&self, j: usize) -> f64 {
        self.field[j * NT]
    }

    fn phi(&self, j: usize) -> f64 {
        self.field[self.n() + j * NT]
    }

    /// Index of the last row before the groove edge `ζ = L`.
    fn jl(&self) -> usize {
        (L * self.nz as f64).round() as usize
    }

    /// Whether a node of the column in `(0, L)` is cavitated.
    fn cavitated(&self) -> bool {
        (1..self.jl()).any(|j| self.phi(j) < 1.0 - 1e-9)
    }

    /// The liquid content `Σ 12 φ H` of the current field (from its balance without
    /// history: the content does not depend on it).
    fn content(&self) -> f64 {
        jfo_balance(&job(self.t()), &self.g, NT, self.nz, 0.0, &self.field, None)
            .expect("a balance")
            .content
    }

    /// The liquid balance of the latest step ([`jfo_balance`]).
    fn balance(&self) -> JfoBalance {
        let t = self.t();
        jfo_balance(
            &job(t),
            &self.g,
            NT,
            self.nz,
            0.0,
            &self.field,
            Some(&self.history()),
        )
        .expect("a balance")
    }
}

/// Columns of the grid (only θ = 0 has the paper's gap; the others are checked nowhere).
const NT: usize = 4;

/// Marches from the full film at `t = 0.24` to `t = 0.31` in `steps` backward-Euler
/// steps on `4 × nz`.
fn march(nz: usize, steps: usize) -> March {
    let t1 = 0.31;
    let mut st = Stepper::new(nz, (t1 - T0) / steps as f64, 1e-8);
    let dt = st.dt;
    let dz = 1.0 / nz as f64;
    let jl = st.jl();
    let checkpoints = [0.26, 0.27, 0.28, 0.29, 0.30, 0.31];
    let mut out = March {
        t_rup: f64::NAN,
        ell_err: 0.0,
        phi_err: 0.0,
        pre_err: 0.0,
    };
    for _ in 1..=steps {
        st.step();
        let t = st.t();
        let k = 12.0 * h_dot(t) / h(t).powi(3);
        if st.cavitated() && out.t_rup.is_nan() {
            out.t_rup = t;
        }
        if out.t_rup.is_nan() {
            for j in 1..jl {
                let z = j as f64 * dz;
                let exact = p0() * z / L + 0.5 * k * z * (z - L);
                out.pre_err = out.pre_err.max((st.p(j) - exact).abs() / p0());
            }
        }
        if let Some(&c) = checkpoints.iter().find(|&&c| (t - c).abs() < 0.5 * dt) {
            // The full-film zone's quadratic through the node next to the groove.
            let ell_num = dz + (2.0 * st.p(jl - 1) / k).sqrt();
            out.ell_err = out.ell_err.max((ell_num - ell(c)).abs() / L);
            if c == 0.31 {
                let front = L - ell(c);
                for j in 1..jl {
                    let z = j as f64 * dz;
                    if z < front - 2.0 * dz {
                        let exact = h(rupture_time(z)) / h(c);
                        out.phi_err = out.phi_err.max((st.phi(j) - exact).abs());
                    }
                }
            }
        }
    }
    out
}

#[test]
fn the_closed_forms_are_the_papers() {
    // The paper's rupture time: h'/h³ = 4 p0 at t_rup (bisection).
    let (mut lo, mut hi) = (0.25, 0.26);
    for _ in 0..80 {
        let m = 0.5 * (lo + hi);
        if h_dot(m) / h(m).powi(3) < 4.0 * P0_PAPER {
            lo = m;
        } else {
            hi = m;
        }
    }
    assert!((lo - T_RUP_PAPER).abs() < 1e-6, "t_rup {lo}");
    // The end of the rupture phase, to the digits printed.
    assert!((t_m() - T_RUPTURE_PHASE_END).abs() < 5e-6, "t_m {}", t_m());
    // Ours ruptures when ℓ reaches L, at the same time.
    assert!((ell(lo) - L).abs() < 1e-9);
    // The stretched front is the paper's: ℓ/L = 2 (1 − Σ).
    for t in [0.26, 0.28, 0.30] {
        assert!((ell(t) / L - 2.0 * (1.0 - sigma_paper(t))).abs() < 1e-12);
    }
    // Values of the paper's curve (Σ at 0.26 and 0.30).
    assert!((sigma_paper(0.26) - 0.95519).abs() < 1e-5);
    assert!((sigma_paper(0.30) - 0.97642).abs() < 1e-5);
}

#[test]
fn oscillatory_squeeze_of_ausas_jai_buscaglia() {
    let runs: Vec<(usize, usize, March)> = [(128, 140), (256, 280), (512, 560)]
        .into_iter()
        .map(|(nz, steps)| (nz, steps, march(nz, steps)))
        .collect();
    for (nz, steps, m) in &runs {
        eprintln!(
            "nz {nz}, {steps} steps: t_rup {:.6} (paper {T_RUP_PAPER}), ℓ error {:.3e} L, φ error {:.3e}, pre-rupture {:.3e} P0",
            m.t_rup, m.ell_err, m.phi_err, m.pre_err
        );
        let dt = 0.07 / *steps as f64;
        // Rupture seen at the first step at or after the paper's time (the discrete film
        // ruptures when its first node does, O(Δζ) later).
        assert!(
            m.t_rup >= T_RUP_PAPER && m.t_rup - dt <= T_RUP_PAPER,
            "nz {nz}: rupture at {} vs {T_RUP_PAPER} (step {dt})",
            m.t_rup
        );
        // Before it, the full film is the closed-form parabola to the iteration tolerance
        // (the 3-point operator is exact on quadratics).
        assert!(m.pre_err < 1e-6, "nz {nz}: pre-rupture {:.3e}", m.pre_err);
    }
    // Measured (4 × nz, 0.07/steps): ℓ error 5.5e-3, 1.9e-4, 1.6e-5 of L; φ error 9.5e-4,
    // 4.8e-4, 2.4e-4 (first order: backward Euler in time, O(Δζ) front).
    for w in runs.windows(2) {
        let (a, b) = (&w[0].2, &w[1].2);
        assert!(
            b.ell_err < 0.5 * a.ell_err,
            "front: {:.3e} -> {:.3e}",
            a.ell_err,
            b.ell_err
        );
        assert!(
            b.phi_err < 0.6 * a.phi_err,
            "φ: {:.3e} -> {:.3e}",
            a.phi_err,
            b.phi_err
        );
    }
    let fine = &runs[2].2;
    assert!(fine.ell_err < 1e-4, "front {:.3e}", fine.ell_err);
    assert!(fine.phi_err < 3e-4, "φ {:.3e}", fine.phi_err);
    // The check can fail: the cavity's film fraction is well below 1 (a model without
    // the liquid's memory, φ ≡ 1, would miss it by more than 100× the error).
    let min_phi = h(T_RUP_PAPER) / h(0.31);
    assert!(1.0 - min_phi > 100.0 * fine.phi_err, "φ down to {min_phi}");
}

/// The reformation phase by front tracking (docs/jfo.md "Reformation phase"): from the
/// end of the rupture phase `t_m` the cavity `[0, Σ]` keeps its liquid `g(ζ) = H(τ_r(ζ))`
/// (no flow at zero pressure, no sliding), the full zone `[Σ, L]` is the parabola
/// `P = (ζ − Σ) (P0/ℓ + (k/2)(ζ − L))`, `ℓ = L − Σ`, and the front moves by the jump
/// condition of the liquid content, `Σ' (H − g(Σ)) = −H³ P'(Σ)/12` with
/// `P'(Σ) = P0/ℓ − k ℓ/2 ≥ 0`: a 1-D ODE, integrated by RK4 in `t` up to `t = ½` (where
/// the front starts from rest, `P'(Σ) = 0` and `H = g(Σ)` at `t_m`) and in `Σ` from there
/// to the cavity's collapse (`dt/dΣ` is regular: the front accelerates without bound as
/// `H` falls back to `g(Σ)`).
struct Reformation {
    /// `(t, Σ)` along the front, `t` increasing, to the collapse.
    path: Vec<(f64, f64)>,
}

impl Reformation {
    /// `steps_t` RK4 steps in `t` over `[t_m, ½]`, `steps_sigma` in `Σ` to 0.
    fn new(steps_t: usize, steps_sigma: usize) -> Self {
        let tm = t_m();
        let k = |t: f64| 12.0 * h_dot(t) / h(t).powi(3);
        let slope = |t: f64, s: f64| p0() / (L - s) - 0.5 * k(t) * (L - s);
        // Σ' and dt/dΣ.
        let speed =
            |t: f64, s: f64| -h(t).powi(3) * slope(t, s) / (12.0 * (h(t) - h(rupture_time(s))));
        let lag =
            |s: f64, t: f64| -12.0 * (h(t) - h(rupture_time(s))) / (h(t).powi(3) * slope(t, s));
        let rk4 = |f: &dyn Fn(f64, f64) -> f64, x: f64, y: f64, d: f64| {
            let k1 = f(x, y);
            let k2 = f(x + 0.5 * d, y + 0.5 * d * k1);
            let k3 = f(x + 0.5 * d, y + 0.5 * d * k2);
            let k4 = f(x + d, y + d * k3);
            y + d / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        };
        // Start a hair after t_m: the front at rest (Σ' = O(t − t_m)).
        let t_start = tm + 1e-9;
        let mut s = L - ell(tm);
        let mut path = vec![(tm, s)];
        let d = (0.5 - t_start) / steps_t as f64;
        for n in 0..steps_t {
            let t = t_start + n as f64 * d;
            s = rk4(&speed, t, s, d);
            path.push((t + d, s));
        }
        let mut t = 0.5;
        let ds = -s / steps_sigma as f64;
        for n in 0..steps_sigma {
            let sn = s + ds;
            t = rk4(&lag, s, t, ds);
            s = if n + 1 == steps_sigma { 0.0 } else { sn };
            path.push((t, s));
        }
        Reformation { path }
    }

    /// The cavity's collapse (Σ = 0): the reformation time.
    fn collapse(&self) -> f64 {
        self.path.last().expect("a path").0
    }

    /// `Σ(t)` by linear interpolation along the path.
    fn sigma(&self, t: f64) -> f64 {
        let i = self
            .path
            .partition_point(|&(tp, _)| tp < t)
            .clamp(1, self.path.len() - 1);
        let ((t0, s0), (t1, s1)) = (self.path[i - 1], self.path[i]);
        s0 + (s1 - s0) * (t - t0) / (t1 - t0)
    }

    /// The void of the cavity at `t`, `∫_0^Σ (H(t) − g(ζ)) dζ`.
    fn void(&self, t: f64) -> f64 {
        Self::void_to(t, self.sigma(t))
    }

    /// The front position whose cavity would hold `void` at `t` (the void grows with `Σ`:
    /// `H(t) > g` in the cavity), by bisection.
    fn front_of_void(t: f64, void: f64) -> f64 {
        let (mut lo, mut hi) = (0.0, L - ell(t_m()));
        for _ in 0..60 {
            let m = 0.5 * (lo + hi);
            if Self::void_to(t, m) < void {
                lo = m;
            } else {
                hi = m;
            }
        }
        0.5 * (lo + hi)
    }

    /// `∫_0^s (H(t) − g(ζ)) dζ` (Simpson, 400 panels).
    fn void_to(t: f64, s: f64) -> f64 {
        let m = 400;
        let dz = s / m as f64;
        let f = |z: f64| h(t) - h(rupture_time(z));
        let mut acc = f(0.0) + f(s);
        for i in 1..m {
            acc += f(i as f64 * dz) * if i % 2 == 1 { 4.0 } else { 2.0 };
        }
        acc * dz / 3.0
    }
}

/// Checkpoints of the reformation phase: slow reformation (front moving 2e-3 L per 0.01)
/// to the final rush (the front crosses the last 40 % of the film in 0.015).
const REFORM_CHECKPOINTS: [f64; 4] = [0.40, 0.60, 0.70, 0.72];

/// What a march through the reformation measured on the column θ = 0.
struct Reform {
    /// First step with no cavitated node in `(0, L)` after the rupture.
    t_collapse: f64,
    /// The collapse between steps: the last two voids extrapolated linearly to zero
    /// (within the step that ended the cavity).
    t_collapse_interp: f64,
    /// The cavity's void `Σ_j (1 − φ_j) H Δζ` at the checkpoints.
    void: Vec<f64>,
    /// Over the whirl-free period [0.24, 0.74]: liquid content change of the free nodes
    /// less the time integral of (supply − end outflow), both `Σ Δτ ·` the balance terms;
    /// the supplied liquid `Σ Δτ |supply|`; the summed residuals `Σ Δτ residual`.
    content_change: f64,
    net_inflow: f64,
    supplied: f64,
    residual: f64,
    /// Largest iteration error the solver reported.
    iteration_error: f64,
}

/// Marches one period of the gap, `[0.24, 0.74]`, in `steps` steps on `4 × nz` at the
/// JFO tolerance `tol`.
fn march_reformation(nz: usize, steps: usize, tol: f64, conservative: bool) -> Reform {
    let mut st = Stepper::new(nz, 0.5 / steps as f64, tol);
    st.conservative = conservative;
    let dz = 1.0 / nz as f64;
    let jl = st.jl();
    let content0 = st.content();
    let mut out = Reform {
        t_collapse: f64::NAN,
        t_collapse_interp: f64::NAN,
        void: Vec::new(),
        content_change: 0.0,
        net_inflow: 0.0,
        supplied: 0.0,
        residual: 0.0,
        iteration_error: 0.0,
    };
    let mut ruptured = false;
    let mut voids = [0.0_f64; 2];
    for _ in 0..steps {
        let rep = st.step();
        out.iteration_error = out.iteration_error.max(rep.iteration_error);
        let t = st.t();
        let b = st.balance();
        out.net_inflow += st.dt * (b.supply - b.ends);
        out.supplied += st.dt * b.supply.abs();
        out.residual += st.dt * b.residual;
        out.content_change = b.content - content0;
        let cav = st.cavitated();
        ruptured |= cav;
        let void: f64 = (1..jl).map(|j| (1.0 - st.phi(j)) * h(t) * dz).sum();
        if ruptured && !cav && out.t_collapse.is_nan() {
            out.t_collapse = t;
            let [v0, v1] = voids;
            let frac = if v0 > v1 { v1 / (v0 - v1) } else { 1.0 };
            out.t_collapse_interp = t - st.dt + st.dt * frac.min(1.0);
        }
        voids = [voids[1], void];
        if REFORM_CHECKPOINTS
            .iter()
            .any(|&c| (t - c).abs() < 0.5 * st.dt)
        {
            out.void.push(void);
        }
    }
    out
}

/// The reformation table of docs/jfo.md "Reformation phase" (ignored: the 512 level
/// takes minutes): `LEVELS=64,128,256,512 cargo test --release --test jfo_squeeze --
/// --ignored --nocapture reformation_levels`.
#[test]
#[ignore]
fn reformation_levels() {
    let r = Reformation::new(4000, 20000);
    let r2 = Reformation::new(8000, 40000);
    eprintln!("collapse {:.9} / {:.9}", r.collapse(), r2.collapse());
    for c in REFORM_CHECKPOINTS {
        eprintln!(
            "t {c}: Σ/L {:.6} void {:.6e} (finer {:.6e})",
            r.sigma(c) / L,
            r.void(c),
            r2.void(c)
        );
    }
    let lv: Vec<(usize, usize)> = std::env::var("LEVELS")
        .map(|v| {
            v.split(',')
                .map(|x| {
                    let n: usize = x.parse().unwrap();
                    (n, n * 500 / 64)
                })
                .collect()
        })
        .unwrap_or(vec![(64, 500), (128, 1000), (256, 2000)]);
    for (nz, steps) in lv {
        let t0 = std::time::Instant::now();
        let m = march_reformation(nz, steps, 1e-8, true);
        let fronts: Vec<f64> = REFORM_CHECKPOINTS
            .iter()
            .zip(&m.void)
            .map(|(&c, &v)| (Reformation::front_of_void(c, v) - r.sigma(c)) / L)
            .collect();
        eprintln!(
            "nz {nz} steps {steps}: collapse {:.6} interp {:.6} (ref {:.6}) void errs {:?} fronts {:?} content Δ {:.6e} inflow {:.6e} supplied {:.3e} residual {:.3e} iter {:.1e} [{:.1?}]",
            m.t_collapse, m.t_collapse_interp, r.collapse(), m.void.iter().zip(REFORM_CHECKPOINTS).map(|(v, c)| v - r.void(c)).collect::<Vec<_>>(), fronts, m.content_change, m.net_inflow, m.supplied, m.residual, m.iteration_error, t0.elapsed()
        );
    }
    let m = march_reformation(64, 500, 1e-8, false);
    eprintln!(
        "product rule: content Δ {:.6e} inflow {:.6e} residual {:.3e}",
        m.content_change, m.net_inflow, m.residual
    );
}

#[test]
fn reformation_phase_against_front_tracking() {
    let r = Reformation::new(4000, 20000);
    // The reference converged in its own steps, and physical: the front retreats
    // monotonically and the cavity collapses before the gap returns to the liquid of its
    // first-ruptured point (h = 0.25 at t = 0.75).
    let r2 = Reformation::new(8000, 40000);
    assert!((r.collapse() - r2.collapse()).abs() < 1e-9);
    for c in REFORM_CHECKPOINTS {
        let d = (r.void(c) - r2.void(c)).abs() / r.void(c);
        eprintln!(
            "reference void at {c}: {:.9e}, halved steps: relative change {d:.1e}",
            r.void(c)
        );
        assert!(d < 1e-6);
    }
    assert!(r
        .path
        .windows(2)
        .all(|w| w[1].0 > w[0].0 && w[1].1 <= w[0].1));
    assert!(
        r.collapse() > 0.5 && r.collapse() < 0.75,
        "{}",
        r.collapse()
    );
    let tol = 1e-8;
    let levels = [(64, 500), (128, 1000), (256, 2000)];
    let runs: Vec<Reform> = levels
        .iter()
        .map(|&(nz, steps)| march_reformation(nz, steps, tol, true))
        .collect();
    let mut collapse_err = Vec::new();
    let mut front_err = Vec::new();
    for (&(nz, steps), m) in levels.iter().zip(&runs) {
        assert_eq!(m.void.len(), REFORM_CHECKPOINTS.len());
        let fronts: Vec<f64> = REFORM_CHECKPOINTS
            .iter()
            .zip(&m.void)
            .map(|(&c, &v)| (Reformation::front_of_void(c, v) - r.sigma(c)).abs() / L)
            .collect();
        let voids: Vec<f64> = REFORM_CHECKPOINTS
            .iter()
            .zip(&m.void)
            .map(|(&c, &v)| (v - r.void(c)).abs() / r.void(c))
            .collect();
        let ce = (m.t_collapse_interp - r.collapse()).abs();
        eprintln!(
            "nz {nz}, {steps} steps/period: collapse {:.6} (step {:.6}; reference {:.6}), error {ce:.2e}; front error / L {fronts:.2?}, void error (relative) {voids:.2?}",
            m.t_collapse_interp,
            m.t_collapse,
            r.collapse()
        );
        // The solver's cavity ends within the step that the interpolation places it in.
        assert!((m.t_collapse - m.t_collapse_interp) <= 0.5 / steps as f64 + 1e-12);
        collapse_err.push(ce);
        front_err.push(fronts.iter().cloned().fold(0.0, f64::max));
        // The liquid balance over the period: content change = net inflow, to the
        // summed residuals (an identity) and to the solver tolerance.
        let mismatch = m.content_change - m.net_inflow;
        eprintln!(
            "  balance: content change {:.6e}, net inflow {:.6e}, mismatch {mismatch:.2e} (summed residuals {:.2e}), supplied {:.3e}",
            m.content_change, m.net_inflow, m.residual, m.supplied
        );
        assert!((mismatch - m.residual).abs() < 1e-12 * m.net_inflow.abs());
        assert!(
            mismatch.abs() < 10.0 * tol * m.net_inflow.abs(),
            "nz {nz}: mismatch {mismatch:.3e}"
        );
        assert!(m.iteration_error <= tol);
    }
    // Measured (4 × nz, 0.5/steps): collapse error 1.1e-3, 5.5e-4, 2.7e-4; largest front
    // error 5.4e-2, 2.7e-2, 1.4e-2 of L (at t = 0.72): first order (backward Euler with
    // Δτ ∝ Δζ, the front within a cell).
    for (name, e) in [("collapse", &collapse_err), ("front", &front_err)] {
        for w in e.windows(2) {
            let order = (w[0] / w[1]).log2();
            eprintln!("{name}: observed order {order:.2}");
            assert!(
                (0.8..1.3).contains(&order),
                "{name}: {:.3e} -> {:.3e}",
                w[0],
                w[1]
            );
        }
    }
    assert!(collapse_err[2] < 5e-4, "collapse {:.3e}", collapse_err[2]);
    assert!(front_err[2] < 2e-2, "front {:.3e}", front_err[2]);
    // The balance can fail: the product-rule time step (no previous gap) misses it by
    // O(Δτ), here 7e-3 of a net inflow of 4.6 at the coarsest level.
    let m = march_reformation(64, 500, tol, false);
    let miss = (m.content_change - m.net_inflow).abs();
    assert!(
        miss > 1e4 * (runs[0].content_change - runs[0].net_inflow).abs(),
        "product rule misses by {miss:.3e}"
    );
}

/// Sweeps of the rupture march at a tolerance (docs/jfo.md "Iteration error", the
/// BENCHMARKS.md figures): `NZ=128 TOL=1e-11 cargo test --release --test jfo_squeeze --
/// --ignored --nocapture rupture_march_sweeps`.
#[test]
#[ignore]
fn rupture_march_sweeps() {
    let nz: usize = std::env::var("NZ")
        .map(|v| v.parse().unwrap())
        .unwrap_or(128);
    let tol: f64 = std::env::var("TOL")
        .map(|v| v.parse().unwrap())
        .unwrap_or(1e-11);
    let t_end: f64 = std::env::var("TEND")
        .map(|v| v.parse().unwrap())
        .unwrap_or(0.31);
    let steps = (140 * nz / 128) as f64 * (t_end - T0) / 0.07;
    let steps = steps.round() as usize;
    let mut st = Stepper::new(nz, (t_end - T0) / steps as f64, tol);
    let n = st.n();
    let mut worst = 0.0_f64;
    let (mut total, mut failed) = (0u64, 0usize);
    for s in 0..steps {
        st.phi_old.clear();
        let f = st.field[n..].to_vec();
        st.phi_old.extend_from_slice(&f);
        st.steps += 1;
        let t = st.t();
        let hist = JfoHistory {
            phi: &st.phi_old,
            dtau: st.dt,
            prev_ecc: Some(job(t - st.dt).state.ecc),
        };
        let (_, rep) = st
            .jfo
            .solve(&mut st.reynolds, &job(t), &st.g, &mut st.field, Some(&hist));
        total += rep.sweeps as u64;
        failed += usize::from(!rep.converged);
        let b = st.balance();
        worst = worst.max(b.residual.abs());
        if !rep.converged || s % (steps / 10).max(1) == 0 {
            eprintln!(
                "t {t:.4} sweeps {} err {:.2e} conv {} residual {:.2e} cav {}",
                rep.sweeps,
                rep.iteration_error,
                rep.converged,
                b.residual,
                st.cavitated()
            );
        }
    }
    eprintln!(
        "{steps} steps, {failed} not converged, total sweeps {total}, worst balance residual {worst:.2e}"
    );
}

/// The solver's iteration error below 1e-8 (docs/jfo.md "Iteration error"): before
/// issue 27's last pass the Gauss–Seidel stalled at an estimated 1e-8 once the film
/// ruptured (rounding of the time step's `O(12 H/Δτ)` storage terms, amplified 1e4× by a
/// contraction measured on noise). At tolerance 1e-11 every step of the rupture march
/// converges (reported ≤ 1e-11). Checked against the exact discrete solution before
/// rupture (the closed-form parabola, which the 3-point operator reproduces): the actual
/// error is below 1e-9 of P0 (the parabola is the exact discrete solution only up to the
/// columns' coupling, 1e-10 of P0 here). The iteration error proper (against the same step
/// solved on to 1e-13, relative to max P as the solver measures it) is within a factor 3
/// of the reported estimate both ways (session 34 compared it relative to P0, 2-30× below
/// max P before rupture, and read up to 37×). After rupture the same step solved from a
/// cold (empty) start agrees with the warm solve within 3× the two reported errors.
#[test]
fn iteration_error_below_1e_8_through_the_rupture() {
    let tol = 1e-11;
    for nz in [128, 512] {
        let steps = 140 * nz / 128;
        let mut st = Stepper::new(nz, 0.07 / steps as f64, tol);
        let n = st.n();
        let dz = 1.0 / nz as f64;
        let jl = st.jl();
        let (mut worst_pre, mut worst_post, mut reported_max) = (0.0_f64, 0.0_f64, 0.0_f64);
        let (mut under_pre, mut over_pre) = (0.0_f64, 0.0_f64);
        let mut under_post = 0.0_f64;
        let mut parabola_gap = 0.0_f64;
        for s in 0..steps {
            let rep = st.step();
            assert!(rep.iteration_error <= tol, "{rep:?}");
            reported_max = reported_max.max(rep.iteration_error);
            let t = st.t();
            if !st.cavitated() {
                let k = 12.0 * h_dot(t) / h(t).powi(3);
                let actual = (1..jl)
                    .map(|j| {
                        let z = j as f64 * dz;
                        (st.p(j) - (p0() * z / L + 0.5 * k * z * (z - L))).abs() / p0()
                    })
                    .fold(0.0, f64::max);
                worst_pre = worst_pre.max(actual);
                // The iteration error proper: against the same step solved on to 1e-13
                // (the parabola itself is 1-2e-10 from the discrete solution here).
                let hist_phi = st.phi_old.clone();
                let hist = JfoHistory {
                    phi: &hist_phi,
                    dtau: st.dt,
                    prev_ecc: Some(job(t - st.dt).state.ecc),
                };
                let mut reference = st.field.clone();
                let (_, rr) = st.jfo.solve(
                    &mut st.reynolds,
                    &job(t),
                    &setup(nz, 1e-13),
                    &mut reference,
                    Some(&hist),
                );
                assert!(rr.converged, "{rr:?}");
                // Relative to max P, as the solver measures its error (max P is 2-30× P0
                // before rupture; comparing to P0 had made the estimate look 37× low).
                let pmax = reference[..n].iter().fold(0.0_f64, |a, &v| a.max(v));
                let to_reference = (0..n)
                    .map(|k| (st.field[k] - reference[k]).abs())
                    .fold(0.0, f64::max)
                    / pmax;
                let to_parabola = (1..jl)
                    .map(|j| {
                        let z = j as f64 * dz;
                        (reference[j * NT] - (p0() * z / L + 0.5 * k * z * (z - L))).abs() / p0()
                    })
                    .fold(0.0, f64::max);
                parabola_gap = parabola_gap.max(to_parabola);
                // Judged where the reference is well below it (its own reported error).
                if to_reference > 10.0 * rr.iteration_error {
                    under_pre = under_pre.max(to_reference / rep.iteration_error);
                    over_pre = over_pre.max(rep.iteration_error / to_reference);
                }
            } else if s % 20 == 0 {
                // The same step from an empty film: both within their reported errors.
                let hist_phi = st.phi_old.clone();
                let hist = JfoHistory {
                    phi: &hist_phi,
                    dtau: st.dt,
                    prev_ecc: Some(job(t - st.dt).state.ecc),
                };
                let mut cold: Vec<f64> =
                    (0..2 * n).map(|k| if k < n { 0.0 } else { 1.0 }).collect();
                let (_, rc) =
                    st.jfo
                        .solve(&mut st.reynolds, &job(t), &st.g, &mut cold, Some(&hist));
                assert!(rc.converged && rc.iteration_error <= tol, "{rc:?}");
                let dp = (0..n)
                    .map(|k| (cold[k] - st.field[k]).abs())
                    .fold(0.0, f64::max)
                    / p0();
                let dphi = (n..2 * n)
                    .map(|k| (cold[k] - st.field[k]).abs())
                    .fold(0.0, f64::max);
                let diff = dp.max(dphi);
                worst_post = worst_post.max(diff);
                under_post = under_post.max(diff / (rep.iteration_error + rc.iteration_error));
                // The reported errors are estimates within a factor 3 (both ways), not
                // bounds.
                assert!(
                    diff <= 3.0 * (rep.iteration_error + rc.iteration_error),
                    "nz {nz}, t {t}: warm and cold differ by {diff:.2e}, reported {:.2e} + {:.2e}",
                    rep.iteration_error,
                    rc.iteration_error
                );
            }
        }
        eprintln!(
            "nz {nz}, tolerance {tol:.0e}: largest reported {reported_max:.2e}; before rupture the actual error is at most {worst_pre:.2e} (the 1e-13 solve is {parabola_gap:.2e} of P0 from the parabola; the iteration error ≤ {under_pre:.2}× reported); after, warm vs cold {worst_post:.2e} (≤ {under_post:.2}× the sum reported)"
        );
        assert!(worst_pre < 1e-9, "nz {nz}: {worst_pre:.2e}");
        // The iteration error against the 1e-13 solve, both relative to max P: within a
        // factor 3 both ways (session 34 had compared it relative to P0 and read the
        // estimate as up to 37× low; the 1e-10 of P0 between the 1e-13 solve and the
        // parabola is the columns' coupling through B/r0 = 1e-5, not rounding:
        // `rounding_floor_is_reported_honestly`).
        eprintln!("nz {nz}: true/reported up to {under_pre:.2}, reported/true up to {over_pre:.2}");
        assert!(
            under_pre <= 3.0 && over_pre <= 3.0 && over_pre > 0.0,
            "nz {nz}: true/reported up to {under_pre:.2}, reported/true up to {over_pre:.2}"
        );
    }
}

/// The reported iteration error against the true one through rupture and reformation
/// (issue 27, session 34; docs/jfo.md "Iteration error"): one gap period `[0.24, 0.74]`
/// at 128 nodes (1000 steps, tolerance 1e-9), every 10th step judged against the same
/// step (same history) solved on to 1e-13: reported/true within a factor 3 both ways
/// wherever the true error is above 1e-11. Before issue 27's session 34 the reported
/// error was the last sweep's change extrapolated, up to 22× below the true error here
/// (the test above, asserted ≤ 25× then).
#[test]
fn iteration_error_honest_through_rupture_and_reformation() {
    let (nz, steps, tol) = (128usize, 1000usize, 1e-9);
    let mut st = Stepper::new(nz, 0.5 / steps as f64, tol);
    let gr = setup(nz, 1e-13);
    let n = st.n();
    let mut ratios = Vec::new();
    let (mut seen_cavity, mut seen_reformed) = (false, false);
    for s in 1..=steps {
        let rep = st.step();
        assert!(rep.iteration_error <= tol, "{rep:?}");
        let cav = st.cavitated();
        seen_cavity |= cav;
        seen_reformed |= seen_cavity && !cav;
        if s % 10 != 0 {
            continue;
        }
        let t = st.t();
        let hist = st.history();
        let mut reference = st.field.clone();
        let (_, rr) = JfoSolver::new().solve(
            &mut FiniteSolver::new(),
            &job(t),
            &gr,
            &mut reference,
            Some(&hist),
        );
        assert!(rr.converged, "reference at t = {t}: {rr:?}");
        let pmax = reference[..n].iter().fold(0.0_f64, |a, &v| a.max(v));
        let dp = (0..n)
            .map(|k| (st.field[k] - reference[k]).abs())
            .fold(0.0, f64::max);
        let dphi = (n..2 * n)
            .map(|k| (st.field[k] - reference[k]).abs())
            .fold(0.0, f64::max);
        let truth = (dp / pmax).max(dphi);
        eprintln!(
            "t {t:.4} cavity {cav}: reported {:.3e}, true {truth:.3e}, ratio {:.2}",
            rep.iteration_error,
            rep.iteration_error / truth
        );
        if truth > 1e-11 {
            ratios.push(rep.iteration_error / truth);
        }
    }
    assert!(
        seen_cavity && seen_reformed,
        "the march ruptures and reforms"
    );
    let lo = ratios.iter().fold(f64::INFINITY, |a, &v| a.min(v));
    let hi = ratios.iter().fold(0.0_f64, |a, &v| a.max(v));
    eprintln!("{} judged, ratios {lo:.2} ... {hi:.2}", ratios.len());
    assert!(ratios.len() >= 50, "{} judged", ratios.len());
    assert!(
        lo >= 1.0 / 3.0 && hi <= 3.0,
        "reported/true {lo:.2} ... {hi:.2}"
    );
}

/// The rounding floor is reported (issue 27, session 35; docs/jfo.md "The rounding
/// floor"): the iteration's floating-point fixed point is off the exact discrete solution
/// by the rounding of its node equations amplified by the operator's inverse, which the
/// changes of the iterate cannot show (they vanish there). Before rupture with the columns
/// decoupled to 1e-16 (`B/r0 = 1e-8` instead of the benchmark's 1e-5, whose coupling
/// moves the column θ = 0 by 3.5e-12 of `max P` from its parabola) the exact discrete
/// solution is the closed-form parabola on the column θ = 0 and `P = 0` on the others
/// (the column θ = 180° separates and is cavitated). Each of 64, 128, 256 and 512 nodes
/// along ζ, two pre-rupture steps, solved at tolerances 1e-12 ... 1e-16: the reported
/// iteration error within a factor 3 of the true one (relative to `max P`) both ways,
/// except where the solve ends at the sweep cap on the stagnation rule (its noise times
/// `ρ/(1 − ρ)` is an upper estimate there: within 10 above); a reported convergence means
/// the true error is within 3× the tolerance, and a tolerance below the floor (1e-16) is
/// reported as not met. Before session 35 the 1e-16 solves reported 9e-16 ("converged")
/// at true errors of 1e-14 to 1e-13.
#[test]
fn rounding_floor_is_reported_honestly() {
    let aspect = 1e-8;
    let mut ratios = Vec::new();
    let mut failed = Vec::new();
    for nz in [64usize, 128, 256, 512] {
        let steps = 140 * nz / 128;
        let mut st = Stepper::new(nz, 0.07 / steps as f64, 1e-9);
        let n = st.n();
        let dz = 1.0 / nz as f64;
        let jb = |t: f64| FiniteJob { aspect, ..job(t) };
        let cap = setup(nz, 1e-16).max_sweeps();
        for s in 0..=steps / 10 {
            st.phi_old.clear();
            let f = st.field[n..].to_vec();
            st.phi_old.extend_from_slice(&f);
            st.steps += 1;
            let t = st.t();
            let hist_phi = st.phi_old.clone();
            let hist = JfoHistory {
                phi: &hist_phi,
                dtau: st.dt,
                prev_ecc: Some(job(t - st.dt).state.ecc),
            };
            let g = st.g;
            st.jfo
                .solve(&mut st.reynolds, &jb(t), &g, &mut st.field, Some(&hist));
            assert!(!st.cavitated(), "nz {nz}, t {t}: before rupture");
            if s % (steps / 10) != 0 {
                continue;
            }
            let k = 12.0 * h_dot(t) / h(t).powi(3);
            let exact = |j: usize, i: usize| {
                let z = (j as f64 * dz).min(1.0 - j as f64 * dz);
                match i {
                    0 if z <= L => p0() * z / L + 0.5 * k * z * (z - L),
                    0 => p0(),
                    _ => 0.0,
                }
            };
            for tol in [1e-12, 1e-13, 1e-14, 1e-16] {
                let mut f = st.field.clone();
                let (_, r) = st.jfo.solve(
                    &mut st.reynolds,
                    &jb(t),
                    &setup(nz, tol),
                    &mut f,
                    Some(&hist),
                );
                let pmax = f[..n].iter().fold(0.0_f64, |a, &v| a.max(v));
                let truth = (1..nz)
                    .flat_map(|j| (0..NT).map(move |i| (j, i)))
                    .map(|(j, i)| (f[j * NT + i] - exact(j, i)).abs())
                    .fold(0.0, f64::max)
                    / pmax;
                let ratio = r.iteration_error / truth;
                eprintln!(
                    "nz {nz} t {t:.4} tol {tol:.0e}: reported {:.2e} converged {} sweeps {} true {truth:.2e} ratio {ratio:.2}",
                    r.iteration_error, r.converged, r.sweeps
                );
                let hi = if r.sweeps >= cap { 10.0 } else { 3.0 };
                if !(ratio >= 1.0 / 3.0 && ratio <= hi) {
                    failed.push(format!(
                        "nz {nz}, t {t}, tol {tol:.0e}: reported/true {ratio:.2}"
                    ));
                }
                if r.converged && truth > 3.0 * tol {
                    failed.push(format!("nz {nz}, tol {tol:.0e}: met at {truth:.2e}"));
                }
                if tol == 1e-16 && r.converged {
                    failed.push(format!("nz {nz}: 1e-16 is below the floor, reported met"));
                }
                ratios.push(ratio);
            }
        }
    }
    let lo = ratios.iter().fold(f64::INFINITY, |a, &v| a.min(v));
    let hi = ratios.iter().fold(0.0_f64, |a, &v| a.max(v));
    eprintln!("{} judged, ratios {lo:.2} ... {hi:.2}", ratios.len());
    assert_eq!(ratios.len(), 32);
    assert!(failed.is_empty(), "{failed:#?}");
}
