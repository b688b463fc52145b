//! The sweep runner: expands the variants, keeps this shard's, asks the
//! [`VariantSink`] which are already done (resume), runs the rest in batches on a
//! [`BatchSimulator`], commits each finished variant's JSON line to the sink before
//! reporting it, then writes the final JSON with the variants in id order. `run` uses the
//! result.jsonl folder ([`FolderSink`]); the service uses its store. Merging shard outputs
//! is in `super::merge`.
//!
//! Files, for `--out R.json`: the stream `R.jsonl` (see [`super::folder_sink`]) and the
//! result `R.json`, written to a temporary file, fsynced and renamed. Everything in the result except its `run`
//! section (timings, machine, resumes) is deterministic: the same spec and settings give
//! the same bytes however the run was sharded, batched or interrupted.

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use serde_json::{json, Map, Value};

use super::expand::Expansion;
pub use super::folder_sink::{stream_path, FolderSink, STREAM_FORMAT};
use super::progress::{Progress, ProgressCounters};
use super::reduce::{kept_series, reduce, Signals};
use super::sink::VariantSink;
use super::spec::SweepSpec;
use super::SweepError;

pub use super::job::RESULT_FORMAT;

/// One variant handed to the simulator.
#[derive(Clone, Debug, PartialEq)]
pub struct VariantJob {
    /// Variant id.
    pub id: u64,
    /// Its scene (validated).
    pub scene: Value,
}

/// What the simulator reports for one variant.
#[derive(Clone, Debug, PartialEq)]
pub struct Outcome {
    /// `"ok"` or a failure status (e.g. `"film_breakdown"`).
    pub status: String,
    /// Details for a non-ok status.
    pub message: Option<String>,
    /// The time series (up to the failure, if any).
    pub signals: Option<Signals>,
    /// Simulator-specific deterministic extras (e.g. step counts), stored as `"sim"`.
    pub extra: Option<Value>,
    /// Reductions and kept series computed as the run went (then `signals` is `None`).
    pub reduced: Option<Reduced>,
}

/// A variant's reductions computed as it ran ([`super::stream::RunReducer`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Reduced {
    /// The reductions.
    pub reductions: super::reduce::Reductions,
    /// The kept series (`None`: nothing kept).
    pub series: Option<Value>,
    /// Most samples held at once while it ran (not written out).
    pub peak_stored_samples: usize,
}

impl Outcome {
    /// The kept series, however the variant was reduced.
    pub fn kept_series(&self, opts: &super::reduce::ReductionOptions) -> Option<Value> {
        match (&self.reduced, &self.signals) {
            (Some(r), _) => r.series.clone(),
            (None, Some(s)) => kept_series(s, opts),
            (None, None) => None,
        }
    }
}

impl Outcome {
    /// A finished variant.
    pub fn ok(signals: Signals) -> Self {
        Outcome {
            status: "ok".into(),
            message: None,
            signals: Some(signals),
            extra: None,
            reduced: None,
        }
    }

    /// A variant that produced no signals.
    pub fn failed(status: &str, message: String) -> Self {
        Outcome {
            status: status.into(),
            message: Some(message),
            signals: None,
            extra: None,
            reduced: None,
        }
    }
}

/// Runs batches of variants: the rotor integrator in lockstep, or a stand-in.
pub trait BatchSimulator {
    /// Batch size for `--batch-size auto`.
    fn auto_batch_size(&self) -> usize;
    /// Description for the result's `run` section (backend, device).
    fn info(&self) -> Value;
    /// Simulates `jobs`, calling `done(index in jobs, outcome)` once per job as it
    /// finishes, in any order. A failing variant reports a status; it never stops the batch.
    fn run_batch(&mut self, jobs: &[VariantJob], done: &mut dyn FnMut(usize, Outcome));
    /// [`BatchSimulator::run_batch`] that stops early once `cancel` is set: every job is
    /// still reported (the runner drops the outcomes that arrive after the flag is set).
    /// Default: checks nothing (a batch runs to its end).
    fn run_batch_cancellable(
        &mut self,
        jobs: &[VariantJob],
        cancel: &AtomicBool,
        done: &mut dyn FnMut(usize, Outcome),
    ) {
        let _ = cancel;
        self.run_batch(jobs, done)
    }
    /// Notices for the user (e.g. a GPU fallback), drained.
    fn take_notices(&mut self) -> Vec<String> {
        Vec::new()
    }
}

/// A deterministic slice of the variants: variant `id` belongs to shard `id mod count`
/// (round-robin, so every shard gets a similar mix of cheap and costly variants).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// This shard, `0..count`.
    pub index: u64,
    /// Number of shards.
    pub count: u64,
}

impl std::str::FromStr for Shard {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let (k, n) = s
            .split_once('/')
            .ok_or_else(|| format!("`{s}`: expected K/N, e.g. 3/16"))?;
        let index: u64 = k
            .trim()
            .parse()
            .map_err(|_| format!("`{s}`: K is not an integer"))?;
        let count: u64 = n
            .trim()
            .parse()
            .map_err(|_| format!("`{s}`: N is not an integer"))?;
        if count == 0 || index >= count {
            return Err(format!("`{s}`: needs 0 <= K < N"));
        }
        Ok(Shard { index, count })
    }
}

impl Shard {
    /// Whether variant `id` is in this shard.
    pub fn owns(&self, id: u64) -> bool {
        id % self.count == self.index
    }

    pub(crate) fn to_json(self) -> Value {
        json!({"index": self.index, "count": self.count})
    }
}

/// Batch size.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BatchSize {
    /// The simulator's choice.
    Auto,
    /// This many variants per batch.
    Fixed(usize),
}

impl std::str::FromStr for BatchSize {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        if s == "auto" {
            return Ok(BatchSize::Auto);
        }
        match s.parse::<usize>() {
            Ok(n) if n > 0 => Ok(BatchSize::Fixed(n)),
            _ => Err(format!("`{s}`: expected `auto` or a positive integer")),
        }
    }
}

/// How [`run_sweep`] runs into the result.jsonl folder: the runner's walk, the settings
/// recorded with the results, and the folder sink's own two options.
#[derive(Clone, Debug)]
pub struct RunOptions {
    /// Result file (no default); the stream is the same path with extension `jsonl`.
    pub result: PathBuf,
    /// Draw a progress bar (only on a terminal); default for `run`: on unless `--quiet`.
    pub progress: bool,
    /// How the runner walks the variants (shard, batch size).
    pub runner: RunnerOptions,
    /// Settings that change results (backend kind, accuracy, ...), as the prepared
    /// simulator gives them: recorded in the result and checked on resume and merge.
    pub settings: Value,
}

/// What a run did.
#[derive(Clone, Debug, PartialEq)]
pub struct RunSummary {
    /// Variants in the whole expansion.
    pub total: u64,
    /// Variants in this shard.
    pub in_shard: u64,
    /// Already in the stream (resumed).
    pub skipped: u64,
    /// Run now.
    pub ran: u64,
    /// Variants whose status is not `ok`, in the result.
    pub not_ok: u64,
    /// The result file.
    pub result: PathBuf,
    /// The stream file.
    pub stream: PathBuf,
    /// Plots written (complete results only), or why one was not.
    pub plots: Vec<Result<PathBuf, String>>,
}

/// Hash of the canonical spec (keys sorted): sha2-256, as 64 hex digits.
pub fn spec_hash(spec: &SweepSpec) -> String {
    use sha2::{Digest, Sha256};
    let text = serde_json::to_string(&spec.canonical).unwrap_or_default();
    Sha256::digest(text.as_bytes())
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// The header that identifies a run to its sink (resume is refused on any difference).
pub fn header(spec: &SweepSpec, settings: &Value, shard: Option<Shard>, total: u64) -> Value {
    json!({"format": STREAM_FORMAT, "spec_hash": spec_hash(spec), "settings": settings,
           "shard": shard.map(Shard::to_json), "count": total})
}

/// How the runner walks the variants, whatever the sink: the `run` flags `--shard` and
/// `--batch-size`; the service runs every variant (`shard: None`) in automatic batches.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RunnerOptions {
    /// Only this shard; default `None` (every variant).
    pub shard: Option<Shard>,
    /// Variants per batch; default [`BatchSize::Auto`] (the simulator's choice).
    pub batch: BatchSize,
}

impl Default for RunnerOptions {
    fn default() -> Self {
        RunnerOptions {
            shard: None,
            batch: BatchSize::Auto,
        }
    }
}

/// What [`run_variants`] did.
#[derive(Clone, Debug, PartialEq)]
pub struct VariantsReport {
    /// Variants in the whole expansion.
    pub total: u64,
    /// Variants in this shard.
    pub in_shard: u64,
    /// Already in the sink (resumed).
    pub skipped: u64,
    /// Run and committed now.
    pub ran: u64,
    /// Committed variants whose status is not `ok`.
    pub not_ok: u64,
    /// Stopped by the cancel flag: the sink holds what finished; a later run resumes.
    pub cancelled: bool,
    /// The result's `run` section (simulator, counts, timings, peak RSS).
    pub run: Value,
}

/// Runs the sweep's variants (this shard's) into `sink`, recording `settings` (see
/// [`RunOptions::settings`]): expands, validates every
/// variant, resumes from what the sink already holds, runs the rest in batches and
/// commits each finished variant before reporting it to `progress`. `cancel` is checked
/// between batches and inside the simulator: the running variants stop, are not
/// committed (a later run recomputes them) and the report says `cancelled`.
#[allow(clippy::too_many_arguments)]
pub fn run_variants(
    spec: &SweepSpec,
    validator: &super::expand::SceneValidator,
    sim: &mut dyn BatchSimulator,
    sink: &mut dyn VariantSink,
    opts: &RunnerOptions,
    settings: &Value,
    progress: &Progress,
    cancel: &AtomicBool,
    notice: &mut dyn FnMut(String),
) -> Result<VariantsReport, SweepError> {
    Expansion::new(spec).validate_all(spec, validator)?;
    run_validated_variants(spec, sim, sink, opts, settings, progress, cancel, notice)
}

/// [`run_variants`] for a spec whose variants were validated already.
#[allow(clippy::too_many_arguments)]
fn run_validated_variants(
    spec: &SweepSpec,
    sim: &mut dyn BatchSimulator,
    sink: &mut dyn VariantSink,
    opts: &RunnerOptions,
    settings: &Value,
    progress: &Progress,
    cancel: &AtomicBool,
    notice: &mut dyn FnMut(String),
) -> Result<VariantsReport, SweepError> {
    let started = Instant::now();
    let exp = Expansion::new(spec);
    let total = exp.count();
    let owns = |id: u64| opts.shard.is_none_or(|s| s.owns(id));
    let mine: Vec<u64> = (0..total).filter(|&id| owns(id)).collect();
    let mut committed = sink.open(&header(spec, settings, opts.shard, total))?;
    if let Some(id) = committed.keys().find(|&&id| !owns(id) || id >= total) {
        return Err(SweepError::Output(format!(
            "the stored variants include {id}, which is not in this run"
        )));
    }
    let todo: Vec<u64> = mine
        .iter()
        .copied()
        .filter(|id| !committed.contains_key(id))
        .collect();
    let skipped = (mine.len() - todo.len()) as u64;
    if skipped > 0 {
        notice(format!(
            "resuming: {skipped} of {} variants already done",
            mine.len()
        ));
    }
    let batch = match opts.batch {
        BatchSize::Auto => sim.auto_batch_size().max(1),
        BatchSize::Fixed(n) => n,
    };
    let resumed_failed = committed.values().filter(|ok| !**ok).count() as u64;
    progress.begin(mine.len() as u64, skipped, resumed_failed);
    let mut ran = 0u64;
    let mut cancelled = false;
    let sim_started = Instant::now();
    for chunk in todo.chunks(batch) {
        if cancel.load(Ordering::Relaxed) {
            cancelled = true;
            break;
        }
        let mut commit_error: Option<SweepError> = None;
        super::job::run_batch(spec, &exp, sim, chunk, cancel, &mut |v, outcome| {
            // A variant stopped by the cancel flag is not a result; nothing is committed
            // after a failed commit.
            if commit_error.is_some() || cancel.load(Ordering::Relaxed) {
                return;
            }
            let (ok, line) = super::job::finished_line(spec, v, outcome);
            // Commit before report.
            match sink.commit(v.id, ok, &line) {
                Ok(()) => {
                    committed.insert(v.id, ok);
                    ran += 1;
                    progress.record(ok);
                }
                Err(e) => commit_error = Some(e),
            }
        });
        if let Some(e) = commit_error.take() {
            return Err(e);
        }
        sink.checkpoint()?;
        for n in sim.take_notices() {
            notice(n);
        }
        if cancel.load(Ordering::Relaxed) {
            cancelled = true;
            break;
        }
    }
    progress.finish();
    let sim_s = sim_started.elapsed().as_secs_f64();
    if !cancelled {
        let missing: Vec<u64> = mine
            .iter()
            .copied()
            .filter(|id| !committed.contains_key(id))
            .take(5)
            .collect();
        if !missing.is_empty() {
            return Err(SweepError::Output(format!(
                "variants {missing:?} missing after the run"
            )));
        }
    }
    let not_ok = committed.values().filter(|ok| !**ok).count() as u64;
    let run = json!({
        "simulator": sim.info(),
        "variants_run": ran,
        "variants_resumed": skipped,
        "simulation_wall_s": sim_s,
        "variants_per_s": if sim_s > 0.0 { ran as f64 / sim_s } else { 0.0 },
        "wall_s": started.elapsed().as_secs_f64(),
        "peak_rss_bytes": peak_rss_bytes(),
    });
    Ok(VariantsReport {
        total,
        in_shard: mine.len() as u64,
        skipped,
        ran,
        not_ok,
        cancelled,
        run,
    })
}

/// Writes `doc` (whose top-level `variants` is empty) to `w` with the sink's variant lines
/// in id order, byte for byte as `run` writes result.json; `on_line` sees each line (e.g.
/// to keep the light part for plots). Memory stays independent of the number of variants.
pub fn write_result_doc(
    w: &mut dyn Write,
    doc: &Value,
    sink: &mut dyn VariantSink,
    on_line: &mut dyn FnMut(&str),
) -> Result<(), SweepError> {
    let mut io_error: Option<std::io::Error> = None;
    let mut first = true;
    let (head, tail) = split_doc(doc)?;
    let io = |e: std::io::Error| SweepError::Output(format!("writing the result: {e}"));
    w.write_all(head.as_bytes()).map_err(io)?;
    sink.for_each_line(&mut |_, line| {
        let r = w
            .write_all(if first { b"\n    " } else { b",\n    " })
            .and_then(|_| w.write_all(line.as_bytes()));
        first = false;
        on_line(line);
        if let Err(e) = r {
            io_error.get_or_insert(e);
        }
        Ok(())
    })?;
    if let Some(e) = io_error {
        return Err(io(e));
    }
    w.write_all(if first { b"]" } else { b"\n  ]" })
        .and_then(|_| w.write_all(tail.as_bytes()))
        .and_then(|_| w.write_all(b"\n"))
        .map_err(io)
}

/// The pretty-printed `doc` split around its empty `variants` array: the text up to and
/// including `"variants": [`, and the text after `]`.
fn split_doc(doc: &Value) -> Result<(String, String), SweepError> {
    let text = serde_json::to_string_pretty(doc).unwrap_or_default();
    // Top-level keys are indented by two spaces; nested ones by more.
    let marker = "\n  \"variants\": []";
    let at = text
        .find(marker)
        .ok_or_else(|| SweepError::Output("internal: no variants field".into()))?;
    Ok((
        format!("{}\n  \"variants\": [", &text[..at]),
        text[at + marker.len()..].to_string(),
    ))
}

/// Runs the sweep (this shard of it) into the folder of `opts.result`, resuming from an
/// existing stream, then writes the result and the plots. The output folder is locked
/// for the run.
pub fn run_sweep(
    spec: &SweepSpec,
    validator: &super::expand::SceneValidator,
    sim: &mut dyn BatchSimulator,
    opts: &RunOptions,
    notice: &mut dyn FnMut(String),
) -> Result<RunSummary, SweepError> {
    let progress = Progress::new(opts.progress, ProgressCounters::shared());
    run_sweep_with(
        spec,
        validator,
        sim,
        opts,
        &progress,
        &AtomicBool::new(false),
        notice,
    )
}

/// [`run_sweep`] with a caller's progress counters and cancel flag. A cancelled run
/// leaves the stream (resumable) and writes no result: the error says so.
pub fn run_sweep_with(
    spec: &SweepSpec,
    validator: &super::expand::SceneValidator,
    sim: &mut dyn BatchSimulator,
    opts: &RunOptions,
    progress: &Progress,
    cancel: &AtomicBool,
    notice: &mut dyn FnMut(String),
) -> Result<RunSummary, SweepError> {
    // A bad variant stops the run before the output folder is touched.
    Expansion::new(spec).validate_all(spec, validator)?;
    // Fail before any work on an output that cannot be written (a directory in the way,
    // another run holding the folder).
    let mut sink = FolderSink::new(&opts.result)?;
    let report = run_validated_variants(
        spec,
        sim,
        &mut sink,
        &opts.runner,
        &opts.settings,
        progress,
        cancel,
        notice,
    )?;
    let stream = sink.stream().to_path_buf();
    if report.cancelled {
        return Err(SweepError::Output(format!(
            "cancelled: {} variants are in {}; run again to resume",
            report.skipped + report.ran,
            stream.display()
        )));
    }
    let shard = opts.runner.shard;
    let doc = super::job::result_document(spec, &opts.settings, shard, report.total, report.run);
    // Figures only of a complete result.
    let want_plots = shard.is_none() && !spec.plots.is_empty();
    let mut figures = super::job::Figures::new(spec);
    write_file_atomically(&opts.result, &mut |w| {
        write_result_doc(w, &doc, &mut sink, &mut |line| {
            if want_plots {
                figures.add_line(line);
            }
        })
    })?;
    drop(sink);
    let plots = if want_plots {
        write_figures(figures.draw(), &opts.result)
    } else {
        Vec::new()
    };
    Ok(RunSummary {
        total: report.total,
        in_shard: report.in_shard,
        skipped: report.skipped,
        ran: report.ran,
        not_ok: report.not_ok,
        result: opts.result.clone(),
        stream,
        plots,
    })
}

/// Writes `path` through a temporary file beside it: written by `fill`, fsynced, renamed
/// over `path`, and the folder fsynced, so a crash or power cut leaves the old file or the
/// whole new one, never half of one, and a finished result is not lost.
pub fn write_file_atomically(
    path: &Path,
    fill: &mut dyn FnMut(&mut dyn Write) -> Result<(), SweepError>,
) -> Result<(), SweepError> {
    if path.is_dir() {
        return Err(SweepError::Output(format!(
            "{}: is a directory; move it away or write elsewhere",
            path.display()
        )));
    }
    let tmp = path.with_extension("json.tmp");
    let file = File::create(&tmp).map_err(|e| SweepError::io(&tmp, e))?;
    let mut w = std::io::BufWriter::new(file);
    fill(&mut w)?;
    let file = w
        .into_inner()
        .map_err(|e| SweepError::io(&tmp, e.into_error()))?;
    file.sync_all().map_err(|e| SweepError::io(&tmp, e))?;
    drop(file);
    std::fs::rename(&tmp, path).map_err(|e| SweepError::io(path, e))?;
    sync_parent(path)
}

/// fsyncs the folder holding `path` (makes a rename in it durable).
fn sync_parent(path: &Path) -> Result<(), SweepError> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    File::open(dir)
        .and_then(|d| d.sync_all())
        .map_err(|e| SweepError::io(dir, e))
}

/// Writes drawn figures into the folder of result file `out`: `<name>.svg` each.
pub fn write_figures(
    figures: Vec<super::job::DrawnFigure>,
    out: &Path,
) -> Vec<Result<PathBuf, String>> {
    let dir = out.parent().unwrap_or(Path::new("."));
    figures
        .into_iter()
        .map(|(name, svg)| {
            let svg = svg.map_err(|e| format!("plot `{name}`: {e}"))?;
            let path = dir.join(format!("{name}.svg"));
            std::fs::write(&path, svg).map_err(|e| format!("{}: {e}", path.display()))?;
            Ok(path)
        })
        .collect()
}

/// Writes the spec's plots of a complete result's variants (light part) into its
/// folder: `<name>.svg`.
pub fn write_plots(
    spec: &SweepSpec,
    variants: &[Value],
    out: &Path,
) -> Vec<Result<PathBuf, String>> {
    write_figures(super::job::draw_figures(spec, variants), out)
}

/// One variant's stream line.
pub(crate) fn variant_line(spec: &SweepSpec, v: &super::expand::Variant, mut o: Outcome) -> Value {
    let mut m = Map::new();
    m.insert("id".into(), json!(v.id));
    m.insert("params".into(), v.params(spec));
    m.insert("status".into(), json!(o.status));
    if let Some(msg) = o.message {
        m.insert("message".into(), json!(msg));
    }
    if let Some(r) = o.reduced.take() {
        m.insert(
            "reductions".into(),
            serde_json::to_value(&r.reductions).unwrap_or(Value::Null),
        );
        if let Some(series) = r.series {
            m.insert("series".into(), series);
        }
    } else if let Some(s) = &o.signals {
        let r = reduce(s, &spec.reductions);
        m.insert(
            "reductions".into(),
            serde_json::to_value(&r).unwrap_or(Value::Null),
        );
        if let Some(series) = kept_series(s, &spec.reductions) {
            m.insert("series".into(), series);
        }
    } else if let Some(r) = o
        .extra
        .as_mut()
        .and_then(|e| e.as_object_mut())
        .and_then(|e| e.remove("reductions"))
    {
        // A simulator without signals (the stability analysis) reports its own reductions.
        m.insert("reductions".into(), r);
    } else {
        m.insert("reductions".into(), Value::Null);
    }
    if let Some(extra) = o.extra {
        m.insert("sim".into(), extra);
    }
    Value::Object(m)
}

/// Writes `doc` (whose top-level `variants` is empty) with the variant lines from
/// `variants` (compact JSON, one per line, in order) to `path` atomically (see
/// [`write_file_atomically`]). Memory stays independent of the number of variants.
pub(crate) fn write_result_streamed(
    path: &Path,
    doc: &Value,
    variants: &mut dyn Iterator<Item = Result<String, SweepError>>,
) -> Result<(), SweepError> {
    let (head, tail) = split_doc(doc)?;
    write_file_atomically(path, &mut |w| {
        let io = |e| SweepError::io(path, e);
        w.write_all(head.as_bytes()).map_err(io)?;
        let mut first = true;
        for line in &mut *variants {
            let line = line?;
            w.write_all(if first { b"\n    " } else { b",\n    " })
                .map_err(io)?;
            w.write_all(line.as_bytes()).map_err(io)?;
            first = false;
        }
        w.write_all(if first { b"]" } else { b"\n  ]" })
            .map_err(io)?;
        w.write_all(tail.as_bytes()).map_err(io)?;
        w.write_all(b"\n").map_err(io)
    })
}

/// Writes `doc` to `path` atomically and durably (see [`write_file_atomically`]).
pub fn write_result(path: &Path, doc: &Value) -> Result<(), SweepError> {
    let text = serde_json::to_string_pretty(doc).unwrap_or_default();
    write_file_atomically(path, &mut |w| {
        w.write_all(text.as_bytes())
            .and_then(|_| w.write_all(b"\n"))
            .map_err(|e| SweepError::io(path, e))
    })
}

/// Peak resident set size of this process (VmHWM), bytes; `None` off Linux.
pub fn peak_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shard_and_batch_parsing() {
        assert_eq!(
            "3/16".parse::<Shard>(),
            Ok(Shard {
                index: 3,
                count: 16
            })
        );
        for bad in ["16/16", "1/0", "a/2", "3", "-1/4"] {
            assert!(bad.parse::<Shard>().is_err(), "`{bad}` accepted");
        }
        let s = Shard { index: 1, count: 3 };
        assert_eq!(
            (0..10).filter(|&i| s.owns(i)).collect::<Vec<_>>(),
            vec![1, 4, 7]
        );
        assert_eq!("auto".parse::<BatchSize>(), Ok(BatchSize::Auto));
        assert_eq!("64".parse::<BatchSize>(), Ok(BatchSize::Fixed(64)));
        assert!("0".parse::<BatchSize>().is_err());
    }

    #[test]
    fn spec_hash_is_sha256_of_the_canonical_spec() {
        use sha2::{Digest, Sha256};
        // FIPS 180-2 test vector, so the hex rendering is checked too: sha256("abc").
        let hex = |b: &[u8]| -> String { b.iter().map(|b| format!("{b:02x}")).collect() };
        assert_eq!(
            hex(&Sha256::digest(b"abc")),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
        let spec = |v: f64| {
            crate::sweep::parse_spec(
                &json!({"kind": "synthetic", "base": {"spin": 1.0},
                        "axes": [{"path": "spin", "values": [1.0, v]}]}),
                None,
            )
            .unwrap()
        };
        let a = spec(2.0);
        let text = serde_json::to_string(&a.canonical).unwrap();
        assert_eq!(spec_hash(&a), hex(&Sha256::digest(text.as_bytes())));
        assert_eq!(spec_hash(&a).len(), 64);
        assert_ne!(spec_hash(&a), spec_hash(&spec(2.0000000000000004)));
    }

    #[test]
    fn stream_path_replaces_the_extension() {
        assert_eq!(
            stream_path(Path::new("out/r.json")),
            PathBuf::from("out/r.jsonl")
        );
        assert_eq!(stream_path(Path::new("r")), PathBuf::from("r.jsonl"));
    }
}
