//! Friction and flow of a converged finite film (issue 24 item 1; docs/finite-film.md
//! "Friction and flow"): post-processing of the pressure field on the solver's own grid
//! and operator, for fields from any backend (the GPU returns its fields too).
//!
//! In the nondimensional form of [`super::solver`], the finite volume of interior node `k`
//! balances, in units of `∫ H³ ∂ζP dθ` (× `r0 δ ρ B / 12` gives m³/s),
//!
//! ```text
//! σ_k = (rhs_k − (L P)_k) Δθ Δζ      (net outflow of the cell's full-film flow),
//! rhs_k = 6 (ω0/ρ) ∂H/∂θ + 12/ρ ∂H/∂t (Couette divergence + squeeze storage),
//! ```
//!
//! `σ_k = 0` at converged free nodes with `P > 0`; at cavitated nodes (`P = 0`) `σ_k ≥ 0`
//! is the Swift–Stieber complementarity's slack; at held nodes it is what the hold feeds.
//! The sums are exact discrete identities:
//!
//! - **side flow** at an end: the pressure flux through the faces between the end row and
//!   the first interior row, `Σ_i a_N (P_1 − P_0) Δθ Δζ` (the interior cells' fluxes
//!   telescope to exactly these two: conservative), carried on to the end face itself
//!   through the end half-cells `[0, Δζ/2]` of the pressure zone's columns (less their
//!   Couette and squeeze outflow `rhs ΔθΔζ/2`; the θ pressure flux there is zero at the
//!   end row), which makes it second order in the grid.
//! - **inlet flow**: `Σ (σ_k − storage_k)` over held and cavitated nodes: the flow into
//!   the held nodes, with the ruptured zone carrying on the Couette flow that left the
//!   pressure zone at rupture (as streamers, at constant flow) instead of a full film.
//!   The Couette divergences of a row sum to zero around the ring, so
//!   `inlet = side + storage + Σ_free σ`: inflow equals side flow plus the squeeze storage
//!   of the pressure zone (`Σ storage_k` over free nodes with `P > 0`) up to the
//!   converged residual `Σ_free σ` (reported as `residual`).
//! - **pressure torque**: `∬ H ∂P/∂θ dθ dζ` as the face sum `Σ H_{i+½} (P_{i+1} − P_i) Δζ`
//!   (rows weighted by Simpson's rule in ζ on the accuracy ladder of the plain film, as
//!   its loads are).

use std::f64::consts::PI;

use super::multigrid::Level;
use super::solver::{film, FiniteGrid, FiniteJob, SolveReport};
use crate::bearing::film_flow::{couette_torque, friction_outputs, FilmFlow};
use crate::bearing::{BearingParams, BearingState, FilmIntegrals, Loads};

/// Nondimensional friction and flow integrals of a converged field (flows in units of
/// `∫ H³ ∂ζP dθ`; see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FlowIntegrals {
    /// Side flow out of the ends `ζ = 0` and `ζ = 1`.
    pub side: [f64; 2],
    /// Inlet flow (held and cavitated nodes).
    pub inlet: f64,
    /// Squeeze storage of the pressure zone (free nodes with `P > 0`).
    pub storage: f64,
    /// Converged residual: `Σ σ` over the free nodes with `P > 0`.
    pub residual: f64,
    /// `Σ |σ|` over the free nodes with `P > 0` plus the side flows (the residual's
    /// scale).
    pub scale: f64,
    /// `∬ H ∂P/∂θ dθ dζ`.
    pub pressure_shear: f64,
    /// The load integrals of the field at the grid's node angles (as the solver returns
    /// them: the check that the post-processing sees the solver's grid).
    pub loads: FilmIntegrals,
}

/// Angle of node 0 of the grid the solver returned its field on, rad: on the accuracy
/// ladder with the `max_film` inlet, the mid-plane's maximum film (the rule of
/// [`super::FiniteSolver::solve`]); 0 on explicit grids.
pub fn solution_theta0(job: &FiniteJob, g: &FiniteGrid) -> f64 {
    if g.accuracy.is_some() {
        ladder_theta0(job, g.max_film_inlet)
    } else {
        0.0
    }
}

/// Angle of node 0 on the accuracy ladder, rad: with the `max_film` inlet the mid-plane's
/// maximum film, `arg(−ε)` of the mean of the end eccentricities (0 for a centred
/// journal); 0 without it. The one rule of the Swift–Stieber and JFO ladders, on the CPU
/// and the GPU hosts.
pub fn ladder_theta0(job: &FiniteJob, max_film_inlet: bool) -> f64 {
    let e = &job.state.ecc;
    let (ex, ey) = (0.5 * (e[0] + e[2]), 0.5 * (e[1] + e[3]));
    if max_film_inlet && (ex != 0.0 || ey != 0.0) {
        (-ey).atan2(-ex)
    } else {
        0.0
    }
}

/// Friction and flow integrals of `field` (the solution of `job` on the `nt × nz` grid of
/// `g`'s kind whose node 0 is at `theta0`); `spin` is `ω0/ρ` (the spin over the rate
/// scale). `None` when the field's length is not the grid's.
pub fn flow_integrals(
    job: &FiniteJob,
    g: &FiniteGrid,
    nt: usize,
    nz: usize,
    theta0: f64,
    spin: f64,
    field: &[f64],
) -> Option<FlowIntegrals> {
    if nt < 2 || nz < 2 || field.len() != nt * (nz + 1) {
        return None;
    }
    let mut lvl = Level::default();
    lvl.setup(job, nt, nz, g.max_film_inlet, &g.layout, theta0, None, true);
    let (ae, an, f, inv_d) = lvl.operator();
    let p = field;
    let dt = 2.0 * PI / nt as f64;
    let dz = 1.0 / nz as f64;
    let e = &job.state.ecc;
    // Node angles (index 2i) and east-face angles (2i + 1).
    let trig: Vec<(f64, f64)> = (0..2 * nt)
        .map(|k| {
            let th = theta0 + 0.5 * dt * k as f64;
            (th.cos(), th.sin())
        })
        .collect();
    let mut out = FlowIntegrals::default();
    let mut abs_residual = 0.0;
    // End half-cells (rows 0 and n_z, area ΔθΔζ/2): the side flow of a column whose first
    // interior node is in the pressure zone is the face flux less the half cell's own
    // Couette and squeeze outflow (the face is Δζ/2 inside the end; without the half
    // cell the side flow would be first order in Δζ); elsewhere the half cell belongs to
    // the ruptured or held zone and its balance goes to the inlet flow.
    for (end, (row, inner, face)) in [(0, nt, 0), (nz * nt, (nz - 1) * nt, (nz - 1) * nt)]
        .into_iter()
        .enumerate()
    {
        let zeta = if end == 0 { 0.0 } else { 1.0 };
        let ex = e[0] + (e[2] - e[0]) * zeta;
        let ey = e[1] + (e[3] - e[1]) * zeta;
        for i in 0..nt {
            let flux = an[face + i] * (p[inner + i] - p[row + i]);
            let rhs = -f[row + i];
            let (c, s) = trig[2 * i];
            let storage = rhs - 6.0 * spin * (ex * s - ey * c);
            if inv_d[inner + i] != 0.0 && p[inner + i] > 0.0 {
                out.side[end] += flux - 0.5 * rhs;
                out.storage += 0.5 * storage;
            } else {
                out.side[end] += flux;
                out.inlet += 0.5 * (rhs - storage);
            }
        }
    }
    let mut loads = [0.0; 4];
    // The accuracy ladder of the plain film sums its loads by Simpson's rule in ζ
    // (`super::solver::ladder_integrals_on`, issue 20 pass 4): the loads and the pressure
    // torque here are summed the same way, so the torque identity holds on the loads the
    // solver returned. Weight of row j over Δζ.
    // (Held grids, `n_theta` > 0, sum by the rectangle rule: `FiniteSolver::rectangle_ladder`.)
    let simpson =
        g.accuracy.is_some() && g.n_theta == 0 && g.layout.is_empty() && nz.is_multiple_of(2);
    for j in 1..nz {
        let zeta = j as f64 * dz;
        let w = match (simpson, j % 2) {
            (false, _) => 1.0,
            (true, 1) => 4.0 / 3.0,
            (true, _) => 2.0 / 3.0,
        };
        let mut shear = 0.0;
        let ex = e[0] + (e[2] - e[0]) * zeta;
        let ey = e[1] + (e[3] - e[1]) * zeta;
        let row = j * nt;
        let (mut lc, mut ls) = (0.0, 0.0);
        for i in 0..nt {
            let k = row + i;
            let ip = row + (i + 1) % nt;
            let im = row + (i + nt - 1) % nt;
            let lp = ae[k] * (p[ip] - p[k]) - ae[im] * (p[k] - p[im]) + an[k] * (p[k + nt] - p[k])
                - an[k - nt] * (p[k] - p[k - nt]);
            let rhs = -f[k];
            let sigma = rhs - lp;
            let (c, s) = trig[2 * i];
            // Squeeze part of the right-hand side: rhs − 6 (ω0/ρ) ∂H/∂θ.
            let storage = rhs - 6.0 * spin * (ex * s - ey * c);
            if inv_d[k] == 0.0 || p[k] <= 0.0 {
                out.inlet += sigma - storage;
            } else {
                out.storage += storage;
                out.residual += sigma;
                abs_residual += sigma.abs();
            }
            let (cf, sf) = trig[2 * i + 1];
            shear += film(e, zeta, cf, sf) * (p[ip] - p[k]);
            lc += p[k] * c;
            ls += p[k] * s;
        }
        out.pressure_shear += w * shear;
        loads[0] += w * lc;
        loads[1] += w * ls;
        loads[2] += w * lc * zeta;
        loads[3] += w * ls * zeta;
    }
    let area = dt * dz;
    out.side = out.side.map(|v| v * area);
    out.inlet *= area;
    out.storage *= area;
    out.residual *= area;
    out.scale = abs_residual * area + out.side[0].abs() + out.side[1].abs();
    out.pressure_shear *= dz;
    out.loads = loads.map(|v| -v * area / 3.0);
    Some(out)
}

/// Film friction and flow in SI from the integrals of a state packed with rate scale
/// `rate_scale` (1/s) whose film force is `w_abs` (N).
pub fn film_flow_of(
    params: &BearingParams,
    state: &BearingState,
    rate_scale: f64,
    w_abs: f64,
    ints: &FlowIntegrals,
) -> FilmFlow {
    let (r, b, d, mu) = (
        params.radius,
        params.length,
        params.clearance,
        params.viscosity,
    );
    let mz = couette_torque(params, state)
        - r * mu * rate_scale * b * b * b / (2.0 * d) * ints.pressure_shear;
    let q = r * d * rate_scale * b / 12.0;
    FilmFlow {
        side_flow_i_m3_per_s: q * ints.side[0],
        side_flow_j_m3_per_s: q * ints.side[1],
        side_flow_m3_per_s: q * (ints.side[0] + ints.side[1]),
        inlet_flow_m3_per_s: q * ints.inlet,
        ..friction_outputs(params, state.omega, mz, w_abs)
    }
}

/// The grid a finite solve returned its field on: `(n_theta, n_z, theta0)`.
pub fn solution_grid(job: &FiniteJob, g: &FiniteGrid, report: &SolveReport) -> (usize, usize, f64) {
    if g.accuracy.is_some() {
        (
            report.n_theta as usize,
            report.n_z as usize,
            solution_theta0(job, g),
        )
    } else {
        (g.n_theta, g.n_z, 0.0)
    }
}

/// Replaces `loads.film` (the short-film closed forms [`crate::bearing::finish_loads`]
/// fills in) with the finite film's friction and flow from its converged `field`. Leaves
/// `loads` as they are when the field does not fit the grid (e.g. a state without
/// pressure, which was never solved: its closed forms are exact, all flows zero).
#[allow(clippy::too_many_arguments)]
pub fn apply_finite_flow(
    loads: &mut Loads,
    params: &BearingParams,
    state: &BearingState,
    rate_scale: f64,
    job: &FiniteJob,
    g: &FiniteGrid,
    report: &SolveReport,
    field: &[f64],
) {
    if g.cavitation == super::Cavitation::Jfo {
        // Mass-conserving cavitation (issue 27): flows and shear over the film fraction.
        super::jfo::apply_jfo_flow(
            loads, params, state, rate_scale, job, g, report, field, None,
        );
        return;
    }
    if rate_scale <= 0.0 {
        return;
    }
    let (nt, nz, theta0) = solution_grid(job, g, report);
    if let Some(ints) = flow_integrals(job, g, nt, nz, theta0, state.omega / rate_scale, field) {
        let flow = film_flow_of(params, state, rate_scale, loads.wx.hypot(loads.wy), &ints);
        let all_finite = [
            flow.friction_torque_nm,
            flow.power_loss_w,
            flow.side_flow_m3_per_s,
            flow.inlet_flow_m3_per_s,
        ]
        .iter()
        .all(|v| v.is_finite());
        if all_finite {
            loads.film = flow;
        }
    }
}
