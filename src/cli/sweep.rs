//! `bearing-sweep run` and `bearing-sweep merge`: thin wrappers over [`crate::sweep`].

use std::path::{Path, PathBuf};

use serde_json::{json, Value};

use super::CliError;
use crate::bearing::Accuracy;
use crate::sweep::friction_map::{friction_map, FrictionMapSpec};
use crate::sweep::runner::{merge, run_sweep, write_result, BatchSize, RunOptions, Shard};
use crate::sweep::spec::{parse_spec, spec_kind};
use crate::sweep::synthetic::{self, SyntheticSimulator};
use crate::sweep::{SweepError, SweepKind};

/// Options of `run`.
#[derive(Clone, Debug)]
pub struct SweepRunOptions {
    /// Result file (default: `<spec stem>.out.json`, or `<stem>.shard-K-of-N.out.json`).
    pub out: Option<PathBuf>,
    /// Run only this shard.
    pub shard: Option<Shard>,
    /// Variants per batch.
    pub batch: BatchSize,
    /// Backend for the film loads.
    pub backend: crate::backend::BackendKind,
    /// Film accuracy.
    pub accuracy: f64,
    /// No progress bar.
    pub quiet: bool,
}

fn default_out(spec_path: &Path, shard: Option<Shard>) -> PathBuf {
    let stem = spec_path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "sweep".into());
    match shard {
        None => PathBuf::from(format!("{stem}.out.json")),
        Some(s) => PathBuf::from(format!("{stem}.shard-{}-of-{}.out.json", s.index, s.count)),
    }
}

/// Runs a spec file; returns the lines to print on standard error when done.
pub fn run_command(
    spec_file: &str,
    opts: &SweepRunOptions,
    notice: &mut dyn FnMut(String),
) -> Result<Vec<String>, CliError> {
    let text = super::read_input(spec_file)?;
    let doc: Value = serde_json::from_str(&text)
        .map_err(|e| CliError::input("$", format!("not valid JSON: {e}")))?;
    let spec_path = Path::new(spec_file);
    let out = opts
        .out
        .clone()
        .unwrap_or_else(|| default_out(spec_path, opts.shard));
    let accuracy = Accuracy::new(opts.accuracy).ok_or_else(|| {
        CliError::input(
            "--accuracy",
            format!("{} is not a positive number >= 1e-12", opts.accuracy),
        )
    })?;
    match spec_kind(&doc) {
        Some("friction_map") => {
            if opts.shard.is_some() {
                return Err(CliError::input(
                    "--shard",
                    "a friction map is not sharded (it runs no dynamics and takes milliseconds)",
                ));
            }
            let spec = FrictionMapSpec::parse(&doc)?;
            let (result, svg) = friction_map(&spec, accuracy);
            if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir)
                    .map_err(|e| CliError::Sweep(SweepError::io(dir, e)))?;
            }
            write_result(&out, &result)?;
            let mut lines = vec![format!(
                "friction map: {} loads x {} speeds from eqs. 10-11{}; no integrator was run; wrote {}",
                spec.load.len(),
                spec.speed.len(),
                if result["model"] == "film" { " on the static film equilibrium" } else { "" },
                out.display()
            )];
            match svg {
                Ok(svg) => {
                    let svg_path = out.with_extension("svg");
                    std::fs::write(&svg_path, svg)
                        .map_err(|e| CliError::Sweep(SweepError::io(&svg_path, e)))?;
                    lines.push(format!("plot: {}", svg_path.display()));
                }
                Err(e) => lines.push(format!("no plot: {e}")),
            }
            Ok(lines)
        }
        _ => {
            let spec_dir = spec_path.parent().filter(|_| spec_file != "-");
            let spec = parse_spec(&doc, spec_dir)?;
            let run_opts = |settings: Value| RunOptions {
                out: out.clone(),
                shard: opts.shard,
                batch: opts.batch,
                progress: !opts.quiet,
                settings,
            };
            let summary = match spec.kind {
                SweepKind::Synthetic => run_sweep(
                    &spec,
                    &synthetic::validate,
                    &mut SyntheticSimulator,
                    &run_opts(json!({"simulator": "synthetic"})),
                    notice,
                )?,
                SweepKind::Rotor => return Err(CliError::input(
                    "kind",
                    "rotor sweeps need the rotor integrator, which this build does not have yet",
                )),
            };
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
pub fn merge_command(out: &str, shards: &[String]) -> Result<Vec<String>, CliError> {
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
