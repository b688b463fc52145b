//! `bearing-sweep stability SCENE`: modes at the scene's speed, threshold speed, and a
//! Campbell diagram with the damping ratios over a speed list (JSON and SVG).

use std::path::{Path, PathBuf};

use serde_json::{json, Value};

use super::AppError;
use crate::backend::{create_backend, BackendKind};
use crate::rotor::{load_scene, ModelKind};
use crate::stability::{
    analyse_points, campbell_svg, damping_svg, geometric_grid, thresholds, RotorDescription,
    SpeedAnalysis,
};

/// Options of `stability` beyond the scene file.
#[derive(Clone, Debug, PartialEq)]
pub struct StabilityOptions {
    /// Backend for the film loads.
    pub backend: BackendKind,
    /// Relative accuracy of the film loads (default 1e-12: the coefficients are
    /// differences of loads).
    pub accuracy: f64,
    /// Speeds of the Campbell diagram and the threshold scan, rad/s; empty: 41 speeds
    /// from 0.1× to 10× the scene's spin (geometric).
    pub speeds: Vec<f64>,
    /// Output root; files go to `out/<file stem>/` (`None`: no files).
    pub out: Option<PathBuf>,
}

/// Grid points of the default speed list.
pub const DEFAULT_SPEEDS: usize = 41;

fn write(path: &Path, text: &str) -> Result<(), AppError> {
    std::fs::write(path, text).map_err(|source| AppError::Io {
        path: path.display().to_string(),
        source,
    })
}

fn campbell_entry(a: &SpeedAnalysis, rotor: &RotorDescription) -> Value {
    let mut entry = json!({
        "speed_rad_s": a.speed_rad_s,
        "eccentricity_ratios": a.linear.bearings.iter().map(|b| b.eccentricity_ratio).collect::<Vec<_>>(),
        "modes": a.modes.iter().map(|m| json!({
            "sigma_1_s": m.sigma_1_s, "frequency_rad_s": m.frequency_rad_s,
            "whirl_ratio": m.whirl_ratio, "damping_ratio": m.damping_ratio, "log_dec": m.log_dec,
            "direction": m.direction,
        })).collect::<Vec<_>>(),
    });
    if let Some(t) = thermal_json(a, rotor) {
        entry["thermal"] = t;
    }
    entry
}

/// Per bearing, the effective-temperature balance the analysis at `a` was linearised at
/// (`null` for a bearing without a lubricant); `None` when no bearing has one (the
/// output then stays as without temperature).
fn thermal_json(a: &SpeedAnalysis, rotor: &RotorDescription) -> Option<Value> {
    let bearings = &a.linear.bearings;
    bearings.iter().any(|b| b.thermal.is_some()).then(|| {
        json!(bearings
            .iter()
            .zip(&rotor.bearings)
            .map(|(b, (p, _))| b
                .thermal
                .map(|t| crate::bearing::thermal::balance_json(&t, p)))
            .collect::<Vec<_>>())
    })
}

/// Runs `stability` on the scene file at `path` (text `text`): the output document, the
/// files written and notices.
pub fn stability_scene_file(
    path: &str,
    text: &str,
    opts: &StabilityOptions,
) -> Result<(Value, Vec<PathBuf>, Vec<String>), AppError> {
    let scenes = load_scene(text).map_err(|e| AppError::input(e.path, e.reason))?;
    let scenes: Vec<_> = scenes
        .into_iter()
        .filter(|s| s.model == ModelKind::Bearing)
        .collect();
    if scenes.is_empty() {
        return Err(AppError::input(
            "model",
            "no scene with the film model (\"bearing\") to linearise",
        ));
    }
    for (k, w) in opts.speeds.iter().enumerate() {
        if !(w.is_finite() && *w > 0.0) {
            return Err(AppError::input(
                format!("--speeds[{k}]"),
                format!("{w}: must be a positive speed (rad/s)"),
            ));
        }
    }
    let accuracy = super::accuracy(opts.accuracy)?;
    let (backend, notice) = create_backend(opts.backend, accuracy)?;
    let mut notices: Vec<String> = notice.into_iter().collect();
    let (mut ev, swap) = crate::stability::difference_evaluator(backend, accuracy);
    notices.extend(swap);
    let stem = Path::new(path)
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into());
    let dir = opts.out.as_ref().map(|o| o.join(&stem));
    if let Some(d) = &dir {
        std::fs::create_dir_all(d).map_err(|source| AppError::Io {
            path: d.display().to_string(),
            source,
        })?;
    }
    let mut files = Vec::new();
    let mut results = Vec::new();
    for (si, scene) in scenes.iter().enumerate() {
        let rotor = RotorDescription::from_scene(scene)
            .map_err(|e| AppError::input(format!("scenes[{si}]"), e.to_string()))?;
        let spin = scene.initial.spin.abs();
        if spin == 0.0 {
            return Err(AppError::input(
                "initial.spin",
                "0: the film carries no load without spin; nothing to linearise",
            ));
        }
        let mut speeds = if opts.speeds.is_empty() {
            geometric_grid(0.1 * spin, 10.0 * spin, DEFAULT_SPEEDS)
        } else {
            opts.speeds.clone()
        };
        speeds.sort_by(f64::total_cmp);
        speeds.dedup();
        let here = analyse_points(&mut ev, &[(&rotor, scene.initial.spin)])
            .remove(0)
            .map_err(|e| {
                AppError::input(
                    "initial.spin",
                    format!("at {} rad/s: {e}", scene.initial.spin),
                )
            })?;
        let threshold = thresholds(&mut ev, &[&rotor], std::slice::from_ref(&speeds)).remove(0);
        let pts: Vec<(&RotorDescription, f64)> = speeds.iter().map(|&w| (&rotor, w)).collect();
        let runs = analyse_points(&mut ev, &pts);
        let mut campbell = Vec::new();
        let mut ok_runs = Vec::new();
        for (w, r) in speeds.iter().zip(runs) {
            match r {
                Ok(a) => {
                    campbell.push(campbell_entry(&a, &rotor));
                    ok_runs.push(a);
                }
                Err(e) => campbell.push(json!({"speed_rad_s": w, "error": e.to_string()})),
            }
        }
        let lin = &here.linear;
        let mut doc = json!({
            "scene": scene.name,
            "speed_rad_s": scene.initial.spin,
            "frame": lin.frame,
            "modes": here.modes,
            "least_damped": here.modes.first(),
            "stable": here.max_growth() < 0.0,
            "threshold_speed_rad_s": threshold.speed_rad_s,
            "threshold": threshold,
            "equilibrium": {
                "q": lin.equilibrium,
                "order": ["s_x (m)", "s_y (m)", "tilt_x (rad)", "tilt_y (rad)"],
                "newton_iterations": lin.newton_iterations,
                "bearings": lin.bearings.iter().map(|b| json!({
                    "state": b.state,
                    "eccentricity_ratio": b.eccentricity_ratio,
                    "loads": b.coefficients.loads,
                    "stiffness": b.coefficients.stiffness,
                    "damping": b.coefficients.damping,
                    "stiffness_error": b.coefficients.stiffness_error,
                    "damping_error": b.coefficients.damping_error,
                })).collect::<Vec<_>>(),
            },
            "matrices": {"mass": lin.mass, "damping": lin.damping, "stiffness": lin.stiffness,
                          "equation": "M q'' + D q' + K q = 0, q = (s_x, s_y, tilt_x, tilt_y); D holds the film damping and the gyroscopic (and, rotating frame, Coriolis) terms"},
            "notes": rotor.notes,
            "campbell": campbell,
        });
        // With lubricants: each bearing's balance at the scene's speed (the campbell
        // entries carry theirs), beside its coefficients.
        if let Some(t) = thermal_json(&here, &rotor) {
            doc["equilibrium"]["thermal"] = t;
            doc["thermal_note"] = json!("each speed's equilibrium is solved together with every lubricated bearing's effective-temperature balance (docs/thermal.md); coefficients, modes and the threshold search are at the bearings' mu(T_eff)");
        }
        if let Some(d) = &dir {
            let suffix = if scenes.len() > 1 {
                format!("-{}", scene.name)
            } else {
                String::new()
            };
            if !ok_runs.is_empty() {
                for (name, svg) in [
                    (
                        format!("campbell{suffix}.svg"),
                        campbell_svg(
                            &format!("Campbell diagram: {}", scene.name),
                            &ok_runs,
                            threshold.speed_rad_s,
                            Some(spin),
                        ),
                    ),
                    (
                        format!("damping{suffix}.svg"),
                        damping_svg(
                            &format!("Logarithmic decrement vs speed: {}", scene.name),
                            &ok_runs,
                            Some(spin),
                        ),
                    ),
                ] {
                    match svg {
                        Ok(s) => {
                            let p = d.join(name);
                            write(&p, &s)?;
                            files.push(p);
                        }
                        Err(e) => notices.push(format!("notice: no figure {name}: {e}")),
                    }
                }
            }
        }
        results.push(doc);
    }
    notices.extend(ev.take_notices());
    let out = if results.len() == 1 {
        results.remove(0)
    } else {
        json!({"scenes": results})
    };
    if let Some(d) = &dir {
        let p = d.join("stability.json");
        write(&p, &serde_json::to_string_pretty(&out).unwrap_or_default())?;
        files.push(p);
    }
    Ok((out, files, notices))
}
