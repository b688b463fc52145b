//! The effective-temperature balance of one bearing (issue 24 item 3, docs/thermal.md):
//! numerical kernel, no I/O.
//!
//! The friction power `P` heats the oil; the side flow `Q` carries it away and the housing
//! conducts some to the surroundings (at the supply temperature):
//!
//! ```text
//! P(μ(T_eff)) = ρ c Q ΔT + H (T_eff − T_supply),   T_eff = T_supply + k ΔT
//! ```
//!
//! `ΔT` is the oil's rise from supply to outlet, `k` the effective-temperature factor
//! (default 0.8; Raimondi-Boyd's textbook procedure uses 0.5), `H` the housing
//! conductance in W/K (default 0: adiabatic, all heat leaves with the oil). Solved for
//! `T_eff` by Brent's method (bracketed inverse-quadratic/secant steps, bisection
//! fallback) on `r(T) = P − (ρ c Q / k + H)(T − T_supply)`, which is positive at
//! `T_supply` and falls as `T` grows (μ falls, the outflow term grows).

use serde::{Deserialize, Serialize};

use super::lubricant::Lubricant;
use super::{BearingParams, BearingState, Loads};

/// Default effective-temperature factor `k` in `T_eff = T_supply + k ΔT`: 0.8, the value
/// Khonsari & Booser (*Applied Tribology*, ch. 8, effective temperature) recommend from
/// measured film temperatures; 0.5 is the Raimondi-Boyd (Shigley) mean.
pub const DEFAULT_EFFECTIVE_FACTOR: f64 = 0.8;
/// Default tolerance on `T_eff`, K: far below any thermometer, cheap (about 6 Brent steps).
pub const DEFAULT_TOLERANCE_K: f64 = 1e-6;
/// Default lumped thermal capacity of a bearing's oil and the metal next to it, J/K (rotor
/// scenes only): 50 J/K ≈ 25 g of oil (c ≈ 2000 J/(kg·K)), the order of the oil in and
/// around a 40 mm bore; docs/thermal.md says what it sets (the time constant).
pub const DEFAULT_THERMAL_CAPACITY: f64 = 50.0;
/// Most Brent iterations; with the bracket halving at worst every other step, 200 covers
/// a 1000 K bracket down to 1e-12 K.
const MAX_ITERATIONS: u32 = 200;
/// Largest temperature rise searched, K: a balance needing more has no physical meaning
/// (the oil would have boiled off), reported as an error.
const MAX_RISE_K: f64 = 1000.0;

/// Settings of the thermal balance of one bearing (all fields default).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ThermalSettings {
    /// Effective-temperature factor `k` (dimensionless, in (0, 1]). Default 0.8.
    pub effective_factor: f64,
    /// Heat-transfer conductance from the film to the surroundings (at the supply
    /// temperature) through the housing, W/K. Default 0 (adiabatic).
    pub housing_conductance: f64,
    /// Lumped thermal capacity of the oil temperature state in rotor scenes, J/K.
    /// Default [`DEFAULT_THERMAL_CAPACITY`].
    pub thermal_capacity: f64,
    /// Tolerance on `T_eff`, K. Default 1e-6.
    pub tolerance: f64,
}

impl Default for ThermalSettings {
    fn default() -> Self {
        ThermalSettings {
            effective_factor: DEFAULT_EFFECTIVE_FACTOR,
            housing_conductance: 0.0,
            thermal_capacity: DEFAULT_THERMAL_CAPACITY,
            tolerance: DEFAULT_TOLERANCE_K,
        }
    }
}

impl ThermalSettings {
    /// The offending field and why, if any.
    pub fn validate(&self) -> Result<(), (&'static str, f64, &'static str)> {
        let k = self.effective_factor;
        if !(k.is_finite() && k > 0.0 && k <= 1.0) {
            return Err(("effective_factor", k, "must be in (0, 1]"));
        }
        let h = self.housing_conductance;
        if !(h.is_finite() && h >= 0.0) {
            return Err(("housing_conductance", h, "must be finite and >= 0 W/K"));
        }
        let c = self.thermal_capacity;
        if !(c.is_finite() && c > 0.0) {
            return Err(("thermal_capacity", c, "must be finite and positive J/K"));
        }
        let t = self.tolerance;
        if !(t.is_finite() && (1e-12..=1.0).contains(&t)) {
            return Err(("tolerance", t, "must be in [1e-12, 1] K"));
        }
        Ok(())
    }
}

/// A solved balance.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Balance {
    /// Effective film temperature, °C.
    pub effective_temperature_c: f64,
    /// Oil temperature rise supply -> outlet `ΔT = (T_eff − T_supply) / k`, K.
    pub temperature_rise_k: f64,
    /// Dynamic viscosity at `T_eff`, Pa·s.
    pub viscosity_pa_s: f64,
    /// Friction power at `T_eff` (the heat source: the film's own friction power in every
    /// caller, [`HEAT_SOURCE`]), W.
    pub power_loss_w: f64,
    /// Side flow at `T_eff`, m³/s.
    pub side_flow_m3_s: f64,
    /// Heat carried away by the side flow, `ρ c Q ΔT`, W.
    pub heat_to_flow_w: f64,
    /// Heat through the housing, `H (T_eff − T_supply)`, W.
    pub heat_to_housing_w: f64,
    /// Heat-flow evaluations (film solutions) the solve used.
    pub evaluations: u32,
}

/// Why a balance has no solution.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ThermalError {
    /// The film gave no power or flow at some temperature (a fault of its own).
    #[error("the film has no solution at {celsius:.3} °C: {reason}")]
    Film {
        /// Where it failed, °C.
        celsius: f64,
        /// The film's reason.
        reason: String,
    },
    /// Friction heats the film but no side flow or housing takes heat away.
    #[error("no heat path: zero side flow and zero housing conductance with {power_w} W of friction (give \"thermal\": {{\"housing_conductance\": ...}})")]
    NoHeatPath {
        /// The friction power, W.
        power_w: f64,
    },
    /// No balance below a [`MAX_RISE_K`] rise.
    #[error("no balance below a {MAX_RISE_K} K rise (friction power outgrows the heat removal)")]
    Runaway,
}

/// What the film gives at one viscosity: (friction power W, side flow m³/s).
pub type HeatFlow = (f64, f64);

/// Solves the balance for a lubricant supplied at `supply_c` (°C). `film(μ)` returns the
/// friction power and side flow of the bearing at dynamic viscosity `μ` (Pa·s), or why
/// not. Converges to `settings.tolerance` in `T_eff`.
pub fn solve_balance(
    lubricant: &Lubricant,
    supply_c: f64,
    settings: &ThermalSettings,
    mut film: impl FnMut(f64) -> Result<HeatFlow, String>,
) -> Result<Balance, ThermalError> {
    let k = settings.effective_factor;
    let h = settings.housing_conductance;
    let mut evaluations = 0u32;
    let mut eval = |t: f64| -> Result<(f64, HeatFlow), ThermalError> {
        evaluations += 1;
        let mu = lubricant.dynamic_viscosity(t);
        let (p, q) = film(mu).map_err(|reason| ThermalError::Film { celsius: t, reason })?;
        let removal = lubricant.heat_capacity_per_volume(t) * q / k + h;
        Ok((p - removal * (t - supply_c), (p, q)))
    };
    let (r0, pq0) = eval(supply_c)?;
    let finish = |t: f64, (p, q): HeatFlow, evaluations: u32| {
        let rise = (t - supply_c) / k;
        Balance {
            effective_temperature_c: t,
            temperature_rise_k: rise,
            viscosity_pa_s: lubricant.dynamic_viscosity(t),
            power_loss_w: p,
            side_flow_m3_s: q,
            heat_to_flow_w: lubricant.heat_capacity_per_volume(t) * q * rise,
            heat_to_housing_w: h * (t - supply_c),
            evaluations,
        }
    };
    if r0 <= 0.0 {
        // No friction power (a still journal): the film stays at the supply temperature.
        return Ok(finish(supply_c, pq0, 1));
    }
    if pq0.1 <= 0.0 && h <= 0.0 {
        return Err(ThermalError::NoHeatPath { power_w: pq0.0 });
    }
    // Bracket: the rise doubles from 1 K until the residual changes sign.
    let (mut a, mut fa, mut pqa) = (supply_c, r0, pq0);
    let mut step = 1.0;
    let (mut b, mut fb, mut pqb) = loop {
        let t = supply_c + step;
        let (r, pq) = eval(t)?;
        if r <= 0.0 {
            break (t, r, pq);
        }
        (a, fa, pqa) = (t, r, pq);
        step *= 2.0;
        if step > MAX_RISE_K {
            return Err(ThermalError::Runaway);
        }
    };
    // Brent's method on [a, b] with f(a) > 0 >= f(b); each point keeps its (P, Q) so
    // the reported power and flow are those at the returned T_eff.
    let tol = settings.tolerance;
    let (mut c, mut fc, mut pqc) = (a, fa, pqa);
    let mut d = b - a;
    let mut e = d;
    for _ in 0..MAX_ITERATIONS {
        if fb == 0.0 {
            break;
        }
        if (fb > 0.0) == (fc > 0.0) {
            (c, fc, pqc) = (a, fa, pqa);
            d = b - a;
            e = d;
        }
        if fc.abs() < fb.abs() {
            (a, fa, pqa) = (b, fb, pqb);
            (b, fb, pqb) = (c, fc, pqc);
            (c, fc, pqc) = (a, fa, pqa);
        }
        let tol1 = 2.0 * f64::EPSILON * b.abs() + 0.5 * tol;
        let xm = 0.5 * (c - b);
        if xm.abs() <= tol1 {
            break;
        }
        if e.abs() >= tol1 && fa.abs() > fb.abs() {
            // Inverse quadratic interpolation (secant when only two points differ).
            let s = fb / fa;
            let (mut p, mut q);
            if a == c {
                p = 2.0 * xm * s;
                q = 1.0 - s;
            } else {
                let qq = fa / fc;
                let r = fb / fc;
                p = s * (2.0 * xm * qq * (qq - r) - (b - a) * (r - 1.0));
                q = (qq - 1.0) * (r - 1.0) * (s - 1.0);
            }
            if p > 0.0 {
                q = -q;
            } else {
                p = -p;
            }
            // Accept the step only inside the bracket and shrinking fast enough.
            if 2.0 * p < (3.0 * xm * q - (tol1 * q).abs()).min((e * q).abs()) {
                e = d;
                d = p / q;
            } else {
                d = xm;
                e = d;
            }
        } else {
            d = xm;
            e = d;
        }
        (a, fa, pqa) = (b, fb, pqb);
        b += if d.abs() > tol1 { d } else { tol1.copysign(xm) };
        (fb, pqb) = eval(b)?;
    }
    Ok(finish(b, pqb, evaluations))
}

/// Largest excursion of a lumped oil temperature from its supply temperature, K, before
/// a rotor run is stopped (the same bound as the steady balance's [`MAX_RISE_K`]; the
/// density law `ρ(T)` and the Walther extrapolation mean nothing far beyond it).
pub const MAX_LUMPED_RISE_K: f64 = MAX_RISE_K;

/// Heat leaving a lumped oil temperature (rotor scenes, docs/thermal.md "Rotor scenes"):
/// with the effective film temperature `T = supply_c + theta` (°C) and the film's side
/// flow `q` (m³/s; a negative flow, oil drawn in at the ends by a squeeze, carries no
/// heat out and counts as 0), returns `(to_flow, to_housing)` in W:
/// `ρ c q ΔT` with the outlet rise `ΔT = theta / k`, and `H theta`. The state's rate is
/// `C dθ/dt = P − to_flow − to_housing`, whose rest point is the steady balance
/// [`solve_balance`] solves (`T = T_eff`).
pub fn lumped_heat_out(
    lubricant: &Lubricant,
    supply_c: f64,
    settings: &ThermalSettings,
    theta: f64,
    q: f64,
) -> (f64, f64) {
    let t = supply_c + theta;
    let to_flow =
        lubricant.heat_capacity_per_volume(t) * q.max(0.0) * theta / settings.effective_factor;
    (to_flow, settings.housing_conductance * theta)
}

/// The balance of one fixed state (`eval`): `loads` were computed with `params.viscosity`
/// = `μ(T_supply)`. At a fixed journal position every load, the friction torque and the
/// power scale with `μ` (the pressure and the shear are linear in `μ`; `f`, `S` and the
/// flow do not change), so the balance needs no further film solutions. Grooves with a
/// supply pressure break that linearity (the held pressure does not scale with `μ`, and
/// the flow it drives scales with `1/μ`): for those bearings (finite film) every balance
/// step solves the film at its trial `μ` (a cold finite solve), and the loads returned
/// are solved at `μ(T_eff)`. Returns the balance and the loads at `μ(T_eff)`; `None` for a
/// bearing without a lubricant.
pub fn state_balance(
    params: &BearingParams,
    state: &BearingState,
    loads: &Loads,
) -> Option<Result<(Balance, Loads), ThermalError>> {
    let (lub, supply) = (params.lubricant?, params.supply_temperature?);
    let mu_s = params.viscosity;
    if params.supply_rate() > 0.0 {
        let solve = |mu: f64| {
            let pm = BearingParams {
                viscosity: mu,
                ..*params
            };
            super::finite::finite_solution(&pm, state, &pm.finite, false)
                .map(|s| s.loads)
                .map_err(|e| e.to_string())
        };
        let bal = solve_balance(&lub, supply, &params.thermal, |mu| {
            solve(mu).map(|l| (l.film.power_loss_w, l.film.side_flow_m3_per_s))
        });
        return Some(bal.and_then(|b| {
            solve(b.viscosity_pa_s)
                .map(|l| (b, l))
                .map_err(|reason| ThermalError::Film {
                    celsius: b.effective_temperature_c,
                    reason,
                })
        }));
    }
    // Side flow of the film itself (short: closed form; finite: its converged field).
    let q = loads.film.side_flow_m3_per_s;
    let bal = solve_balance(&lub, supply, &params.thermal, |mu| {
        // The heat is the film's own friction power (Couette over 360° plus the pressure
        // term, issue 24 item 1), not the paper's friction law (1.91 × Petroff at S < 1).
        Ok((loads.film.power_loss_w * mu / mu_s, q))
    });
    Some(bal.map(|b| {
        let s = b.viscosity_pa_s / mu_s;
        let scaled = Loads {
            wx: loads.wx * s,
            wy: loads.wy * s,
            mx: loads.mx * s,
            my: loads.my * s,
            mz: loads.mz * s,
            power_loss: loads.power_loss * s,
            film: super::film_flow::FilmFlow {
                friction_torque_nm: loads.film.friction_torque_nm * s,
                power_loss_w: loads.film.power_loss_w * s,
                ..loads.film
            },
            ..*loads
        };
        (b, scaled)
    }))
}

/// What heats the film in every balance (steady and lumped), as outputs name it: the
/// film's own friction power, not the paper's Sommerfeld-number law (eqs. 10-11), which
/// stays the loads' `power_loss` with `friction_model: "paper"`.
pub const HEAT_SOURCE: &str =
    "the film's own friction power (film.power_loss_w: shear stress over the film), not the paper's law";

/// The balance of one state as written in outputs (`eval`, friction maps).
pub fn balance_json(b: &Balance, bearing: &BearingParams) -> serde_json::Value {
    serde_json::json!({
        "lubricant": bearing.lubricant.map(|l| l.name()),
        "supply_temperature_c": bearing.supply_temperature,
        "effective_temperature_c": b.effective_temperature_c,
        "temperature_rise_k": b.temperature_rise_k,
        "effective_viscosity_pa_s": b.viscosity_pa_s,
        "power_loss_w": b.power_loss_w,
        "heat_source": HEAT_SOURCE,
        "side_flow_m3_s": b.side_flow_m3_s,
        "heat_to_flow_w": b.heat_to_flow_w,
        "heat_to_housing_w": b.heat_to_housing_w,
        "effective_factor": bearing.thermal.effective_factor,
        "tolerance_k": bearing.thermal.tolerance,
        "evaluations": b.evaluations,
        "side_flow_model": "the film's own side flow at both ends (film.side_flow_m3_per_s)",
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Petroff power `2π μ ω² r³ B / δ` and the short film's side flow `ω r δ B ε` of the
    /// paper's Table 2 bearing at eccentricity ratio `eps` (a film whose position is held).
    fn petroff(
        omega: f64,
        eps: f64,
        flow_scale: f64,
    ) -> impl FnMut(f64) -> Result<HeatFlow, String> {
        let (r, b, d): (f64, f64, f64) = (0.02, 0.02, 3e-4);
        move |mu| {
            Ok((
                2.0 * std::f64::consts::PI * mu * omega * omega * r.powi(3) * b / d,
                flow_scale * omega * r * d * b * eps,
            ))
        }
    }

    #[test]
    fn the_balance_closes_to_its_tolerance() {
        let lub = Lubricant::iso_vg(46).unwrap();
        for (omega, h) in [(100.0, 0.0), (1000.0, 0.0), (3000.0, 0.5), (300.0, 2.0)] {
            let s = ThermalSettings {
                housing_conductance: h,
                ..Default::default()
            };
            let bal = solve_balance(&lub, 40.0, &s, petroff(omega, 0.5, 1.0)).unwrap();
            let out = bal.heat_to_flow_w + bal.heat_to_housing_w;
            // |r(T)| <= |dr/dT| tol: dr/dT is bounded by the removal slope plus |dP/dT|
            // (P ∝ μ, |dμ/dT| < 0.1 μ per K for these oils).
            let slope = lub.heat_capacity_per_volume(bal.effective_temperature_c)
                * bal.side_flow_m3_s
                / s.effective_factor
                + h
                + 0.1 * bal.power_loss_w;
            let bound = slope * s.tolerance;
            assert!(
                (bal.power_loss_w - out).abs() <= bound,
                "ω {omega}, H {h}: heat in {} W, out {out} W, tolerance {bound} W",
                bal.power_loss_w
            );
            assert!(bal.evaluations < 40, "{bal:?}");
            // A tighter tolerance moves T_eff by less than the looser one's.
            let tight = ThermalSettings {
                tolerance: 1e-11,
                ..s
            };
            let b2 = solve_balance(&lub, 40.0, &tight, petroff(omega, 0.5, 1.0)).unwrap();
            let dt = (b2.effective_temperature_c - bal.effective_temperature_c).abs();
            assert!(
                dt <= s.tolerance,
                "T_eff moved {dt} K, tolerance {}",
                s.tolerance
            );
        }
    }

    #[test]
    fn the_rise_grows_with_speed_and_falls_with_flow() {
        let lub = Lubricant::iso_vg(32).unwrap();
        let s = ThermalSettings::default();
        let rise = |omega: f64, flow: f64| {
            solve_balance(&lub, 40.0, &s, petroff(omega, 0.5, flow))
                .unwrap()
                .temperature_rise_k
        };
        let speeds = [50.0, 100.0, 300.0, 1000.0, 3000.0];
        let by_speed: Vec<f64> = speeds.iter().map(|&w| rise(w, 1.0)).collect();
        for k in 1..speeds.len() {
            assert!(
                by_speed[k] > by_speed[k - 1],
                "index {k}: rise {} K at {} rad/s not above {} K at {} rad/s",
                by_speed[k],
                speeds[k],
                by_speed[k - 1],
                speeds[k - 1]
            );
        }
        let flows = [0.5, 1.0, 2.0, 4.0];
        let by_flow: Vec<f64> = flows.iter().map(|&f| rise(1000.0, f)).collect();
        for k in 1..flows.len() {
            assert!(
                by_flow[k] < by_flow[k - 1],
                "index {k}: rise {} K at flow x{} not below {} K at x{}",
                by_flow[k],
                flows[k],
                by_flow[k - 1],
                flows[k - 1]
            );
        }
    }

    #[test]
    fn no_power_no_rise_and_no_heat_path_is_an_error() {
        let lub = Lubricant::iso_vg(46).unwrap();
        let s = ThermalSettings::default();
        let b = solve_balance(&lub, 50.0, &s, |_| Ok((0.0, 0.0))).unwrap();
        assert_eq!(b.effective_temperature_c, 50.0);
        let e = solve_balance(&lub, 50.0, &s, |_| Ok((1.0, 0.0))).unwrap_err();
        assert!(matches!(e, ThermalError::NoHeatPath { .. }), "{e}");
        let e = solve_balance(&lub, 50.0, &s, |_| Err("through the wall".into())).unwrap_err();
        assert!(e.to_string().contains("through the wall"), "{e}");
        // Constant power with a tiny housing path: a rise past 1000 K is refused.
        let hot = ThermalSettings {
            housing_conductance: 1e-6,
            ..s
        };
        let e = solve_balance(&lub, 50.0, &hot, |_| Ok((10.0, 0.0))).unwrap_err();
        assert_eq!(e, ThermalError::Runaway);
    }
}
