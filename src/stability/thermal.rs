//! The rotor's equilibrium solved together with each lubricated bearing's
//! effective-temperature balance (issue 24, docs/thermal.md "Stability"): the bearings'
//! viscosities `μ(T_eff)` at which the rotor is then linearised.
//!
//! One bearing: the balance of `bearing::solve_balance` whose every trial viscosity is a
//! rotor equilibrium at that viscosity (as `coefficients` does for one bearing). Several
//! bearings share the rotor's load and so couple through the equilibrium: Gauss-Seidel
//! sweeps over the lubricated bearings, each solving its own balance with the others'
//! viscosities held, until a whole sweep moves no `T_eff` by more than
//! [`SWEEP_TOLERANCE_FACTOR`] times the bearings' balance tolerance.

use super::linear::{bearing_state, equilibria_batch, RotorDescription};
use super::StabilityError;
use crate::backend::LoadEvaluator;
use crate::bearing::{film_flow::bearing_loads, solve_balance, Balance, FilmRule};

/// A sweep whose largest `T_eff` change is below this many balance tolerances ends the
/// Gauss-Seidel iteration: Brent's `T_eff` is only known to its tolerance, so changes of
/// that order are the solver's own scatter, not coupling still settling.
pub const SWEEP_TOLERANCE_FACTOR: f64 = 10.0;
/// Gauss-Seidel sweeps at most; the coupling through a shared load is weak (a rigid
/// rotor on two bearings shares a static load by the lever rule whatever the films), so
/// the usual count is 2-3.
const MAX_SWEEPS: u32 = 30;

/// Whether any bearing of `rotor` has a lubricant and a supply temperature.
pub fn is_thermal(rotor: &RotorDescription) -> bool {
    rotor
        .bearings
        .iter()
        .any(|(p, _)| p.lubricant.is_some() && p.supply_temperature.is_some())
}

/// The rotor at spin `speed` with each lubricated bearing's viscosity at its `T_eff`
/// (the balance solved together with the rotor's equilibrium), and the balances (`None`
/// for bearings without a lubricant). The film power and side flow of each trial come
/// from the CPU film at the evaluator's rule settings (the heat is the film's own
/// friction power, `bearing::thermal::HEAT_SOURCE`).
pub fn thermal_rotor(
    evaluator: &mut LoadEvaluator,
    rotor: &RotorDescription,
    speed: f64,
) -> Result<(RotorDescription, Vec<Option<Balance>>), StabilityError> {
    let mut r = rotor.clone();
    let mut balances: Vec<Option<Balance>> = vec![None; r.bearings.len()];
    let lubricated: Vec<usize> = (0..r.bearings.len())
        .filter(|&b| {
            let p = &r.bearings[b].0;
            p.lubricant.is_some() && p.supply_temperature.is_some()
        })
        .collect();
    if lubricated.is_empty() {
        return Ok((r, balances));
    }
    let rule = FilmRule::new(evaluator.backend().settings());
    let tolerance = lubricated
        .iter()
        .map(|&b| r.bearings[b].0.thermal.tolerance)
        .fold(0.0, f64::max);
    let mut sweeps = 0;
    loop {
        sweeps += 1;
        let mut change: f64 = 0.0;
        for &b in &lubricated {
            let p = r.bearings[b].0;
            let (Some(lub), Some(supply)) = (p.lubricant, p.supply_temperature) else {
                continue;
            };
            let bal = solve_balance(&lub, supply, &p.thermal, |mu| {
                let mut trial = r.clone();
                trial.bearings[b].0.viscosity = mu;
                let (q, _) = equilibria_batch(evaluator, &[(&trial, speed)])
                    .remove(0)
                    .map_err(|e| e.to_string())?;
                let (pb, a) = &trial.bearings[b];
                let state = bearing_state(&q, pb, *a, speed, trial.frame_rate(speed));
                let l = bearing_loads(pb, &state, &rule).map_err(|e| e.to_string())?;
                Ok((l.film.power_loss_w, l.film.side_flow_m3_per_s))
            })
            .map_err(|e| StabilityError::NoEquilibrium {
                speed_rad_s: speed,
                reason: format!("thermal balance of bearings[{b}]: {e}"),
            })?;
            let before = balances[b].map_or(f64::INFINITY, |o| o.effective_temperature_c);
            change = change.max((bal.effective_temperature_c - before).abs());
            r.bearings[b].0.viscosity = bal.viscosity_pa_s;
            balances[b] = Some(bal);
        }
        // One lubricated bearing: its balance already holds at the final equilibrium.
        if lubricated.len() == 1 || change <= SWEEP_TOLERANCE_FACTOR * tolerance {
            return Ok((r, balances));
        }
        if sweeps >= MAX_SWEEPS {
            return Err(StabilityError::NoEquilibrium {
                speed_rad_s: speed,
                reason: format!(
                    "the bearings' thermal balances did not settle in {MAX_SWEEPS} sweeps (last change {change:.2e} K)"
                ),
            });
        }
    }
}
