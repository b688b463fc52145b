//! `bearing-sweep run FILE`: simulate a scene file, write `OUT/<name>/result.json` and
//! the paper's figures (Figs. 7-10) as SVG.

use std::path::{Path, PathBuf};

use std::io::Write;

use super::AppError;
use crate::backend::{choose_backend_for_film, LoadEvaluator};
use crate::plot::Scale;
use crate::rotor::simplifications::{evaluator_options, evaluator_report, SimplificationSpec};
use crate::rotor::{
    load_scene_within, sample_cap, simulate_batch_capped, ModelKind, Scene, SimResult,
};
use crate::sweep::SweepOptions;

/// Options of `run` beyond the scene file: where results go, and what the scenes compute
/// with (the same [`SweepOptions`] a sweep takes, so no field is declared twice).
#[derive(Clone, Debug, PartialEq)]
pub struct SceneRunOptions {
    /// Output root; results go to `out/<file stem>/`.
    pub out: PathBuf,
    /// Backend, film accuracy, full model and memory budget (`--backend`, `--accuracy`,
    /// `--full-model`, `--max-memory`; the budget checks and caps the scenes' samples);
    /// default [`SweepOptions::default`].
    pub options: SweepOptions,
}

/// What `run` wrote, for the terminal.
#[derive(Debug)]
pub struct RunReport {
    /// Output folder.
    pub dir: PathBuf,
    /// Files written.
    pub files: Vec<PathBuf>,
    /// One line per simulation (name, status, steps).
    pub lines: Vec<String>,
    /// Backend notices.
    pub notices: Vec<String>,
}

fn write(path: &Path, text: &str) -> Result<(), AppError> {
    std::fs::write(path, text).map_err(|source| AppError::Io {
        path: path.display().to_string(),
        source,
    })
}

/// The result document of a scene run.
#[derive(serde::Serialize)]
struct RunDoc<'a> {
    backend: crate::backend::BackendInfo,
    backend_choice: Option<crate::backend::BackendChoice>,
    clearance_convention: Vec<&'static str>,
    film_accuracy: f64,
    model_reductions: crate::rotor::simplifications::SimplificationReport,
    name: &'a str,
    results: &'a [SimResult],
    units: &'static str,
}

/// Runs the scene file at `path` (its text `text`).
pub fn run_scene_file(
    path: &str,
    text: &str,
    opts: &SceneRunOptions,
) -> Result<RunReport, AppError> {
    let mut scenes = load_scene_within(text, opts.options.max_memory)
        .map_err(|e| AppError::input(e.path, e.reason))?;
    let accuracy = opts.options.accuracy.level();
    // Every scene's samples are kept for result.json and the figures, decimated to the
    // cap that the budget leaves each (docs/cli.md "Limits"): only what cannot fit even at the
    // floor cap is refused.
    let total: f64 = scenes
        .iter()
        .map(|s| s.sample_memory_bytes(crate::budget::MIN_SAMPLE_CAP))
        .sum();
    opts.options
        .max_memory
        .check(
            &format!(
                "keeping at least {} samples of each of {} simulations",
                crate::budget::MIN_SAMPLE_CAP,
                scenes.len()
            ),
            total,
        )
        .map_err(|r| AppError::input("scenes", r))?;
    // Every integration stage carries one state per bearing of every scene.
    let states_per_call = scenes.iter().map(|s| s.bearings.len()).sum();
    let finite = scenes
        .iter()
        .flat_map(|s| &s.bearings)
        .any(|b| b.model != crate::bearing::FilmModel::Short);
    let (backend, mut notices) = choose_backend_for_film(
        opts.options.backend,
        accuracy,
        Some(states_per_call),
        finite,
    )?;
    if opts.options.full_model {
        for s in &mut scenes {
            s.reductions = SimplificationSpec::full();
        }
    }
    let eval_options = evaluator_options(scenes.iter().map(|s| &s.reductions));
    let mut evaluator = LoadEvaluator::with_options(backend, eval_options);
    let mut lines = Vec::new();
    // Every scene is in flight at once: they share the budget.
    let cap = sample_cap(&scenes, opts.options.max_memory);
    let results = simulate_batch_capped(
        &scenes,
        &mut evaluator,
        &mut |_, r: &SimResult| {
            lines.push(format!(
                "{}: {} ({} model, {}; {} steps, {} rejected, {} film-load evaluations, {:.3} s)",
                r.name,
                r.status,
                match r.model {
                    ModelKind::Bearing => "bearing",
                    ModelKind::Ideal => "ideal-joint",
                },
                r.method.name(),
                r.stats.steps,
                r.stats.rejected,
                r.stats.load_evaluations,
                r.stats.wall_time_s
            ));
        },
        cap,
        opts.options.max_memory,
    );
    notices.extend(evaluator.take_notices());
    let stem = Path::new(path)
        .file_stem()
        .and_then(|s| s.to_str())
        .filter(|s| !s.is_empty() && *s != "-")
        .unwrap_or("run");
    let dir = opts.out.join(stem);
    std::fs::create_dir_all(&dir).map_err(|source| AppError::Io {
        path: dir.display().to_string(),
        source,
    })?;
    // Serialised straight from the results into the file: no JSON copy of every sample
    // in memory (BENCHMARKS.md "Limits and memory"). Top-level keys in sorted order.
    let doc = RunDoc {
        backend: evaluator.info(),
        backend_choice: evaluator.choice(),
        clearance_convention: scenes
            .iter()
            .flat_map(|s| s.bearings.iter().map(|b| b.clearance_convention.name()))
            .collect(),
        film_accuracy: accuracy.rtol(),
        model_reductions: evaluator_report(
            &eval_options,
            &evaluator.stats(),
            evaluator.info().name == "gpu",
            opts.options.full_model,
        ),
        name: stem,
        results: &results,
        units: "SI (s, m, m/s, rad/s, N, N·m, J)",
    };
    let mut files = Vec::new();
    let result_path = dir.join("result.json");
    let io = |source| AppError::Io {
        path: result_path.display().to_string(),
        source,
    };
    let mut w = std::io::BufWriter::new(std::fs::File::create(&result_path).map_err(io)?);
    serde_json::to_writer(&mut w, &doc).map_err(|e| io(e.into()))?;
    w.flush().map_err(io)?;
    drop(w);
    files.push(result_path);
    for (name, svg) in figures(&results, &scenes) {
        let p = dir.join(name);
        write(&p, &svg)?;
        files.push(p);
    }
    Ok(RunReport {
        dir,
        files,
        lines,
        notices,
    })
}

/// The paper's Figs. 7-10 for any set of results: G's trajectory, x_G(t), y_G(t) (every
/// result) and bearing 1's journal-centre orbit at its first end face inside its clearance
/// circle (bearing model; `scenes[k]` is result `k`'s scene). Displacements in µm.
pub fn figures(results: &[SimResult], scenes: &[Scene]) -> Vec<(String, String)> {
    use crate::plot::{Curve, Guide};
    let label = |r: &SimResult| match r.model {
        ModelKind::Bearing => format!("{} (journal bearings)", r.name),
        ModelKind::Ideal => format!("{} (ideal revolute joints)", r.name),
    };
    /// Metres to micrometres.
    const UM: f64 = 1e6;
    let zip = |a: &[f64], b: &[f64], sa: f64, sb: f64| {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x * sa, y * sb))
            .collect::<Vec<_>>()
    };
    let figure = |title: &str,
                  x: &str,
                  y: &str,
                  equal: bool,
                  only_bearing: bool,
                  f: &dyn Fn(&SimResult) -> Vec<(f64, f64)>| {
        let mut fig = crate::plot::simple(title, x, y, &[], Scale::Linear, Scale::Linear, equal);
        for (k, r) in results.iter().enumerate() {
            if only_bearing && r.model != ModelKind::Bearing {
                continue;
            }
            let pts = f(r);
            if pts.is_empty() {
                continue;
            }
            let mut c = Curve::line(label(r), pts, k);
            c.width = 1.5;
            fig.curves.push(c);
        }
        // One curve needs no legend (the title names the quantity).
        if fig.curves.len() == 1 {
            fig.curves[0].legend = false;
        }
        fig
    };
    let mut out = Vec::new();
    let mut orbit = figure(
        "Fig. 10: bearing 1, journal centre at its first end face",
        "x_i (µm)",
        "y_i (µm)",
        true,
        true,
        &|r| {
            r.samples
                .bearings
                .first()
                .map(|b| zip(&b.xi, &b.yi, UM, UM))
                .unwrap_or_default()
        },
    );
    // The clearance circle of bearing 1 (the first bearing-model scene's).
    if let Some(c) = results
        .iter()
        .zip(scenes)
        .find(|(r, _)| r.model == ModelKind::Bearing)
        .and_then(|(_, s)| s.bearings.first())
        .map(|b| b.params().clearance)
    {
        orbit.guides.push(Guide::Circle {
            centre: (0.0, 0.0),
            radius: c * UM,
            label: format!("clearance circle, {} µm", crate::plot::tick_label(c * UM)),
        });
    }
    let plots: [(&str, Result<String, String>); 4] = [
        (
            "fig7-g-trajectory.svg",
            figure(
                "Fig. 7: trajectory of the centre of mass G",
                "x_G (µm)",
                "y_G (µm)",
                true,
                false,
                &|r| zip(&r.samples.x_g, &r.samples.y_g, UM, UM),
            )
            .svg(),
        ),
        (
            "fig8-x-g.svg",
            figure("Fig. 8: x_G(t)", "t (s)", "x_G (µm)", false, false, &|r| {
                zip(&r.samples.t, &r.samples.x_g, 1.0, UM)
            })
            .svg(),
        ),
        (
            "fig9-y-g.svg",
            figure("Fig. 9: y_G(t)", "t (s)", "y_G (µm)", false, false, &|r| {
                zip(&r.samples.t, &r.samples.y_g, 1.0, UM)
            })
            .svg(),
        ),
        ("fig10-bearing1-orbit.svg", orbit.svg()),
    ];
    for (name, svg) in plots {
        if let Ok(svg) = svg {
            out.push((name.to_string(), svg));
        }
    }
    out
}
