//! `bearing-sweep run` and `bearing-sweep merge`: thin wrappers over [`crate::sweep`].

use std::path::{Path, PathBuf};

use serde_json::Value;

use super::AppError;
use crate::sweep::friction_map::{friction_map, FrictionMapSpec};
use crate::sweep::merge::merge;
use crate::sweep::runner::{run_sweep, write_result, RunOptions, RunnerOptions, Shard};
use crate::sweep::simulator::{prepare_simulator, SetupError};
use crate::sweep::spec::parse_spec;
use crate::sweep::{SweepError, SweepKind, SweepOptions};

/// Options of `run` for a sweep spec: where the result goes, the progress bar, how the
/// runner walks the variants and what the sweep computes with.
#[derive(Clone, Debug)]
pub struct SweepRunOptions {
    /// Output root (`--out`, no default here; the CLI's is `results`): results go to
    /// `out/<spec stem>/` (a shard: `.../shard-K-of-N/`).
    pub out: PathBuf,
    /// No progress bar (`--quiet`); default false.
    pub quiet: bool,
    /// Shard and batch size (`--shard`, `--batch-size`); default: every variant, automatic
    /// batches.
    pub runner: RunnerOptions,
    /// Backend, accuracy, full model and memory budget (`--backend`, `--accuracy`,
    /// `--full-model`, `--max-memory`); default [`SweepOptions::default`].
    pub sweep: SweepOptions,
}

/// Whether a `run` input is a sweep spec (an object with `base` or `kind`) rather than a
/// scene file.
pub fn is_sweep_spec(text: &str) -> bool {
    serde_json::from_str::<Value>(text)
        .ok()
        .and_then(|v| {
            v.as_object()
                .map(|o| o.contains_key("base") || o.contains_key("kind"))
        })
        .unwrap_or(false)
}

/// The result file of a run: `out/<stem>/result.json`, or `out/<stem>/shard-K-of-N/result.json`.
pub fn result_path(out: &Path, spec_file: &str, shard: Option<Shard>) -> PathBuf {
    let stem = Path::new(spec_file)
        .file_stem()
        .and_then(|s| s.to_str())
        .filter(|s| !s.is_empty() && *s != "-")
        .unwrap_or("sweep");
    let dir = out.join(stem);
    match shard {
        None => dir.join("result.json"),
        Some(s) => dir
            .join(format!("shard-{}-of-{}", s.index, s.count))
            .join("result.json"),
    }
}

/// Runs a sweep spec (file name `spec_file`, contents `text`); returns the lines to print
/// on standard error when done.
pub fn run_command(
    spec_file: &str,
    text: &str,
    opts: &SweepRunOptions,
    notice: &mut dyn FnMut(String),
) -> Result<Vec<String>, AppError> {
    let doc: Value =
        crate::json::parse_json(text).map_err(|e| AppError::input(e.path, e.reason))?;
    let spec_path = Path::new(spec_file);
    let shard = opts.runner.shard;
    let out = result_path(&opts.out, spec_file, shard);
    let accuracy = opts.sweep.accuracy.level();
    let mkdir = |dir: &Path| {
        std::fs::create_dir_all(dir).map_err(|e| AppError::Sweep(SweepError::io(dir, e)))
    };
    match SweepKind::of(&doc) {
        Some(SweepKind::FrictionMap) => {
            if shard.is_some() {
                return Err(AppError::input(
                    "--shard",
                    "a friction map is not sharded (it runs no dynamics and takes milliseconds)",
                ));
            }
            let spec = FrictionMapSpec::parse_within(&doc, opts.sweep.max_memory)?;
            if let Some(b) = doc.get("bearing") {
                for w in super::warnings::bearing_warnings("bearing", b) {
                    notice(w);
                }
            }
            let (result, plot) = friction_map(&spec, accuracy);
            let dir = out.parent().unwrap_or(Path::new("."));
            mkdir(dir)?;
            write_result(&out, &result)?;
            let mut lines = vec![format!(
                "friction map: {} loads x {} speeds from eqs. 10-11{}; no integrator was run; wrote {}",
                spec.load.len(),
                spec.speed.len(),
                if result["model"] == "film" {
                    " on the static film equilibrium"
                } else {
                    ""
                },
                out.display()
            )];
            // The figure is drawn after the result is on disk (issue 13 item 1).
            match plot.render() {
                Ok(svg) => {
                    let svg_path = dir.join("friction-map.svg");
                    std::fs::write(&svg_path, svg)
                        .map_err(|e| AppError::Sweep(SweepError::io(&svg_path, e)))?;
                    lines.push(format!("plot: {}", svg_path.display()));
                }
                Err(e) => lines.push(format!("no plot: {e}")),
            }
            Ok(lines)
        }
        _ => {
            let spec_dir = spec_path.parent().filter(|_| spec_file != "-");
            let spec = parse_spec(&doc, spec_dir)?;
            for w in super::warnings::sweep_warnings(&doc, &spec.base) {
                notice(w);
            }
            let mut prepared =
                prepare_simulator(&spec, &opts.sweep, notice).map_err(|e| match e {
                    SetupError::Sweep(e) => AppError::Sweep(e),
                    SetupError::Backend(e) => AppError::Backend(e),
                })?;
            let run_opts = RunOptions {
                result: out.clone(),
                progress: !opts.quiet,
                runner: opts.runner,
                settings: prepared.settings.clone(),
            };
            let summary = run_sweep(
                &spec,
                &*prepared.validator,
                prepared.sim.as_mut(),
                &run_opts,
                notice,
            )?;
            let mut lines = vec![format!(
                "{} of {} variants in this run ({} resumed, {} run, {} not ok); wrote {} (stream {})",
                summary.in_shard,
                summary.total,
                summary.skipped,
                summary.ran,
                summary.not_ok,
                summary.result.display(),
                summary.stream.display()
            )];
            lines.extend(plot_lines(&summary.plots));
            Ok(lines)
        }
    }
}

/// Merges shard results into `out`.
pub fn merge_command(out: &str, shards: &[String]) -> Result<Vec<String>, AppError> {
    let paths: Vec<PathBuf> = shards.iter().map(PathBuf::from).collect();
    let (doc, plots) = merge(Path::new(out), &paths)?;
    let mut lines = vec![format!(
        "merged {} shard results: {} variants; wrote {out}",
        shards.len(),
        doc["variants"].as_array().map_or(0, Vec::len)
    )];
    lines.extend(plot_lines(&plots));
    Ok(lines)
}

fn plot_lines(plots: &[Result<PathBuf, String>]) -> Vec<String> {
    plots
        .iter()
        .map(|p| match p {
            Ok(path) => format!("plot: {}", path.display()),
            Err(e) => format!("no plot: {e}"),
        })
        .collect()
}
