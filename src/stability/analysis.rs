//! Stability of rotors over speed: modes at given speeds, and the threshold speed (the
//! lowest speed where the least-damped growth rate crosses zero) by a scan over a speed
//! grid and regula falsi (Illinois), every step in lockstep over all rotors (one evaluator call per
//! Newton iteration for all of them).

use serde::Serialize;

use super::linear::{linearise_batch, LinearRotor, RotorDescription};
use super::modes::{max_growth, modes, Mode};
use super::thermal::{is_thermal, thermal_rotor};
use super::StabilityError;
use crate::backend::LoadEvaluator;
use crate::bearing::Balance;

/// The linear model and its modes at one speed.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SpeedAnalysis {
    /// Spin, rad/s.
    pub speed_rad_s: f64,
    /// Modes, least damped first.
    pub modes: Vec<Mode>,
    /// The linearisation (equilibrium, bearing coefficients, `M`, `D`, `K`).
    pub linear: LinearRotor,
}

impl SpeedAnalysis {
    /// Largest growth rate, 1/s.
    pub fn max_growth(&self) -> f64 {
        max_growth(&self.modes)
    }
}

/// Linearises and solves every `(rotor, speed)` point. A rotor whose bearings have a
/// lubricant and a supply temperature is linearised at each such bearing's `μ(T_eff)`,
/// the balance solved together with the equilibrium at that speed (`thermal_rotor`;
/// each bearing's `thermal` holds it); other rotors are linearised as given.
pub fn analyse_points(
    evaluator: &mut LoadEvaluator,
    points: &[(&RotorDescription, f64)],
) -> Vec<Result<SpeedAnalysis, StabilityError>> {
    // The thermal rotors first (each its own sequence of equilibria), then every point's
    // linearisation in one lockstep batch as without temperature.
    type Heated = Result<(RotorDescription, Vec<Option<Balance>>), StabilityError>;
    let heated: Vec<Option<Heated>> = points
        .iter()
        .map(|(r, w)| is_thermal(r).then(|| thermal_rotor(evaluator, r, *w)))
        .collect();
    let mut batch: Vec<(&RotorDescription, f64)> = Vec::with_capacity(points.len());
    for ((r, w), h) in points.iter().zip(&heated) {
        match h {
            None => batch.push((*r, *w)),
            Some(Ok((hot, _))) => batch.push((hot, *w)),
            Some(Err(_)) => {}
        }
    }
    let mut lins = linearise_batch(evaluator, &batch).into_iter();
    points
        .iter()
        .zip(heated)
        .map(|((rotor, speed), h)| {
            let balances = match h {
                Some(Err(e)) => return Err(e),
                Some(Ok((_, b))) => b,
                None => Vec::new(),
            };
            let mut lin = lins.next().expect("one linearisation per point")?;
            for (bp, bal) in lin.bearings.iter_mut().zip(balances) {
                bp.thermal = bal;
            }
            let axial: Vec<(f64, f64)> =
                rotor.bearings.iter().map(|(p, a)| (*a, p.length)).collect();
            Ok(SpeedAnalysis {
                speed_rad_s: *speed,
                modes: modes(&lin, &axial),
                linear: lin,
            })
        })
        .collect()
}

/// Threshold speed of one rotor.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Threshold {
    /// The lowest grid-bracketed speed where the largest growth rate turns from negative
    /// to non-negative, rad/s (`null`: no crossing on the grid, see `note`).
    pub speed_rad_s: Option<f64>,
    /// Whirl ratio of the mode that goes unstable there.
    pub whirl_ratio: Option<f64>,
    /// Its whirl frequency, rad/s.
    pub frequency_rad_s: Option<f64>,
    /// Bracket `[stable, unstable]` after the search, rad/s.
    pub bracket_rad_s: Option<[f64; 2]>,
    /// Bracketing steps after the scan (Illinois regula falsi).
    pub iterations: u32,
    /// Largest growth rate at each grid speed, 1/s (`null` where the analysis failed).
    pub grid_growth_1_s: Vec<Option<f64>>,
    /// Grid speeds, rad/s.
    pub grid_rad_s: Vec<f64>,
    /// What the result means when there is no threshold.
    pub note: String,
    /// Every speed whose analysis failed (scan and bracketing), in the order met, with
    /// the reason (issue 20: no failed point is dropped silently).
    pub failed: Vec<FailedSpeed>,
}

/// A speed of a threshold search whose analysis failed.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FailedSpeed {
    /// The speed, rad/s.
    pub speed_rad_s: f64,
    /// Why (the analysis error).
    pub reason: String,
}

/// Failed analyses during the bracketing of one rotor before the search stops and
/// reports the bracket it has.
const MAX_SEARCH_FAILURES: u32 = 3;

/// Relative width of the final bracket.
pub const THRESHOLD_RTOL: f64 = 1e-7;
/// Bracketing steps at most.
const MAX_BISECTIONS: u32 = 60;

/// Geometric speed grid of `n` points from `lo` to `hi`, rad/s.
pub fn geometric_grid(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    if n <= 1 {
        return vec![lo];
    }
    (0..n)
        .map(|k| lo * (hi / lo).powf(k as f64 / (n - 1) as f64))
        .collect()
}

/// Threshold speeds of several rotors, each with its own ascending speed grid.
pub fn thresholds(
    evaluator: &mut LoadEvaluator,
    rotors: &[&RotorDescription],
    grids: &[Vec<f64>],
) -> Vec<Threshold> {
    let mut points = Vec::new();
    for (r, g) in rotors.iter().zip(grids) {
        for &w in g {
            points.push((*r, w));
        }
    }
    let scan = analyse_points(evaluator, &points);
    let mut cursor = 0;
    let mut out = Vec::with_capacity(rotors.len());
    let mut brackets: Vec<Option<(f64, f64)>> = Vec::with_capacity(rotors.len());
    for g in grids {
        let growth: Vec<Option<f64>> = scan[cursor..cursor + g.len()]
            .iter()
            .map(|r| r.as_ref().ok().map(SpeedAnalysis::max_growth))
            .collect();
        cursor += g.len();
        let failed: Vec<FailedSpeed> = scan[cursor - g.len()..cursor]
            .iter()
            .zip(g)
            .filter_map(|(r, &w)| {
                r.as_ref().err().map(|e| FailedSpeed {
                    speed_rad_s: w,
                    reason: e.to_string(),
                })
            })
            .collect();
        let mut bracket = None;
        let mut note = String::new();
        // Consecutive analysed speeds (failed ones skipped): a sign change between them
        // brackets a threshold even across a failed speed.
        let ok: Vec<(f64, f64)> = g
            .iter()
            .zip(&growth)
            .filter_map(|(&w, s)| s.map(|s| (w, s)))
            .collect();
        for pair in ok.windows(2) {
            if pair[0].1 < 0.0 && pair[1].1 >= 0.0 {
                bracket = Some((pair[0].0, pair[1].0));
                break;
            }
        }
        if bracket.is_none() {
            note = match (growth.first().copied().flatten(), growth.iter().flatten().all(|&s| s < 0.0)) {
                (_, true) if !growth.is_empty() && growth.iter().all(Option::is_some) => format!(
                    "stable at every grid speed up to {} rad/s",
                    g.last().copied().unwrap_or(f64::NAN)
                ),
                (Some(s), _) if s >= 0.0 => format!(
                    "unstable already at the lowest grid speed {} rad/s (a lightly loaded journal whirls at any speed)",
                    g[0]
                ),
                _ => "no stable-to-unstable crossing on the grid (some speeds failed: see grid_growth_1_s)".into(),
            };
        }
        brackets.push(bracket);
        out.push(Threshold {
            speed_rad_s: None,
            whirl_ratio: None,
            frequency_rad_s: None,
            bracket_rad_s: bracket.map(|(a, b)| [a, b]),
            iterations: 0,
            grid_growth_1_s: growth,
            grid_rad_s: g.clone(),
            note,
            failed,
        });
    }
    // Bracketing in lockstep: the Illinois variant of regula falsi on the largest growth
    // rate (smooth near the crossing: one mode crosses), which keeps the bracket and
    // converges superlinearly (about 6-8 steps to 1e-7 instead of bisection's 22). The
    // crossing mode is the least-damped one at the unstable end.
    let mut last_unstable: Vec<Option<Mode>> = vec![None; rotors.len()];
    // (g_lo, g_hi, side last moved: -1 lo, +1 hi, 0 none)
    let mut gvals: Vec<(f64, f64, i8)> = vec![(0.0, 0.0, 0); rotors.len()];
    // Failed analyses in the bracketing, and the last failed speed (the next try avoids it).
    let mut search_failures = vec![0u32; rotors.len()];
    let mut avoid: Vec<Option<f64>> = vec![None; rotors.len()];
    let mut stopped: Vec<Option<(f64, f64)>> = vec![None; rotors.len()];
    let mut offset = 0;
    for (k, b) in brackets.iter().enumerate() {
        if let Some((lo, hi)) = b {
            let i_lo = grids[k].iter().position(|w| w == lo).unwrap_or(0);
            let i_hi = grids[k].iter().position(|w| w == hi).unwrap_or(0);
            gvals[k] = (
                out[k].grid_growth_1_s[i_lo].unwrap_or(-1.0),
                out[k].grid_growth_1_s[i_hi].unwrap_or(1.0),
                0,
            );
            if let Ok(a) = &scan[offset + i_hi] {
                last_unstable[k] = top_mode(&a.modes);
            }
        }
        offset += grids[k].len();
    }
    for _ in 0..MAX_BISECTIONS {
        let active: Vec<usize> = (0..rotors.len())
            .filter(|&k| matches!(brackets[k], Some((lo, hi)) if hi - lo > THRESHOLD_RTOL * hi))
            .collect();
        if active.is_empty() {
            break;
        }
        let pts: Vec<(&RotorDescription, f64)> = active
            .iter()
            .map(|&k| {
                let (lo, hi) = brackets[k].expect("active");
                let (glo, ghi, _) = gvals[k];
                let x = (lo * ghi - hi * glo) / (ghi - glo);
                // Safeguard: strictly inside, not closer than 1e-3 of the width... unless
                // the bracket is already tiny (then the midpoint).
                let w = hi - lo;
                let x = if x.is_finite() {
                    x.clamp(lo + 1e-3 * w, hi - 1e-3 * w)
                } else {
                    0.5 * (lo + hi)
                };
                // After a failure: the middle of the larger side of the failed speed.
                let x = match avoid[k] {
                    Some(f) if f - lo > hi - f => 0.5 * (lo + f),
                    Some(f) => 0.5 * (f + hi),
                    None => x,
                };
                (rotors[k], x)
            })
            .collect();
        let res = analyse_points(evaluator, &pts);
        for ((&k, (_, mid)), r) in active.iter().zip(&pts).zip(res) {
            let (lo, hi) = brackets[k].expect("active");
            let (glo, ghi, side) = gvals[k];
            out[k].iterations += 1;
            match r {
                Ok(a) if a.max_growth() >= 0.0 => {
                    avoid[k] = None;
                    brackets[k] = Some((lo, *mid));
                    // Illinois: the same end moved twice in a row halves the other's value.
                    let glo = if side == 1 { 0.5 * glo } else { glo };
                    gvals[k] = (glo, a.max_growth(), 1);
                    last_unstable[k] = top_mode(&a.modes);
                }
                Ok(a) => {
                    avoid[k] = None;
                    brackets[k] = Some((*mid, hi));
                    let ghi = if side == -1 { 0.5 * ghi } else { ghi };
                    gvals[k] = (a.max_growth(), ghi, -1);
                }
                Err(e) => {
                    out[k].failed.push(FailedSpeed {
                        speed_rad_s: *mid,
                        reason: e.to_string(),
                    });
                    search_failures[k] += 1;
                    avoid[k] = Some(*mid);
                    if search_failures[k] >= MAX_SEARCH_FAILURES {
                        // Report the bracket reached: the threshold lies inside it.
                        out[k].note = format!(
                            "threshold search stopped after {} failed speeds (see failed); the \
                             threshold lies in bracket_rad_s, reported at its middle",
                            search_failures[k]
                        );
                        stopped[k] = Some((lo, hi));
                        brackets[k] = None;
                    }
                }
            }
        }
    }
    for (k, t) in out.iter_mut().enumerate() {
        if let Some((lo, hi)) = brackets[k].or(stopped[k]) {
            t.speed_rad_s = Some(0.5 * (lo + hi));
            t.bracket_rad_s = Some([lo, hi]);
            if let Some(m) = &last_unstable[k] {
                t.whirl_ratio = Some(m.frequency_rad_s / hi);
                t.frequency_rad_s = Some(m.frequency_rad_s);
            }
        }
    }
    out
}

/// The mode with the largest growth rate.
fn top_mode(modes: &[Mode]) -> Option<Mode> {
    modes
        .iter()
        .max_by(|a, b| a.sigma_1_s.total_cmp(&b.sigma_1_s))
        .cloned()
}
